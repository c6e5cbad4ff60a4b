"""Tiles of the endless landscape and their level of detail (numpy only).

Tile (i, j) is the square [i TILE_M, (i+1) TILE_M) x [j TILE_M, (j+1) TILE_M). Its level of
detail is 0 (full) to len(LEVEL_FOOTPRINT) - 1, chosen from the beam spacing at the tile's
nearest point to the sensor (its distance times the device's finest angle between beams):
the level is the number of LEVEL_FOOTPRINT thresholds that spacing reaches. What each level
leaves out is what beams that far apart cannot resolve:

    level  beam spacing   terrain lattice     left out
    0      < 0.25 m       full (1 m default)  nothing
    1      0.25-0.6 m     full                grass tufts and reeds (~0.3 m), stumps
    2      0.6-1.5 m      2x                  and stones under SMALL_ROCK
    3      >= 1.5 m       5x                  as level 2

tile_levels(device, x, y, lod) gives them for a sensor at (x, y): every tile within the
device's range plus RANGE_MARGIN; with lod off every tile is level 0. Seams between levels
stay closed by each tile's skirt (build.py).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import UserError

# m, side of a tile: small enough that a short-range scanner's disc (the UTM-30LX-EW's 30 m)
# needs little more than it sees (a 15 m disc touches 1-4 tiles, 0.25-1 ha), large enough that a
# 120 m device needs ~25 of them
TILE_M = 50.0
# m between the terrain lattice's nodes at full detail, per detail level (stages' detail.py
# names): the terrain's finest noise octave is ~7 m, so a 1 m lattice stays within ~2 cm of
# the analytic field (s^2/8 times its curvature), today's default tolerance's range
TERRAIN_SPACING = {"low": 2.5, "default": 1.0, "high": 0.5}
LEVEL_FOOTPRINT = (0.0, 0.25, 0.6, 1.5)  # m of beam spacing from which each level applies
LEVEL_FACTORS = (1, 1, 2, 5)  # lattice spacing per level, in full-detail spacings (divide TILE_M)
SMALL_DROP_LEVEL = 1  # from this level on tufts, reeds and stumps are left out
ROCK_DROP_LEVEL = 2  # from this level on stones under SMALL_ROCK are left out
FULL_DETAIL_M = 25.0  # m: tiles nearer the sensor than this are always full detail
RANGE_MARGIN = 5.0  # m beyond the device's range a tile is still built
MAX_TILE_INDEX = 180  # tiles -180..180 each way (±9 km): instance ids stay within int32
LOD_CHOICES = ("on", "off")


def tile_of(x: float, y: float) -> tuple[int, int]:
    return math.floor(x / TILE_M), math.floor(y / TILE_M)


def tile_rect(i: int, j: int) -> tuple[float, float, float, float]:
    """(xmin, xmax, ymin, ymax) of tile (i, j)."""
    return i * TILE_M, (i + 1) * TILE_M, j * TILE_M, (j + 1) * TILE_M


def tiles_in_region(xmin: float, ymin: float, xmax: float, ymax: float) -> list[tuple[int, int]]:
    """The tiles a region (metres) overlaps, row by row."""
    i0, j0 = tile_of(xmin, ymin)
    i1, j1 = math.ceil(xmax / TILE_M) - 1, math.ceil(ymax / TILE_M) - 1
    return [(i, j) for j in range(j0, max(j1, j0) + 1) for i in range(i0, max(i1, i0) + 1)]


def tile_distance(i: int, j: int, x: float, y: float) -> float:
    """Distance from (x, y) to the nearest point of tile (i, j) (0 inside it)."""
    x0, x1, y0, y1 = tile_rect(i, j)
    dx, dy = max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1)
    return math.hypot(dx, dy)


def tiles_in_disc(x: float, y: float, r: float) -> list[tuple[int, int]]:
    """The tiles any point of which lies within r of (x, y), row by row."""
    return [t for t in tiles_in_region(x - r, y - r, x + r, y + r) if tile_distance(*t, x, y) <= r]


def beam_spacing_rad(device, step_deg: float | None = None) -> float:
    """The device's angle between neighbouring beams (radians), as one number: the square root
    of the solid angle each beam samples, the median gap between its rings' elevations times
    its column step (the mount's default, or `step_deg`: a scan's r_h). A planar fan with no
    column turn (fixed mount) uses its beam gap both ways."""
    elevation = np.sort(np.unique(np.asarray(device.beams.elevation_deg, dtype=np.float64)))
    gaps = np.diff(elevation)
    vertical = float(np.median(gaps)) if len(gaps) else 1.0
    step = float(step_deg if step_deg is not None else device.mount.step_deg)
    step = step if device.mount.kind != "fixed" and step > 0 else vertical
    return math.radians(math.sqrt(vertical * step))


def level_at(distance: float, spacing_rad: float) -> int:
    """The level of a tile whose nearest point is `distance` metres from the sensor, for beams
    `spacing_rad` apart."""
    if distance < FULL_DETAIL_M:
        return 0
    footprint = distance * spacing_rad
    return sum(1 for threshold in LEVEL_FOOTPRINT[1:] if footprint >= threshold)


def tile_levels(
    device, x: float, y: float, lod=True, detail: str = "default", reach: float | None = None
) -> dict[tuple[int, int], int]:
    """{tile: level} for a sensor at (x, y): the tiles within its range plus RANGE_MARGIN,
    each at its level (all 0 with lod off). `device`: a sensors Device (its longest default
    range) or a SensorConfig (its max_range, and r_h as the column step); `lod`: True/False
    or "on"/"off"; `reach`: a range (m) in place of the device's."""
    sensor = device if hasattr(device, "device") else None
    dev = sensor.device if sensor is not None else device
    if reach is None:
        reach = float(sensor.max_range) if sensor is not None else float(dev.ranges.max_m)
    on = lod not in (False, "off")
    spacing = beam_spacing_rad(dev, None if sensor is None else float(sensor.rh_deg))
    out = {}
    for t in tiles_in_disc(x, y, float(reach) + RANGE_MARGIN):
        out[t] = level_at(tile_distance(*t, x, y), spacing) if on else 0
    return out


def check_tile(i: int, j: int) -> None:
    """A tile the landscape can build (instance ids stay within int32), else a UserError."""
    if abs(i) > MAX_TILE_INDEX or abs(j) > MAX_TILE_INDEX:
        limit = MAX_TILE_INDEX * TILE_M
        raise UserError(
            f"reaches tile ({i}, {j}), beyond ±{limit:g} m of the origin, the endless landscape's reach",
            setting="region",
            allowed=(-limit, limit),
        )
