"""Ray casting through Open3D's `RaycastingScene` (Embree inside Open3D), batched from numpy.

The same triangles as EmbreeBackend (offset-local, sealed by padding.pad_triangles,
float32), the same float64 settling of every ambiguous hit (settle.py) and the same
float64 refinement of every distance (refine.RefiningBackend), so its scans are the
same bytes as embree's (tests/test_backends.py); only the float32 caster differs.

Open3D 0.20's API used here: `o3d.t.geometry.RaycastingScene()`,
`add_triangles(vertices Tensor float32 (V,3), triangles Tensor uint32 (T,3))`, and
`cast_rays(rays Tensor float32 (N,6) [origin, direction], nthreads)` -> dict of Tensors:
`t_hit` (inf on a miss), `primitive_ids` (INVALID_ID on a miss), `primitive_uvs` (N,2)
(Embree's u, v). It takes no tfar: hits beyond max range are dropped afterwards, at the
float32 distance embree's tfar would have cut them at. The BVH is built on the first cast.
A cast runs on Open3D's own thread pool, `threads` threads (None: core.threads.cast_threads(),
the cores or what the environment says, as embree's casts are split; 1 in a dataset worker);
each ray's answer is its own, so the bytes are the same however many.
"""

from __future__ import annotations

import numpy as np

from ..core.runtime.threads import cast_threads
from .embree_backend import sealed
from .geometry import SceneGeometry
from .refine import RefiningBackend
from .settle import Settler

_FAR_SLACK = 1e-3  # see embree_backend: cast a little long, cut in float64


class Open3DBackend(RefiningBackend):
    """First hits against one Open3D RaycastingScene of the extracted triangles."""

    name = "open3d"

    def __init__(self, geometry: SceneGeometry, threads: int | None = None, settler: Settler | None = None):
        import open3d as o3d

        self.geometry = geometry
        self.threads = threads
        self._o3d = o3d
        self._scene = None
        self._planes, self._settler = sealed(geometry, settler)
        if geometry.triangle_count:
            count = geometry.triangle_count
            vertices = self._settler.padded.reshape(-1, 3).astype(np.float32)
            triangles = np.arange(3 * count, dtype=np.uint32).reshape(count, 3)
            self._scene = o3d.t.geometry.RaycastingScene()
            self._scene.add_triangles(o3d.core.Tensor(vertices), o3d.core.Tensor(triangles))
            self._invalid = self._scene.INVALID_ID

    def _ready(self) -> bool:
        return self._scene is not None

    def _first_hits(self, local: np.ndarray, dirs: np.ndarray, max_range: float):
        """Open3D's answer, as embree's: hit triangle per ray (-1 for none), float32 distance,
        float32 (u, v) on the uploaded triangle."""
        rays = np.empty((len(dirs), 6), dtype=np.float32)
        rays[:, :3] = local
        rays[:, 3:] = dirs
        threads = self.threads or cast_threads()  # as RefiningBackend.threads: None, the cores
        result = self._scene.cast_rays(self._o3d.core.Tensor(rays), nthreads=threads)
        t = result["t_hit"].numpy()
        primitive = result["primitive_ids"].numpy()
        uv = result["primitive_uvs"].numpy()
        triangle = primitive.astype(np.int64)
        triangle[(primitive == self._invalid) | ~(t <= np.float32(max_range + _FAR_SLACK))] = -1
        return triangle, t, (uv[:, 0], uv[:, 1])
