"""Choosing a ray backend by name, with a fallback when its module is missing.

Backends (all give the same labels; see tests/test_backends.py):
  embree   Embree via the `embreex` wheel, batched from numpy: the default.
  open3d   Open3D's RaycastingScene over the same sealed triangles: the same PLY bytes as embree.
  bvh      mathutils.bvhtree over the same extracted triangles, one ray per Python call.
  blender  Blender's own scene.ray_cast, slowest, cost grows with objects; its float32 answers
           settled in float64 against a fast caster's (settled_blender.py): the same bytes.
  auto     the default: the first of embree, open3d, bvh, blender that imports and passes its
           proof (inside Blender, bvh before a caster of a version the tests do not cover).

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
`notify` gets one line saying which and why. Nor is a caster that imports trusted: before its
first use in a process it casts a tiny known scene (proof.py: straight-down rays like the
placement's lasers, onto shared vertices and edges, into a wall, past max range...) and a
wrong answer refuses it, in one line naming it, its version and what it got wrong, and the
next one is tried (Debian's python3-open3d 0.16.1 misses every ray). Inside Blender, whose
Python finds embreex or Open3D on the system's path in whatever version is installed there,
`auto` tries the built-in BVH before an optional caster of a version the tests do not cover
(COVERED_VERSIONS). Imports of bpy, mathutils, embreex and open3d happen only inside
functions, so this module imports anywhere.
"""

from __future__ import annotations

import sys
from collections.abc import Callable

from ..core.backend import RayBackend
from ..core.checks import one_of
from ..core.errors import UserError
from .proof import proof_failure

BACKEND_NAMES = ("auto", "embree", "open3d", "bvh", "blender")
DEFAULT_BACKEND = "auto"
FALLBACK_ORDER = ("embree", "open3d", "bvh", "blender")
OPTIONAL_CASTERS = ("embree", "open3d")  # not part of Blender: found on whatever path it has
# The versions of the optional casters the tests run (`make setup`'s pip install, tests/
# test_backends.py, test_casters.py): inside Blender a caster of another version comes after
# the built-in BVH (it is proven either way). Major.minor (or exact) versions.
COVERED_VERSIONS = {"embree": ("4.4",), "open3d": ("0.20",)}
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
    """The concrete backends this Python can run and that passed their proof, fastest first."""
    return [name for name in FALLBACK_ORDER if refusal(name) is None]


def refusal(name: str) -> str | None:
    """Why backend `name` is not used here (None: it is usable): its module is missing, or it
    failed its proof (proof.py: a tiny known scene, cast once per process)."""
    why = missing_reason(name)
    if why is None:
        failure = proof_failure(name, _proof_builder(name))
        if failure is not None:
            why = f"{caster_version(name)} failed its proof: {failure}"
    return why


def caster_version(name: str) -> str:
    """What backend `name` is here, with its version: 'Open3D 0.16.1', 'embreex 4.4.0.post1',
    'Blender 3.4.1' (bvh and blender are Blender's own)."""
    if name == "embree":
        return f"embreex {_distribution_version('embreex')}"
    if name == "open3d":
        import open3d

        return f"Open3D {getattr(open3d, '__version__', '(no version)')}"
    import bpy

    return f"Blender {bpy.app.version_string}"


def _distribution_version(module: str) -> str:
    from importlib import metadata

    try:
        return metadata.version(module)
    except metadata.PackageNotFoundError:  # imported from a folder without its metadata
        return str(getattr(__import__(module), "__version__", "(no version)"))


def covered(name: str) -> bool:
    """Whether the optional caster `name` is a version the tests cover (COVERED_VERSIONS)."""
    version = caster_version(name).split(" ", 1)[1]
    return any(version == v or version.startswith(v + ".") for v in COVERED_VERSIONS.get(name, ()))


def inside_blender() -> bool:
    """Whether this Python runs inside a Blender executable (not the bpy wheel, whose
    bpy.app.binary_path is empty): there embreex and Open3D come from the system's path,
    whatever version it has."""
    bpy = sys.modules.get("bpy")
    return bool(getattr(getattr(bpy, "app", None), "binary_path", ""))


