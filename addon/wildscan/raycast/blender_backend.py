"""Reference ray backend: Blender's own `Scene.ray_cast`, one Python call per ray.

It is the slowest backend (its cost grows with the number of objects in the
scene) but it needs nothing beyond Blender and sees exactly what Blender
evaluates (modifiers, instances), so the faster backends are checked against it.
scene.ray_cast decides what each ray hits (object and face); the distance is then
recomputed in float64 against that face (exact_distances), because its float32
hit points are off by up to ~1e-6 of their distance from the world origin.
`Scene.ray_cast(depsgraph, origin, direction, distance)` has the same signature
from 2.91 up to 5.0.
"""

from __future__ import annotations

import gc
from collections.abc import Callable

import bpy
import numpy as np

from ..core import detmath as dm
from ..core.classes import UNLABELED
from ..core.hits import RayHits
from ..core.runtime.cast_clock import CLOCK
from .base import broadcast_origins, tags_from
from .extract import check_scene_tags

PROGRESS_EVERY = 10_000


# A hit's matrix and a depsgraph instance's matrix are the same float32 numbers; this
# only absorbs round-off should a Blender version recompute one of them.
MATRIX_MATCH_TOL = 1e-4
# Below this |cos| between a ray and a face's plane the plane intersection is ill-posed.
_PARALLEL_COS = 1e-9


def _original(obj):
    return obj.original if obj.original is not None else obj


def _object_tags(obj, instancer=None) -> tuple[int, int, float, str | None]:
    """(class id, instance, reflectivity override (nan: none), name if untagged) of the hit
    object, read from the original objects (evaluated copies may not carry custom properties)."""
    sources = [_original(obj)] + ([_original(instancer)] if instancer is not None else [])
    class_id, instance, reflectivity = tags_from(sources)
    return class_id, instance, reflectivity, sources[0].name if class_id == UNLABELED.id else None


def scene_depsgraph(scene):
    """The evaluated depsgraph of `scene`. The context's scene has one at hand; a scene
    outside any window has none (view_layers[0].depsgraph is None) until one is asked
    for in its own context."""
    if scene == bpy.context.scene:
        return bpy.context.evaluated_depsgraph_get()
    with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
        return bpy.context.evaluated_depsgraph_get()


class InstanceCopies:
    """Where the depsgraph puts copies of instanced objects, to tell which copy a
    ray_cast hit (ray_cast gives the instanced object and the copy's matrix only)."""

    def __init__(self, depsgraph):
        copies: list = []
        direct: list = []
        for inst in depsgraph.object_instances:
            if not inst.is_instance:
                direct.append(inst.object)  # evaluated objects stay valid; read them later
                continue
            obj = inst.object
            if obj is not None:
                # copy now: an instance's data is only valid during this iteration step
                parent = _original(inst.parent) if inst.parent is not None else None
                copies.append((_original(obj), np.array(inst.matrix_world, dtype=np.float64).ravel(), parent))
        self.objects = frozenset(orig for orig, _, _ in copies)  # originals instanced somewhere
        self._candidates: dict = {}
        for orig, matrix, parent in copies:
            self._candidates.setdefault(orig, []).append((matrix, parent))
        if self.objects:
            # an instanced object may also be in the scene itself: a hit there is its own
            for obj in direct:
                orig = _original(obj) if obj is not None else None
                if orig in self.objects:
                    self._candidates[orig].append(
                        (np.array(obj.matrix_world, dtype=np.float64).ravel(), None)
                    )

    def instancer(self, obj, matrix):
        """The instancer of the copy of `obj` at world `matrix` (None: the object itself,
        or no copy matches)."""
        candidates = self._candidates.get(_original(obj))
        if not candidates:
            return None
        m = np.array(matrix, dtype=np.float64).ravel()
        diffs = [float(np.abs(c - m).max()) for c, _ in candidates]
        best = int(np.argmin(diffs))
        return candidates[best][1] if diffs[best] <= MATRIX_MATCH_TOL else None


def exact_distances(depsgraph, origins, directions, rough, objects, faces, matrices) -> np.ndarray:
    """Hit distances recomputed in float64 against the face scene.ray_cast reported.

    scene.ray_cast works in float32: its hit points are off by up to ~1e-6 of their
    distance from the world origin (1.5 mm at 10 km), and on a very large single face far
    more (its float32 test works with the face's own coordinates: centimetres to metres
    on a 100 km wall, `wildscan bench --suite far`). The hit (object, face) stays
    scene.ray_cast's; the distance is always the float64 one, the same refinement the
    fast backends apply: only a ray parallel to the face keeps the float32 distance.
    """
    dist = rough.copy()
    groups: dict = {}
    for k, (obj, matrix) in enumerate(zip(objects, matrices)):
        groups.setdefault((obj, tuple(v for row in matrix for v in row)), []).append(k)
    for (obj, flat_matrix), ks in groups.items():
        rows = np.asarray(ks, dtype=np.intp)
        verts, loop_start, loop_total, loop_verts = _evaluated_faces(obj.evaluated_get(depsgraph))
        if verts is None:
            continue
        m = np.asarray(flat_matrix, dtype=np.float64).reshape(4, 4)
        world = dm.apply(m[:3, :3], verts) + m[:3, 3]  # fixed order, not BLAS: same bits on every CPU
        face = np.asarray([faces[k] for k in ks], dtype=np.intp)
        if face.max(initial=-1) >= len(loop_start):
            continue  # the mesh changed under us: keep scene.ray_cast's distances
        dist[rows] = _fan_plane_distances(
            world,
            loop_start[face],
            loop_total[face],
            loop_verts,
            origins[rows],
            directions[rows],
            rough[rows],
        )
    return dist


