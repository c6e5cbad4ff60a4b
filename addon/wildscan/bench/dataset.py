"""`wildscan bench-dataset`: the same dataset made with 1 and 2 workers (or any counts),
side by side: wall time (world builds included), scans per second, speed-up over the first
count, the peak resident memory of every worker, and the floor beside the wall time (the
casts and tile builds summed over the workers, divided by the workers: bench/dataset_floor.py),
where the workers' time went, and what 10,000 scans would take on a Dask cluster. Each count
runs with a new, empty world cache (cold: every tile and world built, app/cache/); the last
count runs once more on the cache its cold run filled (warm: read from it).

On the endless layout (the default): one seed's scans spread over the spec's default region
(a 1 km square). On the paper layout: 20 island worlds, and before the runs one world's steps
built and read back (bench/world_cache.py).

Targets (on this 2-core machine, default biome and porous vegetation, 1,000 scans at r_h = 1
deg into SemanticKITTI, cold cache): endless: at most 60 s with 2 workers, warm at most 40 s,
the wall time within 1.3x the floor; paper: 45 s, warm 30 s; both: at least 1.85x from 1 to
2 workers, each worker under 1.5 GB.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from dataclasses import dataclass, field

from ..app.dataset.timeline import Idle, idle_time
from ..core.runtime.cast_clock import Reading, cast_share_line
from ..core.world import DEFAULT_VEGETATION
from .dataset_floor import cluster_lines, work_of

TARGETS = {"endless": (60.0, 40.0), "paper": (45.0, 30.0)}  # s: cold, warm cache, for TARGET_SCANS
TARGET_SCANS = 1000  # the targets' dataset size: a run of another size is judged scaled to it
TARGET_SPEEDUP = 1.85
TARGET_WORKER_BYTES = 1.5e9
TARGET_FLOOR_RATIO = 1.3  # the wall time at most this many times the floor
LAYOUTS = ("endless", "paper")
DEFAULT_WORLDS = {"endless": 1, "paper": 20}


@dataclass
class BenchRow:
    workers: int
    scans: int
    seconds: float
    world_build_seconds: float
    peak_rss: list[int]
    cache: str = "cold"  # cold: an empty world cache; warm: the one the cold run filled
    worlds: dict[str, int] = field(default_factory=dict)  # "cache" / "built" -> worlds
    scan_seconds: float = 0.0  # summed over workers (core/runtime/cast_clock.py)
    cast_seconds: float = 0.0
    idle: Idle | None = None  # worker time without a task (app/dataset/timeline.py)
    tiles: dict[str, float] = field(default_factory=dict)  # tiles built and read (worker.tile_facts)
    tasks: list[tuple[int, float, float]] = field(default_factory=list)  # (pid, start, end)
    client_poses: float = 0.0  # s: poses placed before the workers started (land.poses_before_the_workers)

    @property
    def rate(self) -> float:
        return self.scans / self.seconds if self.seconds > 0 else 0.0


def bench_spec(
    worlds: int, scans: int, rh: float, formats: tuple[str, ...], vegetation: str, layout: str = "endless"
):
    from ..app.dataset import spec_from_dict

    per_world = max(1, scans // worlds)
    return spec_from_dict(
        {
            "layout": layout,
            "seeds": list(range(1, worlds + 1)) if layout == "endless" else list(range(worlds)),
            "scans_per_world": per_world,
            "formats": list(formats),
            "vegetation": vegetation,
            "sensor": {"rh": rh},
        }
    )


def run_once(spec, workers: int, cache_dir=None, cache: str = "cold") -> BenchRow:
    from ..app.cache.config import cache_config
    from ..app.dataset import run_dataset

    folder = tempfile.mkdtemp(prefix="wildscan-bench-dataset-")
    try:
        # a bench's worlds are not for training: no warning about its splits
        report = run_dataset(
            spec,
            folder,
            workers=workers,
            quiet=True,
            say=lambda text: None,
            warn=lambda text: None,
            cache=None if cache_dir is None else cache_config(cache_dir),
        )
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return BenchRow(
        workers,
        report.written,
        report.seconds,
        report.world_build_seconds,
        sorted(report.peak_rss.values()),
        cache,
        dict(report.worlds),
        report.scan_seconds,
        report.cast_seconds,
        idle_time(report.started, report.tasks),
        dict(report.tiles),
        list(report.tasks),
        report.client_poses_seconds,
    )


def bench_dataset(
    worlds: int = 20,
    scans: int = 1000,
    rh: float = 1.0,
    worker_counts: tuple[int, ...] = (1, 2),
    formats: tuple[str, ...] = ("semantickitti",),
    vegetation: str = DEFAULT_VEGETATION,
    stream=None,
    layout: str = "endless",
) -> list[BenchRow]:
    from .world_cache import print_world_load_steps

    stream = stream or sys.stdout
    spec = bench_spec(worlds, scans, rh, formats, vegetation, layout)
    total = len(spec.seeds) * spec.scans_per_world
    if layout == "paper":
        print_world_load_steps(spec, spec.seeds[0], stream)
    where = f"{layout} layout"
    if layout == "endless":
        where += f", each seed's scans over the region {list(spec.poses.land_region())} m"
    stream.write(
        f"\nwildscan dataset: {total:,} scans at r_h = {rh:g} deg from {worlds} worlds ({where}; "
        f"{spec.detail} detail, {spec.vegetation} vegetation) into "
        f"{', '.join(formats)}, world builds included; one run per worker count on an empty world "
        f"cache, then {worker_counts[-1]} worker(s) again on the cache that run filled\n"
    )
    stream.flush()
    rows = []
    for n in worker_counts:
        with tempfile.TemporaryDirectory(prefix="wildscan-bench-cache-") as cache_dir:
            for cache in ("cold", "warm") if n == worker_counts[-1] else ("cold",):
                rows.append(run_once(spec, n, cache_dir, cache))
                r = rows[-1]
                share = cast_share_line(Reading(r.cast_seconds, r.scan_seconds, r.cast_seconds))
                floor = work_of(r).floor
                stream.write(
                    f"  {n} worker(s), {cache} cache: {r.seconds:.1f} s, floor {floor:.1f} s "
                    f"({r.seconds / max(floor, 1e-9):.2f}x); {share}; {r.idle.line()}\n"
                )
                stream.flush()
    _table(rows, stream, layout)
    stream.write("\nwhere the time went (worker-seconds, summed over the workers):\n")
    for r in rows:
        stream.write(f"  {r.cache} cache, " + "\n  ".join(work_of(r).lines()) + "\n")
    stream.write("\n" + "\n".join(cluster_lines(work_of(rows[0]), worlds)) + "\n")
    stream.flush()
    return rows


def _table(rows: list[BenchRow], stream, layout: str = "endless") -> None:
    cold = [r for r in rows if r.cache == "cold"]
    base = cold[0].rate
    target_seconds, target_warm = TARGETS[layout]
    stream.write(
        "\n| workers | world cache | scans | seconds | floor (s) | wall / floor | scans/s | speed-up "
        "| worlds read / built | world loads (s, summed) | peak memory per worker |\n"
    )
    stream.write("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|\n")
    for r in rows:
        memory = ", ".join(f"{b / 1e9:.2f} GB" for b in r.peak_rss)
        worlds = f"{r.worlds.get('cache', 0)} / {r.worlds.get('built', 0)}"
        floor = work_of(r).floor
        stream.write(
            f"| {r.workers} | {r.cache} | {r.scans:,} | {r.seconds:.1f} | {floor:.1f} | "
            f"{r.seconds / max(floor, 1e-9):.2f} | {r.rate:.1f} | "
            f"{r.rate / base:.2f}x | {worlds} | {r.world_build_seconds:.1f} | {memory} |\n"
        )
    best = min(cold, key=lambda r: r.seconds)
    worst_memory = max((b for r in rows for b in r.peak_rss), default=0)
    stream.write("\ntargets:\n")
    scaled = _scaled(best.seconds, best.scans)
    _target(
        stream,
        f"cold cache, at most {target_seconds:g} s for {TARGET_SCANS:,} scans",
        scaled <= target_seconds,
        f"{_seconds_text(best.seconds, best.scans)}, {best.workers} workers",
    )
    if len(cold) > 1:
        speedup = cold[-1].rate / base
        where = f"{speedup:.2f}x ({cold[0].workers} -> {cold[-1].workers} workers, cold cache)"
        _target(stream, f"speed-up >= {TARGET_SPEEDUP:g}x", speedup >= TARGET_SPEEDUP, where)
    limit = f"every worker under {TARGET_WORKER_BYTES / 1e9:g} GB"
    _target(stream, limit, worst_memory < TARGET_WORKER_BYTES, f"peak {worst_memory / 1e9:.2f} GB")
    for r in (r for r in rows if r.cache == "warm"):
        _target(
            stream,
            f"warm cache, at most {target_warm:g} s for {TARGET_SCANS:,} scans",
            _scaled(r.seconds, r.scans) <= target_warm,
            f"{_seconds_text(r.seconds, r.scans)}, {r.workers} workers",
        )
    if layout == "endless":
        ratio = best.seconds / max(work_of(best).floor, 1e-9)
        where = f"{ratio:.2f}x ({best.workers} workers, cold cache)"
        _target(stream, f"wall within {TARGET_FLOOR_RATIO:g}x the floor", ratio <= TARGET_FLOOR_RATIO, where)
    stream.flush()


def _scaled(seconds: float, scans: int) -> float:
    """A run's seconds scaled to TARGET_SCANS scans (linearly: a smaller run's start-up counts
    as if it were paid again and again, so a small run is judged on the strict side)."""
    return seconds * TARGET_SCANS / max(scans, 1)


def _seconds_text(seconds: float, scans: int) -> str:
    if scans == TARGET_SCANS:
        return f"{seconds:.1f} s"
    return f"{seconds:.1f} s for {scans:,} scans, {_scaled(seconds, scans):.0f} s scaled to {TARGET_SCANS:,}"


def _target(stream, what: str, met: bool, measured: str) -> None:
    stream.write(f"  {what}: {measured}: {'met' if met else 'NOT met'}\n")
