"""A stand-in for Debian's python3-open3d (Open3D 0.16.1 on Debian's libembree3), for tests
without it: its RaycastingScene builds and casts like Open3D's, and misses every ray, the way
the real one does (Open3D 0.16 casts with ray mask 0, which Debian's Embree, built with ray
masks, honours: raycast/proof.py). The real package is tested under Debian's Blender
(tests/test_scan_scene.py)."""

from __future__ import annotations

import types

import numpy as np

INVALID_ID = 2**32 - 1


class Tensor:
    def __init__(self, array):
        self._array = np.asarray(array)

    def numpy(self) -> np.ndarray:
        return self._array


class RaycastingScene:
    INVALID_ID = INVALID_ID

    def __init__(self):
        self.triangles = 0

    def add_triangles(self, vertices: Tensor, triangles: Tensor) -> int:
        assert vertices.numpy().dtype == np.float32 and triangles.numpy().dtype == np.uint32
        self.triangles += len(triangles.numpy())
        return 0

    def cast_rays(self, rays: Tensor, nthreads: int = 0) -> dict:
        n = len(rays.numpy())
        return {
            "t_hit": Tensor(np.full(n, np.inf, dtype=np.float32)),
            "primitive_ids": Tensor(np.full(n, INVALID_ID, dtype=np.uint32)),
            "primitive_uvs": Tensor(np.zeros((n, 2), dtype=np.float32)),
        }


def debian_open3d(version: str = "0.16.1") -> types.ModuleType:
    """A module to put in sys.modules as `open3d`."""
    module = types.ModuleType("open3d")
    module.__version__ = version
    module.core = types.SimpleNamespace(Tensor=Tensor)
    module.t = types.SimpleNamespace(geometry=types.SimpleNamespace(RaycastingScene=RaycastingScene))
    return module