def _evaluated_faces(obj):
    """(vertices (V,3) float64 object space, loop_start, loop_total, loop vertex indices) of
    an evaluated object's mesh (modifiers applied: the faces ray_cast indexes), or Nones."""
    try:
        mesh = obj.to_mesh()
    except RuntimeError:
        return None, None, None, None
    if mesh is None:
        return None, None, None, None
    try:
        co = np.empty(len(mesh.vertices) * 3, dtype=np.float64)
        mesh.vertices.foreach_get("co", co)
        start = np.empty(len(mesh.polygons), dtype=np.int64)
        total = np.empty(len(mesh.polygons), dtype=np.int64)
        mesh.polygons.foreach_get("loop_start", start)
        mesh.polygons.foreach_get("loop_total", total)
        loops = np.empty(len(mesh.loops), dtype=np.int64)
        mesh.loops.foreach_get("vertex_index", loops)
    finally:
        obj.to_mesh_clear()
    return co.reshape(-1, 3), start, total, loops


def _fan_plane_distances(world, start, total, loop_verts, origins, dirs, rough) -> np.ndarray:
    """Per ray, the float64 distance to the plane of the fan triangle (v0, vi, vi+1) of its
    face that the ray passes through in float64; where it passes through none (a hair
    beside the face's edge, as float32 saw it inside), the fan plane nearest the float32
    distance. Planar faces: every fan plane is the face's; bent quads and n-gons: the one
    hit. The float32 distance only ranks the candidates: it is never the answer unless the
    ray runs parallel to every fan plane."""
    best = rough.copy()
    best_gap = np.full(len(rough), np.inf)
    best_inside = np.zeros(len(rough), dtype=bool)
    a = world[loop_verts[start]] - origins  # ray-origin-local: float64 keeps far worlds exact
    for i in range(1, int(total.max(initial=3)) - 1):
        has = total > i + 1
        b = world[loop_verts[start + np.minimum(i, total - 1)]] - origins
        c = world[loop_verts[start + np.minimum(i + 1, total - 1)]] - origins
        n = dm.cross(b - a, c - a)
        denom = dm.dot3(dirs, n)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = dm.dot3(a, n) / denom
        ok = has & np.isfinite(t) & (np.abs(denom) >= _PARALLEL_COS * dm.norm(n))
        inside = ok & _inside_triangle(a, b, c, n, np.where(ok, t, 0.0)[:, None] * dirs)
        gap = np.abs(t - rough)
        better = ok & ((inside & ~best_inside) | ((inside == best_inside) & (gap < best_gap)))
        best[better] = t[better]
        best_gap[better] = gap[better]
        best_inside |= better & inside
    return best


def _inside_triangle(a, b, c, n, p) -> np.ndarray:
    """Whether points p lie in triangles (a, b, c) of (unnormalised) normals n, in their plane."""
    inside = np.ones(len(p), dtype=bool)
    for u, v in ((a, b), (b, c), (c, a)):
        inside &= dm.dot3(dm.cross(v - u, p - u), n) >= 0.0
    return inside


