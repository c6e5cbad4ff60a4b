"""Choosing a ray backend by name, with a fallback when its module is missing.

Backends (all give the same labels; see tests/test_backends.py):
  embree   Embree via the `embreex` wheel, batched from numpy: the default.
  open3d   Open3D's RaycastingScene over the same sealed triangles: the same PLY bytes as embree.
  bvh      mathutils.bvhtree over the same extracted triangles, one ray per Python call.
  blender  Blender's own scene.ray_cast: the reference, slowest, cost grows with objects.
  auto     the default: the first of embree, open3d, bvh, blender that can be imported.

Why embree is the default. Against scene.ray_cast and the BVH: it casts a whole scan's rays
in one batch from numpy, so it is by far the fastest of the three and its time stays nearly
flat in the number of objects, while scene.ray_cast's cost a ray grows with them (`wildscan
bench` measures both); its labels and ranges agree with scene.ray_cast's; and with sealed
edges (padding.pad_triangles) it has no leaks in the stability suite
(tests/test_stability.py), where scene.ray_cast lets some rays aimed at shared edges and
vertices through. Against the other float32 casters (`wildscan bench --suite casters`: all
fed the same sealed triangles and the same scans' rays, docs/benchmarks.md#casters): every
one of them (embreex as it was, Embree packets through ctypes, Open3D, NVIDIA Warp, Mitsuba 3)
gives embree's PLY bytes once the float64 settling has decided the ambiguous hits, so cost
decides, and a world is built once for tens of scans. Embree with its buffers filled by numpy
(embree_buffers.py) builds cheapest of the casters that cast as fast (embreex's item-by-item
upload and build take 2-2.6x as long, Open3D's 1.3-2x, Mitsuba's 3-5x; Warp builds about as
fast and casts 3-4x slower), adds no more memory than embreex did (Open3D a little more, Warp
and Mitsuba far more), casts a scan's rays on one thread as fast as any (Open3D and Mitsuba
are as fast on some ray sets and slower on others; packets from a Python loop are slower; a
low-quality BVH saves nothing measurable) and releases the GIL while casting.
Open3D is the fallback: next to embree on build and cast together, and in `make setup`
already. Warp (CUDA where a GPU exists) and Mitsuba are measured only: their wheels are
hundreds of MB and neither beats Embree on a CPU.

A missing module is not an error: the next backend in FALLBACK_ORDER is used and
`notify` gets one line saying which and why. Imports of bpy, mathutils, embreex and
open3d happen only inside functions, so this module imports anywhere.
"""

from __future__ import annotations

from collections.abc import Callable

from ..core.backend import RayBackend
from ..core.checks import one_of
from ..core.errors import UserError

BACKEND_NAMES = ("auto", "embree", "open3d", "bvh", "blender")
DEFAULT_BACKEND = "auto"
FALLBACK_ORDER = ("embree", "open3d", "bvh", "blender")
_INSTALL_HINT = {
    "embree": "install the embreex wheel (pip install embreex) into this Python to enable it",
    "open3d": "install the open3d wheel (pip install open3d) into this Python to enable it",
    "bvh": "it needs Blender's mathutils (run inside Blender or with the bpy wheel)",
    "blender": "it needs Blender's bpy (run inside Blender or with the bpy wheel)",
}


def check_backend_name(name: str) -> str:
    if name not in BACKEND_NAMES:
        one_of(name, "backend", BACKEND_NAMES)
    return name


def missing_reason(name: str) -> str | None:
    """Why backend `name` cannot run in this Python (None when it can)."""
    try:
        if name == "embree":
            from embreex import mesh_construction, rtcore_scene  # noqa: F401
        elif name == "open3d":
            import open3d  # noqa: F401
        elif name == "bvh":
            from .bvh_backend import load_bvhtree

            load_bvhtree()
        elif name == "blender":
            import bpy  # noqa: F401
        else:
            return f"unknown backend {name!r}"
    except ImportError as exc:
        return str(exc) or type(exc).__name__
    return None


def available_backends() -> list[str]:
    """The concrete backends this Python can run, fastest first."""
    return [name for name in FALLBACK_ORDER if missing_reason(name) is None]


def resolve_backend(name: str = DEFAULT_BACKEND, notify: Callable[[str], None] | None = print) -> str:
    """The concrete backend to use for `name`: itself (or embree for auto) when it can run,
    else the next runnable one in FALLBACK_ORDER, announced in one line through `notify`."""
    check_backend_name(name)
    wanted = FALLBACK_ORDER[0] if name == "auto" else name
    start = FALLBACK_ORDER.index(wanted)
    reasons = []
    for candidate in FALLBACK_ORDER[start:]:
        why = missing_reason(candidate)
        if why is None:
            if reasons and notify is not None:
                notify(_fallback_message(name, wanted, candidate, reasons[0]))
            return candidate
        reasons.append(why)
    tried = "; ".join(f"{c}: {r}" for c, r in zip(FALLBACK_ORDER[start:], reasons))
    raise UserError(f"{name}: no ray backend can run here ({tried})", setting="backend")


def _fallback_message(name: str, wanted: str, used: str, why: str) -> str:
    which = f"the default ray backend '{wanted}'" if name == "auto" else f"ray backend '{wanted}'"
    return f"wildscan: {which} is not available ({why}); using '{used}' instead - {_INSTALL_HINT[wanted]}"


def make_backend(
    name: str = DEFAULT_BACKEND,
    *,
    depsgraph=None,
    center=None,
    radius: float | None = None,
    geometry=None,
    notify: Callable[[str], None] | None = print,
) -> RayBackend:
    """A ready backend. For embree/open3d/bvh the scene is extracted (cropped to `radius` around
    `center` when both are given) unless `geometry` is passed; a passed geometry is
    cropped the same way, so many poses can share one extraction. Call once per command:
    a fallback is announced on every call."""
    chosen = resolve_backend(name, notify)
    if chosen == "blender":
        from .blender_backend import BlenderRayCastBackend

        return BlenderRayCastBackend(depsgraph=depsgraph)
    geometry = _geometry_for(depsgraph, center, radius, geometry)
    if chosen == "embree":
        from .embree_backend import EmbreeBackend

        return EmbreeBackend(geometry)
    if chosen == "open3d":
        from .open3d_backend import Open3DBackend

        return Open3DBackend(geometry)
    from .bvh_backend import BVHBackend

    return BVHBackend(geometry)


def _geometry_for(depsgraph, center, radius, geometry):
    if geometry is None:
        from .extract import extract_scene

        return extract_scene(depsgraph, center=center, radius=radius)
    if center is not None and radius is not None:
        return geometry.cropped(center, radius)
    return geometry
