"""Choosing a ray backend by name, with a fallback when its module is missing.

Backends (all give the same labels; see tests/test_backends.py):
  embree   Embree via the `embreex` wheel, batched from numpy: the default.
  bvh      mathutils.bvhtree over the same extracted triangles, one ray per Python call.
  blender  Blender's own scene.ray_cast: the reference, slowest, cost grows with objects.
  auto     the default: the first of embree, bvh, blender that can be imported.

Why embree is the default: it casts a whole scan's rays in one batch from numpy, so it
is by far the fastest of the three and its time stays nearly flat in the number of
objects, while scene.ray_cast's cost a ray grows with them (`wildscan bench` measures
both, docs/benchmarks.md has its output); its labels and ranges agree with
scene.ray_cast's; and with sealed edges (geometry.pad_triangles) it has no leaks in the
stability suite (tests/test_stability.py), where scene.ray_cast lets some rays aimed at
shared edges and vertices through.

A missing module is not an error: the next backend in FALLBACK_ORDER is used and
`notify` gets one line saying which and why. Imports of bpy, mathutils and
embreex happen only inside functions, so this module imports anywhere.
"""

from __future__ import annotations

from collections.abc import Callable

from ..core.backend import RayBackend
from ..core.checks import one_of
from ..core.errors import UserError

BACKEND_NAMES = ("auto", "embree", "bvh", "blender")
DEFAULT_BACKEND = "auto"
FALLBACK_ORDER = ("embree", "bvh", "blender")
_INSTALL_HINT = {
    "embree": "install the embreex wheel (pip install embreex) into this Python to enable it",
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
    """A ready backend. For embree/bvh the scene is extracted (cropped to `radius` around
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

        return _on_every_core(EmbreeBackend(geometry))
    from .bvh_backend import BVHBackend

    return BVHBackend(geometry)


def _on_every_core(backend):
    """A backend for one command's scans: its large casts split over the cores it may use
    (raycast/parallel.py; the bytes are those of one thread). A dataset worker makes its
    own, one thread each."""
    from .parallel import available_cores

    backend.threads = available_cores()
    return backend


def _geometry_for(depsgraph, center, radius, geometry):
    if geometry is None:
        from .extract import extract_scene

        return extract_scene(depsgraph, center=center, radius=radius)
    if center is not None and radius is not None:
        return geometry.cropped(center, radius)
    return geometry
