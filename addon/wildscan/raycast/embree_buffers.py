"""Embree's triangle buffers filled from numpy in one pass (ctypes; no bpy).

Why: embreex's `TriangleMesh` copies a (T, 3, 3) soup into Embree item by item, each
coordinate read through a Python-level index (~0.3 us a value): 0.95 s for the 1.07 M
triangles of seed 0's porous world, a quarter of a world's build. Here the same
buffers are asked of the same Embree (`rtcSetNewGeometryBuffer`: the float3 vertex
buffer with embreex's 16-byte stride, the uint3 index buffer) and written by numpy in
one vectorised pass each: float64 -> float32 rounds to nearest exactly as embreex's
per-value C cast does, so Embree gets the same bytes, builds the same BVH and answers
every ray the same (tests/test_backends.py compares both uploads ray by ray).

The scene stays embreex's `EmbreeScene`, and its `run` still casts (one `rtcIntersect1`
per ray in C, the GIL released): only the upload moves. To attach a geometry to that
scene takes its `RTCScene` handle, which embreex keeps in a C field without a Python
accessor. `scene_handle` reads it from the object's memory after proving the layout on
the object itself (the public `is_committed` field and the device object found where
embreex's rtcore_scene.pxd declares them) and then asks Embree (`rtcGetSceneDevice`,
`rtcGetSceneFlags`) that the handle is that scene of that device. Any doubt - another
embreex layout, no libembree4 next to it - raises `ImportError`, and EmbreeBackend
uploads through `TriangleMesh` as before.

The library is the libembree4 that the embreex wheel ships and has loaded already
(embreex.libs/ on Linux), so the handles are the same library's. Tested on Linux (x86_64);
elsewhere a library not found where the wheel puts it means the embreex upload.

Embree 4 API (rtcore_geometry.h, rtcore_buffer.h, rtcore_scene.h, rtcore_device.h):
rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE = 0); rtcSetNewGeometryBuffer(geometry,
RTC_BUFFER_TYPE_VERTEX = 1 | RTC_BUFFER_TYPE_INDEX = 0, slot, RTC_FORMAT_FLOAT3 = 0x9003 |
RTC_FORMAT_UINT3 = 0x5003, byte stride, item count) -> void*; rtcCommitGeometry;
rtcAttachGeometry(scene, geometry) -> geometry id; rtcReleaseGeometry;
rtcGetSceneDevice(scene) (one more reference: released); rtcGetSceneFlags;
RTC_SCENE_FLAG_ROBUST = 1 << 2.
"""

from __future__ import annotations

import ctypes
import glob
import os
from functools import lru_cache

import numpy as np

_TRIANGLE = 0
_BUFFER_INDEX, _BUFFER_VERTEX = 0, 1
_FORMAT_UINT3, _FORMAT_FLOAT3 = 0x5003, 0x9003
SCENE_FLAG_ROBUST = 1 << 2
# embreex's Vertex struct is 4 floats (x, y, z and an unused one): its stride, kept so the
# buffer Embree builds from is laid out as embreex's is
VERTEX_STRIDE = 16
_BLOCK = 1 << 18  # index values written at a time
_MARK = 0x5EA1  # written to the public `is_committed` field to find it in memory


@lru_cache(maxsize=1)
def embree_library() -> ctypes.CDLL:
    """The libembree4 inside the embreex wheel, with the signatures used here."""
    import embreex

    here = os.path.dirname(os.path.abspath(embreex.__file__))
    places = (  # where the wheels' repair tools put it: auditwheel, delocate, delvewheel
        (os.pardir, "embreex.libs", "libembree4*"),
        (".dylibs", "libembree4*"),
        (os.pardir, "embreex.libs", "embree4*.dll"),
        ("libembree4*",),
    )
    found = sorted(p for place in places for p in glob.glob(os.path.join(here, *place)))
    if not found:
        raise ImportError(f"no libembree4 beside embreex in {os.path.dirname(here)}")
    lib = ctypes.CDLL(os.path.realpath(found[0]))
    p, u, i = ctypes.c_void_p, ctypes.c_uint, ctypes.c_int
    _sign(lib.rtcNewGeometry, p, p, i)
    _sign(lib.rtcSetNewGeometryBuffer, p, p, i, u, i, ctypes.c_size_t, ctypes.c_size_t)
    _sign(lib.rtcCommitGeometry, None, p)
    _sign(lib.rtcAttachGeometry, u, p, p)
    _sign(lib.rtcReleaseGeometry, None, p)
    _sign(lib.rtcGetSceneDevice, p, p)
    _sign(lib.rtcReleaseDevice, None, p)
    _sign(lib.rtcGetSceneFlags, i, p)
    _sign(lib.rtcGetDeviceError, i, p)
    return lib


