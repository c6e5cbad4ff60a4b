"""The candidates of `wildscan bench --suite casters` (bench/casters.py): each caster's name,
what it is, the modules it needs (and how to get them), how to build it over sealed triangles
and how it casts on two threads; `missing` says why one cannot run here. The casters not
shipped as backends are bench/caster_candidates.py's; each is imported only when built.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

REFERENCE = "embreex"


@dataclass(frozen=True)
class Candidate:
    name: str
    what: str
    modules: tuple[str, ...]  # imported to tell whether it can run
    hint: str  # how to get it where it is missing
    make: Callable  # (geometry, settler) -> RefiningBackend
    two_threads: str  # "split": two Python threads each cast half (GIL released); "own": its pool


def _embreex(geometry, settler):
    from ..raycast.embree_backend import EmbreeBackend

    return EmbreeBackend(geometry, upload="embreex", settler=settler)


def _embree(geometry, settler):
    from ..raycast.embree_backend import EmbreeBackend

    return EmbreeBackend(geometry, settler=settler)


def _embree_low(geometry, settler):
    from .caster_candidates import EmbreeLowQualityBackend

    return EmbreeLowQualityBackend(geometry, settler=settler)


def _packets(geometry, settler):
    from .caster_candidates import EmbreePacketBackend

    return EmbreePacketBackend(geometry, settler=settler)


def _open3d(geometry, settler):
    from ..raycast.open3d_backend import Open3DBackend

    return Open3DBackend(geometry, settler=settler, threads=1)


def _warp(geometry, settler):
    from .caster_candidates import WarpBackend

    return WarpBackend(geometry, settler=settler)


def _warp_cuda(geometry, settler):
    from .caster_candidates import WarpBackend

    return WarpBackend(geometry, settler=settler, device="cuda:0")


def _mitsuba(geometry, settler):
    from .caster_candidates import MitsubaBackend

    return MitsubaBackend(geometry, settler=settler)


CANDIDATES = (
    Candidate(
        REFERENCE,
        "embreex TriangleMesh (item-by-item upload), scene.run",
        ("embreex",),
        "pip install embreex",
        _embreex,
        "split",
    ),
    Candidate(
        "embree",
        "embreex scene, buffers filled by numpy (embree_buffers.py), scene.run",
        ("embreex",),
        "pip install embreex",
        _embree,
        "split",
    ),
    Candidate(
        "embree-low",
        "the same, its BVH built at RTC_BUILD_QUALITY_LOW",
        ("embreex",),
        "pip install embreex",
        _embree_low,
        "split",
    ),
    Candidate(
        "embree-packets",
        "the same scene, rtcIntersect16 through ctypes",
        ("embreex",),
        "pip install embreex",
        _packets,
        "split",
    ),
    Candidate(
        "open3d",
        "Open3D RaycastingScene.cast_rays",
        ("open3d",),
        "pip install open3d",
        _open3d,
        "own",
    ),
    Candidate(
        "warp",
        "NVIDIA Warp wp.Mesh + mesh_query_ray (CPU)",
        ("warp",),
        "pip install warp-lang",
        _warp,
        "",
    ),
    Candidate(
        "warp-cuda",
        "the same on the first CUDA device, where there is one",
        ("warp",),
        "pip install warp-lang, and a CUDA GPU",
        _warp_cuda,
        "",
    ),
    Candidate(
        "mitsuba",
        "Mitsuba 3 llvm_ad_rgb ray_intersect_preliminary",
        ("mitsuba", "drjit"),
        "pip install mitsuba (and a libLLVM)",
        _mitsuba,
        "own",
    ),
)


def missing(candidate: Candidate) -> str | None:
    import importlib

    for module in candidate.modules:
        try:
            importlib.import_module(module)
        except ImportError as exc:
            return f"not installed ({candidate.hint}): {exc}"
    if candidate.name == "warp-cuda" and not _cuda_devices():
        return f"no CUDA device here ({candidate.hint})"
    return None


def _cuda_devices() -> int:
    import warp as wp

    wp.config.quiet = True
    if hasattr(wp, "LOG_ERROR"):
        wp.config.log_level = wp.LOG_ERROR
    wp.init()
    return wp.get_cuda_device_count()
