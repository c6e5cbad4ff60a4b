"""The ground the robot stands on (numpy only): the surface `hag` and the bird's-eye grid's
`terrain_z` measure from (docs/datasets.md "Ground truth real datasets cannot have").

It is the terrain mesh (the triangulated grid, interpolated exactly as its triangles are
split: `TerrainGrid.height_at`) and, where the trail's flooring covers it, the top of the
flooring, which the trail stage lays a few centimetres (plus the grid's measured error) above
the grid. The flooring's top is found triangle by triangle: its triangles are binned on a
1 m lattice, each query point tests the few in its bin, and where it is inside several (a
tight bend folds the strip over itself) the highest wins, as the highest is what a beam from
above meets. Vertical triangles (the flooring's skirts) cover no area and are left out.
"""

from __future__ import annotations

import functools

import numpy as np

from .terrain_grid import TerrainGrid

_BIN = 1.0  # m, side of the lattice the flooring's triangles are binned on
_AREA_MIN = 1e-9  # m^2: a triangle with less plan area is vertical (a skirt)
_INSIDE = -1e-9  # barycentric slack, so a point on a shared edge falls in both triangles
_CHUNK = 8192  # points tested at once (bounds the (points, candidates, 3, 3) temporaries)


class FloorTops:
    """Height of the top of a set of triangles over (x, y), NaN where none covers it."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray):
        tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.intp)]  # (T, 3, 3)
        e1, e2 = tri[:, 1, :2] - tri[:, 0, :2], tri[:, 2, :2] - tri[:, 0, :2]
        det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
        keep = np.abs(det) > 2 * _AREA_MIN
        self.tri, self.det = tri[keep], det[keep]
        self._bin_triangles()

    def _bin_triangles(self) -> None:
        """`self.table[b]`: the triangles whose plan bounding box meets bin b (-1 padded)."""
        xy = self.tri[:, :, :2]
        if not len(xy):
            self.origin, self.shape = np.zeros(2), np.zeros(2, dtype=np.intp)
            self.table = np.full((0, 1), -1, dtype=np.intp)
            return
        self.origin = xy.reshape(-1, 2).min(axis=0)
        self.shape = (np.floor((xy.reshape(-1, 2).max(axis=0) - self.origin) / _BIN) + 1).astype(np.intp)
        lo = np.floor((xy.min(axis=1) - self.origin) / _BIN).astype(np.intp)
        hi = np.floor((xy.max(axis=1) - self.origin) / _BIN).astype(np.intp)
        span = hi - lo + 1
        count = span[:, 0] * span[:, 1]
        owner = np.repeat(np.arange(len(xy)), count)
        k = np.arange(len(owner)) - np.repeat(np.cumsum(count) - count, count)
        bx = lo[owner, 0] + k // span[owner, 1]
        by = lo[owner, 1] + k % span[owner, 1]
        bins = bx * self.shape[1] + by
        order = np.argsort(bins, kind="stable")
        bins, owner = bins[order], owner[order]
        n_bins = int(self.shape[0] * self.shape[1])
        per_bin = np.bincount(bins, minlength=n_bins)
        slot = np.arange(len(bins)) - np.repeat(np.cumsum(per_bin) - per_bin, per_bin)
        self.table = np.full((n_bins, max(int(per_bin.max()), 1)), -1, dtype=np.intp)
        self.table[bins, slot] = owner

    def __call__(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        px, py = x.ravel(), y.ravel()
        out = np.full(px.shape, np.nan)
        if not len(self.table):
            return out.reshape(x.shape)
        # each point's bin of the lattice, kept where the bin holds a triangle: most of a
        # bird's-eye grid lies far from any trail. On the floats, before any integer cast
        # (NaN and values far off the lattice fail the bounds as they are).
        bx = np.floor((px - self.origin[0]) / _BIN)
        by = np.floor((py - self.origin[1]) / _BIN)
        near = np.flatnonzero((bx >= 0) & (bx < self.shape[0]) & (by >= 0) & (by < self.shape[1]))
        rows = bx[near].astype(np.intp) * self.shape[1] + by[near].astype(np.intp)
        occupied = self._occupied.take(rows)
        near, rows = near[occupied], rows[occupied]
        for start in range(0, len(near), _CHUNK):
            part = slice(start, start + _CHUNK)
            out[near[part]] = self._tops(px[near[part]], py[near[part]], self.table[rows[part]])
        return out.reshape(x.shape)

    @functools.cached_property
    def _occupied(self) -> np.ndarray:
        """Per bin of the lattice, whether any triangle meets it."""
        return self.table[:, 0] >= 0

    def _tops(self, px: np.ndarray, py: np.ndarray, cand: np.ndarray) -> np.ndarray:
        """The highest of the candidate triangles (n, M) each point is inside, NaN for none.
        Each point has one at least (its bin's first slot); the -1 padding of a bin with fewer
        than M is left out, not computed and masked (half the slots on a trail's lattice)."""
        point, slot = np.nonzero(cand >= 0)  # row by row: each point's candidates together
        tri_index = cand[point, slot]
        t = self.tri[tri_index]  # (pairs, 3, 3)
        det = self.det[tri_index]
        dx, dy = px[point] - t[:, 0, 0], py[point] - t[:, 0, 1]
        e1, e2 = t[:, 1, :] - t[:, 0, :], t[:, 2, :] - t[:, 0, :]
        u = (dx * e2[:, 1] - dy * e2[:, 0]) / det
        v = (e1[:, 0] * dy - e1[:, 1] * dx) / det
        z = t[:, 0, 2] + u * e1[:, 2] + v * e2[:, 2]
        inside = (u >= _INSIDE) & (v >= _INSIDE) & (u + v <= 1 - _INSIDE)
        first = np.flatnonzero(np.concatenate([[True], point[1:] != point[:-1]]))
        top = np.maximum.reduceat(np.where(inside, z, -np.inf), first)
        return np.where(np.isfinite(top), top, np.nan)


class StandingGround:
    """Height of the ground the robot stands on at (x, y): the terrain mesh, or the top of
    any flooring above it (see the module docstring)."""

    def __init__(self, terrain: TerrainGrid, floors: list[tuple[np.ndarray, np.ndarray]]):
        self.terrain = terrain
        self.floors = [FloorTops(v, f) for v, f in floors]

    def __call__(self, x, y) -> np.ndarray:
        z = self.terrain.height_at(x, y)
        for floor in self.floors:
            # fmax: the flooring where it covers the point (NaN elsewhere), and the terrain
            # where it pokes through the flooring between the flooring's vertices
            z = np.fmax(z, floor(x, y))
        return z
