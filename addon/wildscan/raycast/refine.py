"""A float32 caster's hits made float64-exact (numpy only): rays moved into the geometry's
offset-local frame, ambiguous hits settled (settle.py) and every distance refined against the
hit triangle's float64 plane, so the fast backends' ranges match the reference's.
`RefiningBackend` is what the backends over extracted triangles (embree, bvh, open3d) share.
"""

from __future__ import annotations

import numpy as np

from ..core import detmath as dm
from ..core.backend import NORMALS
from ..core.hits import MISS_CLASS, RayHits
from .geometry import SceneGeometry
from .settle import settle


def prepare_rays(origins: np.ndarray, directions: np.ndarray, offset: np.ndarray):
    """Float64 offset-local origins (N,3) and directions (N,3) for N rays; origins may be (3,)."""
    directions = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
    origins = np.asarray(origins, dtype=np.float64)
    local = origins.reshape(-1, 3) - offset
    if origins.ndim == 1:
        local = np.broadcast_to(local, directions.shape)
    if local.shape != directions.shape:
        raise ValueError(f"{len(local)} origins for {len(directions)} directions")
    return local, directions


# Below this |cos| between ray and triangle plane the ray runs along the plane and the
# plane intersection is ill-posed: the backend's own distance is kept.
_PARALLEL_COS = 1e-9
# Far above how much a caster's float32 distance can differ from the float64 one within a
# world (micrometres): a hit nearer than max_range by more than this is within range.
_ROUGH_DISTANCE_ERROR = 1e-2


def refine_distances(
    normal: np.ndarray,
    d: np.ndarray,
    origins_local: np.ndarray,
    directions: np.ndarray,
    triangle: np.ndarray,
    rough: np.ndarray,
) -> np.ndarray:
    """Float64 distance along each ray to the plane of its hit triangle.

    `normal`, `d` from `SceneGeometry.local_planes`; `triangle` (N,) is the hit
    triangle per ray (>= 0 only), `rough` (N,) the backend's float32 distance. The
    plane intersection is what Möller–Trumbore's t is, computed in float64 from the
    float64 vertices: float32 intersection tests lose millimetres on long thin
    triangles (a wire's facets), this does not. Only for a ray lying in the
    triangle's plane is the rough value kept.
    """
    n = normal.take(triangle, axis=0)  # take: several times faster than fancy indexing of rows
    cos = dm.dot3(n, directions)
    if origins_local.ndim == 2 and len(origins_local) > 1 and origins_local.strides[0] == 0:
        origins_local = origins_local[0]  # one origin (a scan): used as it is, not gathered per ray
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (d.take(triangle) - dm.dot3(n, origins_local)) / cos
    bad = ~np.isfinite(t) | (np.abs(cos) < _PARALLEL_COS)
    t[bad] = rough[bad]
    return np.maximum(t, 0.0)


# -- the backends over extracted triangles -----------------------------------------------


class RefiningBackend:
    """What the backends over extracted triangles share: each finds first hits its own
    way (`_first_hits`, in float32 or float64), every hit the float32 answer could have
    given to another triangle is settled in float64 (settle.py), then every hit distance
    is recomputed in float64 against the exact plane of the hit triangle and cut at max
    range."""

    geometry: SceneGeometry
    _settler = None  # settle.Settler, made by the backend

    def _ready(self) -> bool:
        """Whether there is anything to hit (an empty crop casts nothing)."""
        raise NotImplementedError

    def _first_hits(self, local: np.ndarray, dirs: np.ndarray, max_range: float):
        """(hit triangle per ray, -1 for none; its approximate distance; the hit's (u, v) on
        the uploaded triangle, or None)."""
        raise NotImplementedError

    capabilities = frozenset({NORMALS})  # cast(..., normals=True) gives each hit's triangle normal
    threads: int | None = None  # runtime/threads.py: None the cores (or the environment), 1 a dataset worker

    def cast(
        self, origins: np.ndarray, directions: np.ndarray, max_range: float, normals: bool = False
    ) -> RayHits:
        local, dirs = prepare_rays(origins, directions, self.geometry.offset)
        if (count := len(dirs)) == 0 or not self._ready():
            out = RayHits.empty(count)
            if normals:
                out.normal = np.zeros((count, 3))
            return out
        triangle, rough = self._settled_hits(local, dirs, max_range)
        hit = np.flatnonzero(triangle >= 0)
        distance = np.full(count, np.inf)
        normal, d = self._planes
        # one origin (a scan) stays one row; rows gathered with take, far faster than a mask
        hit_origins = local[0] if local.strides[0] == 0 else local.take(hit, axis=0)
        exact = refine_distances(
            normal, d, hit_origins, dirs.take(hit, axis=0), triangle.take(hit), rough.take(hit)
        )
        distance[hit] = exact
        beyond = hit[exact > max_range]
        triangle[beyond] = -1
        distance[beyond] = np.inf
        return self.geometry.hits(triangle, distance, normal if normals else None)

    def first_hit_classes(self, origins: np.ndarray, directions: np.ndarray, max_range: float) -> np.ndarray:
        """The class id of each ray's first hit within max_range (MISS_CLASS for none): what
        `cast(...).class_id` gives, without the float64 distances a bird's-eye grid does not
        use. Only hits near max_range are measured, to cut them there the way `cast` does."""
        local, dirs = prepare_rays(origins, directions, self.geometry.offset)
        if not len(dirs) or not self._ready():
            return np.full(len(dirs), MISS_CLASS, dtype=np.int16)
        triangle, rough = self._settled_hits(local, dirs, max_range)
        near_end = np.flatnonzero((triangle >= 0) & (rough > max_range - _ROUGH_DISTANCE_ERROR))
        if len(near_end):
            normal, d = self._planes
            exact = refine_distances(
                normal, d, local[near_end], dirs[near_end], triangle[near_end], rough[near_end]
            )
            triangle[near_end[exact > max_range]] = -1
        class_id, _ = self.geometry._with_miss_row()
        return class_id.take(triangle)

    def _settled_hits(self, local: np.ndarray, dirs: np.ndarray, max_range: float):
        """(hit triangle per ray, -1 for none; its approximate distance), ambiguous hits settled."""
        triangle, rough, bary = self._first_hits(local, dirs, max_range)
        if self._settler is not None:
            triangle, rough = settle(self, self._settler, local, dirs, triangle, rough, bary, max_range)
        return triangle, rough
