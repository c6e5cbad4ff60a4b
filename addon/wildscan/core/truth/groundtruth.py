"""Ground truth a real dataset cannot have (numpy only): per point, the height above the
ground the robot stands on under it (`hag`), and per scan a bird's-eye grid around the robot
of that ground's height and the class seen from straight above.

The ground is `WorldPlan.standing_ground()` (core/world/ground.py): the triangulated terrain
mesh every element stands on and, on the trail, the top of its flooring; not the points:
under a bush or a tree crown it is the ground the robot would drive on.

Bird's-eye grid: 300 x 300 cells of 0.1 m, a 30 m square centred on the optical
centre and aligned with the leveled frame (rows along X, the heading; columns along
Y, to the left). Cell [i, j] has its centre at x = -14.95 + 0.1 i, y = -14.95 + 0.1 j
in the leveled frame, so a leveled point falls in cell (floor((x + 15) / 0.1),
floor((y + 15) / 0.1)). `terrain_z` is that ground's height there in the leveled frame
(metres relative to the optical centre; NaN off the world); `top_class` is the class of
the first surface a ray straight down from above the world meets at the cell centre
(0 when it meets nothing), in WildScan ids, water included (13).
"""

from __future__ import annotations

import io
from collections.abc import Callable

import numpy as np

from .. import detmath as dm
from ..placement import Placement
from ..spatial.leveling import rot_z

BEV_CELL = 0.1  # m
BEV_SIZE = 30.0  # m, side of the square
BEV_CELLS = round(BEV_SIZE / BEV_CELL)
# terrain_z and top_class; the traversability fields (core/truth/traversability.py) after them
BEV_DTYPE = np.dtype(
    [
        ("terrain_z", "<f4"),
        ("top_class", "<u2"),
        ("cover_height", "<f4"),
        ("slope", "<f4"),
        ("overhead", "<f4"),
    ]
)
_ABOVE = 1.0  # m above the highest surface where the downward rays start

Ground = Callable[[np.ndarray, np.ndarray], np.ndarray]


def frame_to_world(placement: Placement, frame: str) -> tuple[np.ndarray, np.ndarray]:
    """(R (3,3), t (3,)) with world = R @ p + t for a point p of a scan in `frame`.
    Leveled: Rz(yaw) about the optical centre (docs/architecture.md "Frames"); sensor: the tilted
    structure's rotation; world: the identity."""
    if frame == "world":
        return np.eye(3), np.zeros(3)
    rotation = rot_z(placement.yaw_rad) if frame == "leveled" else placement.rotation
    return rotation, np.asarray(placement.optical_centre, dtype=np.float64)


def pose_matrix(placement: Placement, frame: str) -> np.ndarray:
    """The 4x4 matrix taking a scan's points (in `frame`) to the world frame."""
    rotation, translation = frame_to_world(placement, frame)
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = rotation, translation
    return m


def world_points(xyz: np.ndarray, placement: Placement, frame: str) -> np.ndarray:
    rotation, translation = frame_to_world(placement, frame)
    return dm.apply(rotation, np.asarray(xyz, dtype=np.float64)) + translation


def height_above_ground(world_xyz: np.ndarray, ground: Ground) -> np.ndarray:
    """z minus the terrain height under each point (float32, metres)."""
    world_xyz = np.asarray(world_xyz, dtype=np.float64)
    if not len(world_xyz):
        return np.zeros(0, dtype=np.float32)
    # x and y as contiguous arrays once: the ground's steps would each copy a strided column
    x, y = (np.ascontiguousarray(world_xyz[:, k]) for k in (0, 1))
    return (world_xyz[:, 2] - ground(x, y)).astype(np.float32)


def bev_cell_centres() -> np.ndarray:
    """Leveled-frame coordinate of each row (and column) centre, (300,)."""
    return (np.arange(BEV_CELLS) + 0.5) * BEV_CELL - BEV_SIZE / 2


def bev_grid(
    top_classes: Callable[[np.ndarray, float], np.ndarray],
    ground: Ground,
    placement: Placement,
    extent: tuple[float, float, float, float],
    z_range: tuple[float, float],
    traversability: Callable[[np.ndarray, np.ndarray, np.ndarray], dict[str, np.ndarray]] | None = None,
) -> np.ndarray:
    """The (300, 300) BEV_DTYPE grid of a scan (see the module docstring).
    `top_classes(origins (N,3), max_range)` gives the class of the first surface straight
    below each origin (0 for none); `z_range` is the lowest and highest height of any surface;
    `traversability(x, y, z)` the traversability fields at world points, z the ground's height
    there (NaN without it)."""
    u = bev_cell_centres()
    uu, vv = np.meshgrid(u, u, indexing="ij")
    s, c = dm.sincos(placement.yaw_rad)
    ox, oy, oz = (float(v) for v in placement.optical_centre)
    x, y = ox + c * uu - s * vv, oy + s * uu + c * vv
    x0, x1, y0, y1 = extent
    inside = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
    # Only the cells on the world are evaluated (a pose near its edge has part of its grid
    # off it): every value is a cell's own, so the grid holds the same bytes as one
    # evaluated whole and masked.
    x, y = x[inside], y[inside]
    grid = np.zeros(uu.shape, dtype=BEV_DTYPE)
    for name in ("terrain_z", "cover_height", "slope", "overhead"):
        grid[name] = np.nan
    z = ground(x, y)
    grid["terrain_z"][inside] = z - oz
    start = z_range[1] + _ABOVE
    origins = np.column_stack([x, y, np.full(x.size, start)])
    grid["top_class"][inside] = top_classes(origins, start - z_range[0] + _ABOVE)
    fields = traversability(x, y, z) if traversability is not None else {}
    for name in ("cover_height", "slope", "overhead"):
        if name in fields:
            grid[name][inside] = fields[name]
    return grid


def map_top_class(grid: np.ndarray, lookup: np.ndarray) -> np.ndarray:
    """The grid with `top_class` translated by a label scheme's lookup (indexed by WildScan id)."""
    out = grid.copy()
    out["top_class"] = lookup[grid["top_class"].astype(np.intp)]
    return out


def npy_bytes(array: np.ndarray) -> bytes:
    """`np.save` into memory: a .npy file any numpy reads with np.load (deterministic)."""
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    return buffer.getvalue()
