"""A dataset's intensity (numpy only): `physical`, a sensor-like return strength that does not
name the class, or `class`, the paper's tag (Table I reflectivity of the point's class).

Both are in percent (0..100) in `PointCloud.intensity`, so every format carries the same
number: PLY `intensity` float 0..100, LAS `intensity` uint16 0..100 (rounded), SemanticKITTI
remission = intensity / 100 in [0, 1] (docs/formats.md "Intensity").

Physical: the lidar range equation for an extended Lambertian target (received power
∝ ρ cos θ / R²; Höfle & Pfeifer, "Correction of laser scanning intensity data: Data and
model-driven approaches", ISPRS J. Photogramm. 62(6), 2007, Eq. 1-3; Kashani et al., "A
Review of LIDAR Radiometric Processing", Sensors 15(11), 2015, doi:10.3390/s151128099):

    remission = ρ_s · cos θ · min(1, (R_NEAR / R)²) · speckle

ρ_s is the surface's own reflectance at the 905 nm of the UTM-30LX-EW, drawn per surface
(per instance; the terrain per spot of ground) from its class's material range below, so
two trunks, two bushes or two patches of soil differ and the ranges of different classes
overlap: intensity no longer identifies the class. The 1/R² loss holds beyond R_NEAR;
closer, terrestrial scanners' intensity stops rising as 1/R² (near-range reduction of the
receiver: Kaasalainen et al., "Analysis of Incidence Angle and Distance Effects on
Terrestrial Laser Scanner Intensity", Remote Sensing 3(10), 2011, doi:10.3390/rs3102207,
Figs. 5-6), modelled as flat. The UTM-30LX-EW's datasheet gives no intensity calibration,
so R_NEAR = 5 m is a modelling choice that spreads the remission over [0, 1] within its 30 m.
speckle is a per-point factor in [1 - SPECKLE, 1 + SPECKLE] (the return of a rough surface
fluctuates pulse to pulse), clipped so remission stays in [0, 1].
"""

from __future__ import annotations

import numpy as np

from ..classes import GROUND_IDS, NUM_IDS, REFLECTIVITY_BY_ID, WATER_ID, class_by_name, counts_by_class
from ..rng import hash_unit
from ..world.cover import is_cover_instance

INTENSITY_MODES = ("physical", "class")
DEFAULT_DATASET_INTENSITY = "physical"
R_NEAR = 5.0  # m: below it the return strength is flat (see the module docstring)
SPECKLE = 0.15  # relative pulse-to-pulse fluctuation of a return's strength
TERRAIN_CELL = 4.0  # m: the size of the terrain's patches of one soil (moisture, litter)
COS_FLOOR = 0.05  # a grazing return still reads this much (cos 87 deg)

# Reflectance at 905 nm (fraction) of the materials of each class: the (low, high) a
# surface of that class draws from uniformly. Read off the ECOSTRESS spectral library
# (Meerdink et al., Remote Sens. Environ. 230, 2019, https://speclib.jpl.nasa.gov) at
# 0.9 µm and widened for weathering, moisture and canopy gaps: soils 0.1-0.45 (wet dark
# loam to dry sand), bark 0.25-0.55, green leaves and grass 0.35-0.6 (the NIR plateau),
# dry grass 0.25-0.55, rocks 0.1-0.5 (basalt to granite), weathered wood 0.3-0.6, galvanised
# steel wire 0.1-0.4. Water droplets (the particle class) return little: 0.02-0.1.
MATERIALS: dict[str, tuple[float, float]] = {
    "unlabeled": (0.2, 0.6),
    "terrain": (0.10, 0.45),
    "trunk": (0.25, 0.55),
    "treetop": (0.35, 0.60),
    "table": (0.30, 0.60),
    "bush": (0.35, 0.60),
    "fence": (0.30, 0.60),
    "bench": (0.30, 0.60),
    "low grass": (0.35, 0.60),
    "rock": (0.10, 0.50),
    "high grass": (0.25, 0.55),
    "wire": (0.10, 0.40),
    "pole": (0.20, 0.50),
    "log": (0.20, 0.50),
    "particle": (0.02, 0.10),
    # the endless landscape's ground materials (classes.GROUND_MATERIALS), at 0.9 um: dry soils
    # 0.2-0.45 (ECOSTRESS soils, above); gravel and crushed stone 0.2-0.45 (USGS splib07,
    # Kokaly et al. 2017, doi:10.3133/ds1035: limestone and granite chips); wet soil and mud
    # about half its dry reflectance, 0.05-0.2 (Lobell & Asner 2002, "Moisture effects on soil
    # reflectance", Soil Sci. Soc. Am. J. 66:722-727); asphalt 0.05-0.2, darker when new
    # (Herold et al. 2004, "Spectrometry for urban area remote sensing", Remote Sens. Environ.
    # 91:304-319); dry leaf litter, non-photosynthetic vegetation, 0.3-0.5 (ECOSTRESS
    # non-photosynthetic vegetation spectra); bare rock 0.1-0.5 (as rock above)
    "soil": (0.20, 0.45),
    "gravel": (0.20, 0.45),
    "mud": (0.05, 0.20),
    "paved": (0.05, 0.20),
    "leaf litter": (0.30, 0.50),
    "rock slab": (0.10, 0.50),
}


