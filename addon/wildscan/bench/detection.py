"""Suite "detection" (`wildscan bench --suite detection`): the realistic model's detection by
received power (core/realism/lost_returns.py) against each device's datasheet (its [detection] table,
core/sensors/detection.py).

1. Flat targets. For every preset, a flat wall at normal incidence of reflectance 10 % and
   80 % (an object's own `wildscan_reflectance`) is scanned by TARGET_BEAMS beams of the
   device's own footprint through the realistic model (core/realism/realistic.py echo_points, the
   detection step in), at ranges from 0.8 to 1.2 times the limit's, RANGE_STEP apart. The
   farthest detected range is the farthest at which at least half the beams return a point
   (the limit is where speckle makes detection a coin toss); the last range any beam returns
   is printed beside it. Goal: the farthest detected range within TOLERANCE of the
   datasheet's (or of what the table's threshold gives where the datasheet states no figure
   for that reflectance), and none farther.
2. Lost returns of a realistic scan of the default world from its first valid pose, per
   preset: the share of echoes lost by class, range and incidence.
3. The time of that scan with and without the detection step, side by side: RUNS pairs, the two
   scans of a pair back to back, so a change in the machine's load falls on both; the medians,
   and the median of the pairs' ratios. Goal: that ratio at most TARGET_TIME_RATIO.
"""

from __future__ import annotations

import statistics
from dataclasses import replace

import numpy as np

from .report import text_table

TARGET_BEAMS = 64  # beams a target and range
QUICK_TARGET_BEAMS = 16
RANGE_STEP = 0.005  # of the limit's range between target placements
RANGE_SPAN = (0.8, 1.2)
TOLERANCE = 0.05
TARGET_TIME_RATIO = 1.1
RUNS = 7
QUICK_RUNS = 1
TARGET_CLASS = 4  # a table: a flat surface of a class with a Table I reflectivity (its energy is divided out)
TARGET_INSTANCE = 1
BEAM_SPREAD_DEG = 2.0  # the target's beams fan this much about the wall's normal (cos >= 0.9994)


def wall_backend(distance: float):
    """Embree over one wall 0.1 m thick, its face at x = distance, 60 m square: every beam near +X
    meets it whole, at normal incidence."""
    from ..core.world.shapes.primitives import box
    from ..raycast.embree_backend import EmbreeBackend
    from ..raycast.geometry import SceneGeometry, local_origin

    v, f = box(center=(distance + 0.05, 0.0, 0.0), size=(0.1, 60.0, 60.0))
    g = SceneGeometry(
        np.asarray(v, dtype=np.float64),
        np.asarray(f),
        np.full(len(f), TARGET_CLASS),
        np.full(len(f), TARGET_INSTANCE),
        np.zeros(len(f)),
        ("wall",),
    )
    g.offset = local_origin(g.vertices, g.faces)
    return EmbreeBackend(g)


