"""The label schemes (core/label_schemes.py) and the ASPRS codes (core/io/las.py), by class name.

The literal ids below are read from each dataset's published label configuration, not from
our own table: semantic-kitti-api `config/semantic-kitti-all.yaml` (`labels:`), RELLIS-3D
`benchmarks/SalsaNext/train/tasks/semantic/config/labels/rellis.yaml` (`labels:`), GOOSE's
`goose_label_mapping.csv` (64 classes, `label_key`), and LAS 1.4 R15 table 17 (ASPRS standard
classes).
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from wildscan.core.classes import ALL_ELEMENTS, ElementClass, class_by_name
from wildscan.core.io.las import ASPRS_BY_CLASS, asprs_codes
from wildscan.core.label_schemes import OTHER, SCHEMES, SchemeError, ids_by_class_id, scheme

CLASS_NAMES = [c.name for c in ALL_ELEMENTS]


def mapped(scheme_name: str, class_name: str) -> int:
    return int(scheme(scheme_name).map(np.array([class_by_name(class_name).id]))[0])


@pytest.mark.parametrize("name", sorted(SCHEMES))
def test_every_class_water_included_has_an_entry_in_every_scheme(name):
    s = SCHEMES[name]
    assert set(s.by_class) == set(CLASS_NAMES)
    assert set(s.from_wildscan) == {c.id for c in ALL_ELEMENTS}
    assert all(raw in s.labels for raw in s.from_wildscan.values())


def test_every_class_has_an_asprs_code():
    assert set(ASPRS_BY_CLASS) == set(CLASS_NAMES)


# (class, the published id, the published name of that id)
SEMANTICKITTI = [
    ("trunk", 71, "trunk"),
    ("terrain", 72, "terrain"),
    ("treetop", 70, "vegetation"),
    ("fence", 51, "fence"),
    ("pole", 80, "pole"),
    ("rock", 99, "other-object"),
]
RELLIS3D = [
    ("terrain", 1, "dirt"),
    ("low grass", 3, "grass"),
    ("trunk", 4, "tree"),
    ("pole", 5, "pole"),
    ("water", 6, "water"),
    ("table", 9, "object"),
    ("fence", 18, "fence"),
    ("bush", 19, "bush"),
    ("rock", 34, "rubble"),
]
GOOSE = [
    ("bench", 4, "obstacle"),
    ("bush", 17, "bush"),
    ("treetop", 27, "tree_crown"),
    ("trunk", 28, "tree_trunk"),
    ("terrain", 31, "soil"),
    ("rock", 40, "rock"),
    ("fence", 41, "fence"),
    ("pole", 45, "pole"),
    ("low grass", 50, "low_grass"),
    ("high grass", 51, "high_grass"),
    ("water", 54, "water"),
    ("wire", 55, "wire"),
]


@pytest.mark.parametrize(
    "scheme_name, class_name, raw, raw_name",
    [("semantickitti", *row) for row in SEMANTICKITTI]
    + [("rellis3d", *row) for row in RELLIS3D]
    + [("goose", *row) for row in GOOSE],
)
def test_a_class_gets_the_published_id_of_its_counterpart(scheme_name, class_name, raw, raw_name):
    assert mapped(scheme_name, class_name) == raw
    assert scheme(scheme_name).labels[raw] == raw_name


def test_wildscan_ids_are_the_class_table_ids():
    assert mapped("wildscan", "trunk") == 2 and mapped("wildscan", "pole") == 12
    assert mapped("wildscan", "water") == 13


@pytest.mark.parametrize("class_name, code", [("terrain", 2), ("low grass", 3), ("bush", 4), ("treetop", 5)])
def test_asprs_standard_classes(class_name, code):
    assert asprs_codes(np.array([class_by_name(class_name).id]))[0] == code


def test_classes_without_a_counterpart_are_marked_other_in_the_table():
    s = scheme("semantickitti")
    assert s.is_other(class_by_name("table").id) and not s.is_other(class_by_name("trunk").id)
    assert s.by_class["table"] == OTHER and mapped("semantickitti", "table") == s.other == 99


def test_a_scheme_missing_a_class_raises_naming_the_scheme_and_the_class():
    by_class = dict(scheme("semantickitti").by_class)
    del by_class["water"]
    with pytest.raises(SchemeError, match=r"'semantickitti' has no id for class 'water'"):
        ids_by_class_id("semantickitti", by_class, 99)


def test_a_scheme_naming_no_class_raises():
    by_class = dict(scheme("goose").by_class, boulder=40)
    with pytest.raises(SchemeError, match=r"'goose' names 'boulder', which is no class"):
        ids_by_class_id("goose", by_class, 4)


def test_a_class_added_to_the_table_but_not_to_the_schemes_stops_the_import():
    """What adding a class (a hypothetical 99 `moss`) to core/classes.py alone does: the import
    of the schemes fails and says which scheme lacks which class."""
    code = (
        "import wildscan.core.classes as c\n"
        "moss = c.ElementClass(99, 'moss', 87.0, (120, 160, 20))\n"
        "c.CLASSES += (moss,)\n"
        "c.ALL_ELEMENTS += (moss,)\n"
        "c.BY_ID[99] = moss\n"
        "import wildscan.core.label_schemes\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode != 0
    assert "SchemeError: label scheme 'semantickitti' has no id for class 'moss'" in done.stderr


def test_log_maps_to_each_schemes_deadwood_or_nearest_class():
    """Class 14 `log` (fallen deadwood): RELLIS-3D's own `log`, SemanticKITTI's trunk, GOOSE's
    obstacle (neither has deadwood), itself in WildScan's ids."""
    assert mapped("rellis3d", "log") == 15 and scheme("rellis3d").labels[15] == "log"
    assert mapped("semantickitti", "log") == 71
    assert mapped("goose", "log") == 4 and scheme("goose").is_other(14)
    assert mapped("wildscan", "log") == 14


def test_two_classes_with_one_reflectivity_stop_the_import():
    """Labels come from intensities (the paper): a new class needs a reflectivity of its own."""
    from wildscan.core.classes import _check_table

    twin = ElementClass(99, "moss", 90.0, (1, 2, 3))  # trunk's 90
    with pytest.raises(ValueError, match=r"share the reflectivity \[90.0\]"):
        _check_table((*ALL_ELEMENTS, twin))
