"""The class table (docs/architecture.md "Classes", paper Table I): the single source of class ids,
names, reflectivities and colour tags.

Ids are a contract with users (they are the PLY `label` field): never renumber.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import UserError


@dataclass(frozen=True)
class ElementClass:
    """One class. `optional`: not one of the paper's, so a file lists it only where its scan could
    make it (an effect declares it, `Effect.classes`) or a point carries it (`listed_classes`):
    files of scans that cannot make it keep the bytes they had before the class existed."""

    id: int
    name: str
    reflectivity: float
    color: tuple[int, int, int]
    optional: bool = False


# The custom properties that tag an object (docs/architecture.md: all a user adds to scan a scene).
CLASS_PROP = "wildscan_class"
INSTANCE_PROP = "wildscan_instance"

UNLABELED = ElementClass(0, "unlabeled", 0.0, (255, 255, 255))

CLASSES: tuple[ElementClass, ...] = (
    ElementClass(1, "terrain", 100.0, (139, 90, 43)),
    ElementClass(2, "trunk", 90.0, (255, 0, 255)),
    ElementClass(3, "treetop", 80.0, (128, 128, 0)),
    ElementClass(4, "table", 75.0, (255, 255, 0)),
    ElementClass(5, "bush", 70.0, (0, 160, 0)),
    ElementClass(6, "fence", 60.0, (0, 0, 0)),
    ElementClass(7, "bench", 55.0, (255, 150, 200)),
    ElementClass(8, "low grass", 50.0, (255, 165, 0)),
    ElementClass(9, "rock", 40.0, (128, 128, 128)),
    ElementClass(10, "high grass", 30.0, (255, 0, 0)),
    ElementClass(11, "wire", 20.0, (0, 0, 255)),
    ElementClass(12, "pole", 15.0, (0, 255, 255)),
)

# Water is an element, not a label: a beam whose first hit is water returns no
# point (the paper drops ranges with water reflectivity). It gets an internal id
# so backends can report it; that id never reaches a PLY file.
WATER = ElementClass(13, "water", 120.0, (0, 0, 0))
WATER_ID = WATER.id

# Weather's returns (core/effects/weather.py): a beam returned by a raindrop, a snowflake, fog or
# dust before any surface. A label like any other, but only weather makes it: optional, so the
# class tables of files list it only when weather is on (a clear-air file keeps its bytes). Its reflectivity
# is the intensity the paper model reports for such a return; like every class's it must be
# unique (labels are read back from intensities).
PARTICLE = ElementClass(15, "particle", 2.0, (150, 200, 255), optional=True)
PARTICLE_ID = PARTICLE.id

# Fallen deadwood and stumps (docs/ground.md): the class RELLIS-3D calls `log` (rellis.yaml id 15).
# Not one of the paper's Table I: optional like the particle class, the tables of files list it
# only where a world can hold it (a biome with ground cover, core/world/biomes.py, whose cover
# effect declares it) or a point is one:
# a `paper` world's files keep their bytes. Its reflectivity is a tag as Table I's are (the paper
# gives each class an arbitrary, unique value, section IV-C); 85 is free and sits beside trunk's
# 90 because a log is bark and wood like a trunk. Colour: dark brown, apart from terrain's brown.
LOG = ElementClass(14, "log", 85.0, (92, 51, 23), optional=True)
LOG_ID = LOG.id

# The ground's surface materials of the endless landscape (core/world/endless/ground.py): what the
# ground is where no sward covers it. Appended after 15 (ids never change); like log and particle
# they are optional: a file's class table lists them only when its points carry one, so every
# file of the paper's island (whose ground is `terrain`) keeps its bytes. Reflectivities are tags
# (unique, as Table I's: the paper labels a return by its intensity); each material's reflectance
# at 905 nm, with its source, is in core/intensity.py MATERIALS.
GROUND_MATERIALS: tuple[ElementClass, ...] = (
    ElementClass(16, "soil", 95.0, (176, 122, 70), optional=True),
    ElementClass(17, "gravel", 65.0, (190, 182, 160), optional=True),
    ElementClass(18, "mud", 35.0, (84, 62, 40), optional=True),
    ElementClass(19, "paved", 45.0, (64, 64, 72), optional=True),
    ElementClass(20, "leaf litter", 25.0, (196, 136, 40), optional=True),
    ElementClass(21, "rock slab", 10.0, (104, 104, 116), optional=True),
)
GROUND_IDS: tuple[int, ...] = tuple(c.id for c in GROUND_MATERIALS)
# Every class that is the ground itself: the paper's terrain and the materials.
GROUND_CLASS_IDS: tuple[int, ...] = (1, *GROUND_IDS)

# The classes beyond the paper's Table I and water, one a line in id order: each optional, so a
# file lists it only where its scan could make it (docs/extending.md "Add a class").
OPTIONAL_CLASSES: tuple[ElementClass, ...] = (
    LOG,
    PARTICLE,
    *GROUND_MATERIALS,
)

ALL_ELEMENTS: tuple[ElementClass, ...] = (UNLABELED, *CLASSES, WATER, *OPTIONAL_CLASSES)


def _check_table(elements: tuple[ElementClass, ...]) -> None:
    """Ids and names must be unique, and so must reflectivities: the paper labels a return by
    its intensity (label_from_reflectivity), which needs Table I to be a bijection."""
    for what in ("id", "name", "reflectivity"):
        values = [getattr(c, what) for c in elements]
        twice = sorted({v for v in values if values.count(v) > 1})
        if twice:
            raise ValueError(f"core/classes.py: two classes share the {what} {twice}")


_check_table(ALL_ELEMENTS)
BY_ID: dict[int, ElementClass] = {c.id: c for c in ALL_ELEMENTS}
NUM_IDS = max(BY_ID) + 1

# Lookup tables indexed by internal class id (an id no class has yet: reflectivity nan, white).
REFLECTIVITY_BY_ID = np.array(
    [BY_ID[i].reflectivity if i in BY_ID else np.nan for i in range(NUM_IDS)], dtype=np.float32
)
COLOR_BY_ID = np.array(
    [BY_ID[i].color if i in BY_ID else (255, 255, 255) for i in range(NUM_IDS)], dtype=np.uint8
)

# Class names as users write them in the `wildscan_class` custom property;
# "low grass", "low_grass" and "Low-Grass" all mean the same class.
_TAGGED = tuple(c for c in ALL_ELEMENTS if c not in (UNLABELED, PARTICLE))  # a tag names no particle
_BY_NAME: dict[str, ElementClass] = {c.name: c for c in _TAGGED}
TAG_NAMES: tuple[str, ...] = tuple(c.name for c in _TAGGED)


def normalize_name(name: str) -> str:
    return " ".join(str(name).strip().lower().replace("_", " ").replace("-", " ").split())


def class_by_name(name: str) -> ElementClass:
    """The class a `wildscan_class` tag names; KeyError with the allowed names otherwise."""
    try:
        return _BY_NAME[normalize_name(name)]
    except KeyError:
        allowed = ", ".join(repr(n) for n in TAG_NAMES)
        raise KeyError(f"unknown class {name!r}; allowed: {allowed}") from None


def class_id_for_tag(tag: object) -> int:
    """Internal id for a custom-property value; untagged or unknown tags give 0 (unlabeled).
    Lenient, for drawing; a scan reads tags with `object_tags`, which refuses unknown ones."""
    if tag is None:
        return UNLABELED.id
    try:
        return class_by_name(str(tag)).id
    except KeyError:
        return UNLABELED.id


# The largest `wildscan_instance`: instance ids travel as int32 in hits and uint32 in PLY files.
MAX_INSTANCE = 2**31 - 1
# Per-object reflectivity override (intensity only; the label still comes from the class).
REFLECTIVITY_PROP = "wildscan_reflectivity"
# An object's diffuse reflectance (0-1) at the laser's wavelength: what the realistic model's
# detection step weighs in place of its class's material draw (core/realism/lost_returns.py)
REFLECTANCE_PROP = "wildscan_reflectance"
MAX_REFLECTIVITY = 1000.0


def object_tags(name: str, class_tag: object, instance_tag: object, reflectivity: object = None):
    """(class id, instance id, reflectivity override or None) of the object `name` from its
    custom-property values (None where it has none). A tag the user got wrong is a
    UserError naming the object, the value and what is allowed: a class must be one of
    TAG_NAMES (case, `_`, `-` and extra spaces do not matter), an instance a whole number
    in 0..MAX_INSTANCE, a reflectivity a number in [0, MAX_REFLECTIVITY]."""
    class_id = UNLABELED.id if class_tag is None else _strict_class(name, class_tag)
    instance = 0 if instance_tag is None else _strict_instance(name, instance_tag)
    override = None if reflectivity is None else _strict_reflectivity(name, reflectivity)
    return class_id, instance, override


def object_reflectance(name: str, value: object) -> float:
    """The object `name`'s `wildscan_reflectance` (a number from 0 to 1), or a UserError naming
    the object, the value and what is allowed."""
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not ok or not 0.0 <= float(value) <= 1.0:
        raise UserError(
            f"object {name!r} has {REFLECTANCE_PROP} = {value!r}; it must be a number from 0 to 1 "
            "(its diffuse reflectance at the laser's wavelength)",
            allowed=(0.0, 1.0),
        )
    return float(value)


def _strict_class(name: str, tag: object) -> int:
    if isinstance(tag, str) and normalize_name(tag) in _BY_NAME:
        return _BY_NAME[normalize_name(tag)].id
    allowed = ", ".join(TAG_NAMES)
    raise UserError(
        f"object {name!r} has {CLASS_PROP} = {tag!r}, which is not a class; allowed: {allowed}",
        allowed=TAG_NAMES,
    )


def _strict_instance(name: str, tag: object) -> int:
    value = tag
    if isinstance(value, float) and value.is_integer():
        value = int(value)
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_INSTANCE:
        raise UserError(
            f"object {name!r} has {INSTANCE_PROP} = {tag!r}; it must be a whole number from 0 to "
            f"{MAX_INSTANCE}",
            allowed=(0, MAX_INSTANCE),
        )
    return value


def _strict_reflectivity(name: str, value: object) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not ok or not 0.0 <= float(value) <= MAX_REFLECTIVITY:
        raise UserError(
            f"object {name!r} has {REFLECTIVITY_PROP} = {value!r}; it must be a number from 0 to "
            f"{MAX_REFLECTIVITY:g}",
            allowed=(0.0, MAX_REFLECTIVITY),
        )
    return float(value)


def reflectivity_of(class_ids: np.ndarray) -> np.ndarray:
    """What the emulated sensor measures as intensity for each hit class."""
    return REFLECTIVITY_BY_ID[np.asarray(class_ids, dtype=np.intp)]


def label_from_reflectivity(intensity: np.ndarray) -> np.ndarray:
    """Label each return by its intensity, as the paper does (Table I is a bijection).

    Water (120) maps to WATER_ID so the caller can drop it; an intensity that
    matches no class is a programming error and raises.
    """
    intensity = np.asarray(intensity, dtype=np.float32)
    order = np.array(sorted(BY_ID, key=lambda i: BY_ID[i].reflectivity))
    sorted_refl = REFLECTIVITY_BY_ID[order]
    pos = np.clip(np.searchsorted(sorted_refl, intensity), 0, len(sorted_refl) - 1)
    if not np.all(sorted_refl[pos] == intensity):
        bad = np.unique(intensity[sorted_refl[pos] != intensity])
        raise ValueError(f"intensities match no class: {bad[:5]}")
    return order[pos].astype(np.uint16)


# The label each class's reflectivity reads back as (label_from_reflectivity of every class,
# taken once here): a scan labels its beams by class id through it, one gather a beam where
# reading each beam's intensity back took a sorted search, with the same labels.
LABEL_BY_ID = np.zeros(NUM_IDS, dtype=np.uint16)  # an id no class has (a gap in the ids) reads 0
LABEL_BY_ID[sorted(BY_ID)] = label_from_reflectivity(REFLECTIVITY_BY_ID[sorted(BY_ID)])


def counts_by_class(label: np.ndarray, bins: np.ndarray, bin_count: int) -> dict[str, list[int]]:
    """{class id as text: its points' counts in each of `bin_count` bins}, for the classes
    present, in id order: one bincount over (class, bin) pairs, where one per class read
    every point once for each class."""
    label = np.asarray(label, dtype=np.int64)
    if not len(label):
        return {}
    counts = np.bincount(label * bin_count + bins, minlength=(int(label.max()) + 1) * bin_count)
    counts = counts.reshape(-1, bin_count)
    return {str(c): counts[c].tolist() for c in np.flatnonzero(counts.sum(axis=1)).tolist()}


def colors_of(labels: np.ndarray) -> np.ndarray:
    """(N, 3) uint8 colour tags for PLY labels."""
    return COLOR_BY_ID[np.asarray(labels, dtype=np.intp)]


# The classes a point can carry, in id order: every class but water (never a label).
LABELS: tuple[ElementClass, ...] = tuple(
    sorted((c for c in ALL_ELEMENTS if c is not WATER), key=lambda c: c.id)
)


def listed_classes(labels: np.ndarray = (), declared=()) -> tuple[ElementClass, ...]:
    """The classes a scan's files list (PLY header and sidecar, labels.yaml, class weights, LAS):
    every class that is not optional, and each optional one that `declared` names (the ids the
    scan's effects can produce, `Effects.classes`, or a table the scan already carries) or a
    point carries (`labels`). In id order. The one answer every writer reads, so a file's
    tables agree with each other and with its points."""
    present = set(ids_present(labels)) | {int(i) for i in declared}
    return tuple(c for c in LABELS if not c.optional or c.id in present)


def ids_present(labels) -> list[int]:
    """The ids among `labels` (class ids are small and non-negative: a count per id costs one
    pass, where np.unique sorts every point: ~25x faster on a 100 k-point scan)."""
    ids = np.asarray(labels, dtype=np.int64).ravel()
    if ids.size == 0:
        return []
    if ids.min() < 0:  # not a class id; let the caller's tables ignore it as before
        return np.unique(ids).tolist()
    return np.flatnonzero(np.bincount(ids)).tolist()


def table_ids(table) -> tuple[int, ...]:
    """The ids of a class table as `class_table_dict` writes it (a scan's metadata "classes")."""
    return tuple(int(row["id"]) for row in table or ())


def class_table_lines(classes: tuple[ElementClass, ...] | None = None) -> list[str]:
    """One line per class a file lists (`listed_classes`; None: the classes that are not
    optional), for PLY headers."""
    return [
        f"{c.id} {c.name.replace(' ', '_')} reflectivity={c.reflectivity:g} rgb={','.join(map(str, c.color))}"
        for c in (listed_classes() if classes is None else classes)
    ]


def class_table_dict(classes: tuple[ElementClass, ...] | None = None) -> list[dict]:
    """The same table for sidecars and metadata."""
    return [
        {"id": c.id, "name": c.name, "reflectivity": c.reflectivity, "color": list(c.color)}
        for c in (listed_classes() if classes is None else classes)
    ]
