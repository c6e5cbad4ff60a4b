"""The real datasets' rigs and label sets (issue 35): a dataset written in WildScenes' label
ids with the WildScenes rig, read back as WildScenes' own tools read label files, in
SemanticKITTI's layout and in WildScenes' own (Clouds/ + Labels/)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

from wildscan.core.classes import ALL_ELEMENTS
from wildscan.core.label_schemes import scheme

from tests.helpers.dataset_helpers import written_dataset

WILDSCENES_SPEC = """\
layout = "paper"
seeds = [1]
scans_per_world = 2
formats = ["semantickitti", "wildscenes"]
label_scheme = "wildscenes"
detail = "low"
split = { train = 1.0 }

[sensor]
device = "wildscenes"
mount_height = 1.2
"""


@pytest.fixture(scope="module")
def wildscenes_dataset(tmp_path_factory):
    root, _ = written_dataset(tmp_path_factory.mktemp("wildscenes"), WILDSCENES_SPEC)
    return root


@pytest.mark.slow
def test_a_wildscenes_dataset_writes_wildscenes_ids_and_a_config_mapping_every_class(wildscenes_dataset):
    s = scheme("wildscenes")
    labels = sorted((wildscenes_dataset / "sequences" / "00" / "labels").glob("*.label"))
    assert len(labels) == 2
    seen = set()
    for path in labels:
        semantic = np.fromfile(path, dtype="<u4") & 0xFFFF  # SemanticKITTI's .label: class in the low 16
        assert set(np.unique(semantic).tolist()) <= set(s.labels) - {10}  # never sky
        seen |= set(np.unique(semantic).tolist())
    assert {0, 1, 3, 12, 13} <= seen  # bush, dirt, grass, tree-foliage, tree-trunk in a forest world
    config = yaml.safe_load((wildscenes_dataset / "labels.yaml").read_text())
    assert config["labels"] == s.labels and config["labels"][13] == "tree-trunk"
    # every WildScan class maps to an id the config lists, and its learning map is the benchmark's
    assert {s.from_wildscan[c.id] for c in ALL_ELEMENTS} <= set(config["labels"])
    assert config["learning_map"][10] == config["learning_map"][14] == 255
    assert config["learning_ignore"][255] is True
    # at its mount height: the card says it, every manifest row and placement has it
    assert "device wildscenes at 1.2 m" in (wildscenes_dataset / "CARD.md").read_text()
    rows = [json.loads(x) for x in (wildscenes_dataset / "manifest.jsonl").read_text().splitlines()]
    assert all(r["sensor"]["mount_height"] == 1.2 for r in rows if r["status"] == "ok")
    # the tilted VLP-16 on its turning mount: more than 110 deg of elevation in the scans
    bins = sorted((wildscenes_dataset / "sequences" / "00" / "velodyne").glob("*.bin"))
    for path in bins:
        xyz = np.fromfile(path, dtype="<f4").reshape(-1, 4)[:, :3]
        elevation = np.degrees(np.arctan2(xyz[:, 2], np.hypot(xyz[:, 0], xyz[:, 1])))
        assert elevation.max() - elevation.min() >= 110.0


@pytest.mark.slow
def test_the_wildscenes_layout_is_read_as_wildscenes_view_cloud_reads_it(wildscenes_dataset):
    """scripts/visualisation/view_cloud.py: np.fromfile(cloud, float32).reshape(-1, 3) and
    np.fromfile(labels, int32), the same points as the SemanticKITTI files in the same order."""
    from wildscan.bench.learn_real import find_real_scans

    seq = wildscenes_dataset / "sequences" / "00"
    for cloud in sorted((seq / "Clouds").glob("*.bin")):
        points = np.fromfile(cloud, dtype=np.float32).reshape(-1, 3)
        labels = np.fromfile(seq / "Labels" / f"{cloud.stem}.label", dtype=np.int32)
        kitti = np.fromfile(seq / "velodyne" / cloud.name, dtype="<f4").reshape(-1, 4)
        kitti_labels = np.fromfile(seq / "labels" / f"{cloud.stem}.label", dtype="<u4") & 0xFFFF
        assert np.array_equal(points, kitti[:, :3]) and np.array_equal(labels, kitti_labels.astype(np.int32))
    layout, pairs = find_real_scans(wildscenes_dataset)
    assert layout.name == "semantickitti" and len(pairs) == 2  # the SemanticKITTI layout is looked for first


def test_like_wildscenes_writes_wildscenes_files():
    from wildscan.app.dataset import spec_from_dict

    assert spec_from_dict({"like": "wildscenes"}).formats == ("wildscenes",)
