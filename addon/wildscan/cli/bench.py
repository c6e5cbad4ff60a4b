"""`wildscan bench [--suite backends|world|drive|realism|far|weather|devices|learn DIR|biomes|casters|
lod|detection]` and `wildscan bench-world` (= `bench --suite world`)."""

from __future__ import annotations

import argparse

from ..core.label_schemes import SCHEME_NAMES
from . import options
from .options import ArgumentParser, Option

SUITES = (
    "backends",
    "world",
    "drive",
    "realism",
    "far",
    "weather",
    "devices",
    "learn",
    "biomes",
    "casters",
    "lod",
    "detection",
)
HELP = "time and check every ray backend against scene.ray_cast (--suite world: world building)"
DESCRIPTION = (
    "Measure scan time (median of several runs, side by side) and accuracy of every ray backend on the test "
    "world, analytic primitives and the default world at each detail level, print ratios against "
    "scene.ray_cast and scaling tables, and write a CSV and a chart of time against error. With --suite "
    "world, time the building of the world instead (as `wildscan bench-world`); with --suite realism, "
    "measure the porous vegetation (crown and canopy gap fractions), the realistic sensor model's echoes "
    "and its speed beside the paper model's, and the world's build time and memory, porous beside solid. "
    "A suite that casts rays ends with the share of its scans' time spent in the ray caster's own calls "
    "and their ratio (scan/cast)."
)
WORLD_HELP = "time every world-building stage at each detail level (= bench --suite world)"
WORLD_DESCRIPTION = (
    "Build the world at each detail level and print the time of every stage, object and triangle "
    "counts, and the terrain's height error against the analytic heightfield."
)


