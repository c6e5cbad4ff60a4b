"""Ray casting with mathutils.bvhtree over the extracted triangles (mathutils only).

One BVHTree holds every triangle of the (cropped) scene, so the cost of a ray
no longer grows with the number of objects the way `scene.ray_cast` does. Rays
are still cast one by one from Python, so keep the loop lean: plain tuples in,
the triangle index and distance out, everything else done in numpy.

BVHTree stores float32, so it gets offset-local coordinates (see geometry.py)
and hit distances are recomputed in float64 against the hit triangle's plane.
"""

from __future__ import annotations

import gc

import numpy as np

from ..core.runtime.cast_clock import CLOCK
from .geometry import SceneGeometry
from .refine import RefiningBackend
from .settle import Settler

_FAR_SLACK = 1e-3  # see embree_backend: cast a little long, cut in float64
_CHUNK = 16384  # rays converted to Python floats at a time


def load_bvhtree():
    """mathutils' BVHTree class. Inside Blender mathutils is built in; with the bpy
    wheel it only becomes importable once bpy has been imported."""
    try:
        from mathutils.bvhtree import BVHTree
    except ImportError:
        import bpy  # noqa: F401  (registers mathutils as a side effect)
        from mathutils.bvhtree import BVHTree
    return BVHTree


class BVHBackend(RefiningBackend):
    """First hits against one mathutils BVHTree of the extracted triangles."""

    name = "bvh"

    def __init__(self, geometry: SceneGeometry, seal: bool = True, epsilon: float = 0.0):
        BVHTree = load_bvhtree()
        self.geometry = geometry
        self.seal = seal
        self._tree = None
        corners = geometry.local_triangles()  # gathered once for the planes and the padding
        self._planes = geometry.local_planes(corners)
        self._settler = None  # unsealed (tests measuring why sealing is needed): the BVH's answer as is
        if seal:
            self._settler = Settler.sealing(geometry, self._planes, corners)
            vertices = self._settler.padded.reshape(-1, 3)
            faces = np.arange(len(vertices)).reshape(-1, 3)
        else:
            vertices, faces = geometry.local_vertices(np.float64), geometry.faces
        if geometry.triangle_count:
            self._tree = BVHTree.FromPolygons(
                vertices.tolist(), faces.tolist(), all_triangles=True, epsilon=epsilon
            )

    def _ready(self) -> bool:
        return self._tree is not None

    def _first_hits(self, local: np.ndarray, dirs: np.ndarray, max_range: float):
        triangle = np.full(len(dirs), -1, dtype=np.int64)
        rough = np.zeros(len(dirs))
        ray_cast = self._tree.ray_cast
        far = float(max_range) + _FAR_SLACK
        # Each ray_cast allocates a result tuple, so the garbage collector would run every
        # few hundred rays and walk all of Blender's Python objects: pausing it spares the
        # loop that walk. Rays go to Python floats a chunk at a time to bound memory.
        was_enabled = gc.isenabled()
        gc.disable()
        try:
            with CLOCK.casting():
                for start in range(0, len(dirs), _CHUNK):
                    stop = start + _CHUNK
                    rays = zip(local[start:stop].tolist(), dirs[start:stop].tolist())
                    for i, (o, d) in enumerate(rays, start):
                        _, _, index, dist = ray_cast(o, d, far)
                        if index is not None:
                            triangle[i] = index
                            rough[i] = dist
        finally:
            if was_enabled:
                gc.enable()
        return triangle, rough, None  # no barycentrics: settle finds them in float64
