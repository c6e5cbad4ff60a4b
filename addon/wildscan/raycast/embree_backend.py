"""Embree ray casting through the `embreex` wheel, batched from numpy (no bpy).

Embree works in float32. The scene is uploaded relative to `geometry.offset`
(a local origin near the scan, see geometry.py), rays are shifted the same way,
and each hit distance is then recomputed in float64 against the plane of the
hit triangle (`refine.refine_distances`), so ranges match the float64
geometry to far better than 1e-4 m even in a world 10 km from the origin.

Cracks: even in Embree's robust mode (RTC_SCENE_FLAG_ROBUST, kept on: it costs
nothing measurable here) rays aimed at shared edges and vertices slip through
(3 of 10,703 in tests/test_stability.py; 1,288 without robust mode). So by
default (`seal=True`) every triangle is uploaded grown in its own plane by a few
float32 ulps (padding.pad_triangles), which closes them all. Tests build the
unsealed variants to keep measuring why.

The upload: the padded (T,3,3) soup goes into Embree's own vertex and index buffers in one
numpy pass each (embree_buffers.py: ~0.1 s for seed 0's porous world, where embreex's
TriangleMesh, which copies item by item, took ~1 s quiet), the same float32 bytes, so the
same BVH and the same answers. Where that path cannot be proven safe (another embreex
layout) or `upload="embreex"` is asked, TriangleMesh is used.

embreex 4.4's API used here: `rtcore.EmbreeDevice()`, `rtcore_scene.EmbreeScene(device,
robust=...)`, `mesh_construction.TriangleMesh(scene, vertices, indices=None)` (a (T,3,3)
soup or (V,3) + (T,3)), and `scene.run(origins f32 (N,3), dirs f32 (N,3), dists=f32 (N,)
tfar, output=1)` -> dict with primID/geomID (-1 on a miss), tfar, u, v, Ng. `run` commits
the scene (builds the BVH) on its first call, then casts one ray after another
(rtcIntersect1), with the GIL released (two threads can cast at once): a command's large
casts are split over its cores (core/runtime/threads.py), while a dataset runs one single-threaded
worker per core.
"""

from __future__ import annotations

import numpy as np

from ..core.backend import THREADS
from ..core.runtime.cast_clock import CLOCK
from .geometry import SceneGeometry
from .refine import RefiningBackend
from .sealing import sealed_settler
from .settle import Settler

# Rays are cast a little past max range in float32, then cut in float64, so a
# hit right at max range is decided by the float64 distance, not by rounding.
_FAR_SLACK = 1e-3


def sealed(geometry: SceneGeometry, settler: Settler | None = None):
    """(planes, settler) of a sealed float32 caster over `geometry`: the padded triangles it
    uploads and the float64 data settling its answers needs. Pass a `settler` made before
    (Settler.sealing over the same geometry) to share it between casters."""
    if settler is None:
        settler = sealed_settler(geometry)  # planes, padding and bands in one pass
    return (settler.normal, settler.d), settler


class EmbreeBackend(RefiningBackend):
    """First hits against one Embree scene of the extracted triangles."""

    name = "embree"
    # its `run` traces with the GIL released, one ray after another (core/runtime/threads.py)
    capabilities = RefiningBackend.capabilities | {THREADS}

    def __init__(
        self,
        geometry: SceneGeometry,
        robust: bool = True,
        seal: bool = True,
        upload: str = "buffers",
        settler: Settler | None = None,
    ):
        """`settler`: the sealing Settler of `geometry` made before (a dataset worker's world
        cache, app/cache/worlds.py): its planes and padded triangles are used as they are."""
        from embreex import rtcore_scene

        self.geometry = geometry
        self.robust = robust
        self.seal = seal
        self._scene = rtcore_scene.EmbreeScene(device=self._device(), robust=robust)
        self._mesh = None
        self._settler = None  # unsealed (tests measuring why sealing is needed): Embree's answer as is
        self.upload = upload
        if seal:
            self._planes, self._settler = sealed(geometry, settler)
            if geometry.triangle_count:
                self._mesh = self._upload(self._settler.padded)
        else:
            self._planes = geometry.local_planes()
        if not seal and geometry.triangle_count:
            from embreex import mesh_construction

            self.upload = "embreex"
            self._mesh = mesh_construction.TriangleMesh(
                self._scene, geometry.local_vertices(np.float32), geometry.faces
            )

    def _device(self):
        from embreex import rtcore

        self._embree_device = rtcore.EmbreeDevice()  # kept: the scene's handle is checked against it
        return self._embree_device

    def _upload(self, soup: np.ndarray):
        """Put the (T, 3, 3) float64 triangle soup into the scene as float32: through Embree's
        own buffers in one pass (embree_buffers.py), or, with upload="embreex" or where that
        cannot be proven safe, through embreex's TriangleMesh (item by item, the same bytes)."""
        if self.upload == "buffers":
            try:
                from . import embree_buffers as eb

                handle = eb.scene_handle(self._scene, self._embree_device, self.robust)
                return eb.attach_triangle_soup(handle, eb.device_pointer(self._embree_device), soup)
            except ImportError:
                self.upload = "embreex"
        from embreex import mesh_construction

        # float64 in: embreex rounds each value to float32 as numpy's astype would, and reads
        # float64 items faster
        return mesh_construction.TriangleMesh(self._scene, soup)

    def _ready(self) -> bool:
        return self._mesh is not None

    def _first_hits(self, local: np.ndarray, dirs: np.ndarray, max_range: float):
        """Embree's answer: hit triangle per ray (-1 for none), float32 distance, and the
        hit's float32 (u, v) on the uploaded triangle."""
        far = np.full(len(dirs), max_range + _FAR_SLACK, dtype=np.float32)
        origins, directions = float32_rows(local), np.ascontiguousarray(dirs, dtype=np.float32)
        with CLOCK.casting():
            result = self._scene.run(origins, directions, dists=far, output=1)
        triangle = result["primID"].astype(np.int64)
        triangle[result["geomID"] == -1] = -1
        return triangle, result["tfar"], (result["u"], result["v"])


def float32_rows(points: np.ndarray) -> np.ndarray:
    """(N, 3) float32 contiguous copy of `points`, each value rounded as astype rounds it. One
    origin broadcast to every ray (a scan) is rounded once and copied: converting the
    broadcast row by row took as long as a fifth of the cast."""
    if points.ndim == 2 and len(points) > 1 and points.strides[0] == 0:
        out = np.empty(points.shape, dtype=np.float32)
        for k, value in enumerate(points[0].astype(np.float32)):
            out[:, k] = value  # a column filled with one value: faster than copying the row
        return out
    return np.ascontiguousarray(points, dtype=np.float32)
