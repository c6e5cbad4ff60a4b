"""Float32 casters measured by `wildscan bench --suite casters` but not shipped as backends
(their wheels are not in the Makefile's setup, or they are slower): each a
refine.RefiningBackend whose `_first_hits` is the candidate's own, so its hits go through
the same float64 settling and refinement as embree's and its scans can be compared byte
for byte.

- EmbreeLowQualityBackend: EmbreeBackend's scene built by Embree's low-quality (Morton) BVH
  builder: what a cheaper build costs in casting.
- EmbreePacketBackend: the very Embree scene EmbreeBackend builds, cast 16 rays at a time
  by `rtcIntersect16` through ctypes (one foreign call a packet from a Python loop) instead
  of embreex's `run` (one `rtcIntersect1` a ray in C).
- WarpBackend: NVIDIA Warp's `wp.Mesh` BVH and `wp.mesh_query_ray` in a kernel (compiled
  on its first use, cached in Warp's kernel cache; CPU here, CUDA where a GPU exists).
  warp-lang 1.19: its `u, v` weigh corners 0 and 1 (point = u v0 + v v1 + (1-u-v) v2),
  turned here into Embree's (weights of corners 1 and 2).
- MitsubaBackend: Mitsuba 3's `llvm_ad_rgb` variant (Dr.Jit's LLVM backend, which needs a
  libLLVM on the machine), `scene.ray_intersect_preliminary`: prim_index, t, prim_uv
  (Embree's convention: Mitsuba casts through Embree in its LLVM variants).

No `from __future__ import annotations` here: Warp reads the kernel's annotations as types.
"""

import ctypes

import numpy as np

from ..raycast.embree_backend import EmbreeBackend, sealed
from ..raycast.refine import RefiningBackend

_FAR_SLACK = 1e-3  # as embree_backend


class EmbreeLowQualityBackend(EmbreeBackend):
    """EmbreeBackend's scene with its BVH built at low quality (rtcSetSceneBuildQuality,
    RTC_BUILD_QUALITY_LOW = 0: Embree's fast Morton builder): a cheaper build, a slower cast."""

    name = "embree-low"
    QUALITY_LOW = 0

    def __init__(self, geometry, settler=None):
        super().__init__(geometry, settler=settler)
        from ..raycast import embree_buffers as eb

        lib = eb.embree_library()
        lib.rtcSetSceneBuildQuality.restype = None
        lib.rtcSetSceneBuildQuality.argtypes = [ctypes.c_void_p, ctypes.c_int]
        lib.rtcSetSceneBuildQuality(
            eb.scene_handle(self._scene, self._embree_device, self.robust), self.QUALITY_LOW
        )


