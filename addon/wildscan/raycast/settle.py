"""Which triangle a ray hits, settled in float64 wherever the float32 caster could go either way.

Why: the fast backends find first hits in float32 against triangles grown a little in their
own plane (padding.pad_triangles: neighbours overlap, so no ray slips between them). Where
a ray lands in that overlap, two triangles are hit at (nearly) the same distance, and which
one the caster reports depends on its arithmetic: Embree picks its code by CPU at run time
(SSE2, AVX, AVX2, AVX-512; BVH4 or BVH8, with or without FMA). Measured on 79 scans of
seeds 1-2, an AVX (Sandy Bridge) Embree reported another triangle than this AVX-512 one
for 305 rays (3.9 a scan): the same object each time, but 127 of them then got a float64
range that differed by up to 5.5 um (float32 PLY bytes differ), and one ray at a grown
silhouette hit on one CPU and passed on the other.

So the float64 geometry decides. A hit whose point lies well inside the unpadded triangle
(its barycentric coordinates clear of every edge by the padding plus float32 noise: almost
all of them) is kept as it is. For the rest, the triangle and every triangle sharing a
vertex position with it are intersected in float64 (unpadded, grown by EDGE_TOLERANCE so
float64 rounding cannot open a crack); the nearest hit wins, the lower triangle index on a
tie. If none of them is hit, the ray passed beside the triangle's true edge: it is cast
again from just beyond that triangle's plane. Every answer then follows from the float64
geometry alone, whatever the caster's instruction set, for every ray whose float32 answer
was ambiguous between triangles of one surface (all the differences measured). Two
separate objects crossing at the very point a ray hits are not looked for (none measured).
"""

from __future__ import annotations

from functools import cached_property
from typing import Protocol

import numpy as np

from ..core import detmath as dm
from .blocks import by_blocks

# Barycentric margin around the padding band: Embree's float32 u, v are good to ~1e-7.
BAND_MARGIN = 1e-4
EDGE_TOLERANCE = 1e-9  # m: the float64 test's unpadded triangles are grown by this
RECAST_STEP = 1e-4  # m beyond a triangle's plane where a ray passing beside it restarts
MAX_RECASTS = 4
_PARALLEL_COS = 1e-9  # as refine.refine_distances: a ray in a triangle's plane misses it