def candidates(name: str) -> tuple[str, ...]:
    """The backends to try for `name`, in order: itself (auto: FALLBACK_ORDER's first) and
    then those after it in FALLBACK_ORDER. Inside Blender, auto puts an optional caster
    (embree, open3d) of a version the tests do not cover after the built-in BVH."""
    if name != "auto":
        return FALLBACK_ORDER[FALLBACK_ORDER.index(name) :]
    if not inside_blender():
        return FALLBACK_ORDER
    late = [c for c in OPTIONAL_CASTERS if missing_reason(c) is None and not covered(c)]
    order = [c for c in FALLBACK_ORDER if c not in late]
    at = order.index("bvh") + 1
    return tuple(order[:at] + late + order[at:])


def resolve_backend(name: str = DEFAULT_BACKEND, notify: Callable[[str], None] | None = print) -> str:
    """The concrete backend to use for `name`: the first of candidates(name) that can run
    and passes its proof. A fallback is announced through `notify` in one line, and so is
    each other caster refused by its proof on the way."""
    check_backend_name(name)
    order = candidates(name)
    wanted = order[0]
    reasons = []
    for candidate in order:
        why = refusal(candidate)
        if why is None:
            if reasons and notify is not None:
                notify(_fallback_message(name, wanted, candidate, reasons[0]))
            return candidate
        if reasons and notify is not None and missing_reason(candidate) is None:
            notify(f"wildscan: ray backend '{candidate}' is not used: {why}")
        reasons.append(why)
    tried = "; ".join(f"{c}: {r}" for c, r in zip(order, reasons))
    raise UserError(f"{name}: no ray backend can run here ({tried})", setting="backend")


def _fallback_message(name: str, wanted: str, used: str, why: str) -> str:
    which = f"the default ray backend '{wanted}'" if name == "auto" else f"ray backend '{wanted}'"
    if missing_reason(wanted) is None:  # it runs, but answered wrongly
        return f"wildscan: {which} is not used: {why}; using '{used}' instead"
    return f"wildscan: {which} is not available ({why}); using '{used}' instead - {_INSTALL_HINT[wanted]}"


def _proof_builder(name: str):
    """A function of the proof's KnownScene giving backend `name` over it (for blender, a
    context manager: its scene is made for the proof and removed after)."""
    if name == "blender":
        from .blender_proof import proof_scene_backend

        return proof_scene_backend
    from .proof import known_geometry

    return lambda scene: _over_geometry(name, known_geometry(scene))


def _over_geometry(name: str, geometry) -> RayBackend:
    if name == "embree":
        from .embree_backend import EmbreeBackend

        return EmbreeBackend(geometry)
    if name == "open3d":
        from .open3d_backend import Open3DBackend

        return Open3DBackend(geometry)
    from .bvh_backend import BVHBackend

    return BVHBackend(geometry)


def make_backend(
    name: str = DEFAULT_BACKEND,
    *,
    depsgraph=None,
    center=None,
    radius: float | None = None,
    geometry=None,
    notify: Callable[[str], None] | None = print,
) -> RayBackend:
    """A ready backend. The scene is extracted (cropped to `radius` around `center` when both
    are given) unless `geometry` is passed; a passed geometry is cropped the same way, so many
    poses can share one extraction. embree, open3d and bvh cast over it; blender casts with
    scene.ray_cast and settles its answers against a fast caster over it (settled_blender.py).
    Call once per command: a fallback is announced on every call."""
    chosen = resolve_backend(name, notify)
    geometry = _geometry_for(depsgraph, center, radius, geometry)
    if chosen == "blender":
        return _settled_blender(depsgraph, geometry)
    return _over_geometry(chosen, geometry)


def _settled_blender(depsgraph, geometry) -> RayBackend:
    """scene.ray_cast with its answers settled in float64 against the first proven fast
    caster over the same triangles (settled_blender.py: then it gives their bytes)."""
    from .blender_backend import BlenderRayCastBackend
    from .settled_blender import SettledSceneRayCast

    raw = BlenderRayCastBackend(depsgraph=depsgraph)
    for name in candidates("auto"):
        if name != "blender" and refusal(name) is None:
            return SettledSceneRayCast(raw, _over_geometry(name, geometry))
    return raw


def _geometry_for(depsgraph, center, radius, geometry):
    if geometry is None:
        from .extract import extract_scene

        return extract_scene(depsgraph, center=center, radius=radius)
    if center is not None and radius is not None:
        return geometry.cropped(center, radius)
    return geometry
