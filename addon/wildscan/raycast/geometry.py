"""Scene geometry as plain numpy: what every fast ray backend reads (numpy only, no bpy).

`SceneGeometry` is one indexed triangle mesh of the whole (cropped) scene in
world metres, with per-triangle class id, instance id and the object it came
from. It is built once per world by `extract.extract_scene` and shared by every
pose scanned in that world.

Precision, and why there is an `offset`
---------------------------------------
Vertices are kept in float64 world coordinates. Accelerated backends (Embree,
mathutils' BVHTree) work in float32, whose spacing is about 1 mm at 10 km:
a world moved 10 km from the origin would lose its millimetres there. So every
float32 copy is made *relative to* `offset`, a local origin near the scan
(the crop centre, or the middle of the geometry's bounding box): within the
sensor's 30 m reach float32 keeps ~2 µm. Ray origins are shifted by the same
offset before casting. Backends then recompute each hit distance in float64
against the hit triangle's plane (`refine_distances`), so reported ranges are
those of the float64 geometry, not of its float32 copy.

Sealed edges
------------
Single-precision ray/triangle tests are not watertight: a ray through a shared
edge or vertex can slip between neighbouring triangles (tests/test_stability.py
counts it per backend). The float32 backends therefore upload each triangle grown
in its own plane by a few float32 ulps (`pad_triangles`), so neighbours overlap
and no ray slips through; refined ranges are unaffected.

Cropping
--------
A scan cannot see farther than its max range, so only triangles near the pose
matter. `cropped(center, radius)` keeps every triangle whose axis-aligned bounding box
comes within `radius` of `center` in the XY plane (an infinite vertical cylinder: the
optical centre's height is only known after placement, which casts through this geometry).
The box test is conservative: a triangle a ray can reach within the radius is never dropped.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core import detmath as dm
from ..core.backend import NORMALS
from ..core.hits import MISS_CLASS, MISS_INSTANCE, RayHits
from .blocks import by_blocks
from .settle import settle

# the arrays of one entry a triangle (subset and concatenate carry each along)
PER_TRIANGLE = ("class_id", "instance", "object_index", "reflectivity", "reflectance")


@dataclass
class SceneGeometry:
    """One indexed triangle mesh of the scene, world metres (float64), Z up.

    vertices:     float64 (V, 3) world coordinates.
    faces:        int32 (T, 3) vertex indices of each triangle.
    class_id:     int16 (T,) internal class id per triangle (classes.BY_ID; 0 untagged, WATER_ID water).
    instance:     int32 (T,) `wildscan_instance` of the triangle's object (0 when absent).
    object_index: int32 (T,) index into `object_names` of the object the triangle came from.
    object_names: names of the extracted objects (instances use the instanced object's name).
    offset:       float64 (3,) local origin for float32 copies (see module docstring).
    reflectivity: float32 (T,) the object's `wildscan_reflectivity` override, nan where the
                  class's reflectivity applies (None given: no override anywhere).
    reflectance:  float32 (T,) `wildscan_reflectance` (0-1, core/realism/lost_returns.py), nan: none.
    cover:        the world's ground cover (core/world/cover.py CoverGrid), not triangles: a
                  layer the scan's medium walks (core/effects/cover.py); None: bare ground.
    """

    vertices: np.ndarray
    faces: np.ndarray
    class_id: np.ndarray
    instance: np.ndarray
    object_index: np.ndarray
    object_names: tuple[str, ...] = ()
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    reflectivity: np.ndarray | None = None
    cover: object = None
    reflectance: np.ndarray | None = None

    def __post_init__(self) -> None:
        self.vertices = np.ascontiguousarray(self.vertices, dtype=np.float64).reshape(-1, 3)
        self.faces = np.ascontiguousarray(self.faces, dtype=np.int32).reshape(-1, 3)
        t = len(self.faces)
        self.class_id = _per_triangle(self.class_id, t, np.int16, "class_id")
        self.instance = _per_triangle(self.instance, t, np.int32, "instance")
        self.object_index = _per_triangle(self.object_index, t, np.int32, "object_index")
        self.reflectivity = _per_triangle(self.reflectivity, t, np.float32, "reflectivity")  # None: nan
        self.reflectance = _per_triangle(self.reflectance, t, np.float32, "reflectance")
        self.object_names = tuple(self.object_names)
        self.offset = np.asarray(self.offset, dtype=np.float64).reshape(3)
        if t and (self.faces.min() < 0 or self.faces.max() >= len(self.vertices)):
            raise ValueError("faces index vertices that do not exist")

    # -- sizes and views ---------------------------------------------------------------

    @property
    def triangle_count(self) -> int:
        return len(self.faces)

    def triangles(self) -> np.ndarray:
        """(T, 3, 3) float64 world coordinates of each triangle's corners."""
        return self.vertices[self.faces]

    def local_vertices(self, dtype=np.float32) -> np.ndarray:
        """Vertices relative to `offset` (subtracted in float64, then cast)."""
        return np.ascontiguousarray(self.vertices - self.offset, dtype=dtype)

    def local_triangles(self) -> np.ndarray:
        """(T, 3, 3) offset-local float64 corners of each triangle."""
        return (self.vertices - self.offset)[self.faces]

    def padded_local_triangles(self, pad: float | None = None, dtype=np.float32, corners=None) -> np.ndarray:
        """(T, 3, 3) offset-local triangles, each grown in its own plane so every edge moves
        outward by `pad` metres (default `edge_pad`). See `pad_triangles` for why. `corners`:
        `local_triangles()` when the caller has them already."""
        tris = self.local_triangles() if corners is None else corners
        if pad is None:
            pad = edge_pad(tris)
        return np.ascontiguousarray(by_blocks(lambda block: pad_triangles(block, pad), tris), dtype=dtype)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(min (3,), max (3,)) of the vertices actually used by triangles."""
        if not self.triangle_count:
            return np.zeros(3), np.zeros(3)
        return corner_extent(self.vertices, self.faces)

    def local_planes(self, corners=None) -> tuple[np.ndarray, np.ndarray]:
        """Per-triangle plane in offset-local float64 coordinates: (unit normal (T,3), d (T,))
        with n·x = d on the plane; degenerate triangles get a zero normal. `corners`:
        `local_triangles()` when the caller has them already."""
        tris = self.local_triangles() if corners is None else corners
        return by_blocks(_planes, tris[:, 0], tris[:, 1], tris[:, 2])

    # -- cropping ------------------------------------------------------------------------

    def cropped(self, center, radius: float) -> "SceneGeometry":
        """Triangles whose XY bounding box comes within `radius` of `center` (see module
        docstring); vertices are compacted and `offset` moves to the centre."""
        center = np.asarray(center, dtype=np.float64).ravel()
        if center.size not in (2, 3):
            raise ValueError(f"crop centre must have 2 or 3 coordinates, got {center.size}")
        keep = triangles_near_xy(self.vertices, self.faces, center[:2], float(radius))
        part = self.subset(keep)
        part.offset = local_origin(part.vertices, part.faces, center)
        return part

    def subset(self, keep: np.ndarray) -> "SceneGeometry":
        """The triangles selected by a boolean mask or index array, with unused vertices dropped."""
        faces = self.faces[keep]
        used = used_vertices(faces, len(self.vertices))
        remap = np.cumsum(used, dtype=np.int64) - 1
        return SceneGeometry(
            vertices=self.vertices[used],
            faces=remap[faces].astype(np.int32),
            object_names=self.object_names,
            offset=self.offset.copy(),
            cover=self.cover,
            **{name: getattr(self, name)[keep] for name in PER_TRIANGLE},
        )

    # -- turning triangle hits into RayHits ---------------------------------------------

    def hits(self, triangle: np.ndarray, distance: np.ndarray, normals: np.ndarray | None = None) -> RayHits:
        """RayHits from per-ray hit triangle index (-1 for a miss) and distance (inf for a
        miss, as given); with the per-triangle unit `normals` (local_planes) given, each hit's
        normal."""
        triangle = np.asarray(triangle, dtype=np.int64)
        # One gather each from arrays ending in a miss row (index -1 is the last): faster than
        # boolean masks on big batches (the realistic model casts a million sub-rays a scan).
        class_id, instance = self._with_miss_row()
        hit_class = class_id.take(triangle)
        out = RayHits(
            distance=distance,
            class_id=hit_class,
            instance=instance.take(triangle),
            # read off the gathered classes: a miss's is MISS_CLASS, never untagged
            untagged_objects=self.names_of(triangle[hit_class == 0]) if self.object_names else frozenset(),
        )
        if self._has_overrides():
            out.reflectivity = np.append(self.reflectivity, np.float32(np.nan)).take(triangle)
        if normals is not None:
            # zeroed on a miss (a miss row appended copied a whole world's normals each cast)
            hit = triangle >= 0
            out.normal = normals.take(np.where(hit, triangle, 0), axis=0)
            out.normal[~hit] = 0.0
        return out

    def _has_overrides(self) -> bool:
        """Whether any triangle's reflectivity is overridden (tested once, not every cast)."""
        seen, answer = self.__dict__.get("_overrides", (None, False))
        if seen is not self.reflectivity:
            self.__dict__["_overrides"] = (self.reflectivity, answer := not np.isnan(self.reflectivity).all())
        return answer

    def _with_miss_row(self) -> tuple[np.ndarray, np.ndarray]:
        """class_id and instance, each with the miss value appended (cached)."""
        cached = self.__dict__.get("_miss_rows")
        if cached is None or len(cached[0]) != len(self.class_id) + 1:
            cached = (
                np.append(self.class_id, np.int16(MISS_CLASS)).astype(np.int16),
                np.append(self.instance, np.int32(MISS_INSTANCE)).astype(np.int32),
            )
            self.__dict__["_miss_rows"] = cached
        return cached

    def untagged_names(self, triangles: np.ndarray) -> frozenset[str]:
        """Names of the untagged (class 0) objects owning these triangles."""
        if not len(triangles) or not self.object_names:
            return frozenset()
        return self.names_of(triangles[self.class_id[triangles] == 0])

    def names_of(self, triangles: np.ndarray) -> frozenset[str]:
        """Names of the objects owning these triangles."""
        idx = np.unique(self.object_index.take(triangles))
        return frozenset(self.object_names[i] for i in idx if 0 <= i < len(self.object_names))


def _planes(v0: np.ndarray, v1: np.ndarray, v2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unit normal, d) of the triangles with these corners (zero normal when degenerate)."""
    normal = dm.cross(v1 - v0, v2 - v0)  # detmath: summed in a fixed order on every CPU
    length = dm.norm(normal)
    normal /= np.where(length > 0, length, 1.0)[:, None]
    return normal, dm.dot3(normal, v0)


def _per_triangle(values, count: int, dtype, name: str) -> np.ndarray:
    arr = np.asarray(np.nan if values is None else values, dtype=dtype).ravel()
    if arr.size == 1 and count != 1:
        arr = np.full(count, arr[0], dtype=dtype)
    if len(arr) != count:
        raise ValueError(f"{name} has {len(arr)} entries for {count} triangles")
    return np.ascontiguousarray(arr)


def triangles_near_xy(vertices: np.ndarray, faces: np.ndarray, center_xy, radius: float) -> np.ndarray:
    """Boolean mask: the triangle's XY bounding box is within `radius` of `center_xy`."""
    xy = vertices[:, :2][faces]  # (T, 3, 2)
    lo, hi = xy.min(axis=1), xy.max(axis=1)
    c = np.asarray(center_xy, dtype=np.float64)[:2]
    gap = np.clip(c, lo, hi) - c
    return gap[:, 0] * gap[:, 0] + gap[:, 1] * gap[:, 1] <= radius * radius


def used_vertices(faces: np.ndarray, vertex_count: int) -> np.ndarray:
    """Boolean mask of the vertices some face uses."""
    used = np.zeros(vertex_count, dtype=bool)
    used[faces.ravel()] = True
    return used


def corner_extent(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(min (3,), max (3,)) of the vertices some face uses (faces not empty). Column by
    column: numpy's min(axis=0) over an (N, 3) array strides across rows and is much slower."""
    used = used_vertices(faces, len(vertices))
    points = vertices if used.all() else vertices[used]
    low = np.array([points[:, k].min() for k in range(3)])
    high = np.array([points[:, k].max() for k in range(3)])
    return low, high


def local_origin(vertices: np.ndarray, faces: np.ndarray, center=None) -> np.ndarray:
    """A local origin near the data: `center` in XY (and Z when given), else the middle of
    the used vertices' bounding box. Rounded to whole metres so it prints cleanly;
    float32 precision near it is unaffected by that."""
    if len(faces):
        low, high = corner_extent(vertices, faces)
        mid = 0.5 * (low + high)
    else:
        mid = np.zeros(3)
    if center is not None:
        center = np.asarray(center, dtype=np.float64).ravel()
        mid[: center.size] = center[:3]
    return np.round(mid)


def world_vertices(local: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """(V,3) float64 object-space vertices moved by a 4x4 world matrix, in float64. The one
    expression the Blender extraction and the Blender-free path both use, so the same
    inputs give the same bits (summed in a fixed order by dm.apply, not by BLAS)."""
    return dm.apply(matrix[:3, :3], local) + matrix[:3, 3]


def concatenate(parts: list[SceneGeometry], object_names=None, offset=None) -> SceneGeometry:
    """Join geometries into one; object indices must already refer to `object_names`."""
    if not parts:
        return empty_geometry(object_names or ())
    starts = np.cumsum([0] + [len(p.vertices) for p in parts[:-1]])
    geometry = SceneGeometry(
        vertices=np.concatenate([p.vertices for p in parts]),
        faces=np.concatenate([p.faces.astype(np.int64) + s for p, s in zip(parts, starts)]),
        object_names=object_names if object_names is not None else parts[0].object_names,
        **{name: np.concatenate([getattr(p, name) for p in parts]) for name in PER_TRIANGLE},
    )
    geometry.offset = local_origin(geometry.vertices, geometry.faces) if offset is None else offset
    return geometry


def empty_geometry(object_names=()) -> SceneGeometry:
    return SceneGeometry(
        vertices=np.zeros((0, 3)),
        faces=np.zeros((0, 3), dtype=np.int32),
        class_id=np.zeros(0, dtype=np.int16),
        instance=np.zeros(0, dtype=np.int32),
        object_index=np.zeros(0, dtype=np.int32),
        object_names=tuple(object_names),
    )


def from_triangles(
    triangles, class_id=0, instance=0, object_index=0, object_names=("mesh",)
) -> SceneGeometry:
    """A SceneGeometry from a (T, 3, 3) triangle soup (tests and benchmarks)."""
    tris = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    faces = np.arange(3 * len(tris)).reshape(-1, 3)
    geometry = SceneGeometry(tris.reshape(-1, 3), faces, class_id, instance, object_index, object_names)
    geometry.offset = local_origin(geometry.vertices, geometry.faces)
    return geometry


# -- closing the cracks between triangles -------------------------------------------------

# In-plane growth of a triangle: 8 float32 spacings (ulps) of the largest offset-local
# coordinate, at least 10 µm. One ulp already closes every crack the stability tests
# find; 8 is margin. Within a cropped scan (coordinates <= ~35 m) that is ~3e-5 m,
# far below anything a 15 mm-noise sensor can see.
PAD_ULPS = 8.0
MIN_EDGE_PAD = 1e-5
# A vertex never moves more than this many pads (very acute corners of slivers).
_MAX_PAD_STRETCH = 20.0


def edge_pad(local_coordinates: np.ndarray) -> float:
    """The pad that float32 coordinates of this size need: well above their rounding."""
    extent = float(np.abs(local_coordinates).max()) if local_coordinates.size else 0.0
    return max(MIN_EDGE_PAD, PAD_ULPS * float(np.finfo(np.float32).eps) * extent)


def pad_triangles(tris: np.ndarray, pad: float) -> np.ndarray:
    """Grow each triangle (T,3,3) in its own plane so that each edge moves outward by `pad`.

    Why: single-precision ray/triangle tests (Embree, BVHTree) are not watertight;
    a ray through a shared edge or vertex can slip between the two triangles and
    report the surface behind, or nothing (the stability tests measure it). With
    every triangle overlapping its neighbours by `pad`, such a ray hits one of them.
    Growing in-plane keeps each triangle's plane, so float64 refined ranges are
    unchanged; silhouettes grow by `pad` (10-30 µm in a cropped scan).

    Offsetting all three edges by `pad` is a scaling about the incentre by
    (r + pad) / r (r the inradius). Slivers' acute corners would shoot far out,
    so no vertex moves more than _MAX_PAD_STRETCH pads; degenerate triangles stay.
    """
    tris = np.asarray(tris, dtype=np.float64)
    v0, v1, v2 = tris[:, 0], tris[:, 1], tris[:, 2]
    a = dm.norm(v1 - v2)  # side lengths opposite each vertex
    b = dm.norm(v2 - v0)
    c = dm.norm(v0 - v1)
    perimeter = a + b + c
    double_area = dm.norm(dm.cross(v1 - v0, v2 - v0))
    ok = (double_area > 0) & (perimeter > 0)
    safe_perimeter = np.where(ok, perimeter, 1.0)
    inradius = np.where(ok, double_area / safe_perimeter, 1.0)
    incentre = (a[:, None] * v0 + b[:, None] * v1 + c[:, None] * v2) / safe_perimeter[:, None]
    out = tris.copy()
    for k in range(3):
        away = tris[:, k] - incentre
        length = dm.norm(away)
        shift = np.minimum(pad * length / inradius, _MAX_PAD_STRETCH * pad)
        scale = np.where(ok & (length > 0), shift / np.where(length > 0, length, 1.0), 0.0)
        out[:, k] += away * scale[:, None]
    return out


# -- float64 hit refinement (shared by the float32 backends) -----------------------------


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
    threads: int | None = None  # core/threads.py: None the cores (or the environment), 1 a dataset worker

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
