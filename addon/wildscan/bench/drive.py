"""`wildscan bench --suite drive`: a 60 s drive at 1 m/s along a world's trail, r_h = 1 deg
(2,400 2D scans, 13 3D scans), with both ROS bags, timed stage by stage.

Targets (on this 2-core machine, quiet): at most 4 s for the whole drive without wind and 10 s
with wind, world planning and every file included; every row is printed beside its target,
met or not.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

TARGET_SECONDS = 4.0  # without wind
WIND_TARGET_SECONDS = 10.0
DRIVE_SECONDS = 60.0
SPEED = 1.0


def trail_waypoints(seed: int, length: float) -> np.ndarray:
    """The first `length` metres of the seed's trail (its centre line)."""
    from ..app.drive.world import layout_of
    from ..core import detmath as dm
    from ..core.motion.trajectory import step_lengths

    path = layout_of(seed).trail.path
    along = np.concatenate([[0.0], np.cumsum(step_lengths(path))])
    if along[-1] < length:
        raise ValueError(f"the trail of seed {seed} is {along[-1]:.1f} m, shorter than {length:g} m")
    end = np.column_stack([dm.interp(length, along, path[:, 0]), dm.interp(length, along, path[:, 1])])
    return np.concatenate([path[along < length], end])


def run_case(seed: int, head: str, wind: float, bag: str, folder: Path) -> dict:
    from ..app.drive import DriveRequest, run_drive
    from ..core.sensors import SensorConfig

    csv = folder / "trail.csv"
    csv.write_text("".join(f"{x!r},{y!r}\n" for x, y in trail_waypoints(seed, DRIVE_SECONDS * SPEED)))
    out = folder / f"drive-{head}-{wind:g}-{bag}"
    request = DriveRequest(
        out=str(out),
        seed=seed,
        waypoints=str(csv),
        speed=SPEED,
        head=head,
        sensor=SensorConfig(rh_deg=1.0),
        bag=bag,
        wind=wind,
    )
    t0 = time.perf_counter()
    report = run_drive(request, say=lambda text: None)
    seconds = time.perf_counter() - t0
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    return {
        "case": f"{head}, wind {wind:g}, bags {bag}",
        "wind": wind,
        "seconds": seconds,
        "stages": report.seconds,
        "scans_2d": report.scans_2d,
        "scans_3d": report.scans_3d,
        "points": sum(report.points),
        "files": len(report.files),
        "bytes": size,
    }


def bench_drive(
    seed: int = 0, cases=(("stepped", 0.0, "both"), ("continuous", 0.0, "both"), ("stepped", 3.0, "both"))
) -> list[dict]:
    """Run each case (head, wind degrees, bags) in a fresh temporary folder and print a table."""
    folder = Path(tempfile.mkdtemp(prefix="wildscan-bench-drive-"))
    rows = []
    try:
        for head, wind, bag in cases:
            rows.append(run_case(seed, head, wind, bag, folder))
            shutil.rmtree(folder / f"drive-{head}-{wind:g}-{bag}", ignore_errors=True)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print_rows(seed, rows)
    return rows


def target_seconds(row: dict) -> float:
    """The target of a row: with wind or without."""
    return WIND_TARGET_SECONDS if row["wind"] else TARGET_SECONDS


def print_rows(seed: int, rows: list[dict]) -> None:
    print(
        f"wildscan drive: {DRIVE_SECONDS:g} s at {SPEED:g} m/s along the trail of seed {seed}, r_h = 1 deg, "
        f"both bags (targets: at most {TARGET_SECONDS:g} s without wind, {WIND_TARGET_SECONDS:g} s with wind)"
    )
    stages = ("world", "crop", "placement", "sweep", "write")
    head = f"  {'case':<32} {'2D':>6} {'3D':>3} {'points':>10} {'MB':>6} " + " ".join(
        f"{s:>9}" for s in stages
    )
    print(head + f" {'total s':>8} {'target':>7}")
    for r in rows:
        times = " ".join(f"{r['stages'].get(s, 0.0):9.2f}" for s in stages)
        target = target_seconds(r)
        ok = f"<= {target:g} {'met' if r['seconds'] <= target else 'MISSED'}"
        print(
            f"  {r['case']:<32} {r['scans_2d']:>6,} {r['scans_3d']:>3} {r['points']:>10,} "
            f"{r['bytes'] / 1e6:>6.0f} {times} {r['seconds']:8.2f} {ok}"
        )
