"""`--backend blender`: Blender's scene.ray_cast, its float32 answers settled in float64 like
every other caster's (no bpy here: it wraps the scene.ray_cast backend).

Why: on seed 2's default world, pose (-48.869, 65.879, 42.7), r_h = 1, scene.ray_cast
answered 4 of 194,400 rays otherwise than the float64 geometry: twice it missed a leaf that
the ray enters 1e-6 m inside its edge, once it hit a grass blade the ray passes 1e-6 m beside,
once it took a face of a crown 4.7 um behind the nearer one. It casts in float32 world
coordinates (a ray's origin 65 m from the world's origin is rounded by up to 4 um), so for a
ray within micrometres of a silhouette or of a second face its answer is a coin toss. The
fast casters settle exactly those rays in float64 (settle.py). And the sward medium (core/
effects/cover.py) draws its stopping depths from one stream per part of 49,152 rays, in ray
order: a ray whose hit differs takes another number of draws, and every later stop of its
part moves, so those 4 rays changed 724 beams (the low grass and bush "0.2-1.9 m apart").

So scene.ray_cast's answers are held against the fastest proven caster's over the same
extracted triangles (the one that scans the same crop; select.make_backend), and each ray they
disagree on (class, instance, or a distance more than AGREE apart) is decided by the float64
geometry: its nearest triangle, by brute force over every triangle, each grown by settle's
EDGE_TOLERANCE (as settle.py decides ambiguous hits), the lower index on a tie. Where they
agree, the distance is the settled caster's float64 one, so the bytes are the same. The raw
scene.ray_cast (blender_backend.BlenderRayCastBackend) stays what the benchmarks and tests
measure every caster against.
"""

from __future__ import annotations

import numpy as np

from ..core.hits import RayHits
from .reference import _edge_frames, _plane_hits
from .refine import RefiningBackend, prepare_rays, refine_distances
from .settle import EDGE_TOLERANCE

# Two answers agree when they name the same class and instance at distances this close: far
# above the float64 refinements' differences (1e-15 m), far below a second face behind (um).
AGREE = 1e-9  # m
_TRIANGLES_AT_ONCE = 1 << 18  # a disputed ray is tested against this many triangles at a time


class SettledSceneRayCast:
    """scene.ray_cast (`raw`) settled against `settled` (a RefiningBackend over the extraction
    of the same scene: `settled.geometry`)."""

    name = "blender"
    capabilities = frozenset()  # as the raw backend: no normals

    def __init__(self, raw, settled: RefiningBackend):
        self.raw = raw
        self.settled = settled
        self._frames = None  # reference._edge_frames of the geometry, made at the first dispute
        self.disputed = 0  # rays decided by the float64 geometry so far (tests, benchmarks)

    def cast(self, origins, directions, max_range: float, progress=None) -> RayHits:
        mine = self.raw.cast(origins, directions, max_range, progress)
        theirs = self.settled.cast(origins, directions, max_range)
        disputed = np.flatnonzero(~_agree(mine, theirs))
        if not len(disputed):
            return theirs
        self.disputed += len(disputed)
        local, dirs = prepare_rays(origins, directions, self.settled.geometry.offset)
        triangle, distance = self._float64_first_hits(local, dirs, disputed, max_range)
        decided = self.settled.geometry.hits(triangle, distance)
        return _spliced(theirs, disputed, decided)

    def _float64_first_hits(self, local, dirs, rays, max_range: float):
        """Per disputed ray, its nearest triangle in float64 (-1: none) and the distance the
        settled caster gives a hit on it (refine_distances over its planes)."""
        geometry = self.settled.geometry
        if self._frames is None:
            self._frames = _edge_frames(geometry)
        triangle = np.full(len(rays), -1, dtype=np.int64)
        for k, ray in enumerate(rays.tolist()):
            triangle[k] = _nearest(self._frames, local[ray], dirs[ray], max_range, geometry.triangle_count)
        distance = np.full(len(rays), np.inf)
        hit = np.flatnonzero(triangle >= 0)
        if len(hit):
            normal, d = self.settled._planes
            rough = np.zeros(len(hit))
            exact = refine_distances(normal, d, local[rays[hit]], dirs[rays[hit]], triangle[hit], rough)
            beyond = exact > max_range
            triangle[hit[beyond]] = -1
            distance[hit[~beyond]] = exact[~beyond]
        return triangle, distance


def _nearest(frames, origin, direction, max_range: float, count: int) -> int:
    """The triangle one ray meets first in float64 (grown by EDGE_TOLERANCE), -1 for none."""
    best_t, best = np.inf, -1
    normal, d, inward, ok = frames
    for start in range(0, count, _TRIANGLES_AT_ONCE):
        part = slice(start, start + _TRIANGLES_AT_ONCE)
        block = (normal[part], d[part], [(m[part], off[part]) for m, off in inward], ok[part])
        t, depth, valid, _ = _plane_hits(block, origin[None, :], direction[None, :], max_range)
        t = np.where(valid & (depth >= -EDGE_TOLERANCE), t, np.inf)[0]
        k = int(np.argmin(t))  # the first of equal distances: the lower index
        if t[k] < best_t:
            best_t, best = float(t[k]), start + k
    return best


def _agree(a: RayHits, b: RayHits) -> np.ndarray:
    both_miss = ~a.hit & ~b.hit
    same = (a.class_id == b.class_id) & (a.instance == b.instance)
    with np.errstate(invalid="ignore"):
        close = np.abs(a.distance - b.distance) <= AGREE
    return both_miss | (same & close)


def _spliced(into: RayHits, rows: np.ndarray, new: RayHits) -> RayHits:
    """`into` with the rays `rows` answered by `new` (one answer a row)."""
    distance, class_id, instance = into.distance.copy(), into.class_id.copy(), into.instance.copy()
    distance[rows], class_id[rows], instance[rows] = new.distance, new.class_id, new.instance
    reflectivity = None
    if into.reflectivity is not None or new.reflectivity is not None:
        reflectivity = into.overrides().copy()
        reflectivity[rows] = new.overrides()
    untagged = into.untagged_objects | new.untagged_objects
    return RayHits(distance, class_id, instance, untagged, None, reflectivity)
