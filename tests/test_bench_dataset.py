"""`wildscan bench-dataset` on the endless layout (the default): the rows of each worker count,
the floor (casts + tile builds over the workers) beside the wall time, where the workers'
time went, the cluster's extrapolation, and the section it writes with --markdown."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from wildscan.app.dataset.timeline import Idle
from wildscan.bench.dataset_floor import CLUSTER_MACHINES, cluster_lines, work_of

from tests.helpers.dataset_helpers import wildscan


def _row(workers=1, scans=100, seconds=50.0, casts=10.0, scan_seconds=40.0, poses=8.0, tiles=None):
    tiles = tiles or {
        "world_built": 4,
        "world_build_seconds": 2.0,
        "world_read": 0,
        "world_read_seconds": 0.0,
        "scans_built": 6,
        "scans_build_seconds": 3.0,
        "scans_read": 10,
        "scans_read_seconds": 1.0,
    }
    tasks = [(1, 0.0, 49.0)] if workers == 1 else [(1, 0.0, 25.0), (2, 0.0, 26.0)]
    return SimpleNamespace(
        workers=workers,
        scans=scans,
        seconds=seconds,
        cast_seconds=casts,
        scan_seconds=scan_seconds,
        world_build_seconds=poses,
        tiles=tiles,
        tasks=tasks,
        idle=Idle(1.0, 0.0, 0.0, workers),
    )


def test_the_floor_is_the_casts_and_tile_builds_over_the_workers():
    work = work_of(_row(workers=2))
    assert work.floor == pytest.approx((10.0 + 2.0 + 3.0) / 2)
    assert (work.tiles_built, work.tiles_read) == (10, 10)
    text = "\n".join(work.lines())
    assert "floor 7.5 s (casts 10.0 s + tile builds 5.0 s, over 2), wall 50.0 s = 6.67x the floor" in text
    # around the casts: the scans' time but their casts and their tiles' builds and reads
    assert "labels, truth, files): 26.0 s (260 ms a scan)" in text


def test_the_cluster_divides_the_scans_but_each_worker_places_its_worlds_poses():
    one = work_of(_row())
    lines = cluster_lines(one, worlds=1, scans=10_000)
    assert "10,000 scans (100 worlds of 100)" in lines[0]
    minutes = [float(line.split(":")[1].split("min")[0]) for line in lines[1:]]
    assert len(minutes) == len(CLUSTER_MACHINES) and minutes == sorted(minutes, reverse=True)
    # one world of 10,000: every worker places all its poses, however many machines
    alone = cluster_lines(work_of(_row(scans=10_000, poses=800.0)), worlds=1, scans=10_000)
    poses = [line.split("poses ")[1].split(" min")[0] for line in alone[1:]]
    assert len(set(poses)) == 1 and float(poses[0]) == pytest.approx(800.0 / 60, abs=0.05)


def test_bench_dataset_on_the_endless_layout_prints_the_floor_and_writes_its_section(tmp_path):
    page = tmp_path / "benchmarks.md"
    page.write_text("# Benchmarks\n\nkept\n", encoding="utf-8")
    result = wildscan(
        "bench-dataset", "--scans", "3", "--rh", "10", "--workers", "1",
        "--vegetation", "solid", "--markdown", str(page),
    )  # fmt: skip
    assert result.returncode == 0 and result.stderr == "", result.stderr
    out = result.stdout
    assert "3 scans at r_h = 10 deg from 1 worlds (endless layout, each seed's scans over the region" in out
    lines = out.splitlines()
    table = lines[lines.index(next(line for line in lines if line.startswith("| workers |"))) + 2 :]
    rows = [[c.strip() for c in line.split("|")[1:-1]] for line in table if line.startswith("| ")]
    assert [r[:3] for r in rows] == [["1", "cold", "3"], ["1", "warm", "3"]]
    for r in rows:  # the floor beside the wall time, and their ratio (of the unrounded figures)
        wall, floor, ratio = float(r[3]), float(r[4]), float(r[5])
        # a warm run's floor is its casts alone: 3 coarse scans' may print as 0.0 s
        assert (floor > 0 if r[1] == "cold" else floor >= 0) and ratio > 0
        assert wall == pytest.approx(floor * ratio, abs=0.05 * ratio + 0.05)
    assert "wall within 1.3x the floor" in out and "warm cache, at most 40 s" in out
    assert "where the time went" in out and "tiles:" in out and "poses of the world" in out
    assert "10,000 scans" in out and "N = 16:" in out
    text = page.read_text(encoding="utf-8")
    assert text.startswith("# Benchmarks\n\nkept\n\n<!-- begin wildscan bench-dataset (generated")
    assert "- Command: `wildscan bench-dataset --scans 3" in text and "N = 16:" in text
