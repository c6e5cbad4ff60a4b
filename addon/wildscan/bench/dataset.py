"""`wildscan bench-dataset`: the same dataset made with 1 and 2 workers (or any counts),
side by side: wall time (world builds included), scans per second, speed-up over the first
count, and the peak resident memory of every worker.

Targets (set for distributed datasets, on this 2-core machine): 1,000 scans at r_h = 1 deg from 20 worlds into
SemanticKITTI in under 60 s, at least 1.8x from 1 to 2 workers, each worker under 1.5 GB.
They were set for the worlds of that time, whose crowns were closed shells
(`--vegetation solid`); the porous crowns, the default since, make a world of several times as many triangles
and are timed the same way.

"""

from __future__ import annotations

import shutil
import sys
import tempfile
from dataclasses import dataclass

from ..core.cast_clock import Reading, cast_share_line
from ..core.world import DEFAULT_VEGETATION

TARGET_SECONDS = 60.0
TARGET_SPEEDUP = 1.8
TARGET_WORKER_BYTES = 1.5e9


@dataclass
class BenchRow:
    workers: int
    scans: int
    seconds: float
    world_build_seconds: float
    peak_rss: list[int]
    scan_seconds: float = 0.0  # summed over workers (core/cast_clock.py)
    cast_seconds: float = 0.0

    @property
    def rate(self) -> float:
        return self.scans / self.seconds if self.seconds > 0 else 0.0


def bench_spec(worlds: int, scans: int, rh: float, formats: tuple[str, ...], vegetation: str):
    from ..app.dataset import spec_from_dict

    per_world = max(1, scans // worlds)
    return spec_from_dict(
        {
            "seeds": list(range(worlds)),
            "scans_per_world": per_world,
            "formats": list(formats),
            "vegetation": vegetation,
            "sensor": {"rh": rh},
        }
    )


def run_once(spec, workers: int) -> BenchRow:
    from ..app.dataset import run_dataset

    folder = tempfile.mkdtemp(prefix="wildscan-bench-dataset-")
    try:
        # a bench's worlds are not for training: no warning about its splits
        report = run_dataset(
            spec, folder, workers=workers, quiet=True, say=lambda text: None, warn=lambda text: None
        )
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return BenchRow(
        workers,
        report.written,
        report.seconds,
        report.world_build_seconds,
        sorted(report.peak_rss.values()),
        report.scan_seconds,
        report.cast_seconds,
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
    stream = stream or sys.stdout
    spec = bench_spec(worlds, scans, rh, formats, vegetation)
    total = len(spec.seeds) * spec.scans_per_world
    stream.write(
        f"wildscan dataset: {total:,} scans at r_h = {rh:g} deg from {worlds} worlds "
        f"({spec.detail} detail, {spec.vegetation} vegetation) into "
        f"{', '.join(formats)}, world builds included; one run per worker count\n"
    )
    stream.flush()
    rows = []
    for n in worker_counts:
        rows.append(run_once(spec, n))
        r = rows[-1]
        share = cast_share_line(Reading(r.cast_seconds, r.scan_seconds, r.cast_seconds))
        stream.write(f"  {n} worker(s): {r.seconds:.1f} s; {share}\n")
        stream.flush()
    _table(rows, stream)
    return rows


def _table(rows: list[BenchRow], stream) -> None:
    base = rows[0].rate
    stream.write(
        "\n| workers | scans | seconds | scans/s | speed-up | world builds (s, summed) "
        "| peak memory per worker |\n"
    )
    stream.write("|---:|---:|---:|---:|---:|---:|---|\n")
    for r in rows:
        memory = ", ".join(f"{b / 1e9:.2f} GB" for b in r.peak_rss)
        stream.write(
            f"| {r.workers} | {r.scans:,} | {r.seconds:.1f} | {r.rate:.1f} | {r.rate / base:.2f}x | "
            f"{r.world_build_seconds:.1f} | {memory} |\n"
        )
    best = min(rows, key=lambda r: r.seconds)
    worst_memory = max((b for r in rows for b in r.peak_rss), default=0)
    stream.write("\ntargets:\n")
    stream.write(f"  under {TARGET_SECONDS:g} s: {best.seconds:.1f} s with {best.workers} workers\n")
    if len(rows) > 1:
        stream.write(
            f"  speed-up >= {TARGET_SPEEDUP:g}x: {rows[-1].rate / base:.2f}x "
            f"({rows[0].workers} -> {rows[-1].workers})\n"
        )
    stream.write(f"  every worker under {TARGET_WORKER_BYTES / 1e9:g} GB: peak {worst_memory / 1e9:.2f} GB\n")
    stream.flush()