def _sign(function, result, *arguments) -> None:
    function.restype = result
    function.argtypes = list(arguments)


def _pointer_at(address: int) -> int:
    return ctypes.c_void_p.from_address(address).value or 0


def scene_handle(scene, device, robust: bool) -> int:
    """The RTCScene of embreex's `EmbreeScene(device, robust)`, proven to be it (see the module
    docstring), else ImportError. Layout (rtcore_scene.pxd, a Cython class without cdef
    methods): the object header, then `RTCScene scene_i`, `int is_committed`, `EmbreeDevice
    device`; an EmbreeDevice is the header, then `RTCDevice device`."""
    lib = embree_library()
    header = object.__basicsize__
    pointer = ctypes.sizeof(ctypes.c_void_p)
    base = id(scene)
    committed_at = base + header + pointer
    device_at = base + header + 2 * pointer
    if type(scene).__basicsize__ < header + 3 * pointer or type(device).__basicsize__ < header + pointer:
        raise ImportError("embreex's EmbreeScene is smaller than rtcore_scene.pxd 4.4 declares")
    was = scene.is_committed
    scene.is_committed = _MARK
    try:
        layout_ok = ctypes.c_int.from_address(committed_at).value == _MARK
    finally:
        scene.is_committed = was
    if not layout_ok or _pointer_at(device_at) != id(device):
        raise ImportError("embreex's EmbreeScene is not laid out as rtcore_scene.pxd 4.4 declares")
    handle = _pointer_at(base + header)
    device_handle = _pointer_at(id(device) + header)
    owner = lib.rtcGetSceneDevice(handle) if handle else None
    if owner:
        lib.rtcReleaseDevice(owner)
    flags = lib.rtcGetSceneFlags(handle) if owner == device_handle else -1
    if not owner or owner != device_handle or bool(flags & SCENE_FLAG_ROBUST) != robust:
        raise ImportError("embreex's EmbreeScene handle is not the scene Embree reports")
    return handle


def attach_triangle_soup(scene_pointer: int, device_pointer: int, soup: np.ndarray) -> int:
    """Attach a (T, 3, 3) triangle soup (any float dtype, rounded to float32 as embreex
    rounds it) to the scene as one triangle geometry, its buffers written in one pass
    each; returns its geometry id."""
    lib = embree_library()
    soup = np.asarray(soup).reshape(-1, 3, 3)
    count = len(soup)
    geometry = lib.rtcNewGeometry(device_pointer, _TRIANGLE)
    if not geometry:
        raise MemoryError(f"Embree could not make a geometry (error {lib.rtcGetDeviceError(device_pointer)})")
    try:
        floats = _buffer(lib, geometry, _BUFFER_VERTEX, _FORMAT_FLOAT3, VERTEX_STRIDE, 3 * count, np.float32)
        vertices = floats.reshape(3 * count, VERTEX_STRIDE // 4)
        vertices[:, :3] = soup.reshape(-1, 3)  # the one copy, float64 -> float32 rounded to nearest
        vertices[:, 3] = 0.0
        indices = _buffer(lib, geometry, _BUFFER_INDEX, _FORMAT_UINT3, 12, count, np.uint32)
        for start in range(0, 3 * count, _BLOCK):  # in blocks: no (3T,) temporary beside Embree's copy
            stop = min(start + _BLOCK, 3 * count)
            indices[start:stop] = np.arange(start, stop, dtype=np.uint32)
        lib.rtcCommitGeometry(geometry)
        return lib.rtcAttachGeometry(scene_pointer, geometry)
    finally:
        lib.rtcReleaseGeometry(geometry)  # the scene holds its own reference


def _buffer(lib, geometry, kind: int, fmt: int, stride: int, items: int, dtype) -> np.ndarray:
    """A numpy view of a new Embree-owned geometry buffer (flat, `stride * items` bytes)."""
    address = lib.rtcSetNewGeometryBuffer(geometry, kind, 0, fmt, stride, items)
    if not address:
        raise MemoryError(f"Embree could not allocate {stride * items:,} bytes")
    return np.frombuffer((ctypes.c_char * (stride * items)).from_address(address), dtype=dtype)


def device_pointer(device) -> int:
    """The RTCDevice inside embreex's EmbreeDevice (checked by scene_handle)."""
    return _pointer_at(id(device) + object.__basicsize__)
