"""What the label ids of a dataset mean: WildScan's own ids, or those of SemanticKITTI,
RELLIS-3D, GOOSE or WildScenes, so a model trained on one of those datasets reads our scans directly.
Numpy only.

Every WildScan class (classes.py, plus water, which appears only in the bird's-eye
grids) maps to one id of the scheme, by name: each scheme is a dict `{"trunk": 71, ...}`
checked when this module is imported, so a class missing from a scheme (or a name that is
no class) stops the import with a message naming the scheme and the class. A class with no
counterpart maps to OTHER, the scheme's "other" id, and the table says so. The label
lists and learning maps follow each dataset's published label configuration
(semantic-kitti-api's `semantic-kitti-all.yaml`, RELLIS-3D's `rellis.yaml`, GOOSE's
64-class `goose_label_mapping.csv` order, WildScenes' `wildscenes/tools/utils3d.py` and the
3D benchmark's `configs3d/_base_/datasets/wildscenes.py`); colours are BGR as in those files (GOOSE's
colours are WildScan's own, which the GOOSE files do not fix here).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .classes import ALL_ELEMENTS, BY_ID, CLASSES, GROUND_IDS, OPTIONAL_CLASSES, PARTICLE_ID, WATER_ID

SCHEME_NAMES = ("wildscan", "semantickitti", "rellis3d", "goose", "wildscenes")
OTHER = "other"  # a class with no counterpart in a scheme: it gets the scheme's "other" id


class SchemeError(ValueError):
    """A class table that does not cover the classes of core/classes.py exactly."""


def ids_by_class_id(scheme_name: str, by_class: dict[str, int | str], other: int | None) -> dict[int, int]:
    """WildScan id -> the scheme's id, from a dict by class name (OTHER: the scheme's "other"
    id). SchemeError naming the scheme and the classes unless `by_class` names every class
    of ALL_ELEMENTS (water included) and nothing else."""
    names = {c.name for c in ALL_ELEMENTS}
    missing = [c.name for c in ALL_ELEMENTS if c.name not in by_class]
    unknown = sorted(set(by_class) - names)
    if missing or unknown:
        why = [f"has no id for class {', '.join(map(repr, missing))}"] if missing else []
        why += [f"names {', '.join(map(repr, unknown))}, which is no class"] if unknown else []
        raise SchemeError(
            f"label scheme {scheme_name!r} {' and '.join(why)} (core/classes.py lists "
            f"{', '.join(c.name for c in ALL_ELEMENTS)}): give every class one entry"
        )
    if other is None and OTHER in by_class.values():
        raise SchemeError(f"label scheme {scheme_name!r} has no other id, yet maps a class to OTHER")
    return {c.id: (other if by_class[c.name] == OTHER else by_class[c.name]) for c in ALL_ELEMENTS}


@dataclass(frozen=True)
class LabelScheme:
    name: str
    title: str
    labels: dict[int, str]  # raw id -> name, the ids written to the label files
    colors_bgr: dict[int, tuple[int, int, int]]
    by_class: dict[str, int | str]  # WildScan class name -> raw id, or OTHER (the table as written)
    other: int | None  # the id that classes without a counterpart get (None: every class has one)
    learning_map: dict[int, int]
    learning_map_inv: dict[int, int]
    learning_ignore: dict[int, bool]
    from_wildscan: dict[int, int] = field(init=False, repr=False)  # WildScan id -> raw id, from by_class
    # What a label config lists for data without an optional class (classes.listed_classes; the
    # bytes it had before that class): not the raw ids only that class uses (`only_for`, by
    # WildScan id), and the colours of `colors_without` where that class's differ.
    only_for: dict[int, tuple[int, ...]] = field(default_factory=dict)
    colors_without: dict[int, dict[int, tuple[int, int, int]]] = field(default_factory=dict)

    def __post_init__(self):
        from_wildscan = ids_by_class_id(self.name, self.by_class, self.other)
        unknown = sorted({raw for raw in from_wildscan.values() if raw not in self.labels})
        if unknown:
            raise SchemeError(f"label scheme {self.name!r} maps classes to ids it does not list: {unknown}")
        object.__setattr__(self, "from_wildscan", from_wildscan)  # frozen: set once, here

    def lookup(self) -> np.ndarray:
        """uint16 table indexed by WildScan id giving the raw id."""
        table = np.zeros(max(BY_ID) + 1, dtype=np.uint16)
        for wildscan_id, raw in self.from_wildscan.items():
            table[wildscan_id] = raw
        return table

    def map(self, wildscan_ids: np.ndarray) -> np.ndarray:
        return self.lookup()[np.asarray(wildscan_ids, dtype=np.intp)]

    def config_tables(self, classes) -> dict[str, dict]:
        """The tables of a label config (labels.yaml) for data that lists `classes`
        (classes.listed_classes): without the raw ids and colours of the optional classes it
        does not list (`only_for`, `colors_without`)."""
        listed = {c.id for c in classes}
        absent = [i for i in (*self.only_for, *self.colors_without) if i not in listed]
        dropped = {raw for i in absent for raw in self.only_for.get(i, ())}
        colors = dict(self.colors_bgr)
        for i in absent:
            colors.update(self.colors_without.get(i, {}))
        tables = dict(
            labels=self.labels,
            color_map=colors,
            learning_map=self.learning_map,
            learning_map_inv=self.learning_map_inv,
            learning_ignore=self.learning_ignore,
        )
        return {name: {k: v for k, v in t.items() if k not in dropped} for name, t in tables.items()}

    def is_other(self, wildscan_id: int) -> bool:
        """Whether this class has no counterpart in the scheme (it got the "other" id)."""
        return self.by_class[BY_ID[wildscan_id].name] == OTHER


def _bgr(rgb: tuple[int, int, int]) -> tuple[int, int, int]:
    return rgb[2], rgb[1], rgb[0]


def _identity(ids) -> dict[int, int]:
    return {i: i for i in ids}


# -- WildScan's own ids (classes.py); water only ever appears in a bird's-eye grid ---------------

_WILDSCAN = LabelScheme(
    name="wildscan",
    title="WildScan (paper Table I)",
    labels={c.id: c.name for c in ALL_ELEMENTS},
    colors_bgr={c.id: _bgr(c.color) for c in ALL_ELEMENTS if c.id != WATER_ID} | {WATER_ID: (255, 128, 0)},
    by_class={c.name: c.id for c in ALL_ELEMENTS},
    other=None,
    # weather's particles are a class to learn (to filter them), not noise to ignore
    learning_map={
        **_identity(c.id for c in CLASSES),
        0: 0,
        WATER_ID: 0,
        **_identity(c.id for c in OPTIONAL_CLASSES),
    },
    learning_map_inv={0: 0, **_identity(c.id for c in (*CLASSES, *OPTIONAL_CLASSES))},
    learning_ignore={0: True, **{c.id: False for c in (*CLASSES, *OPTIONAL_CLASSES)}},
    # the raw ids 15 and 16-21 are weather's and the ground materials' alone
    only_for={PARTICLE_ID: (PARTICLE_ID,), **{i: (i,) for i in GROUND_IDS}},
)

# -- SemanticKITTI (semantic-kitti-api, config/semantic-kitti-all.yaml) ------------------------

_SK_LABELS = {
    0: "unlabeled", 1: "outlier", 10: "car", 11: "bicycle", 13: "bus", 15: "motorcycle", 16: "on-rails",
    18: "truck", 20: "other-vehicle", 30: "person", 31: "bicyclist", 32: "motorcyclist", 40: "road",
    44: "parking", 48: "sidewalk", 49: "other-ground", 50: "building", 51: "fence", 52: "other-structure",
    60: "lane-marking", 70: "vegetation", 71: "trunk", 72: "terrain", 80: "pole", 81: "traffic-sign",
    99: "other-object", 252: "moving-car", 253: "moving-bicyclist", 254: "moving-person",
    255: "moving-motorcyclist", 256: "moving-on-rails", 257: "moving-bus", 258: "moving-truck",
    259: "moving-other-vehicle",
}  # fmt: skip
_SK_COLORS = {
    0: (0, 0, 0), 1: (0, 0, 255), 10: (245, 150, 100), 11: (245, 230, 100), 13: (250, 80, 100),
    15: (150, 60, 30), 16: (255, 0, 0), 18: (180, 30, 80), 20: (255, 0, 0), 30: (30, 30, 255),
    31: (200, 40, 255), 32: (90, 30, 150), 40: (255, 0, 255), 44: (255, 150, 255), 48: (75, 0, 75),
    49: (75, 0, 175), 50: (0, 200, 255), 51: (50, 120, 255), 52: (0, 150, 255), 60: (170, 255, 150),
    70: (0, 175, 0), 71: (0, 60, 135), 72: (80, 240, 150), 80: (150, 240, 255), 81: (0, 0, 255),
    99: (255, 255, 50), 252: (245, 150, 100), 253: (200, 40, 255), 254: (30, 30, 255),
    255: (90, 30, 150), 256: (255, 0, 0), 257: (250, 80, 100), 258: (180, 30, 80), 259: (255, 0, 0),
}  # fmt: skip
_SK_LEARNING_MAP = {
    0: 0, 1: 0, 10: 1, 11: 2, 13: 5, 15: 3, 16: 5, 18: 4, 20: 5, 30: 6, 31: 7, 32: 8, 40: 9, 44: 10,
    48: 11, 49: 12, 50: 13, 51: 14, 52: 0, 60: 9, 70: 15, 71: 16, 72: 17, 80: 18, 81: 19, 99: 0,
    252: 1, 253: 7, 254: 6, 255: 8, 256: 5, 257: 5, 258: 4, 259: 5,
}  # fmt: skip
_SK_LEARNING_MAP_INV = {
    0: 0, 1: 10, 2: 11, 3: 15, 4: 18, 5: 20, 6: 30, 7: 31, 8: 32, 9: 40, 10: 44, 11: 48, 12: 49,
    13: 50, 14: 51, 15: 70, 16: 71, 17: 72, 18: 80, 19: 81,
}  # fmt: skip

_SEMANTICKITTI = LabelScheme(
    name="semantickitti",
    title="SemanticKITTI",
    labels=_SK_LABELS,
    colors_bgr=_SK_COLORS,
    by_class={
        "unlabeled": 0,
        "terrain": 72,  # terrain
        "trunk": 71,  # trunk
        "treetop": 70,  # vegetation
        "table": OTHER,
        "bush": 70,  # vegetation
        "fence": 51,  # fence
        "bench": OTHER,
        "low grass": 72,  # terrain (SemanticKITTI labels grass as terrain)
        "rock": OTHER,
        "high grass": 72,  # terrain
        "wire": OTHER,
        "pole": 80,  # pole
        "water": OTHER,
        "log": 71,  # trunk: SemanticKITTI has no deadwood class; a log is a lying trunk
        "particle": 1,  # outlier (SemanticKITTI's label for spurious returns)
        "soil": 72,  # terrain (SemanticKITTI's terrain: grass and soil)
        "gravel": 49,  # other-ground (unpaved ground that is neither road nor terrain)
        "mud": 72,  # terrain
        "paved": 48,  # sidewalk (a paved path is for walking, not driving)
        "leaf litter": 72,  # terrain
        "rock slab": 49,  # other-ground
    },
    other=99,  # other-object
    # the single-scan (19-class) learning map of semantic-kitti.yaml: moving objects as static
    learning_map=_SK_LEARNING_MAP,
    learning_map_inv=_SK_LEARNING_MAP_INV,
    learning_ignore={k: k == 0 for k in _SK_LEARNING_MAP_INV},
)

# -- RELLIS-3D (benchmarks/.../config/labels/rellis.yaml) --------------------------------------

_RELLIS_LABELS = {
    0: "void", 1: "dirt", 3: "grass", 4: "tree", 5: "pole", 6: "water", 7: "sky", 8: "vehicle",
    9: "object", 10: "asphalt", 12: "building", 15: "log", 17: "person", 18: "fence", 19: "bush",
    23: "concrete", 27: "barrier", 31: "puddle", 33: "mud", 34: "rubble",
}  # fmt: skip
_RELLIS_COLORS = {
    0: (0, 0, 0), 1: (108, 64, 20), 3: (0, 102, 0), 4: (0, 255, 0), 5: (0, 153, 153), 6: (0, 128, 255),
    7: (0, 0, 255), 8: (255, 255, 0), 9: (255, 0, 127), 10: (64, 64, 64), 12: (255, 0, 0),
    15: (102, 0, 0), 17: (204, 153, 255), 18: (102, 0, 204), 19: (255, 153, 204), 23: (170, 170, 170),
    27: (41, 121, 255), 31: (134, 255, 239), 33: (99, 66, 34), 34: (110, 22, 138),
}  # fmt: skip
_RELLIS_LEARNING_MAP = {
    0: 0, 1: 0, 3: 1, 4: 2, 5: 3, 6: 4, 7: 0, 8: 5, 9: 0, 10: 0, 12: 0, 15: 6, 17: 7, 18: 8, 19: 9,
    23: 10, 27: 11, 31: 12, 33: 13, 34: 14,
}  # fmt: skip
# RELLIS-3D's labeled LiDAR points per class (the `content` of rellis.yaml): grass, bush and tree
# are about 45 %, 29 % and 19 % of the labeled (non-void) points.
RELLIS_POINT_COUNTS = {
    "dirt": 0, "grass": 261005182, "tree": 107172982, "pole": 22852, "water": 224173, "sky": 0,
    "vehicle": 111345, "object": 2, "asphalt": 479, "building": 10, "log": 554091, "person": 10626325,
    "fence": 1588416, "bush": 168764964, "concrete": 10944799, "barrier": 3502156, "puddle": 1493276,
    "mud": 5798200, "rubble": 3395458,
}  # fmt: skip

_RELLIS3D = LabelScheme(
    name="rellis3d",
    title="RELLIS-3D",
    labels=_RELLIS_LABELS,
    colors_bgr=_RELLIS_COLORS,
    by_class={
        "unlabeled": 0,  # void
        "terrain": 1,  # dirt
        "trunk": 4,  # tree
        "treetop": 4,  # tree
        "table": OTHER,
        "bush": 19,  # bush
        "fence": 18,  # fence
        "bench": OTHER,
        "low grass": 3,  # grass
        "rock": 34,  # rubble
        "high grass": 3,  # grass
        "wire": OTHER,
        "pole": 5,  # pole
        "water": 6,  # water
        "log": 15,  # log
        "particle": 0,  # void: RELLIS-3D has no class for returns from the air
        "soil": 1,  # dirt
        "gravel": 1,  # dirt (RELLIS-3D's unpaved trails are dirt; it has no gravel class)
        "mud": 33,  # mud
        "paved": 10,  # asphalt
        "leaf litter": 1,  # dirt (the forest floor)
        "rock slab": 34,  # rubble (as rock)
    },
    other=9,  # object
    learning_map=_RELLIS_LEARNING_MAP,
    learning_map_inv={v: k for k, v in _RELLIS_LEARNING_MAP.items() if v or k == 0},
    learning_ignore={v: v == 0 for v in sorted(set(_RELLIS_LEARNING_MAP.values()))},
)

# -- GOOSE (64 classes, goose_label_mapping.csv order) ------------------------------------------

_GOOSE_NAMES = (
    "undefined", "traffic_cone", "snow", "cobble", "obstacle", "leaves", "street_light", "bikeway",
    "ego_vehicle", "pedestrian_crossing", "road_block", "road_marking", "car", "bicycle", "person", "bus",
    "forest", "bush", "moss", "traffic_light", "motorcycle", "sidewalk", "curb", "asphalt", "gravel",
    "boom_barrier", "rail_track", "tree_crown", "tree_trunk", "debris", "crops", "soil", "rider", "animal",
    "truck", "on_rails", "caravan", "trailer", "building", "wall", "rock", "fence", "guard_rail", "bridge",
    "tunnel", "pole", "traffic_sign", "misc_sign", "barrier_tape", "kick_scooter", "low_grass",
    "high_grass", "scenery_vegetation", "sky", "water", "wire", "outlier", "heavy_machinery", "container",
    "hedge", "barrel", "pipe", "tree_root", "military_vehicle",
)  # fmt: skip
_GOOSE_BY_CLASS: dict[str, int | str] = {
    "unlabeled": 0,  # undefined
    "terrain": 31,  # soil
    "trunk": 28,  # tree_trunk
    "treetop": 27,  # tree_crown
    "table": OTHER,
    "bush": 17,  # bush
    "fence": 41,  # fence
    "bench": OTHER,
    "low grass": 50,  # low_grass
    "rock": 40,  # rock
    "high grass": 51,  # high_grass
    "wire": 55,  # wire
    "pole": 45,  # pole
    "water": 54,  # water
    "log": OTHER,  # obstacle: GOOSE's 64 classes have no deadwood class; to a robot a log is an obstacle
    "particle": 56,  # outlier
    "soil": 31,  # soil
    "gravel": 24,  # gravel
    "mud": 31,  # soil (GOOSE has no mud class: wet soil)
    "paved": 23,  # asphalt
    "leaf litter": 5,  # leaves
    "rock slab": 40,  # rock
}
_GOOSE_OTHER = 4  # obstacle


def _goose_colors(particles: bool = True) -> dict[int, tuple[int, int, int]]:
    colors = {i: (160, 160, 160) for i in range(len(_GOOSE_NAMES))}
    elements = ALL_ELEMENTS if particles else [c for c in ALL_ELEMENTS if c.id != PARTICLE_ID]
    # the ground materials keep GOOSE's colours as they were (a label config keeps its bytes)
    for c in (
        c for c in elements if c.id not in GROUND_IDS
    ):  # in id order: where classes share an id, the last one's colour
        if _GOOSE_BY_CLASS[c.name] != OTHER:
            colors[_GOOSE_BY_CLASS[c.name]] = _WILDSCAN.colors_bgr[c.id]
    colors[0] = (0, 0, 0)
    return colors


_GOOSE = LabelScheme(
    name="goose",
    title="GOOSE",
    labels=dict(enumerate(_GOOSE_NAMES)),
    colors_bgr=_goose_colors(),
    # outlier (56) grey without weather, as before it
    colors_without={PARTICLE_ID: {_GOOSE_BY_CLASS["particle"]: _goose_colors(particles=False)[56]}},
    by_class=_GOOSE_BY_CLASS,
    other=_GOOSE_OTHER,
    learning_map=_identity(range(len(_GOOSE_NAMES))),
    learning_map_inv=_identity(range(len(_GOOSE_NAMES))),
    learning_ignore={i: i == 0 for i in range(len(_GOOSE_NAMES))},
)

# -- WildScenes (csiro-robotics/WildScenes at 9eb4e10b) -----------------------------------------
# wildscenes/tools/utils3d.py METAINFO: the classes with their label ids (`cidx`) and RGB palette;
# 255 unlabelled. Its 3D benchmark (wildscenes/configs3d/_base_/datasets/wildscenes.py
# `labels_map`) learns 13 classes, ids 0-9 as they are and 11-13 as 10-12, and ignores (255)
# unlabelled, sky (10) and water (14).

_WS_NAMES = {
    0: "bush", 1: "dirt", 2: "fence", 3: "grass", 4: "gravel", 5: "log", 6: "mud", 7: "other-object",
    8: "other-terrain", 9: "rock", 10: "sky", 11: "structure", 12: "tree-foliage", 13: "tree-trunk",
    14: "water", 255: "unlabelled",
}  # fmt: skip
_WS_RGB = {
    0: (230, 25, 75), 1: (60, 180, 75), 2: (0, 128, 128), 3: (128, 128, 128), 4: (145, 30, 180),
    5: (128, 128, 0), 6: (255, 225, 25), 7: (250, 190, 190), 8: (70, 240, 240), 9: (170, 255, 195),
    10: (0, 0, 128), 11: (170, 110, 40), 12: (210, 245, 60), 13: (240, 50, 230), 14: (0, 130, 200),
    255: (0, 0, 0),
}  # fmt: skip
WILDSCENES_IGNORED = (255, 10, 14)  # unlabelled, sky, water: left out of its benchmark
_WS_LEARNING_MAP = {raw: (255 if raw in WILDSCENES_IGNORED else raw - (raw > 10)) for raw in _WS_NAMES}
# The ground materials of the endless landscape (classes 16-21), mapped as soon as
# core/classes.py has them: WildScenes has gravel and mud of its own; soil is its dirt, a
# rock slab its rock, paving and leaf litter its other-terrain. (Its config always lists all
# 15 ids: no WildScenes config from before them to keep.)
_WS_GROUNDS = {"soil": 1, "gravel": 4, "mud": 6, "paved": 8, "leaf litter": 8, "rock slab": 9}

_WILDSCENES = LabelScheme(
    name="wildscenes",
    title="WildScenes",
    labels=_WS_NAMES,
    colors_bgr={raw: _bgr(rgb) for raw, rgb in _WS_RGB.items()},
    by_class={
        "unlabeled": 255,  # unlabelled
        "terrain": 1,  # dirt
        "trunk": 13,  # tree-trunk
        "treetop": 12,  # tree-foliage
        "table": OTHER,
        "bush": 0,  # bush
        "fence": 2,  # fence
        "bench": OTHER,
        "low grass": 3,  # grass
        "rock": 9,  # rock
        "high grass": 3,  # grass
        "wire": 11,  # structure: a power line is a man-made structure
        "pole": 11,  # structure
        "water": 14,  # water (ignored by the benchmark)
        "log": 5,  # log
        "particle": 255,  # unlabelled: WildScenes has no class for returns from the air
        **{name: raw for name, raw in _WS_GROUNDS.items() if name in {c.name for c in ALL_ELEMENTS}},
    },
    other=7,  # other-object
    learning_map=_WS_LEARNING_MAP,
    learning_map_inv={xid: raw for raw, xid in _WS_LEARNING_MAP.items() if raw not in WILDSCENES_IGNORED[1:]},
    learning_ignore={xid: xid == 255 for xid in sorted(set(_WS_LEARNING_MAP.values()))},
)

SCHEMES: dict[str, LabelScheme] = {
    s.name: s for s in (_WILDSCAN, _SEMANTICKITTI, _RELLIS3D, _GOOSE, _WILDSCENES)
}


def scheme(name: str) -> LabelScheme:
    return SCHEMES[name]


def mapping_table_rows() -> list[tuple[str, ...]]:
    """(WildScan id and name, then per scheme "id name" with "(other)" where it has no counterpart),
    one row per WildScan class: the mapping table of docs/formats.md."""
    rows = []
    for wildscan_id in sorted(BY_ID):
        cells = [f"{wildscan_id} {BY_ID[wildscan_id].name}"]
        for name in SCHEME_NAMES[1:]:
            s = SCHEMES[name]
            raw = s.from_wildscan[wildscan_id]
            cells.append(f"{raw} {s.labels[raw]}" + (" (other)" if s.is_other(wildscan_id) else ""))
        rows.append(tuple(cells))
    return rows