class EmbreePacketBackend(EmbreeBackend):
    """EmbreeBackend's scene, cast by rtcIntersect16 packets through ctypes."""

    name = "embree-packets"
    LANES = 16
    # RTCRayHit16 (rtcore_ray.h, Embree 4): RTCRay16 (12 arrays of 16 x 4 bytes: org xyz,
    # tnear, dir xyz, time, tfar, mask, id, flags) then RTCHit16 (Ng xyz, u, v, primID,
    # geomID, instID[1], instPrimID[1]); 64-byte aligned. Offsets in 16-lane rows.
    ROWS = 22  # 21 rows used, one spare; 22 x 64 = 1408 bytes a packet (a multiple of 64)
    ORG, TNEAR, DIR, TIME, TFAR, MASK, ID, FLAGS = 0, 3, 4, 7, 8, 9, 10, 11
    U, V, PRIM, GEOM = 15, 16, 17, 18

    def __init__(self, geometry, settler=None):
        super().__init__(geometry, settler=settler)
        from ..raycast import embree_buffers as eb

        lib = eb.embree_library()
        self._intersect = lib.rtcIntersect16
        self._intersect.restype = None
        self._intersect.argtypes = [ctypes.c_void_p] * 4
        self._handle = eb.scene_handle(self._scene, self._embree_device, self.robust)

    def _first_hits(self, local, dirs, max_range):
        count = len(dirs)
        if not self._scene.is_committed:  # embreex commits on its first run: let it
            self._scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
        packets = -(-count // self.LANES)
        raw = np.zeros(packets * self.ROWS * self.LANES + 16, dtype=np.float32)
        start = (-raw.ctypes.data % 64) // 4  # 64-byte aligned
        rows = raw[start : start + packets * self.ROWS * self.LANES].reshape(packets, self.ROWS, self.LANES)
        flat = rows.reshape(packets, self.ROWS, self.LANES)
        lanes = np.zeros((packets * self.LANES, 3), dtype=np.float32)
        for k, first in ((0, self.ORG), (1, self.DIR)):
            lanes[:count] = local if k == 0 else dirs
            flat[:, first : first + 3, :] = lanes.reshape(packets, self.LANES, 3).transpose(0, 2, 1)
        flat[:, self.TFAR, :] = np.float32(max_range + _FAR_SLACK)
        ints = flat.view(np.uint32)
        ints[:, self.MASK, :] = 0xFFFFFFFF
        ints[:, self.GEOM, :] = 0xFFFFFFFF
        ints[:, self.PRIM, :] = 0xFFFFFFFF
        valid = np.zeros((packets, self.LANES), dtype=np.int32)
        valid.reshape(-1)[:count] = -1
        intersect, scene = self._intersect, self._handle
        base, step = flat.ctypes.data, self.ROWS * self.LANES * 4
        valid_base = valid.ctypes.data
        for p in range(packets):
            intersect(valid_base + 64 * p, scene, base + step * p, None)
        geom = ints[:, self.GEOM, :].reshape(-1)[:count]
        triangle = ints[:, self.PRIM, :].reshape(-1)[:count].astype(np.int64)
        triangle[geom == 0xFFFFFFFF] = -1
        tfar = flat[:, self.TFAR, :].reshape(-1)[:count].copy()
        u = flat[:, self.U, :].reshape(-1)[:count].copy()
        v = flat[:, self.V, :].reshape(-1)[:count].copy()
        return triangle, tfar, (u, v)


class WarpBackend(RefiningBackend):
    """NVIDIA Warp's mesh BVH over the sealed triangles (CPU unless a CUDA device exists)."""

    name = "warp"

    def __init__(self, geometry, settler=None, device: str = "cpu"):
        import warp as wp

        wp.config.quiet = True  # Warp's greeting and kernel-load lines stay out of the suite's table
        if hasattr(wp, "LOG_ERROR"):
            wp.config.log_level = wp.LOG_ERROR  # warp-lang 1.19's switch for them
        wp.init()
        self.geometry = geometry
        self._wp = wp
        self._device = device
        self._planes, self._settler = sealed(geometry, settler)
        self._mesh = None
        if geometry.triangle_count:
            soup = self._settler.padded.reshape(-1, 3).astype(np.float32)
            self._points = wp.array(soup, dtype=wp.vec3, device=device)
            self._indices = wp.array(np.arange(len(soup), dtype=np.int32), dtype=wp.int32, device=device)
            self._mesh = wp.Mesh(points=self._points, indices=self._indices)
            self._kernel = _warp_kernel(wp)

    def _ready(self) -> bool:
        return self._mesh is not None

    def _first_hits(self, local, dirs, max_range):
        wp, device, count = self._wp, self._device, len(dirs)
        origins = wp.array(np.ascontiguousarray(local, dtype=np.float32), dtype=wp.vec3, device=device)
        directions = wp.array(np.ascontiguousarray(dirs, dtype=np.float32), dtype=wp.vec3, device=device)
        face = wp.empty(count, dtype=wp.int32, device=device)
        t, u, v = (wp.empty(count, dtype=float, device=device) for _ in range(3))
        far = float(np.float32(max_range + _FAR_SLACK))
        inputs = [self._mesh.id, origins, directions, far, face, t, u, v]
        wp.launch(self._kernel, dim=count, inputs=inputs, device=device)
        wp.synchronize_device(device)
        triangle = face.numpy().astype(np.int64)
        w0, w1 = u.numpy(), v.numpy()
        return triangle, t.numpy(), (w1, np.float32(1.0) - w0 - w1)  # Embree's: weights of corners 1, 2


def _warp_kernel(wp):
    """The first-hit kernel (made once; Warp compiles it on its first launch)."""
    global _WARP_KERNEL
    if _WARP_KERNEL is None:

        def first_hits(
            mesh: wp.uint64,
            origins: wp.array(dtype=wp.vec3),
            directions: wp.array(dtype=wp.vec3),
            far: float,
            face: wp.array(dtype=wp.int32),
            t: wp.array(dtype=float),
            u: wp.array(dtype=float),
            v: wp.array(dtype=float),
        ):
            i = wp.tid()
            query = wp.mesh_query_ray(mesh, origins[i], directions[i], far)
            face[i] = -1
            t[i] = far
            u[i] = 0.0
            v[i] = 0.0
            if query.result:
                face[i] = query.face
                t[i] = query.t
                u[i] = query.u
                v[i] = query.v

        _WARP_KERNEL = wp.kernel(first_hits)
    return _WARP_KERNEL


_WARP_KERNEL = None


class MitsubaBackend(RefiningBackend):
    """Mitsuba 3 (llvm_ad_rgb) over the sealed triangles."""

    name = "mitsuba"
    VARIANT = "llvm_ad_rgb"

    def __init__(self, geometry, settler=None, threads: int = 1):
        import drjit as dr
        import mitsuba as mi

        mi.set_variant(self.VARIANT)
        dr.set_thread_count(threads)
        self.geometry = geometry
        self._mi = mi
        self._planes, self._settler = sealed(geometry, settler)
        self._scene = None
        if geometry.triangle_count:
            count = geometry.triangle_count
            mesh = mi.Mesh("wildscan", vertex_count=3 * count, face_count=count)
            params = mi.traverse(mesh)
            params["vertex_positions"] = mi.Float(self._settler.padded.reshape(-1).astype(np.float32))
            params["faces"] = mi.UInt32(np.arange(3 * count, dtype=np.uint32))
            params.update()
            self._scene = mi.load_dict({"type": "scene", "triangles": mesh})

    def _ready(self) -> bool:
        return self._scene is not None

    def _first_hits(self, local, dirs, max_range):
        mi = self._mi
        o = np.ascontiguousarray(local, dtype=np.float32)
        d = np.ascontiguousarray(dirs, dtype=np.float32)
        ray = mi.Ray3f(
            mi.Ray3f(mi.Point3f(o[:, 0], o[:, 1], o[:, 2]), mi.Vector3f(d[:, 0], d[:, 1], d[:, 2])),
            float(np.float32(max_range + _FAR_SLACK)),
        )
        hit = self._scene.ray_intersect_preliminary(ray, coherent=True)
        valid = np.array(hit.is_valid(), dtype=bool)
        triangle = np.array(hit.prim_index, dtype=np.int64)
        triangle[~valid] = -1
        uv = np.array(hit.prim_uv, dtype=np.float32)
        return triangle, np.array(hit.t, dtype=np.float32), (uv[0], uv[1])
