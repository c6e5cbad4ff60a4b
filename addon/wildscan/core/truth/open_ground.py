"""Open ground (numpy only): the places of a world, seen from above, where the terrain is
the only surface, so a ray straight down can meet nothing else.

Why: every dataset scan's bird's-eye grid (groundtruth.bev_grid) casts 90,000 rays straight
down for the class of the first surface under each cell. Most of them meet nothing but the
terrain (open ground between trees, the park's lawns, the hills); a lookup in this raster
answers those for a fraction of a cast, and only the rest are cast.

The answer is the cast's, not an estimate. The raster has square cells over the world's
extent; a cell is open when no triangle of any other class has its xy bounding box, grown
by MARGIN, reaching into it. Then, for a point whose cell is open:
  - no other surface lies anywhere on its vertical line: MARGIN is hundreds of times the
    growth the ray casters give triangles (padding.pad_triangles) and the float32 rounding
    of a ray's origin, so not even a grown copy of another triangle reaches it;
  - the terrain is there: it is a heightfield grid covering the whole extent (the caller
    checks), and the downward rays start above every surface and reach below them;
  - a point inside a grown box always falls in a cell the box marked: both use the same
    floor((x - x0) / cell), which never decreases as x grows, however it rounds.
The cells on the border of the extent are never open: a ray along the terrain's very edge
is left to the caster.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

RASTER_CELL = 0.1  # m
MARGIN = 0.01  # m by which every other triangle's bounding box is grown
BLOCK = 1 << 17  # triangles at a time (a porous world has a million): bounds the temporaries


@dataclass(frozen=True)
class OpenGround:
    """Open cells of a raster over the extent: `is_open[i, j]` for the cell whose lower
    corner is (x0 + i cell, y0 + j cell)."""

    x0: float
    y0: float
    cell: float
    is_open: np.ndarray  # (nx, ny) bool

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Whether each point (x, y) lies in an open cell (False off the raster)."""
        i = _raster_index(np.asarray(x, dtype=np.float64), self.x0, self.cell)
        j = _raster_index(np.asarray(y, dtype=np.float64), self.y0, self.cell)
        nx, ny = self.is_open.shape
        on = (i >= 0) & (i < nx) & (j >= 0) & (j < ny)
        out = np.zeros(i.shape, dtype=bool)
        out[on] = self.is_open[i[on], j[on]]
        return out


def _raster_index(v: np.ndarray, origin: float, cell: float) -> np.ndarray:
    """The raster index of coordinates v (the one expression marking and lookup share)."""
    return np.floor((v - origin) / cell).astype(np.int64)


def open_ground(
    xy: np.ndarray, faces: np.ndarray, extent: tuple[float, float, float, float], cell: float = RASTER_CELL
) -> OpenGround:
    """The open ground of a world whose terrain covers `extent` (x0, x1, y0, y1), given the
    vertices' xy (V, 2) and the faces (T, 3) of every triangle that is not terrain."""
    faces = np.asarray(faces).reshape(-1, 3)

    def boxes():
        for start in range(0, len(faces), BLOCK):
            low, high = corner_boxes(xy, faces[start : start + BLOCK])
            yield (low[:, 0], high[:, 0]), (low[:, 1], high[:, 1])

    return open_outside_blocks(boxes(), extent, cell)


def corner_boxes(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per triangle, the least and the greatest of each coordinate over its three corners:
    (T, D) each, for vertices (V, D)."""
    a, b, c = (np.asarray(vertices, dtype=np.float64).take(faces[:, k], axis=0) for k in range(3))
    return np.minimum(np.minimum(a, b), c), np.maximum(np.maximum(a, b), c)


def open_outside(x_range, y_range, extent, cell: float = RASTER_CELL) -> OpenGround:
    """The raster over `extent` whose open cells are those no box reaches: the boxes are
    x_range = (least x, greatest x) and y_range likewise, one entry each, grown by MARGIN (the
    extent's border cells are never open)."""
    return open_outside_blocks([(x_range, y_range)], extent, cell)


def open_outside_blocks(blocks, extent, cell: float = RASTER_CELL) -> OpenGround:
    """open_outside of the boxes of every (x_range, y_range) of `blocks`, taken a block at a
    time (what bounds the temporaries of a million boxes)."""
    x0, x1, y0, y1 = extent
    nx, ny = _raster_shape(extent, cell)
    diff = np.zeros((nx + 1) * (ny + 1))  # whole counts, exact in float64
    for x_range, y_range in blocks:
        boxes = []
        for (low, high), origin, count in ((x_range, x0, nx), (y_range, y0, ny)):
            boxes.append(np.clip(_raster_index(low - MARGIN, origin, cell), 0, count - 1))
            boxes.append(np.clip(_raster_index(high + MARGIN, origin, cell), 0, count - 1))
        diff += _box_corners(*boxes, nx, ny)
    counts = diff.reshape(nx + 1, ny + 1)
    np.cumsum(counts, axis=0, out=counts)  # in place: the raster is 2.25 M cells
    np.cumsum(counts, axis=1, out=counts)
    covered = counts[:nx, :ny] > 0
    covered[[0, -1], :] = True
    covered[:, [0, -1]] = True
    return OpenGround(float(x0), float(y0), float(cell), ~covered)


def no_open_ground(extent: tuple[float, float, float, float], cell: float = RASTER_CELL) -> OpenGround:
    """A raster with no open cell: every point is left to the caster."""
    return OpenGround(
        float(extent[0]), float(extent[2]), float(cell), np.zeros(_raster_shape(extent, cell), bool)
    )


def _raster_shape(extent, cell: float) -> tuple[int, int]:
    x0, x1, y0, y1 = extent
    return int(np.ceil((x1 - x0) / cell)) + 1, int(np.ceil((y1 - y0) / cell)) + 1


def _box_corners(i0, i1, j0, j1, nx: int, ny: int) -> np.ndarray:
    """The difference array ((nx + 1) * (ny + 1)) of the index boxes [i0, i1] x [j0, j1]:
    each box adds +1 at two corners and -1 at the other two; its running sums along both axes
    count the boxes over each cell."""
    rows, cols = nx + 1, ny + 1
    corners = np.concatenate(
        [i0 * cols + j0, (i1 + 1) * cols + j0, i0 * cols + j1 + 1, (i1 + 1) * cols + j1 + 1]
    )
    signs = np.repeat(np.array([1.0, -1.0, -1.0, 1.0]), len(i0))
    return np.bincount(corners, weights=signs, minlength=rows * cols)