def _material_table() -> tuple[np.ndarray, np.ndarray]:
    low = np.full(NUM_IDS, MATERIALS["unlabeled"][0])
    high = np.full(NUM_IDS, MATERIALS["unlabeled"][1])
    for name, (lo, hi) in MATERIALS.items():
        try:
            cid = class_by_name(name).id
        except (KeyError, ValueError):
            continue  # a class this version does not have yet (log)
        low[cid], high[cid] = lo, hi
    low[WATER_ID] = high[WATER_ID] = 0.0
    return low, high


MATERIAL_LOW, MATERIAL_HIGH = _material_table()
TERRAIN_ID = class_by_name("terrain").id


def _terrain_field(seed: int, xy: np.ndarray) -> np.ndarray:
    """A smooth [0, 1) value over the ground (bilinear between per-cell draws): patches of
    one soil a few metres wide, not one number for the whole terrain. (x and y as separate
    columns: numpy's reductions and arithmetic over an (N, 2) array's axis 0 are several
    times slower than over two contiguous arrays, for the same numbers.)"""
    xy = np.asarray(xy, dtype=np.float64)
    gx, gy = xy[:, 0] / TERRAIN_CELL, xy[:, 1] / TERRAIN_CELL
    ix, iy = np.floor(gx).astype(np.int64), np.floor(gy).astype(np.int64)
    fx, fy = gx - ix, gy - iy
    draw = _cell_draws(np.int64(seed), ix, iy)

    def corner(dx, dy):
        return draw(ix + dx, iy + dy)

    top = corner(0, 0) * (1 - fx) + corner(1, 0) * fx
    bottom = corner(0, 1) * (1 - fx) + corner(1, 1) * fx
    return top * (1 - fy) + bottom * fy


def _cell_draws(seed: np.int64, ix: np.ndarray, iy: np.ndarray):
    """The draw of each lattice corner (ix, iy) around the cells (ix, iy): hashed once per
    corner into a table when the corners are fewer than the points (a scan's terrain spans a
    few dozen cells), else per point; the same numbers either way."""
    if not len(ix):
        return lambda cx, cy: hash_unit(seed, np.int64(0x7E44A1), cx, cy)
    low_x, low_y = int(ix.min()), int(iy.min())
    size_x, size_y = int(ix.max()) + 2 - low_x, int(iy.max()) + 2 - low_y
    if size_x * size_y > len(ix):
        return lambda cx, cy: hash_unit(seed, np.int64(0x7E44A1), cx, cy)
    table = hash_unit(
        seed, np.int64(0x7E44A1), low_x + np.arange(size_x)[:, None], low_y + np.arange(size_y)[None, :]
    ).ravel()
    return lambda cx, cy: table.take((cx - low_x) * size_y + (cy - low_y))


def surface_reflectance(
    seed: int, label: np.ndarray, instance: np.ndarray, world_xy: np.ndarray
) -> np.ndarray:
    """ρ_s (fraction) per point: its surface's draw within its class's material range."""
    label = np.asarray(label, dtype=np.intp)
    u = _hash_per_run(np.int64(seed), label, np.asarray(instance, dtype=np.int64))
    # the terrain, and the ground cover's sward (one instance a class: core/world/cover.py), vary
    # spot by spot rather than one draw for the whole surface
    terrain = (label == TERRAIN_ID) | is_cover_instance(instance)
    if len(label) and label.max() >= min(GROUND_IDS):  # the endless landscape's ground materials
        terrain |= np.isin(label, GROUND_IDS)
    if terrain.any():
        u[terrain] = _terrain_field(seed, np.asarray(world_xy)[terrain])
    return MATERIAL_LOW[label] + (MATERIAL_HIGH[label] - MATERIAL_LOW[label]) * u


