"""`wildscan dataset` and `wildscan bench-dataset`: argument parsing only (the work is in
app/dataset and bench/dataset.py)."""

from __future__ import annotations

import argparse
import sys

from ..core.checks import whole_number
from ..core.errors import UserError
from . import options

HELP, DESCRIPTION = (
    "make (or finish) a labeled dataset: many worlds x many poses, on Dask",
    "Scan every world seed of SPEC.toml from many valid poses and write the scans in the formats training "
    "code reads (SemanticKITTI, LAS 1.4, PLY), with a manifest of every file (size, SHA-256), a dataset card "
    "and ground truth for traversability (height above terrain per point, a bird's-eye grid per scan). Runs "
    "on a local Dask cluster, or on an existing one with --scheduler; rerunning the same command into the "
    "same --out resumes and gives the bytes of one uninterrupted run. By default each seed's scans stand "
    "over a 1 km square of the endless landscape, weighed by land cover ([poses] region, cover, tall_cover); "
    'layout = "paper" scans the paper\'s island of six zones. See docs/datasets.md for the spec keys.',
)
BENCH_HELP, BENCH_DESCRIPTION = (
    "time `wildscan dataset` with 1 and 2 workers side by side, cold and warm world cache",
    "Make the same SemanticKITTI dataset (default: 1,000 scans at r_h = 1 deg of one seed spread over the "
    "endless layout's default region, tiles and poses included; --layout paper: 20 island worlds) once per "
    "worker count, in fresh temporary folders with an empty world cache (cold), then with the last count "
    "again on the cache that run filled (warm), and print scans per second, the speed-up, the worlds read "
    "and built, the peak memory of each worker and the floor (casts + tile builds summed over the workers, "
    "divided by the workers) beside the wall time, with the targets met or not; then where the workers' "
    "time went and what 10,000 scans would take on a Dask cluster of N machines. Each run's line also gives "
    "the caster's share of the scans' time and how long the workers waited (starting, between tasks, in the "
    "tail). On the paper layout, first one world's steps built and read back from the cache.",
)


def _positive(text: str, setting: str, high: int = 1_000_000) -> int:
    try:
        return whole_number(text, setting, 1, high)
    except UserError as e:
        raise argparse.ArgumentTypeError(e.message) from None


def _like(text: str) -> str:
    from ..app.dataset.like import LIKES

    if text not in LIKES:
        raise UserError(f"must be one of {', '.join(LIKES)}, got {text!r}", setting="like")
    return text


def add_arguments(p: argparse.ArgumentParser, in_blender: bool = False) -> None:
    p.add_argument("spec", nargs="?", metavar="SPEC.toml", help="the dataset spec (docs/datasets.md)")
    p.add_argument(
        "--out", metavar="DIR", help="the dataset folder (created if missing; rerun into it to resume)"
    )
    engine = p.add_mutually_exclusive_group()
    engine.add_argument(
        "--workers",
        type=lambda t: _positive(t, "workers", 1024),
        metavar="N",
        help="local Dask worker processes, one thread each (default: one per core)",
    )
    engine.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="run on an existing Dask cluster (tcp://host:port) whose workers have WildScan installed and "
        "see DIR at the same path",
    )
    p.add_argument(
        "--limit",
        type=lambda t: _positive(t, "limit", 10**9),
        metavar="K",
        help="write at most K more scans in this run (the next run continues)",
    )
    p.add_argument(
        "--verify",
        metavar="DIR",
        help="re-check the dataset in DIR against its spec and manifest (every planned scan, every file's "
        "size and SHA-256, no file nothing lists) and exit",
    )
    p.add_argument("--quiet", action="store_true", help="no progress, only the summary")
    options.add(
        p,
        options.Option("like", dict(metavar="NAME"), _like),
        help="a real dataset's rig, mount height, label ids and files in one word (SPEC.toml's `like`, "
        "which this replaces; the spec's own keys win): rellis3d (OS1-64 at 1.14 m), goose (VLS-128 at "
        "2.0 m), wildscenes (the tilted VLP-16 on its turning mount at 1.2 m), semantickitti (HDL-64E at "
        "1.73 m); without SPEC.toml every other key is the default",
    )
    options.add_cache_arguments(p)


def run(args, in_blender: bool = False) -> int:
    from ..app.cache.config import cache_from_options
    from ..app.dataset import Interrupted, RunFailed, load_spec, run_dataset

    if args.verify is not None:
        if args.spec or args.out or args.workers or args.scheduler or args.limit:
            raise UserError("--verify DIR takes no SPEC.toml, --out, --workers, --scheduler or --limit")
        return _verify(args.verify)
    if (args.spec is None and args.like is None) or args.out is None:
        raise UserError("give SPEC.toml (or --like NAME) and --out DIR (or --verify DIR)")
    spec = load_spec(args.spec, args.like)
    cache = cache_from_options(args.cache, args.no_cache, args.cache_size, args.scheduler, _warn)
    try:
        report = run_dataset(
            spec, args.out, args.workers, args.scheduler, args.limit, args.quiet, cache=cache
        )
    except Interrupted as e:
        sys.stderr.write(f"wildscan dataset: {e}\n")
        return e.code
    except RunFailed as e:  # not the user's mistake, and not a bug: one line, exit 1
        sys.stderr.write(f"wildscan dataset: error: {e}\n")
        return 1
    print(_summary(report))
    return 0


