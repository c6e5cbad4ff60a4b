"""A cover grid's per-cell tables for the scan's medium (numpy only): built once a world.

The medium (core/effects/cover.py) looks a grid cell up for every ray that can be in the
sward, two or three times a ray. CoverGrid's own lookups gather a (cells, 6) table and work
on its strided columns; here each field a lookup needs is its own contiguous array, so a
lookup gathers only the fields it uses and every operation after runs on contiguous arrays
(a strided column costs numpy about five times a contiguous one). The values are the grid's
own, exactly: the terrain at a cell's corners (CoverGrid.node_ground), the layer's height,
class, top (CoverGrid._tops) and extinction (core/world/cover.py extinction, the same
operations on the same numbers), and the terrain's differences across the cell, divided by
the cell where the cell is a power of two (then the division is exact and commutes with the
slope's products and sum: the slope has the bits CoverGrid.surface_at gives it).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass

import numpy as np

from .cover import BOTTOM_SLACK, CoverGrid, extinction

# m: the bounds' margin (CoverLookup.below_top); the interpolated terrain's rounding is about
# 1e-14 m a metre of height, so a micrometre is a bound for any terrain below 10^7 m
MARGIN = 1e-6


@dataclass(frozen=True)
class CoverLookup:
    """A grid's cells as flat contiguous arrays, row-major (j * nx + i). `slope_*` are the
    terrain's differences across the cell (x: z10 - z00 at y0, z11 - z01 at y1; y: z01 - z00
    at x0, z11 - z10 at x1), over the cell when `slopes_scaled` (a power-of-two cell)."""

    x0: float
    y0: float
    cell: float
    nx: int
    ny: int
    z00: np.ndarray
    z10: np.ndarray
    z01: np.ndarray
    z11: np.ndarray
    height: np.ndarray  # float64, the layer's height (the grid's float32, exactly)
    cls: np.ndarray  # int16, 0 bare
    top: np.ndarray  # the highest corner plus the height, -inf where bare
    ext: np.ndarray  # extinction per metre (1/m), 0 where bare
    slope_x0: np.ndarray
    slope_x1: np.ndarray
    slope_y0: np.ndarray
    slope_y1: np.ndarray
    slopes_scaled: bool
    # bounds for deciding most points without interpolating the terrain (a margin MARGIN
    # inside, far above any rounding of the interpolation): a point of a covered cell with
    # bottom <= z <= below_top lies in its layer; a ray of direction (dx, dy, dz) with
    # dz + steepest * horizontal < 0 comes down towards the terrain there (its rate < 0)
    below_top: np.ndarray  # the lowest corner plus the height, less MARGIN (-inf where bare)
    bottom: np.ndarray  # the highest corner less BOTTOM_SLACK, plus MARGIN (inf where bare)
    steepest: np.ndarray  # sqrt(2) x the steepest slope within the cell (x or y), plus MARGIN

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
    """The lookup tables of `grid`, made at its first scan and kept while the grid lives."""
    found = _LOOKUPS.get(id(grid))
    if found is None:
        found = _build(grid)
        _LOOKUPS[id(grid)] = found
        weakref.finalize(grid, _LOOKUPS.pop, id(grid), None)
    return found


def _build(grid: CoverGrid) -> CoverLookup:
    ny, nx = grid.shape
    z = grid.node_ground()
    z00, z10, z01, z11 = (np.ascontiguousarray(a, dtype=np.float64).reshape(-1) for a in _corners(z))
    height = grid.height.astype(np.float64).reshape(-1)
    cls = grid.class_id.astype(np.int16).reshape(-1)
    scaled = math.frexp(grid.cell)[0] == 0.5  # a power of two
    scale = grid.cell if scaled else 1.0
    covered = cls > 0
    low = np.minimum(np.minimum(z00, z10), np.minimum(z01, z11))
    high = np.maximum(np.maximum(z00, z10), np.maximum(z01, z11))
    steep = np.maximum.reduce([np.abs(z10 - z00), np.abs(z11 - z01), np.abs(z01 - z00), np.abs(z11 - z10)])
    return CoverLookup(
        x0=float(grid.x0),
        y0=float(grid.y0),
        cell=float(grid.cell),
        nx=int(nx),
        ny=int(ny),
        z00=z00,
        z10=z10,
        z01=z01,
        z11=z11,
        height=height,
        cls=cls,
        top=np.ascontiguousarray(grid._tops(), dtype=np.float64),
        ext=np.ascontiguousarray(extinction(cls, height), dtype=np.float64),
        slope_x0=(z10 - z00) / scale,
        slope_x1=(z11 - z01) / scale,
        slope_y0=(z01 - z00) / scale,
        slope_y1=(z11 - z10) / scale,
        slopes_scaled=scaled,
        below_top=np.where(covered, low + height - MARGIN, -np.inf),
        bottom=np.where(covered, high - BOTTOM_SLACK + MARGIN, np.inf),
        steepest=math.sqrt(2.0) * steep / grid.cell + MARGIN,
    )


def _corners(z: np.ndarray):
    """The terrain at each cell's corners x0y0, x1y0, x0y1, x1y1 (CoverGrid._cell_table's)."""
    return z[:-1, :-1], z[:-1, 1:], z[1:, :-1], z[1:, 1:]