class BlenderRayCastBackend:
    name = "blender"
    capabilities = frozenset()  # its cast gives no normals (the realistic model refuses it)

    def __init__(self, scene=None, depsgraph=None):
        self.scene = scene if scene is not None else bpy.context.scene
        # Without an explicit depsgraph, re-fetch it at every cast so edits made to the
        # scene after constructing the backend are seen.
        self._own_depsgraph = depsgraph is None
        self.depsgraph = depsgraph if depsgraph is not None else self._evaluated_depsgraph()

    def _evaluated_depsgraph(self):
        return scene_depsgraph(self.scene)

    def cast(
        self,
        origins: np.ndarray,
        directions: np.ndarray,
        max_range: float,
        progress: Callable[[int, int], None] | None = None,
    ) -> RayHits:
        """First hit of each ray within max_range; `progress(done, total)` is called every
        PROGRESS_EVERY rays and once at the end."""
        directions = np.asarray(directions, dtype=np.float64).reshape(-1, 3)
        n = len(directions)
        hits = RayHits.empty(n)
        max_range = float(max_range)
        if n == 0 or max_range <= 0:
            return hits
        single_origin = np.ndim(origins) == 1
        origins = broadcast_origins(origins, n)
        if origins.shape != directions.shape:
            raise ValueError(f"origins {origins.shape} do not match directions {directions.shape}")
        if self._own_depsgraph:
            self.depsgraph = self._evaluated_depsgraph()
        # every visible object's tags, hit or not: the fast backends refuse the same scenes
        check_scene_tags(self.depsgraph)
        copies = InstanceCopies(self.depsgraph)
        # The loop allocates several objects per ray; with generational GC on, each
        # collection walks the growing lists below, a large share of the run for nothing.
        gc_was_enabled = gc.isenabled()
        gc.disable()
        try:
            with CLOCK.casting():
                found = self._loop(origins, directions, max_range, single_origin, progress)
            if found[0]:
                self._fill(hits, self.depsgraph, origins, directions, max_range, copies, *found)
        finally:
            if gc_was_enabled:
                gc.enable()
        return hits

    def _loop(self, origins, directions, max_range, single_origin, progress):
        """(ray indices, locations, objects, face indices, matrices) of the hits."""
        n = len(directions)
        # Python floats in tuples are what ray_cast converts fastest.
        d_list = list(map(tuple, directions.tolist()))
        hit_index: list[int] = []
        hit_loc: list = []
        hit_obj: list = []
        hit_face: list[int] = []
        hit_matrix: list = []
        ray_cast, depsgraph = self.scene.ray_cast, self.depsgraph
        add_index, add_loc, add_obj = hit_index.append, hit_loc.append, hit_obj.append
        add_face, add_matrix = hit_face.append, hit_matrix.append
        if single_origin:
            origin = tuple(origins[0].tolist())
        else:
            o_list = list(map(tuple, origins.tolist()))
        for start in range(0, n, PROGRESS_EVERY):
            stop = min(start + PROGRESS_EVERY, n)
            if single_origin:
                for k in range(start, stop):
                    ok, loc, _normal, face, obj, matrix = ray_cast(
                        depsgraph, origin, d_list[k], distance=max_range
                    )
                    if ok:
                        add_index(k)
                        add_loc(loc)
                        add_obj(obj)
                        add_face(face)
                        add_matrix(matrix)
            else:
                for k in range(start, stop):
                    ok, loc, _normal, face, obj, matrix = ray_cast(
                        depsgraph, o_list[k], d_list[k], distance=max_range
                    )
                    if ok:
                        add_index(k)
                        add_loc(loc)
                        add_obj(obj)
                        add_face(face)
                        add_matrix(matrix)
            if progress is not None:
                progress(stop, n)
        return hit_index, hit_loc, hit_obj, hit_face, hit_matrix

    @staticmethod
    def _fill(
        hits: RayHits,
        depsgraph,
        origins,
        directions,
        max_range,
        copies,
        hit_index,
        hit_loc,
        hit_obj,
        hit_face,
        hit_matrix,
    ) -> None:
        idx = np.asarray(hit_index, dtype=np.intp)
        loc = np.array([v[:] for v in hit_loc], dtype=np.float64).reshape(-1, 3)
        dist = exact_distances(
            depsgraph,
            origins[idx],
            directions[idx],
            dm.norm(loc - origins[idx]),
            hit_obj,
            hit_face,
            hit_matrix,
        )
        # float32 round-off can put a hit a hair past the limit ray_cast was given
        keep = np.flatnonzero(dist <= max_range)
        # Per call only: evaluated objects are rebuilt (and their memory reused) whenever
        # the depsgraph re-evaluates, so a cache kept across calls could go stale.
        tags: dict = {}
        class_ids = np.empty(len(keep), dtype=np.int16)
        instances = np.empty(len(keep), dtype=np.int32)
        reflectivity = np.empty(len(keep), dtype=np.float32)
        instancers: dict = {}
        for j, k in enumerate(keep.tolist()):
            obj = hit_obj[k]
            key = obj
            matrix = hit_matrix[k] if obj in copies.objects else None
            if matrix is not None:
                # a copy of an instanced object: which one, by its matrix
                m_key = (obj, tuple(v for row in matrix for v in row))
                if m_key not in instancers:
                    instancers[m_key] = copies.instancer(obj, matrix)
                key = (obj, instancers[m_key])
            tag = tags.get(key)
            if tag is None:
                tag = tags[key] = _object_tags(obj, key[1] if isinstance(key, tuple) else None)
            class_ids[j], instances[j], reflectivity[j] = tag[0], tag[1], tag[2]
        idx = idx[keep]
        hits.distance[idx] = dist[keep]
        hits.class_id[idx] = class_ids
        hits.instance[idx] = instances
        if not np.isnan(reflectivity).all():
            hits.reflectivity = np.full(len(hits.distance), np.nan, dtype=np.float32)
            hits.reflectivity[idx] = reflectivity
        hits.untagged_objects = frozenset(t[3] for t in tags.values() if t[3] is not None)