def _warn(text: str) -> None:
    sys.stderr.write(f"wildscan dataset: warning: {text}\n")


def _summary(report) -> str:
    """What this run wrote, what was there before it, and what the dataset now holds."""
    from ..app.cache.config import worlds_text

    rate = report.written / report.seconds if report.seconds > 0 else 0.0
    notes = [f"{rate:.1f} scans/s"]
    if report.without_pose:
        notes.append(f"{report.without_pose:,} more recorded without a valid pose")
    if report.before:
        notes.append(f"{report.before:,} were there from before, re-checked")
    if report.worlds:
        notes.append(worlds_text(report.worlds))
    state = "complete" if report.complete else "incomplete (rerun the same command to continue)"
    return (
        f"wrote {report.written - report.without_pose:,} scans in {report.seconds:.1f} s "
        f"({'; '.join(notes)}); the dataset in {report.root} is {state}: {report.ok:,} of "
        f"{report.planned:,} scans, {report.failed:,} without a valid pose"
    )


def _verify(folder: str) -> int:
    from ..app.dataset import verify_dataset

    report = verify_dataset(folder)
    for problem in report.problems:
        sys.stderr.write(f"wildscan dataset --verify: {problem}\n")
    state = "complete" if report.complete else f"incomplete ({report.scans:,} of {report.planned:,} scans)"
    if report.problems:  # never "complete" beside them: the rerun that repairs them says so
        print(
            f"{len(report.problems):,} problems: {report.file_problems:,} of {report.checked:,} files differ "
            f"from the manifest, {len(report.unlisted):,} files nothing lists; the dataset is incomplete "
            f"({report.scans:,} of {report.planned:,} scans) until they are repaired (the same "
            "`wildscan dataset` command repairs them)"
        )
        return 1
    print(
        f"all {report.checked:,} files match the manifest (size and SHA-256) and every file is listed; "
        f"the dataset is {state}"
    )
    return 0


def add_bench_arguments(p: argparse.ArgumentParser, in_blender: bool = False) -> None:
    from ..bench.dataset import DEFAULT_WORLDS, LAYOUTS

    p.add_argument(
        "--layout",
        choices=LAYOUTS,
        default="endless",
        help="endless (default): one seed's scans spread over the spec's default region of the endless "
        "landscape; paper: the island's worlds",
    )
    p.add_argument(
        "--worlds",
        type=lambda t: _positive(t, "worlds", 10_000),
        default=None,
        metavar="N",
        help=f"seeds to scan (default {DEFAULT_WORLDS['endless']} on endless, "
        f"{DEFAULT_WORLDS['paper']} on paper)",
    )
    p.add_argument("--scans", type=lambda t: _positive(t, "scans", 10**7), default=1000, metavar="N")
    options.add(
        p,
        options.OPTIONS["rh"]._replace(check=options.rh_alone),
        default=options.DEFAULT_RH,
        help=f"horizontal resolution r_h in degrees of the default device (default {options.DEFAULT_RH:g})",
    )
    p.add_argument(
        "--workers",
        type=lambda t: _positive(t, "workers", 1024),
        action="append",
        metavar="N",
        help="a worker count to time; repeat (default: 1 and 2)",
    )
    from ..core.io.formats import FORMATS

    p.add_argument("--format", default="semantickitti", choices=FORMATS)
    options.add(p, "vegetation")
    from .bench import _markdown_file

    options.add(
        p,
        options.Option("markdown", dict(metavar="FILE.md"), _markdown_file),
        help="also write what it prints, with the date, the machine, the WildScan version and this command, "
        "into FILE.md: created, or its bench-dataset section replaced (the rest of the page is kept). "
        "docs/benchmarks.md is made this way",
    )


def run_bench(args, in_blender: bool = False) -> int:
    from ..bench.dataset import DEFAULT_WORLDS, bench_dataset

    def bench() -> None:
        worlds = args.worlds or DEFAULT_WORLDS[args.layout]
        counts = tuple(args.workers or (1, 2))
        bench_dataset(
            worlds, args.scans, args.rh, counts, (args.format,), args.vegetation, layout=args.layout
        )

    if args.markdown is None:
        bench()
        return 0
    from ..bench.markdown import printed_copy, run_facts, write_markdown

    facts = run_facts(getattr(args, "command_line", "wildscan bench-dataset"))
    with printed_copy() as printed:
        bench()
    written = write_markdown(args.markdown, "bench-dataset", facts, printed.getvalue())
    print(f"wrote {written} (section bench-dataset)")
    return 0