def _names(setting: str):
    """A check for a comma-separated list of names."""

    def check(text: str) -> list[str]:
        from ..core.errors import UserError

        names = [n.strip() for n in str(text).split(",")]
        if not all(names):
            raise UserError(
                f"must be a comma-separated list without empty entries, got {text!r}", setting=setting
            )
        return names

    return check


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    from ..bench.config import (
        DEFAULT_OUT,
        DEFAULT_REFERENCE_RAYS,
        DEFAULT_RUNS,
        QUICK_REFERENCE_RAYS,
        QUICK_RUNS,
    )

    p.add_argument(
        "--suite",
        choices=SUITES,
        default="backends",
        help="backends: every ray backend on the test world, analytic primitives, the default world per "
        "detail level and scaling (default); world: the world built at each detail level, as "
        "`wildscan bench-world`; drive: a 60 s drive along the trail with both ROS bags on the "
        "--seed world's trail, stepped and continuous head, then `drive --seed 1 --trail --distance 2000 "
        "--bag ros2` in a process of its own (wall, CPU, peak memory; --quick: 100 m); realism: "
        "vegetation porosity, echoes, "
        "realistic scan speed, build time and memory; far: the largest point error of every backend "
        "and frame with the scene 0 m to 999 km from the origin (docs/accuracy.md 'Far from the origin'); "
        "weather: each effect's lost returns on a wall at known ranges and its maximum range against the "
        "model's curve, and the default world in each (docs/weather.md); devices: every device preset's "
        "full-frame scan time beside Embree's own cast of the same rays (goal <= 1.5x); learn DIR: train a "
        "fixed CPU-only baseline (gradient boosting on per-point geometry) on the dataset DIR's train split "
        "and print per-class IoU, mIoU and the confusion matrix on its test split (docs/benchmarks.md), or "
        "with --test REAL_DIR --scheme NAME score it on real scans beside a real-trained ceiling "
        "(docs/training.md); "
        "biomes: per biome the class mix in RELLIS-3D's categories beside RELLIS-3D's, build time, scan time "
        "and memory beside the paper world of the same seeds at the same poses; the default biome also with "
        "poses uniform over the world, and its bare ground by zone (docs/ground.md); "
        "casters: every float32 ray caster (embreex, "
        "Embree filled from numpy, Embree packets, Open3D, Warp, Mitsuba) on the same triangles and rays: "
        "build time, rays/s on 1 and 2 threads, memory, and whether its scans are the same bytes as "
        "embree's; lod: per device preset on the endless world, cold scan time (tile builds included) and "
        "agreement "
        "(labels, ranges within the device's noise sigma) of level-of-detail scans against --lod off scans "
        "of the same poses, a cold and a warm Hokuyo scan, and the memory of a process that scans 100 poses "
        "over 2 km (docs/scanning.md); "
        "detection: per device preset the farthest range a flat 10 %% and 80 %% target is "
        "detected at by the realistic model beside its datasheet's (goal within 5 %%), the default world's "
        "lost returns by class, range and incidence, and the realistic scan time with and without the "
        "detection step (goal <= 1.1x)",
    )
    p.add_argument("dataset", nargs="?", metavar="DIR", help="--suite learn: the dataset to measure")
    p.add_argument(
        "--card", action="store_true", help="--suite learn: also write its table into DIR's CARD.md"
    )
    p.add_argument(
        "--test",
        metavar="REAL_DIR",
        help="--suite learn: score the baseline trained on DIR on the real scans in REAL_DIR, in their "
        "dataset's own layout (SemanticKITTI, RELLIS-3D or GOOSE .bin + .label, WildScenes Clouds/ + "
        "Labels/), beside the same model trained on the earlier half of REAL_DIR (the ceiling); needs "
        "--scheme",
    )
    p.add_argument(
        "--scheme",
        choices=SCHEME_NAMES,
        help="--suite learn --test: the label ids of REAL_DIR's labels (its learning map decides the "
        "classes)",
    )
    p.add_argument(
        "--with-intensity",
        action="store_true",
        help="--suite learn: give the baseline the remission too (by default it sees geometry only)",
    )
    options.add(p, "seed", default="0", help=f"{options.SEED_HELP} (default 0)")
    options.add(
        p,
        Option("details", dict(metavar="LIST"), _names("details")),
        help="detail levels of the default world, comma-separated from low, default, high "
        "(default: low,default,high; with --quick: low)",
    )
    options.add(
        p,
        Option("backends", dict(metavar="LIST"), _names("backends")),
        help="fast backends to compare, comma-separated from auto, embree, bvh (default: every one "
        "available here); scene.ray_cast (blender) is always measured: ratios are against it",
    )
    p.add_argument(
        "--runs",
        metavar="N",
        help=f"runs per timing, the median is reported, 1..50 (default {DEFAULT_RUNS}; --quick {QUICK_RUNS})",
    )
    p.add_argument(
        "--reference-rays",
        metavar="N",
        help="rays per pose cast with scene.ray_cast where its full-scan time is extrapolated, 100..194400 "
        f"(default {DEFAULT_REFERENCE_RAYS}; --quick {QUICK_REFERENCE_RAYS}); one full scene.ray_cast "
        "scan of the test world and one of the default world are always timed whole (not in --quick)",
    )
    options.add(
        p,
        "out",
        required=False,
        metavar="DIR",
        help=f"directory for bench.csv, bench.png and scaling.md (default {DEFAULT_OUT})",
    )
    options.add(
        p,
        Option("markdown", dict(metavar="FILE.md"), _markdown_file),
        help="also write what the suite prints, with the date, the machine, the WildScan version and "
        "this command, into FILE.md: created, or its section of this suite replaced (the rest of the "
        "page is kept), whole or not at all. docs/benchmarks.md is made this way",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="a smoke run in well under a minute: low detail, 2 poses, 1 run, small subsets, no full "
        "scene.ray_cast scan of the default world",
    )


def _markdown_file(text: str):
    """A page the run can write, and read first when it exists (its other sections are kept)."""
    import os

    from ..core.errors import UserError
    from ..core.io.files import check_output_path

    path = check_output_path(text, ".md", "markdown")
    if path.exists() and not os.access(path, os.R_OK):
        raise UserError(f"{path}: cannot read it (permission denied)", setting="markdown")
    return path


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    if args.markdown is None:
        return _run_suite(args)
    from ..bench.markdown import printed_copy, run_facts, write_markdown

    facts = run_facts(getattr(args, "command_line", "wildscan bench"))
    with printed_copy() as printed:
        code = _run_suite(args)
    if code == 0:
        written = write_markdown(args.markdown, args.suite, facts, printed.getvalue())
        print(f"wrote {written} (section of suite {args.suite})")
    return code


def _bench_weather_within_tolerance():
    from ..bench.weather import TOLERANCE, bench_weather

    return lambda seed, quick: bench_weather(seed, quick)["worst"] <= TOLERANCE


def _bench_realism():
    from ..bench.realism import bench_realism

    return bench_realism


def _bench_devices():
    from ..bench.devices import bench_devices

    return bench_devices


