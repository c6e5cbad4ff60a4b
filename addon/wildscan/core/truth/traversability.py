"""Traversability ground truth (numpy only): what a robot needs to know about the ground that
the class labels alone do not say (docs/ground.md).

Per bird's-eye cell (core/groundtruth.py's grid gains three fields):

  cover_height  m of vegetation over the terrain in the cell: the sward layer's height
                (core/world/cover.py), 0 on bare ground and in the paper biome. A robot drives
                through it; the points in it are grass or bush, not obstacles.
  slope         the standing ground's gradient there (rise over run, m/m: 1 is 45 deg), from
                central differences SLOPE_STEP apart; a robot's climbing limit is a slope.
  overhead      m from the ground up to the first surface above the robot's height there
                (a cave roof, a low branch, a crown), NaN where nothing is within OVERHEAD_REACH
                above it: the clearance a robot needs.

Per point, `support`: 1 where the point lies on the surface the robot would rest on (a terrain
point within SUPPORT_TOLERANCE of the standing ground), 0 elsewhere (grass over it, bushes, the
cave's roof; where the biome covers the ground the roof and the pit's walls are rock, in the
paper biome terrain, and a wall's points lie on the standing ground).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..classes import GROUND_CLASS_IDS, class_by_name, counts_by_class
from ..placement import COLUMN_HEIGHT

TERRAIN_ID = class_by_name("terrain").id
SUPPORT_TOLERANCE = 0.1  # m: the range noise (sigma 1.5 cm, 6 sigma) and the flooring's step
SLOPE_STEP = 0.05  # m: half the bird's-eye cell
# The robot's height: its optical centre (paper section II, placement.COLUMN_HEIGHT) plus the
# scanner's head above it (the UTM-30LX-EW is 87 mm tall, Hokuyo's datasheet; rounded up).
ROBOT_HEIGHT = COLUMN_HEIGHT + 0.1  # m
OVERHEAD_REACH = 10.0  # m above the robot's height looked up to


def support_flags(labels: np.ndarray, hag: np.ndarray) -> np.ndarray:
    """uint8 per point: 1 on the surface the robot would rest on (module docstring)."""
    labels = np.asarray(labels)
    hag = np.asarray(hag, dtype=np.float64)
    return (np.isin(labels, GROUND_CLASS_IDS) & (np.abs(hag) <= SUPPORT_TOLERANCE)).astype(np.uint8)


def traversability_fields(
    x: np.ndarray,
    y: np.ndarray,
    ground: Callable[[np.ndarray, np.ndarray], np.ndarray],
    cover_height: Callable[[np.ndarray, np.ndarray], np.ndarray] | None,
    cast_up: Callable[[np.ndarray, float], np.ndarray],
    z: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """cover_height, slope and overhead (float32, the shape of x) at world points (x, y).
    `ground(x, y)`: the standing ground's height; `cover_height(x, y)`: the sward's (None: no
    cover); `cast_up(origins (N,3), max_range)`: the distance to the first surface straight up
    from each origin (inf where none); `z`: ground(x, y), when the caller has it already."""
    h = SLOPE_STEP
    gx = (ground(x + h, y) - ground(x - h, y)) / (2 * h)
    gy = (ground(x, y + h) - ground(x, y - h)) / (2 * h)
    z = ground(x, y) if z is None else z
    origins = np.column_stack([np.ravel(x), np.ravel(y), np.ravel(z) + ROBOT_HEIGHT])
    up = np.asarray(cast_up(origins, OVERHEAD_REACH)).reshape(np.shape(x))
    cover = np.zeros(np.shape(x)) if cover_height is None else cover_height(x, y)
    return {
        "cover_height": np.asarray(cover, dtype=np.float32),
        "slope": np.sqrt(gx * gx + gy * gy).astype(np.float32),
        "overhead": np.where(np.isfinite(up), up + ROBOT_HEIGHT, np.nan).astype(np.float32),
    }


# Height above the standing ground, bin edges (m): on it, in a sward, in shrubs, at a robot's
# height, in the lower crowns, above (the dataset card's "points of each class against height").
HEIGHT_EDGES = (0.1, 0.5, 1.0, 2.0, 5.0)
HEIGHT_BINS = ("< 0.1", "0.1-0.5", "0.5-1", "1-2", "2-5", ">= 5")


def class_height_histogram(labels: np.ndarray, hag: np.ndarray) -> dict[str, list[int]]:
    """Class id (as text) -> points in each HEIGHT_BINS bin of height above the ground."""
    bins = np.searchsorted(np.asarray(HEIGHT_EDGES), np.asarray(hag, dtype=np.float64), side="right")
    return counts_by_class(labels, bins, len(HEIGHT_BINS))
