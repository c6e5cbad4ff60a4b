"""Suite "backends" (`wildscan bench`): every ray backend side by side. Runs the test
world, primitives, default world and scaling measurements, prints their tables and the
targets, and writes bench.csv, bench.png and scaling.md."""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from .config import BenchConfig
from .levels import bench_world_levels
from .primitives import bench_analytic
from .report import Report, backend_title, text_table, write_bench_files
from .scaling import bench_objects, scaling_tables
from .targets import format_targets, targets
from .testworld import bench_test_world


def run_backends(cfg: BenchConfig, out: Callable[[str], None] | None = None) -> int:
    """Every measurement of the suites, printed, with bench.csv, bench.png and scaling.md
    written to cfg.out. Works the same inside Blender (it builds in scenes of its own)."""
    report = Report(out or _print_flush)
    start = time.perf_counter()
    report.say(
        f"wildscan bench{' --quick' if cfg.quick else ''}: seed {cfg.seed}, details {','.join(cfg.details)}, "
        f"backends {', '.join(backend_title(n) for n in cfg.all_backends)}, median of {cfg.runs} run(s); "
        f"noise off"
    )
    with tempfile.TemporaryDirectory(dir=cfg.out, prefix=".bench-scans-") as tmp:
        tmp = Path(tmp)
        bench_test_world(cfg, report, tmp)
        bench_analytic(cfg, report)
        bench_world_levels(cfg, report, tmp)
        bench_objects(cfg, report, tmp)
    tables = scaling_tables(report, cfg)
    for title, headers, body in tables:
        report.say(f"\n== {title}\n{text_table(headers, body)}")
    report.say(format_targets(targets(report, cfg)))
    csv_path, png_path, md_path = write_bench_files(report.rows, tables, cfg.out)
    report.say(
        f"\nwrote {csv_path}\nwrote {png_path}\nwrote {md_path} (the scaling tables in markdown)\n"
        f"bench finished in {time.perf_counter() - start:.0f} s"
    )
    return 0


def _print_flush(text: str) -> None:
    print(text, flush=True)