def _hash_per_run(seed: np.int64, label: np.ndarray, instance: np.ndarray) -> np.ndarray:
    """hash_unit(seed, label, instance), hashed once per run of points on one surface (a
    scan's points follow its beams, and neighbouring beams mostly meet the same surface):
    the same numbers, each a pure function of its keys."""
    if len(label) < 2:
        return hash_unit(seed, label, instance)
    heads = np.flatnonzero(
        np.concatenate([[True], (label[1:] != label[:-1]) | (instance[1:] != instance[:-1])])
    )
    runs = np.diff(np.append(heads, len(label)))
    return np.repeat(hash_unit(seed, label.take(heads), instance.take(heads)), runs)


def range_factor(distance: np.ndarray) -> np.ndarray:
    """min(1, (R_NEAR / R)²): the 1/R² loss beyond R_NEAR, flat closer."""
    r = np.maximum(np.asarray(distance, dtype=np.float64), 1e-6)
    return np.minimum(1.0, (R_NEAR / r) ** 2)


def speckle(seed: int, scan: int, count: int) -> np.ndarray:
    """The per-point factor in [1 - SPECKLE, 1 + SPECKLE] of scan `scan` of world `seed`."""
    u = hash_unit(np.int64(seed), np.int64(scan), np.int64(0x5BEC), np.arange(count, dtype=np.int64))
    return 1.0 - SPECKLE + 2.0 * SPECKLE * u


def physical_percent(reflectance: np.ndarray, cos_incidence: np.ndarray, distance, factor) -> np.ndarray:
    """100 · ρ_s · cos θ · min(1, (R_NEAR/R)²) · speckle, clipped to 0..100."""
    cos = np.clip(np.abs(np.asarray(cos_incidence, dtype=np.float64)), COS_FLOOR, 1.0)
    value = 100.0 * reflectance * cos * range_factor(distance) * factor
    return np.clip(value, 0.0, 100.0)


def class_percent(label: np.ndarray) -> np.ndarray:
    """The paper's tag: the Table I reflectivity of each point's class (0..100)."""
    return np.nan_to_num(REFLECTIVITY_BY_ID[np.asarray(label, dtype=np.intp)].astype(np.float64))


# ---------------------------------------------------------------------------------------
# how much the remission says about the label (the dataset card)

REMISSION_BINS = 100  # 0.01 wide over [0, 1]


def remission_histogram(remission: np.ndarray, label: np.ndarray) -> dict[str, list[int]]:
    """{class id: counts of its points per remission bin}, for the classes present."""
    bins = np.clip((np.asarray(remission, dtype=np.float64) * REMISSION_BINS).astype(np.int64), 0, 99)
    return counts_by_class(label, bins, REMISSION_BINS)


def add_histograms(total: dict[str, list[int]], more: dict[str, list[int]]) -> dict[str, list[int]]:
    for cid, counts in more.items():
        have = total.get(cid, [0] * REMISSION_BINS)
        total[cid] = [a + b for a, b in zip(have, counts, strict=True)]
    return total


def _by_class_id(histogram: dict[str, list[int]]) -> np.ndarray:
    """The histogram as a (classes, bins) table in class-id order: the rows' order must not
    depend on which scan a run wrote first (a resumed run adds them in another order, and
    the mean of the recalls and the ties would follow it)."""
    return np.array([histogram[cid] for cid in sorted(histogram, key=int)], dtype=np.int64)


def lookup_accuracy(histogram: dict[str, list[int]]) -> float | None:
    """The share of points a lookup on remission alone labels right: each 0.01 bin of
    remission predicts its most common class. 1.0 when each class has its own value."""
    if not histogram:
        return None
    table = _by_class_id(histogram)
    total = int(table.sum())
    return float(table.max(axis=0).sum() / total) if total else None


def majority_share(histogram: dict[str, list[int]]) -> float | None:
    """The share of the commonest class: what a lookup that ignores remission reaches."""
    table = _by_class_id(histogram)
    total = int(table.sum()) if len(table) else 0
    return float(table.sum(axis=1).max() / total) if total else None


def balanced_lookup_accuracy(histogram: dict[str, list[int]]) -> float | None:
    """The remission lookup's recall averaged over the classes (each class counts the same,
    so the commonest class does not hide what remission says about the rare ones)."""
    table = _by_class_id(histogram)
    if not len(table) or not table.sum():
        return None
    predicted = np.argmax(table, axis=0)  # per bin (ties: the first class listed)
    right = table[predicted, np.arange(table.shape[1])]
    recall = np.bincount(predicted, right, minlength=len(table)) / np.maximum(table.sum(axis=1), 1)
    return float(recall[table.sum(axis=1) > 0].mean())