def target_beams(count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(directions, e_u, e_v) of `count` beams fanned BEAM_SPREAD_DEG about +X."""
    a = np.radians(np.linspace(-BEAM_SPREAD_DEG / 2, BEAM_SPREAD_DEG / 2, count))
    dirs = np.stack([np.cos(a), np.sin(a), np.zeros(count)], axis=1)
    e_u = np.stack([-np.sin(a), np.cos(a), np.zeros(count)], axis=1)
    e_v = np.tile([0.0, 0.0, 1.0], (count, 1))
    return dirs, e_u, e_v


def target_sensor(device):
    from ..core.sensors import SensorConfig

    return SensorConfig.for_device(device, model="realistic", max_range=device.ranges.max_dark_m).validate()


def returned_share(device, reflectance: float, distance: float, beams: int) -> float:
    """The share of `beams` beams at normal incidence on a wall of `reflectance` at `distance`
    that return a point through the realistic model with its detection step."""
    from ..core.realism.footprint import subrays_around
    from ..core.realism.lost_returns import Detecting
    from ..core.realism.realistic import echo_points

    sensor = target_sensor(device)
    backend = wall_backend(distance)
    dirs, e_u, e_v = target_beams(beams)
    sub = subrays_around(dirs, e_u, e_v, sensor.divergence_mrad)
    detecting = Detecting(
        device.detection, seed=0, noise_seed=0, reflectances=((TARGET_CLASS, TARGET_INSTANCE, reflectance),)
    )

    def cast(o, d, r, normals):
        return backend.cast(o, d, r, normals=normals)

    cast_range = sensor.max_range * 1.5
    pts = echo_points(cast, np.zeros(3), sub, sensor, cast_range, detecting=detecting)
    return pts.beams_returning / beams


def target_row(name: str, reflectance: float, beams: int, fractions) -> dict:
    """The farthest ranges a flat target of `reflectance` is detected at, beside the limit's."""
    from ..core.sensors import device_named

    device = device_named(name)
    table = device.detection
    limit = table.farthest_range(reflectance)
    stated = reflectance in table.reflectance and not table.estimate[table.reflectance.index(reflectance)]
    shares = [(f * limit, returned_share(device, reflectance, f * limit, beams)) for f in fractions]
    half = [r for r, s in shares if s >= 0.5]
    anything = [r for r, s in shares if s > 0]
    farthest = max(half) if half else 0.0
    return {
        "device": name,
        "reflectance": reflectance,
        "datasheet_m": limit,
        "source": "datasheet" if stated else "estimate" if reflectance in table.reflectance else "derived",
        "farthest_m": farthest,
        "last_any_m": max(anything) if anything else 0.0,
        "within": abs(farthest / limit - 1.0) <= TOLERANCE + 1e-9,
    }


def range_fractions(quick: bool) -> list[float]:
    if quick:
        return [1.0 - TOLERANCE, 1.0 + TOLERANCE]
    lo, hi = RANGE_SPAN
    return [float(f) for f in np.arange(lo, hi + RANGE_STEP / 2, RANGE_STEP)]


def flat_targets(quick: bool) -> list[dict]:
    from ..core.sensors import preset_names
    from ..core.sensors.detection import REFERENCE_REFLECTANCES

    beams = QUICK_TARGET_BEAMS if quick else TARGET_BEAMS
    fractions = range_fractions(quick)
    return [target_row(n, rho, beams, fractions) for n in preset_names() for rho in REFERENCE_REFLECTANCES]


def print_targets(rows: list[dict], quick: bool) -> bool:
    table = [
        [
            r["device"],
            f"{100 * r['reflectance']:.0f} %",
            f"{r['datasheet_m']:.1f} ({r['source']})",
            f"{r['farthest_m']:.1f}",
            f"{100 * (r['farthest_m'] / r['datasheet_m'] - 1):+.1f} %",
            f"{r['last_any_m']:.1f}",
            "yes" if r["within"] else "NO",
        ]
        for r in rows
    ]
    headers = ["preset", "target", "datasheet m", "detected to m", "off", "any return to m", "within 5 %"]
    grid = "0.95 and 1.05 times the limit" if quick else f"{RANGE_SPAN[0]}-{RANGE_SPAN[1]} x the limit"
    print(f"flat targets at normal incidence ({grid}, detected: at least half the beams return)")
    print(text_table(headers, table))
    met = all(r["within"] for r in rows)
    verdict = "met" if met else "NOT met"
    print(f"goal: every preset's 10 % and 80 % targets seen to the datasheet's range within 5 %: {verdict}")
    return met


def world_rows(seed: int, quick: bool) -> list[dict]:
    """Per preset: a realistic scan of the default world with and without the detection step."""
    from ..core.scan import run_scan
    from ..core.sensors import SensorConfig, device_named, preset_names
    from .devices import embree_backend, world_and_pose

    geometry, pose, z_start = world_and_pose(seed, "default")
    runs = QUICK_RUNS if quick else RUNS
    rows = []
    for name in preset_names():
        sensor = SensorConfig.for_device(device_named(name), model="realistic").validate()
        without = replace(sensor, detection=False)
        backend = embree_backend(geometry, pose, sensor)
        result = run_scan(backend, pose, sensor, "leveled", z_start, world_seed=seed)  # warm: untimed
        times, times_off = [], []
        for _ in range(runs):  # interleaved, so a change in the machine's load touches both
            times_off.append(_timed_scan(backend, pose, without, z_start, seed))
            times.append(_timed_scan(backend, pose, sensor, z_start, seed))
        rows.append(
            {
                "device": name,
                "lost": result.metadata["echoes"]["lost_returns"],
                "points": len(result.cloud),
                "with_s": statistics.median(times),
                "without_s": statistics.median(times_off),
                "ratio": statistics.median(a / b for a, b in zip(times, times_off, strict=True)),
            }
        )
    return rows


def _timed_scan(backend, pose, sensor, z_start, seed: int) -> float:
    from ..core.scan import run_scan
    from .measure import timed

    return timed(run_scan, backend, pose, sensor, "leveled", z_start, world_seed=seed)[1]


def share(pair) -> str:
    weighed, lost = pair
    return f"{100 * lost / weighed:.1f} % of {weighed:,}" if weighed else "-"


def print_world(rows: list[dict], seed: int) -> bool:
    from ..core.classes import BY_ID

    print(f"\nlost returns of a realistic scan of the default world (seed {seed}, its first valid pose)")
    for r in rows:
        lost = r["lost"]
        total = share((lost["weighed"], lost["lost"]))
        print(f"{r['device']}: {total} echoes lost ({r['points']:,} points kept)")
        by_class = [
            [BY_ID[int(c)].name, share(v)]
            for c, v in sorted(lost["by_class"].items(), key=lambda x: int(x[0]))
        ]
        print(text_table(["class", "lost"], by_class))
        print(text_table(["range", "lost"], [[k, share(v)] for k, v in lost["by_range"].items()]))
        print(text_table(["incidence", "lost"], [[k, share(v)] for k, v in lost["by_incidence"].items()]))
    print("\nrealistic scan time with and without the detection step (medians of pairs run back to back)")
    table = [[r["device"], f"{r['without_s']:.3f}", f"{r['with_s']:.3f}", f"{r['ratio']:.3f}x"] for r in rows]
    print(text_table(["preset", "without s", "with s", "ratio (median of pairs)"], table))
    worst = max(r["ratio"] for r in rows)
    met = worst <= TARGET_TIME_RATIO
    verdict = "met" if met else "NOT met"
    print(f"goal: at most {TARGET_TIME_RATIO:g}x the time without the step: {verdict} (worst {worst:.3f}x)")
    return met


def bench_detection(seed: int, quick: bool) -> bool:
    import os

    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    targets = print_targets(flat_targets(quick), quick)
    print_world(world_rows(seed, quick), seed)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    # the accuracy rule decides the exit code; the time goal depends on the machine's load
    # (printed beside it), as the other suites' speed goals
    return targets
