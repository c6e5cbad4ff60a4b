"""What a benchmark run measures and the goals it checks: the constants of every suite and
the run's configuration (BenchConfig), checked before anything runs."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from ..core.errors import UserError

RANGE_TOLERANCE = 1e-4  # metres: "ranges within 1e-4 m"
AGREEMENT_TARGET = 0.9999
SPEEDUP_TARGET = 100.0
FINE_RH = 0.25
FINE_SCAN_TARGET_S = 0.25
SCAN_RH = 1.0
ANALYTIC_TARGET_M = 1e-4
# "Flat in the number of objects", made measurable: over the object-count steps (30x the
# objects, and with them 12x the triangles and more hits in reach) the scan time may at most
# double, where scene.ray_cast's time a ray grows with the objects.
FLAT_TARGET = 2.0
BEAM_STEPS = (4.0, 2.0, 1.0, 0.5, 0.25)
QUICK_BEAM_STEPS = (4.0, 1.0, 0.25)
OBJECT_COUNTS = (100, 1000, 3000)
QUICK_OBJECT_COUNTS = (20, 200)
DEFAULT_RUNS, QUICK_RUNS = 3, 1
RUNS_RANGE = (1, 50)
REFERENCE_RAYS_RANGE = (100, 194_400)
DEFAULT_REFERENCE_RAYS, QUICK_REFERENCE_RAYS = 2000, 300
TERRAIN_RAYS, QUICK_TERRAIN_RAYS = 20_000, 2_000
QUICK_ZONES = 2
DEFAULT_OUT = "out/bench"
BENCH_COLLECTION = "WildScanBench"
REFERENCE = "blender"
PHASES = ("placement", "beam_directions", "ray_casting", "labels_leveling", "ply_write")
PHASE_TITLES = {
    "placement": "placement",
    "beam_directions": "beam directions",
    "ray_casting": "ray casting",
    "labels_leveling": "labels + leveling",
    "ply_write": "PLY write",
}
DEFAULT_POSES = ((0.0, 0.0, 0.0), (8.0, -6.0, 30.0), (-12.0, 10.0, 90.0))  # synthetic scenes


@dataclass
class BenchConfig:
    seed: int
    details: tuple[str, ...]
    fast_backends: tuple[str, ...]
    runs: int
    reference_rays: int
    out: Path
    quick: bool

    @property
    def all_backends(self) -> tuple[str, ...]:
        return (REFERENCE, *self.fast_backends)

    @property
    def full_reference(self) -> bool:
        """Time one FULL scene.ray_cast scan of the default world (~50 s; not in --quick)."""
        return not self.quick

    @property
    def headline_detail(self) -> str:
        return "default" if "default" in self.details else self.details[0]

    @property
    def beam_steps(self) -> tuple[float, ...]:
        return QUICK_BEAM_STEPS if self.quick else BEAM_STEPS

    @property
    def object_counts(self) -> tuple[int, ...]:
        return QUICK_OBJECT_COUNTS if self.quick else OBJECT_COUNTS

    @property
    def terrain_rays(self) -> int:
        return QUICK_TERRAIN_RAYS if self.quick else TERRAIN_RAYS

    @property
    def analytic_rh(self) -> float:
        return 6.0 if self.quick else 4.0


def make_config(
    seed: int = 0,
    details: Sequence[str] | None = None,
    backends: Sequence[str] | None = None,
    runs: int | str | None = None,
    reference_rays: int | str | None = None,
    out: str | os.PathLike = DEFAULT_OUT,
    quick: bool = False,
) -> BenchConfig:
    """The configuration of a `wildscan bench` run, every setting checked before anything runs
    (UserError names what is wrong); the output directory is created last. None takes the
    default (of --quick when `quick`). Without matplotlib it stops first: the run draws a chart."""
    from ..core.checks import whole_number
    from ..core.io.files import output_directory
    from ..core.world import DETAILS, check_seed
    from ..raycast.select import missing_reason, resolve_backend
    from ..viz import have_matplotlib

    if not have_matplotlib():
        raise UserError(
            "wildscan bench draws its chart with matplotlib (pip install matplotlib); "
            "it is not installed here"
        )
    seed = check_seed(seed)
    details = check_details(details) if details else (["low"] if quick else list(DETAILS))
    names = ("auto", "embree", "bvh", REFERENCE)
    fast: list[str] = []
    for name in backends or ["embree", "bvh"]:
        if name not in names:
            raise UserError(
                f"must list names from {', '.join(names)}, got {name!r}", setting="backends", allowed=names
            )
        if name == "auto":
            name = resolve_backend("auto", notify=None)
        elif backends and name != REFERENCE and missing_reason(name):
            raise UserError(
                f"{name}: not available in this Python ({missing_reason(name)})", setting="backends"
            )
        if name != REFERENCE and name not in fast and missing_reason(name) is None:
            fast.append(name)
    if not fast:
        raise UserError(
            "must name at least one fast backend (embree or bvh) to compare with scene.ray_cast",
            setting="backends",
        )
    if runs is None:
        runs = QUICK_RUNS if quick else DEFAULT_RUNS
    if reference_rays is None:
        reference_rays = QUICK_REFERENCE_RAYS if quick else DEFAULT_REFERENCE_RAYS
    runs = whole_number(runs, "runs", *RUNS_RANGE)
    reference_rays = whole_number(reference_rays, "reference_rays", *REFERENCE_RAYS_RANGE)
    return BenchConfig(
        seed, tuple(dict.fromkeys(details)), tuple(fast), runs, reference_rays, output_directory(out), quick
    )


def check_details(details: Sequence[str]) -> list[str]:
    """The detail levels asked for (--details), each one known."""
    from ..core.world import DETAILS

    for d in details:
        if d not in DETAILS:
            raise UserError(
                f"must list levels from {', '.join(DETAILS)}, got {d!r}",
                setting="details",
                allowed=tuple(DETAILS),
            )
    return list(details)
