"""Reference ray backend: Blender's own `Scene.ray_cast`, one Python call per ray.

It is the slowest backend (its cost grows with the number of objects in the
scene) but it needs nothing beyond Blender and sees exactly what Blender
evaluates (modifiers, instances), so the faster backends are checked against it.
`Scene.ray_cast(depsgraph, origin, direction, distance)` has the same signature
from 2.91 up to 5.0.
"""
from __future__ import annotations

import gc
from collections.abc import Callable

import bpy
import numpy as np

from ..core.classes import UNLABELED, class_id_for_tag
from .base import RayHits, broadcast_origins

PROGRESS_EVERY = 10_000


def _object_tags(obj) -> tuple[int, int, str | None]:
    """(class id, instance, name if untagged) of the hit object, read from the original
    object: evaluated copies may not carry custom properties."""
    orig = obj.original if obj.original is not None else obj
    class_id = class_id_for_tag(orig.get("wildscan_class"))
    try:
        instance = int(orig.get("wildscan_instance", 0))
    except (TypeError, ValueError):
        instance = 0
    untagged = orig.name if class_id == UNLABELED.id else None
    return class_id, instance, untagged


class BlenderRayCastBackend:
    name = "blender"

    def __init__(self, scene=None, depsgraph=None):
        self.scene = scene if scene is not None else bpy.context.scene
        # Without an explicit depsgraph, re-fetch it at every cast so edits made to the
        # scene after constructing the backend are seen.
        self._own_depsgraph = depsgraph is None
        self.depsgraph = depsgraph if depsgraph is not None else self._evaluated_depsgraph()

    def _evaluated_depsgraph(self):
        if self.scene == bpy.context.scene:
            return bpy.context.evaluated_depsgraph_get()
        depsgraph = self.scene.view_layers[0].depsgraph
        depsgraph.update()
        return depsgraph

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
        # The loop allocates several objects per ray; with generational GC on, each
        # collection walks the growing lists below, which costs ~30% of the run.
        gc_was_enabled = gc.isenabled()
        gc.disable()
        try:
            found = self._loop(origins, directions, max_range, single_origin, progress)
        finally:
            if gc_was_enabled:
                gc.enable()
        if found[0]:
            self._fill(hits, origins, max_range, *found)
        return hits

    def _loop(self, origins, directions, max_range, single_origin, progress):
        n = len(directions)
        # Python floats in tuples are what ray_cast converts fastest.
        d_list = list(map(tuple, directions.tolist()))
        hit_index: list[int] = []
        hit_loc: list = []
        hit_obj: list = []
        ray_cast, depsgraph = self.scene.ray_cast, self.depsgraph
        add_index, add_loc, add_obj = hit_index.append, hit_loc.append, hit_obj.append
        if single_origin:
            origin = tuple(origins[0].tolist())
        else:
            o_list = list(map(tuple, origins.tolist()))
        for start in range(0, n, PROGRESS_EVERY):
            stop = min(start + PROGRESS_EVERY, n)
            if single_origin:
                for k in range(start, stop):
                    ok, loc, _normal, _face, obj, _matrix = ray_cast(depsgraph, origin, d_list[k], distance=max_range)
                    if ok:
                        add_index(k)
                        add_loc(loc)
                        add_obj(obj)
            else:
                for k in range(start, stop):
                    ok, loc, _normal, _face, obj, _matrix = ray_cast(depsgraph, o_list[k], d_list[k], distance=max_range)
                    if ok:
                        add_index(k)
                        add_loc(loc)
                        add_obj(obj)
            if progress is not None:
                progress(stop, n)
        return hit_index, hit_loc, hit_obj

    @staticmethod
    def _fill(hits: RayHits, origins, max_range, hit_index, hit_loc, hit_obj) -> None:
        idx = np.asarray(hit_index, dtype=np.intp)
        loc = np.array([v[:] for v in hit_loc], dtype=np.float64).reshape(-1, 3)
        dist = np.linalg.norm(loc - origins[idx], axis=1)
        # float32 round-off can put a hit a hair past the limit ray_cast was given
        keep = np.flatnonzero(dist <= max_range)
        # Per call only: evaluated objects are rebuilt (and their memory reused) whenever
        # the depsgraph re-evaluates, so a cache kept across calls could go stale.
        tags: dict = {}
        class_ids = np.empty(len(keep), dtype=np.int16)
        instances = np.empty(len(keep), dtype=np.int32)
        for j, k in enumerate(keep.tolist()):
            obj = hit_obj[k]
            tag = tags.get(obj)
            if tag is None:
                tag = tags[obj] = _object_tags(obj)
            class_ids[j], instances[j] = tag[0], tag[1]
        idx = idx[keep]
        hits.distance[idx] = dist[keep]
        hits.class_id[idx] = class_ids
        hits.instance[idx] = instances
        hits.untagged_objects = frozenset(t[2] for t in tags.values() if t[2] is not None)
