"""A cover grid's per-cell arrays for the scan's medium (numpy only): built once a world.

The medium (core/effects/cover.py) looks a grid cell up for every ray that can be in the
sward, two or three times a ray. CoverGrid's own lookups gather a (cells, 6) table and work
on its strided columns (numpy's strided loops cost about four times its contiguous ones);
here each field a lookup needs is its own contiguous array, so a lookup gathers only the
fields it uses. A cell's index is j * row + i with row = nx + 1, a node row's length: cell
(j, i)'s corners are then the nodes at that index, +1, +row and +row+1 of the terrain at the
nodes (CoverGrid.node_ground, not copied), and the per-cell arrays carry one unused column.
The values are the grid's own, exactly: the layer's height, class, top (CoverGrid._tops)
and extinction (core/world/cover.py extinction: the same operations on the same numbers).

Bounds decide most points without interpolating the terrain (a margin MARGIN inside, far
above any rounding of the interpolation): a point of a covered cell with
bottom <= z <= below_top lies in its layer; a ray of direction (dx, dy, dz) with
dz + steepest * horizontal < 0 comes down towards the terrain there (its height above the
terrain falls along it: |slope . direction| <= sqrt(2) max|slope| horizontal).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from .cover import BOTTOM_SLACK, CoverGrid, extinction

# m: the bounds' margin; the interpolated terrain's rounding is about 1e-16 of its height, so
# a micrometre bounds it for any terrain below 10^7 m
MARGIN = 1e-6


@dataclass(frozen=True)
class CoverLookup:
    """A grid's cells as flat contiguous arrays, a cell at j * row + i (row = nx + 1)."""

    x0: float
    y0: float
    cell: float
    nx: int
    ny: int
    row: int
    nodes: np.ndarray  # the terrain at the nodes, (ny + 1) * row
    height: np.ndarray  # float64, the layer's height (the grid's float32, exactly)
    cls: np.ndarray  # int16, 0 bare
    top: np.ndarray  # the highest corner plus the height, -inf where bare
    ext: np.ndarray  # extinction per metre (1/m), 0 where bare
    below_top: np.ndarray  # the lowest corner plus the height, less MARGIN (-inf where bare)
    bottom: np.ndarray  # the highest corner less BOTTOM_SLACK, plus MARGIN (inf where bare)
    steepest: np.ndarray  # sqrt(2) x the steepest slope within the cell (x or y), plus MARGIN

    def corners(self, flat: np.ndarray):
        """The terrain at the corners x0y0, x1y0, x0y1, x1y1 of cells `flat`."""
        return (
            self.nodes.take(flat),
            self.nodes.take(flat + 1),
            self.nodes.take(flat + self.row),
            self.nodes.take(flat + (self.row + 1)),
        )

    def contains(self, x_lo: float, x_hi: float, y_lo: float, y_hi: float) -> bool:
        """Whether every point of the box lies in a cell of the grid (a cell's margin spare: a
        point's own rounding never takes it out)."""
        c = self.cell
        return (
            x_lo - c >= self.x0
            and y_lo - c >= self.y0
            and x_hi + c < self.x0 + self.nx * c
            and y_hi + c < self.y0 + self.ny * c
        )


_LOOKUPS: dict[int, CoverLookup] = {}


def cover_lookup(grid: CoverGrid) -> CoverLookup:
    """The lookup arrays of `grid`, made at its first scan and kept while the grid lives."""
    found = _LOOKUPS.get(id(grid))
    if found is None:
        found = _build(grid)
        _LOOKUPS[id(grid)] = found
        weakref.finalize(grid, _LOOKUPS.pop, id(grid), None)
    return found


def _build(grid: CoverGrid) -> CoverLookup:
    ny, nx = grid.shape
    z = np.ascontiguousarray(grid.node_ground(), dtype=np.float64)
    z00, z10, z01, z11 = z[:-1, :-1], z[:-1, 1:], z[1:, :-1], z[1:, 1:]
    height = grid.height.astype(np.float64)
    cls = grid.class_id.astype(np.int16)
    covered = cls > 0
    low = np.minimum(np.minimum(z00, z10), np.minimum(z01, z11))
    high = np.maximum(np.maximum(z00, z10), np.maximum(z01, z11))
    steep = np.maximum.reduce([np.abs(z10 - z00), np.abs(z11 - z01), np.abs(z01 - z00), np.abs(z11 - z10)])

    def per_cell(values, dtype=np.float64) -> np.ndarray:
        out = np.zeros((ny, nx + 1), dtype=dtype)  # one unused column: a node row's length
        out[:, :nx] = values
        return out.reshape(-1)

    return CoverLookup(
        x0=float(grid.x0),
        y0=float(grid.y0),
        cell=float(grid.cell),
        nx=int(nx),
        ny=int(ny),
        row=int(nx + 1),
        nodes=z.reshape(-1),
        height=per_cell(height),
        cls=per_cell(cls, np.int16),
        top=per_cell(grid._tops().reshape(ny, nx)),
        ext=per_cell(extinction(cls, height)),
        below_top=per_cell(np.where(covered, low + height - MARGIN, -np.inf)),
        bottom=per_cell(np.where(covered, high - BOTTOM_SLACK + MARGIN, np.inf)),
        steepest=per_cell(math.sqrt(2.0) * steep / grid.cell + MARGIN),
    )
