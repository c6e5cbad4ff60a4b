"""The cells of a world's cover grid along a scan's rays, for the sward medium (numpy only).

core/effects/cover.py finds each ray's runs through the layer and its stops; this module finds
where rays are relative to the grid: their cells, the terrain interpolated there (bilinear
between the cell's corners, with CoverGrid.surface_at's operations, so every decision is the
grid's own), its slope, and where a ray leaves its cell. The per-cell arrays are
core/world/cover_lookup.py's. Cost is per element in numpy: a gather (take) costs about six
arithmetic operations, a boolean index about twenty, np.where six (instructions counted by
callgrind on this machine's numpy); so the code gathers by take and compacts by flatnonzero.
"""

from __future__ import annotations

import numpy as np

from ..world.cover import BOTTOM_SLACK
from ..world.cover_lookup import CoverLookup

# The robot flattens what it stands on: within this horizontal distance of the sensor no cover
# stops a beam (about the half-diagonal of the paper's robot, Andabata: 0.67 m x 0.54 m).
TRAMPLED = 0.45  # m
CELL_EXIT = 1e-6  # m past a cell's edge, where a ray going on from it starts (in the next cell)
# share of a part's rays above which the hits' cells are found for all its rays at once
# (hits_near; ~45 % is where both ways cost the same array operations, counted by callgrind)
WHOLE = 0.45


def hits_near(look: CoverLookup, ray: CoverRays, at, wanted, contained: bool):
    """Of the `wanted` rays, those whose point `at` along lies in a cell whose layer top it is
    not above (CoverLookup.top; -inf where bare): (their rows, (the point's z, its cell, tx,
    ty into it)). `contained`: every wanted point lies in the grid. Where most rays are wanted
    (a cave's or a trail's hits, none under a sward) the points of all the rays are found at
    once from the directions' columns, not gathered ray by ray (about half the operations)."""
    ox, oy, oz = ray.origin(slice(None))
    if np.count_nonzero(wanted) > WHOLE * len(wanted):
        d = ray.d
        x, y, z = ox + d[:, 0] * at, oy + d[:, 1] * at, oz + ray.dz * at
        contained = ray.single and look.contains(*ray.box)  # every ray's point, hit or not
        fx, fy, fi, fj, flat, ok = cells(look, x, y, contained)
        near = wanted & (z <= look.top.take(flat))
        if ok is not None:
            near &= ok
        rows = np.flatnonzero(near)
        return rows, (z.take(rows), flat.take(rows), (fx - fi).take(rows), (fy - fj).take(rows))
    rows = np.flatnonzero(wanted)
    dx, dy, dz = ray.cols(rows)
    at = at.take(rows)
    ox, oy, oz = ray.origin(rows)
    z = oz + dz * at
    fx, fy, fi, fj, flat, ok = cells(look, ox + dx * at, oy + dy * at, contained)
    near = z <= look.top.take(flat)
    if ok is not None:
        near &= ok
    k = np.flatnonzero(near)
    return rows.take(k), (z.take(k), flat.take(k), (fx - fi).take(k), (fy - fj).take(k))


def trampled(dx, dy, end):
    """Where each ray (directions dx, dy) is TRAMPLED from its origin in x and y, or its end
    (TRAMPLED / 0 is inf: a vertical ray's end)."""
    return np.minimum(TRAMPLED / np.sqrt(dx * dx + dy * dy), end)


def inside(look: CoverLookup, x, y, z, dx, dy, dz):
    """Of the points (x, y, z) on rays (dx, dy, dz), all in the grid and none above their
    cell's top (CoverLookup.top), those inside the layer: (their places, (height above the
    terrain, layer height, rate, cell) there: the height above the terrain changes along the
    ray at that rate, its climb less the slope of the terrain)."""
    fx, fy, fi, fj, flat, _ = cells(look, x, y, True)
    tx, ty = fx - fi, fy - fj
    sx, sy = 1.0 - tx, 1.0 - ty
    ground, corners = ground_at(look, flat, tx, ty, sx, sy)
    above = z - ground
    height = look.height.take(flat)
    gx, gy = slope_at(look, corners, tx, ty, sx, sy)
    rate = dz - (gx * dx + gy * dy)
    m = np.flatnonzero((above >= -BOTTOM_SLACK) & (above <= height))
    return m, (above.take(m), height.take(m), rate.take(m), flat.take(m))


