"""`wildscan bench-dataset`: the same dataset made with 1 and 2 workers (or any counts),
side by side: wall time (world builds included), scans per second, speed-up over the first
count, and the peak resident memory of every worker. Each count runs with a new, empty world
cache (cold: every world built, app/cache/); the last count runs once more on the cache its
cold run filled (warm: every world read from it). Before the runs, one world's steps built
and read back (bench/world_cache.py).

Targets (on this 2-core machine, default biome and porous vegetation): 1,000 scans at r_h =
1 deg from 20 worlds into SemanticKITTI, world builds included, cold cache: in at most 45 s
with 2 workers, at least 1.85x from 1 to 2 workers, each worker under 1.5 GB; warm cache:
at most 30 s.
"""

from __future__ import annotations

import shutil
import sys
import tempfile
from dataclasses import dataclass, field

from ..app.dataset.timeline import Idle, idle_time
from ..core.runtime.cast_clock import Reading, cast_share_line
from ..core.world import DEFAULT_VEGETATION

TARGET_SECONDS = 45.0  # cold cache
TARGET_WARM_SECONDS = 30.0
TARGET_SPEEDUP = 1.85
TARGET_WORKER_BYTES = 1.5e9


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

    @property
    def rate(self) -> float:
        return self.scans / self.seconds if self.seconds > 0 else 0.0


def bench_spec(worlds: int, scans: int, rh: float, formats: tuple[str, ...], vegetation: str):
    from ..app.dataset import spec_from_dict

    per_world = max(1, scans // worlds)
    return spec_from_dict(
        {
            "layout": "paper",  # the island's worlds, as this bench's figures were measured
            "seeds": list(range(worlds)),
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
    )


def bench_dataset(
    worlds: int = 20,
    scans: int = 1000,
    rh: float = 1.0,
    worker_counts: tuple[int, ...] = (1, 2),
    formats: tuple[str, ...] = ("semantickitti",),
    vegetation: str = DEFAULT_VEGETATION,
    stream=None,
) -> list[BenchRow]:
    from .world_cache import print_world_load_steps

    stream = stream or sys.stdout
    spec = bench_spec(worlds, scans, rh, formats, vegetation)
    total = len(spec.seeds) * spec.scans_per_world
    print_world_load_steps(spec, spec.seeds[0], stream)
    stream.write(
        f"\nwildscan dataset: {total:,} scans at r_h = {rh:g} deg from {worlds} worlds "
        f"({spec.detail} detail, {spec.vegetation} vegetation) into "
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
                stream.write(f"  {n} worker(s), {cache} cache: {r.seconds:.1f} s; {share}; {r.idle.line()}\n")
                stream.flush()
    _table(rows, stream)
    return rows


def _table(rows: list[BenchRow], stream) -> None:
    cold = [r for r in rows if r.cache == "cold"]
    base = cold[0].rate
    stream.write(
        "\n| workers | world cache | scans | seconds | scans/s | speed-up | worlds read / built "
        "| world loads (s, summed) | peak memory per worker |\n"
    )
    stream.write("|---:|---|---:|---:|---:|---:|---:|---:|---|\n")
    for r in rows:
        memory = ", ".join(f"{b / 1e9:.2f} GB" for b in r.peak_rss)
        worlds = f"{r.worlds.get('cache', 0)} / {r.worlds.get('built', 0)}"
        stream.write(
            f"| {r.workers} | {r.cache} | {r.scans:,} | {r.seconds:.1f} | {r.rate:.1f} | "
            f"{r.rate / base:.2f}x | {worlds} | {r.world_build_seconds:.1f} | {memory} |\n"
        )
    best = min(cold, key=lambda r: r.seconds)
    worst_memory = max((b for r in rows for b in r.peak_rss), default=0)
    stream.write("\ntargets:\n")
    met = best.seconds <= TARGET_SECONDS
    _target(
        stream,
        f"cold cache, at most {TARGET_SECONDS:g} s",
        met,
        f"{best.seconds:.1f} s, {best.workers} workers",
    )
    if len(cold) > 1:
        speedup = cold[-1].rate / base
        where = f"{speedup:.2f}x ({cold[0].workers} -> {cold[-1].workers} workers, cold cache)"
        _target(stream, f"speed-up >= {TARGET_SPEEDUP:g}x", speedup >= TARGET_SPEEDUP, where)
    limit = f"every worker under {TARGET_WORKER_BYTES / 1e9:g} GB"
    _target(stream, limit, worst_memory < TARGET_WORKER_BYTES, f"peak {worst_memory / 1e9:.2f} GB")
    for r in (r for r in rows if r.cache == "warm"):
        met = r.seconds <= TARGET_WARM_SECONDS
        _target(
            stream,
            f"warm cache, at most {TARGET_WARM_SECONDS:g} s",
            met,
            f"{r.seconds:.1f} s, {r.workers} workers",
        )
    stream.flush()


def _target(stream, what: str, met: bool, measured: str) -> None:
    stream.write(f"  {what}: {measured}: {'met' if met else 'NOT met'}\n")
