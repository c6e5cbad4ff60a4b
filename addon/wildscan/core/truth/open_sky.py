"""Open sky (numpy only): the places of a world where a ray straight up from a robot's height
above the ground can meet nothing.

Why: every dataset scan's bird's-eye grid casts 90,000 rays straight up, one from
ROBOT_HEIGHT above the standing ground at each cell, for the clearance over it (`overhead`,
core/truth/traversability.py). Most meet nothing (open ground, lawns, the sky between crowns): a
lookup in this raster answers those (nothing above) for a fraction of a cast, and only the
rest are cast.

The answer is the cast's, not an estimate. A triangle can stop an upward ray at (x, y) only
if its xy bounding box holds (x, y) and its highest corner is at or above the ray's start,
ground(x, y) + ROBOT_HEIGHT; the standing ground is the terrain grid or a flooring above it
(core/world/ground.py), and the triangulated grid lies, cell by cell, between the heights of
its nodes. So a triangle is harmless, out of reach of every upward ray from its box, when its
highest corner lies more than Z_MARGIN below the lowest grid node around its box plus
ROBOT_HEIGHT: the grid's own triangles (unless a cell rises more than that), grass, low
shrubs, logs. Every other triangle marks the raster cells its box, grown by MARGIN, reaches
(core/truth/open_ground.py's raster, with the same guarantees: MARGIN and Z_MARGIN are hundreds of
times the growth the casters give triangles and the float32 rounding of a ray's origin);
the cells none reaches are open sky. A triangle whose box (grown) spans more than three grid cells
either way is counted as reaching its whole box, whatever its height (conservative, rare).
"""

from __future__ import annotations

import numpy as np

from ..world.terrain_grid import TerrainGrid
from .open_ground import BLOCK, MARGIN, OpenGround, corner_boxes, no_open_ground, open_outside_blocks

Z_MARGIN = 1e-3  # m by which a harmless triangle stays below the lowest upward ray's start
_SPAN = 4  # grid nodes each way looked at around a triangle's box (three cells)


def open_sky(
    vertices: np.ndarray,
    faces: np.ndarray,
    terrain: TerrainGrid,
    start_height: float,
    extent: tuple[float, float, float, float],
) -> OpenGround:
    """The open sky over `extent` of a world of triangles (vertices (V, 3), faces (T, 3))
    standing on `terrain`, for upward rays starting `start_height` above the standing ground.
    None open unless the grid covers the extent (what bounds the ground from below)."""
    x0, x1, y0, y1 = extent
    xs, ys = terrain.xs, terrain.ys
    if not (xs[0] <= x0 and xs[-1] >= x1 and ys[0] <= y0 and ys[-1] >= y1):
        return no_open_ground(extent)
    faces = np.asarray(faces).reshape(-1, 3)
    lowest = _LowestGround(terrain)

    def reaching_boxes():
        for start in range(0, len(faces), BLOCK):
            low, high = corner_boxes(vertices, faces[start : start + BLOCK])
            (x_lo, y_lo), (x_hi, y_hi, z_hi) = low[:, :2].T, high.T
            low = lowest(x_lo, x_hi, y_lo, y_hi)
            reach = (z_hi + Z_MARGIN >= low + start_height) | np.isnan(low)  # NaN: a wide box
            yield (x_lo[reach], x_hi[reach]), (y_lo[reach], y_hi[reach])

    return open_outside_blocks(reaching_boxes(), extent)


class _LowestGround:
    """Per box, the lowest grid node of a node rectangle holding the box grown by MARGIN (the
    grid's lowest point over the box or below it); NaN where that rectangle is wider than
    _SPAN nodes either way."""

    def __init__(self, terrain: TerrainGrid):
        self.x_nodes, self.y_nodes = _NodeIndex(terrain.xs), _NodeIndex(terrain.ys)
        self.nx = len(terrain.xs)
        self.block_min = _block_minimum(np.asarray(terrain.z, dtype=np.float64)).ravel()

    def __call__(self, x_lo, x_hi, y_lo, y_hi) -> np.ndarray:
        i_lo, i_hi = self.x_nodes.around(x_lo - MARGIN, x_hi + MARGIN)
        j_lo, j_hi = self.y_nodes.around(y_lo - MARGIN, y_hi + MARGIN)
        lowest = self.block_min.take(j_lo * self.nx + i_lo)
        lowest[(i_hi - i_lo >= _SPAN) | (j_hi - j_lo >= _SPAN)] = np.nan
        return lowest


def _block_minimum(z: np.ndarray) -> np.ndarray:
    """m[j, i] = the least of z[j : j + _SPAN, i : i + _SPAN] (cut at the grid's edges)."""
    m = z.copy()
    for axis in (0, 1):
        shifted = m.copy()
        for k in range(1, _SPAN):
            tail = [slice(None), slice(None)]
            tail[axis] = slice(None, -k)
            head = [slice(None), slice(None)]
            head[axis] = slice(k, None)
            shifted[tuple(tail)] = np.minimum(shifted[tuple(tail)], m[tuple(head)])
        m = shifted
    return m


class _NodeIndex:
    """The nodes of a grid axis around coordinates, looked up in a table of buckets BUCKET
    wide (a searchsorted of a million unsorted values costs ten times more). Conservative:
    `around(low, high)` gives a node at or before `low` and one at or after `high`."""

    BUCKET = 0.05  # m

    def __init__(self, nodes: np.ndarray):
        self.nodes, self.start = nodes, float(nodes[0])
        count = int(np.ceil((nodes[-1] - nodes[0]) / self.BUCKET)) + 2
        edges = self.start + self.BUCKET * np.arange(count + 1)
        last = len(nodes) - 1
        # bucket k spans [edges[k], edges[k + 1]]: the last node at or before its start, the
        # first at or after its end
        self.before = np.clip(np.searchsorted(nodes, edges[:-1], side="right") - 1, 0, last)
        self.after = np.clip(np.searchsorted(nodes, edges[1:], side="left"), 0, last)

    def around(self, low: np.ndarray, high: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # a bucket's index one lower and one higher than the coordinate's, in case its
        # division rounds across an edge
        top = len(self.before) - 1
        k_low = np.clip(np.floor((low - self.start) / self.BUCKET).astype(np.int64) - 1, 0, top)
        k_high = np.clip(np.floor((high - self.start) / self.BUCKET).astype(np.int64) + 1, 0, top)
        return self.before.take(k_low), self.after.take(k_high)