def cells(look: CoverLookup, x, y, contained: bool = False):
    """(fx, fy, floor(fx), floor(fy), flat cell index, inside the grid (None: all)) of points,
    fx and fy in cells from the grid's origin; outside the grid the index is clipped to it.
    `contained`: the points are known to lie in the grid."""
    fx = (x - look.x0) / look.cell
    fy = (y - look.y0) / look.cell
    fi, fj = np.floor(fx), np.floor(fy)
    if not contained:
        ok = (fi >= 0) & (fi < look.nx) & (fj >= 0) & (fj < look.ny)
        if not ok.all():
            ci, cj = np.clip(fi, 0, look.nx - 1), np.clip(fj, 0, look.ny - 1)
            return fx, fy, fi, fj, (cj * look.row + ci).astype(np.intp), ok
    flat = fj * look.row
    flat += fi
    return fx, fy, fi, fj, flat.astype(np.intp), None


def ground_at(look: CoverLookup, flat, tx, ty, sx, sy):
    """(the terrain's height at points of cells `flat`, (tx, ty) into them (sx = 1 - tx, sy =
    1 - ty), the cells' corners): bilinear between the corners, CoverGrid.surface_at's
    operations."""
    z00, z10, z01, z11 = corners = look.corners(flat)
    return (z00 * sx + z10 * tx) * sy + (z01 * sx + z11 * tx) * ty, corners


def slope_at(look: CoverLookup, corners, tx, ty, sx, sy):
    """The terrain's slope d/dx, d/dy at points of cells with `corners` (CoverGrid.surface_at's
    operations)."""
    z00, z10, z01, z11 = corners
    gx = ((z10 - z00) * sy + (z11 - z01) * ty) / look.cell
    gy = ((z01 - z00) * sx + (z11 - z10) * tx) / look.cell
    return gx, gy


def surface(look: CoverLookup, x, y, slopes: bool = True, contained: bool = False):
    """At points (x, y): (class, layer height, terrain height, extinction, slope d/dx, d/dy;
    the slopes None unless `slopes`): CoverGrid.surface_at's values; outside the grid the
    class is 0. `contained`: every point lies in the grid."""
    fx, fy, fi, fj, flat, ok = cells(look, x, y, contained)
    tx, ty = fx - fi, fy - fj
    if ok is not None:  # (inside the grid fx - fi lies in [0, 1) already)
        tx, ty = np.clip(tx, 0.0, 1.0), np.clip(ty, 0.0, 1.0)
    sx, sy = 1.0 - tx, 1.0 - ty
    ground, corners = ground_at(look, flat, tx, ty, sx, sy)
    cls, height, ext = look.cls.take(flat), look.height.take(flat), look.ext.take(flat)
    if ok is not None:
        cls = np.where(ok, cls, 0).astype(np.int16, copy=False)
    gx = gy = None
    if slopes:
        gx, gy = slope_at(look, corners, tx, ty, sx, sy)
    return cls, height, ground, ext, gx, gy


def cell_exit(look: CoverLookup, x, y, dx, dy, t):
    """Where rays (dx, dy), at t along them at (x, y), leave their cell (in x and y; a
    micrometre past its edge): inf for a ray with no way out (straight up or down)."""
    ix = np.floor((x - look.x0) / look.cell)
    iy = np.floor((y - look.y0) / look.cell)
    to_x = ((ix + (dx > 0)) * look.cell + look.x0 - x) / dx
    to_y = ((iy + (dy > 0)) * look.cell + look.y0 - y) / dy
    out = t + np.minimum(np.where(dx != 0, to_x, np.inf), np.where(dy != 0, to_y, np.inf))
    return out + CELL_EXIT


class CoverRays:
    """A scan's rays: directions (n, 3) and origins, one (3,) for all (`single`) or (n, 3)."""

    def __init__(self, origins: np.ndarray, dirs: np.ndarray, max_range: float):
        self.d = dirs
        self.o = origins
        self.single = origins.ndim == 1
        self.dz = np.ascontiguousarray(dirs[:, 2])  # every ray's (the tests over all rays)
        self.box = (0.0, 0.0, 0.0, 0.0)  # x and y bounds of every point within reach (one origin)
        if self.single:
            self.ox, self.oy, self.oz = (float(v) for v in origins)
            reach = float(max_range) + 1.0
            self.box = (self.ox - reach, self.ox + reach, self.oy - reach, self.oy + reach)

    def cols(self, rows: np.ndarray):
        """The directions of `rows` as contiguous x, y, z arrays (an index into a column
        gathers; a column's take would copy it whole first)."""
        return self.d[:, 0][rows], self.d[:, 1][rows], self.d[:, 2][rows]

    def origin(self, rows: np.ndarray):
        """The origins of `rows`: numbers (one origin) or x, y, z arrays."""
        if self.single:
            return self.ox, self.oy, self.oz
        return self.o[:, 0][rows], self.o[:, 1][rows], self.o[:, 2][rows]


def in_layer(cls, above, height) -> np.ndarray:
    """Whether points `above` the terrain lie in the layer of their cell (class `cls`, layer
    height `height`): CoverGrid.class_inside's test."""
    return (cls > 0) & (above >= -BOTTOM_SLACK) & (above <= height)