class Settler:
    """The float64 data about one geometry's triangles the settling needs, made when needed."""

    def __init__(
        self, geometry, padded: np.ndarray, planes: tuple[np.ndarray, np.ndarray], corners: np.ndarray
    ):
        self.geometry = geometry
        self.padded = padded  # (T, 3, 3) offset-local float64, as uploaded (before float32)
        self.normal, self.d = planes
        self.corners = corners  # (T, 3, 3) offset-local float64 corners of the unpadded triangles

    @classmethod
    def sealing(cls, geometry, planes: tuple[np.ndarray, np.ndarray], corners: np.ndarray) -> Settler:
        """For a float32 caster: the padded triangles it uploads (`padded`, float64) and what
        settling its answers needs; `corners` are geometry.local_triangles()."""
        return cls(
            geometry, geometry.padded_local_triangles(dtype=np.float64, corners=corners), planes, corners
        )

    @classmethod
    def restored(cls, geometry, padded, planes, corners, band, neighbours) -> Settler:
        """A Settler whose `band` and `neighbours` were made before (a world cache's entry,
        app/cache/worlds.py): the same arrays, not made again."""
        settler = cls(geometry, padded, planes, corners)
        settler.__dict__.update(band=band, neighbours=neighbours)  # what cached_property keeps
        return settler

    @cached_property
    def band(self) -> np.ndarray:
        """(T,) float32: a hit whose smallest barycentric coordinate on the padded triangle is
        below this may lie outside the unpadded triangle (the widest of its three edges'
        bands: the unpadded edge is at most the largest corner shift inside the padded one)."""
        return by_blocks(_band, self.padded, self.corners)

    @cached_property
    def neighbours(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(position id of each corner (T, 3), CSR offsets, triangles) over vertex positions:
        triangles of different objects or meshes meeting at one point are neighbours too."""
        position = position_ids(self.geometry.vertices)
        corner_pos = position[self.geometry.faces]
        order = stable_order(corner_pos.ravel())
        triangles = order // 3
        starts = np.r_[0, np.cumsum(np.bincount(corner_pos.ravel(), minlength=position.max() + 1))]
        return corner_pos, starts, triangles

    def in_band(self, triangle, bary, local, dirs, rough) -> np.ndarray:
        """Hits (triangle >= 0) whose point may be outside their unpadded triangle. `bary` is
        the caster's (u, v) on the padded triangle, or None: then found in float64 from the
        caster's distance."""
        hit = triangle >= 0
        if bary is None:
            u, v = np.ones(len(triangle)), np.ones(len(triangle))
            u[hit], v[hit] = _barycentrics(
                self.padded[triangle[hit]], local[hit] + rough[hit, None] * dirs[hit]
            )
        else:
            u, v = bary
        smallest = np.minimum(np.minimum(u, v), (1.0 - u) - v)
        return hit & (smallest < self.band.take(triangle))

    def decide(self, local, dirs, triangle, start) -> np.ndarray:
        """For rays (local origins, dirs) that hit `triangle` in its band: the triangle among it
        and its neighbours hit first in float64 beyond distance `start` (ties: lowest index),
        or -1 where none is."""
        ray, slot, cand = self.pairs(triangle)
        # vectors as three contiguous columns, not (P, 3) rows: the same products and sums
        # (detmath's order), on contiguous arrays, and the pairs outside dropped as found
        normal = _columns(self.normal.take(cand, axis=0))  # a candidate's, gathered by its slot
        d = [np.ascontiguousarray(dirs[:, k]).take(ray) for k in range(3)]
        cos = dot_columns([column.take(slot) for column in normal], d)
        if local.ndim == 2 and len(local) > 1 and local.strides[0] == 0:
            # one origin (a scan): each candidate plane's offset from it once, then gathered
            o = [local[0, k] for k in range(3)]
            reach = (self.d.take(cand) - dot_columns(normal, o)).take(slot)
        else:
            o = [np.ascontiguousarray(local[:, k]).take(ray) for k in range(3)]
            reach = self.d.take(cand).take(slot) - dot_columns([c.take(slot) for c in normal], o)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            t = np.divide(reach, cos, out=reach)
            ahead = np.abs(cos, out=cos) >= _PARALLEL_COS
            ahead &= np.isfinite(t)
            # a scan's first round starts every ray at 0: compared with 0 as with a row of zeros
            ahead &= t >= (start.take(ray) if start.any() else 0.0)
            # the point on every pair's plane (those not ahead are dropped with the first edge's
            # test): o + t d, as for the pairs ahead alone
            point = [np.add(o[k], np.multiply(t, d[k], out=d[k]), out=d[k]) for k in range(3)]
            for k, edge in enumerate(_edges(normal, self.corners.take(cand, axis=0))):
                inside = edge.holds(point, slot, ahead if k == 0 else None).nonzero()[0]
                t, slot, ray = t.take(inside), slot.take(inside), ray.take(inside)
                if k < 2:
                    point = [column.take(inside) for column in point]
        winner = np.full(len(triangle), -1, dtype=np.int64)
        ray, cand = nearest_per_ray(ray, cand.take(slot), t)
        winner[ray] = cand
        return winner

    def pairs(self, triangle: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(ray, slot, candidates): every (ray, candidate) pair once, sorted by ray then
        candidate, as the ray's index and its candidate's slot in `candidates` (each triangle
        once, ascending). Rays share their hit triangles (a multi-beam lidar's thousands of
        ambiguous hits fall on a few hundred terrain cells): each hit triangle's candidates
        are found once; and hit triangles share candidates (neighbours of neighbours): each
        candidate's planes and edges are made once (Settler.decide)."""
        hit_triangles, group_of_ray = unique_inverse(triangle)
        group, cand = self.candidates(hit_triangles)
        group_starts = np.zeros(len(hit_triangles) + 1, dtype=np.intp)
        np.cumsum(np.bincount(group, minlength=len(hit_triangles)), out=group_starts[1:])
        counts = (group_starts[1:] - group_starts[:-1]).take(group_of_ray)
        ray = np.arange(len(triangle)).repeat(counts)
        # each ray's run of entries is its triangle's, in candidate order
        entry = (group_starts.take(group_of_ray) - counts.cumsum() + counts).repeat(counts)
        entry += np.arange(len(entry))
        candidates, slot_of_entry = unique_inverse(cand)
        return ray, slot_of_entry.take(entry), candidates

    def candidates(self, triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(group, candidate) pairs, sorted: for each of `triangles` (its index in them, the
        group), every triangle with a corner at one of its corners' positions, itself
        included, each once."""
        corner_pos, starts, owners = self.neighbours
        pos = corner_pos.take(triangles, axis=0).ravel()
        counts = starts.take(pos + 1) - starts.take(pos)
        group = np.arange(len(triangles)).repeat(3).repeat(counts)
        first = (starts.take(pos) - counts.cumsum() + counts).repeat(counts)
        cand = owners.take(first + np.arange(len(first)))
        size = len(self.normal)
        keys = sorted_unique(group * size + cand)  # each (group, candidate) once, in that order
        return keys // size, keys % size


class _Edge:
    """Edge k of each candidate (Settler.pairs' slots): its start corner and
    inward normal (normal x edge), three columns each, and how far outside it a point may lie
    (EDGE_TOLERANCE times the inward normal's length, negated)."""

    def __init__(self, start: list, inward: list, tolerance: np.ndarray):
        self.start, self.inward, self.tolerance = start, inward, tolerance

    def holds(self, point: list, slot: np.ndarray, also: np.ndarray | None = None) -> np.ndarray:
        """Whether each pair's `point` (three columns) is on the inner side of its candidate's
        (`slot`) edge, within the tolerance (and `also`, where given): dot_columns(point - start,
        inward), its products and sums in that order, in place."""
        value = point[0] - self.start[0].take(slot)
        value *= self.inward[0].take(slot)
        for j in (1, 2):
            term = point[j] - self.start[j].take(slot)
            term *= self.inward[j].take(slot)
            value += term
        inside = value >= self.tolerance.take(slot)
        if also is not None:
            inside &= also
        return inside


def _edges(normal: list, corners: np.ndarray) -> list:
    """The three edges (_Edge) of each candidate, its `normal` (three columns) and
    `corners` ((C, 3, 3)) given: made for the three at once, each value by the same
    products, differences and root as one edge at a time, every column contiguous."""
    start = np.ascontiguousarray(corners.transpose(1, 2, 0))  # (corner k, coordinate j, E)
    edge = start[[1, 2, 0]] - start  # corner k + 1 minus corner k
    inward = np.stack(cross_columns(normal, [edge[:, j] for j in range(3)]), axis=1)  # (k, j, E)
    tolerance = -EDGE_TOLERANCE * np.sqrt(
        dot_columns([inward[:, j] for j in range(3)], [inward[:, j] for j in range(3)])
    )
    return [_Edge(list(start[k]), list(inward[k]), tolerance[k]) for k in range(3)]


def _columns(vectors: np.ndarray) -> list:
    """(N, 3) rows as three contiguous columns."""
    return [np.ascontiguousarray(vectors[:, k]) for k in range(3)]


def dot_columns(a: list, b: list):
    """dm.dot3 of vectors given as three columns (or scalars) each: (a0 b0 + a1 b1) + a2 b2."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross_columns(a: list, b: list) -> list:
    """dm.cross of vectors given as three columns each: the same products and differences."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def unique_inverse(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """np.unique(keys, return_inverse=True) for integer keys, by stable_order's radix sort
    (about 3x faster here than np.unique's quicksort)."""
    order = stable_order(keys)
    ordered = keys.take(order)
    new = run_starts(ordered)
    inverse = np.empty(len(keys), dtype=np.intp)
    inverse[order] = np.cumsum(new) - 1
    return ordered[new], inverse


def run_starts(values: np.ndarray) -> np.ndarray:
    """(N,) bool, True where a run of equal values begins: np.r_[True, v[1:] != v[:-1]]
    without np.r_'s cost (a few microseconds a call, a sizeable part of deciding a few rays)."""
    starts = np.empty(len(values), dtype=bool)
    starts[:1] = True
    np.not_equal(values[1:], values[:-1], out=starts[1:])
    return starts


def sorted_unique(keys: np.ndarray) -> np.ndarray:
    """np.unique(keys) for keys that come in runs (a ray's candidates, rays in order): the
    stable sort finds the runs, about 7x faster here than np.unique's quicksort."""
    keys = np.sort(keys, kind="stable")
    return keys[run_starts(keys)]


def nearest_per_ray(ray: np.ndarray, cand: np.ndarray, t: np.ndarray):
    """For pairs sorted by (ray, cand): each ray once, with its candidate of smallest t (ties:
    the lowest cand, the first in its run) - what a lexsort by (ray, t, cand) picks, without
    the sort."""
    if not len(ray):
        return ray, cand
    starts = run_starts(ray).nonzero()[0]
    nearest = np.minimum.reduceat(t, starts)
    at_min = (t == nearest.repeat(np.diff(starts, append=len(ray)))).nonzero()[0]
    firsts = at_min[run_starts(ray.take(at_min))]
    return ray[firsts], cand[firsts]


def rows(points: np.ndarray, index: np.ndarray) -> np.ndarray:
    """points[index], except that one origin broadcast to every ray of a scan stays a
    broadcast (no copy): gathering it once per ray and candidate took a sixth of the
    settling; the arithmetic on it is the same."""
    if points.ndim == 2 and len(points) and points.strides[0] == 0:
        return np.broadcast_to(points[0], (len(index), 3))
    return points.take(index, axis=0)


def stable_order(keys: np.ndarray) -> np.ndarray:
    """np.argsort(keys, kind="stable") for integer keys in [0, 2**32): two passes of numpy's
    radix sort on 16-bit digits (low, then high: the second pass keeps the first's order among
    equal high digits), ~2.5x faster than the merge sort numpy uses for wider integers."""
    if not len(keys) or keys.min() < 0 or keys.max() >= 1 << 32:
        return np.argsort(keys, kind="stable")
    low = np.argsort((keys & 0xFFFF).astype(np.uint16), kind="stable")
    high = np.argsort((keys >> 16).astype(np.uint16).take(low), kind="stable")
    return low.take(high)


def _band(padded: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Settler.band of these triangles."""
    shift = np.max(dm.norm(padded - corners), axis=1)
    double_area = dm.norm(dm.cross(padded[:, 1] - padded[:, 0], padded[:, 2] - padded[:, 0]))
    longest = np.max([dm.norm(padded[:, k] - padded[:, k - 1]) for k in range(3)], axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        band = 2.0 * shift * longest / double_area + BAND_MARGIN  # 2 shift / the lowest altitude
    return np.where(double_area > 0, band, np.inf).astype(np.float32)


def position_ids(vertices: np.ndarray) -> np.ndarray:
    """(V,) ids equal exactly where vertices are at the same float64 position (the grouping
    of np.unique(vertices, axis=0), 0.0 and -0.0 alike) without np.unique's sort of every
    row by all three columns: sorted by x alone, only the few rows sharing an x (mostly
    terrain) are sorted by y and z too."""
    bits = np.ascontiguousarray(vertices + 0.0, dtype=np.float64).view(np.int64)  # + 0.0: -0.0 -> 0.0
    order = np.argsort(bits[:, 0], kind="stable")
    x = bits[order, 0]
    tie = x[1:] == x[:-1]
    shared_x = np.flatnonzero(np.r_[tie, False] | np.r_[False, tie])
    rows = bits[order[shared_x]]
    # x stays the first key, so each run of one x keeps its place in `order`
    by_yz = np.lexsort((rows[:, 2], rows[:, 1], rows[:, 0]))
    order[shared_x], rows = order[shared_x][by_yz], rows[by_yz]
    # a new position where x changes, or, inside a run of one x, where y or z does
    new_position = np.r_[True, x[1:] != x[:-1]]
    follows = shared_x[1:] - 1 == shared_x[:-1]
    new_position[shared_x[1:]] |= follows & np.any(rows[1:, 1:] != rows[:-1, 1:], axis=1)
    ids = np.empty(len(bits), dtype=np.int64)
    ids[order] = np.cumsum(new_position) - 1
    return ids


def _barycentrics(tris: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, v) of points in triangles (weights of corners 1 and 2), float64."""
    e1, e2, p = tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0], points - tris[:, 0]
    d11, d12, d22 = dm.dot3(e1, e1), dm.dot3(e1, e2), dm.dot3(e2, e2)
    p1, p2 = dm.dot3(p, e1), dm.dot3(p, e2)
    with np.errstate(divide="ignore", invalid="ignore"):
        det = d11 * d22 - d12 * d12
        return (d22 * p1 - d12 * p2) / det, (d11 * p2 - d12 * p1) / det


class FirstHits(Protocol):
    """What settle needs of a backend over extracted triangles (refine.RefiningBackend):
    its own first hits, before any are settled."""

    def _first_hits(self, local: np.ndarray, dirs: np.ndarray, max_range: float): ...


def settle(backend: FirstHits, settler: Settler, local, dirs, triangle, rough, bary, max_range):
    """The backend's first hits (triangle, rough distance) with every ambiguous one decided
    by `Settler.decide`, re-casting the rays that pass beside their triangle. In place."""
    todo = np.flatnonzero(settler.in_band(triangle, bary, local, dirs, rough))
    start = np.zeros(len(todo))  # each of `todo`'s distance it starts from (beyond a plane it passed)
    for _ in range(MAX_RECASTS):
        if not len(todo):
            break
        winner = settler.decide(rows(local, todo), dirs.take(todo, axis=0), triangle.take(todo), start)
        decided = winner >= 0
        triangle[todo[decided]] = winner[decided]
        passed = todo[~decided]
        if not len(passed):
            break
        # beyond the plane of the triangle it passed beside, then cast again from there
        beside = triangle[passed]
        n = settler.normal[beside]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (settler.d[beside] - dm.dot3(n, local[passed])) / dm.dot3(n, dirs[passed])
        t = np.where(np.isfinite(t), t, rough[passed]) + RECAST_STEP
        origin = local[passed] + t[:, None] * dirs[passed]
        rough = rough.astype(np.float64)  # now holding distances from the first origin
        far = max_range - t
        again, again_rough, again_bary = backend._first_hits(origin, dirs[passed], max(float(far.max()), 0.0))
        again[(again >= 0) & (again_rough > far)] = -1
        triangle[passed] = again
        rough[passed] = t + again_rough
        band = settler.in_band(again, again_bary, origin, dirs[passed], again_rough)
        todo, start = passed[band], t[band]
    return triangle, rough