def _bench_casters():
    from ..bench.casters import bench_casters

    return bench_casters


def _bench_lod():
    from ..bench.lod import bench_lod

    return bench_lod


def _bench_biomes():
    from ..bench.biomes import bench_biomes

    return bench_biomes


def _bench_detection():
    from ..bench.detection import bench_detection

    return bench_detection


# Suites run as f(seed, quick); each entry imports its module only when chosen. A suite
# returning False (weather beyond its tolerance) exits 1.
SEED_AND_QUICK_SUITES = {
    "realism": _bench_realism,
    "weather": _bench_weather_within_tolerance,
    "devices": _bench_devices,
    "biomes": _bench_biomes,
    "casters": _bench_casters,
    "lod": _bench_lod,
    "detection": _bench_detection,
}


def _run_suite(args: argparse.Namespace) -> int:
    """The suite, then how much of its scans' time was the ray caster's own (core/runtime/cast_clock.py)."""
    from ..core.runtime.cast_clock import CLOCK, cast_share_line

    before = CLOCK.reading()
    code = _run_chosen_suite(args)
    spent = CLOCK.reading() - before
    if spent.cast > 0:
        print(f"suite {args.suite}: {cast_share_line(spent)}")
    return code


def _run_chosen_suite(args: argparse.Namespace) -> int:
    if args.suite == "learn":
        _only_for_backends(args, also=("details",))
        if args.test is not None or args.scheme is not None:
            from ..bench.learn_real import run_transfer

            return run_transfer(args)
        from ..bench.learn import run_learn

        return run_learn(args)
    _only_for_learn(args)
    if args.suite == "far":
        from ..bench.far import OFFSETS, QUICK_OFFSETS, bench_far

        _only_for_backends(args, also=("details",), allowed=("backends",))
        bench_far(QUICK_OFFSETS if args.quick else OFFSETS, args.backends)
        return 0
    if args.suite == "drive":
        from ..bench.drive import bench_drive
        from ..bench.drive_long import bench_long_drive

        _only_for_backends(args, also=("details",))
        bench_drive(args.seed)
        bench_long_drive(args.quick)  # drive --seed 1 --trail --distance 2000 (--quick: 100 m)
        return 0
    if args.suite in SEED_AND_QUICK_SUITES:
        _only_for_backends(args, also=("details",))
        return 0 if SEED_AND_QUICK_SUITES[args.suite]()(args.seed, args.quick) is not False else 1
    if args.suite == "world":
        from ..bench.config import check_details

        _only_for_backends(args)
        return _world_suite(args.seed, check_details(args.details or (["low"] if args.quick else [])))
    from ..bench.backends import run_backends
    from ..bench.config import DEFAULT_OUT, make_config

    cfg = make_config(
        args.seed,
        args.details,
        args.backends,
        args.runs,
        args.reference_rays,
        args.out or DEFAULT_OUT,
        args.quick,
    )
    return run_backends(cfg)


def _only_for_backends(
    args: argparse.Namespace, also: tuple[str, ...] = (), allowed: tuple[str, ...] = ()
) -> None:
    from ..core.errors import UserError

    for setting in ("backends", "runs", "reference_rays", "out", *also):
        if setting not in allowed and getattr(args, setting) is not None:
            raise UserError("applies to {suite} backends only", setting=setting, related=("suite",))


def _only_for_learn(args: argparse.Namespace) -> None:
    from ..core.errors import UserError

    if args.dataset is not None:
        raise UserError(f"a dataset folder ({args.dataset}) is measured by --suite learn only")
    for flag in ("card", "with_intensity", "test", "scheme"):
        if getattr(args, flag):
            raise UserError(f"--{flag.replace('_', '-')} applies to --suite learn only")


def add_world_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    options.add(p, "seed", default="0", help=f"{options.SEED_HELP} (default 0)")
    options.add(
        p,
        Option(
            "detail",
            dict(action="append", metavar="LEVEL"),
            lambda names: [options.detail_name(n) for n in names],
        ),
        help="detail level to measure; repeat for several (default: low, default, high)",
    )


def run_world(args: argparse.Namespace, in_blender: bool = False) -> int:
    return _world_suite(args.seed, args.detail)


def _world_suite(seed: int, details: list[str] | None) -> int:
    from ..bench.world_build import bench_world
    from ..core.world import DETAILS

    bench_world(seed, details or list(DETAILS))
    return 0
