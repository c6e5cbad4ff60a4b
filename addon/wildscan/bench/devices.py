"""Suite "devices" (`wildscan bench --suite devices`): for every device preset
(core/sensors `preset_names()`), a full-frame scan of the default world from its first valid
pose, timed whole (core/scan.py run_scan: placement, beam directions, casting, ranges and
labels, leveling, the cloud) beside Embree's own time for the very same rays (embreex's
`scene.run` as the backend calls it, with the rays' float32 conversion, and nothing of the
float64 refinement, settling or labels around it), and their ratio: what WildScan adds to
the caster. The goal: at most TARGET_RATIO. The scan is timed as a user's runs, its large
casts split over the cores (core/runtime/threads.py), and again on one thread, as a dataset
worker's runs; Embree's own cast is one thread's. Between them, the backend's whole
cast of the same rays (`backend.cast`: Embree, then every ambiguous hit settled and every
distance refined in float64) says how much of the rest is the caster's exactness and how
much the scan's own work.
"""

from __future__ import annotations

import statistics
import sys

from .measure import timed
from .report import text_table

RUNS = 5  # timings per device, the median is reported
QUICK_RUNS = 1
TARGET_RATIO = 1.5
FRAME = "leveled"


def world_and_pose(seed: int, detail: str):
    """The default world's scan geometry (planned without Blender) and its first valid pose."""
    from ..app.poses import plan_backend, valid_poses
    from ..core.placement import Pose
    from ..core.world import plan_world
    from ..raycast.from_plan import plan_geometry

    plan = plan_world(seed, detail)
    found = next(v[0] for v in valid_poses(plan, plan_backend(plan), 1).values() if v)
    return plan_geometry(plan), Pose(found["x"], found["y"], found["yaw"]), found.get("z_start")


def embree_backend(geometry, pose, sensor):
    """Embree over the triangles a scan with `sensor` from `pose` can reach."""
    from ..app.scan import make_scene_backend

    return make_scene_backend("embree", pose, sensor, notify=lambda _t: None, geometry=geometry)


def embree_cast(backend, origin, dirs, max_range):
    """Embree's own first hits of the rays (float32, as embreex takes them): the caster alone."""
    from ..raycast.refine import prepare_rays

    local, directions = prepare_rays(origin, dirs, backend.geometry.offset)
    return lambda: backend._first_hits(local, directions, max_range)


def device_row(name: str, geometry, pose, z_start, runs: int) -> dict:
    from ..core.runtime.threads import backend_threads
    from ..core.scan import NOISE_MARGIN_SIGMAS, run_scan
    from ..core.sensors import SensorConfig, device_named, rotated_beam_directions

    device = device_named(name)
    sensor = SensorConfig.for_device(device).validate()
    backend = embree_backend(geometry, pose, sensor)
    run_scan(backend, pose, sensor, FRAME, z_start)  # the first builds the settling's index: untimed
    scans = [timed(run_scan, backend, pose, sensor, FRAME, z_start) for _ in range(runs)]
    threads, backend.threads = backend_threads(backend), 1
    one_thread = [timed(run_scan, backend, pose, sensor, FRAME, z_start)[1] for _ in range(runs)]
    result = scans[0][0]
    placement = result.placement
    dirs = rotated_beam_directions(placement.rotation, sensor.rh_deg, device)
    cast_range = sensor.max_range + NOISE_MARGIN_SIGMAS * sensor.max_noise_sigma
    cast = embree_cast(backend, placement.optical_centre, dirs, cast_range)
    casts = [timed(cast)[1] for _ in range(runs)]
    whole = [timed(backend.cast, placement.optical_centre, dirs, cast_range)[1] for _ in range(runs)]
    scan_s, cast_s = statistics.median(t for _, t in scans), statistics.median(casts)
    return {
        "device": name,
        "model": device.name,
        "beams": sensor.beam_count,
        "points": len(result.cloud),
        "scan_s": scan_s,
        "threads": threads,
        "one_thread_s": statistics.median(one_thread),
        "backend_s": statistics.median(whole),
        "cast_s": cast_s,
        "ratio": scan_s / cast_s,
        # like for like, both on one thread: what the scan adds to the caster's own work
        "one_thread_ratio": statistics.median(one_thread) / cast_s,
    }


def bench_devices(seed: int = 0, quick: bool = False, stream=None) -> list[dict]:
    from ..core.sensors import preset_names

    out = stream or sys.stdout
    detail, runs = ("low", QUICK_RUNS) if quick else ("default", RUNS)
    geometry, pose, z_start = world_and_pose(seed, detail)
    rows = [device_row(name, geometry, pose, z_start, runs) for name in preset_names()]
    print(
        f"Full-frame scan (run_scan, {FRAME} frame, the device's defaults) beside Embree's own cast of the "
        f"same rays;\nworld of seed {seed} at {detail} detail, pose ({pose.x:.2f}, {pose.y:.2f}, "
        f"{pose.yaw_deg:.1f}), median of {runs} run(s)",
        file=out,
    )
    table = [
        [
            r["device"],
            r["model"],
            f"{r['beams']:,}",
            f"{r['points']:,}",
            f"{1000 * r['scan_s']:.1f}",
            f"{1000 * r['one_thread_s']:.1f}",
            f"{1000 * r['backend_s']:.1f}",
            f"{1000 * r['cast_s']:.1f}",
            f"{r['ratio']:.2f}x",
            "met" if r["ratio"] <= TARGET_RATIO else "NOT met",
            f"{r['one_thread_ratio']:.2f}x",
        ]
        for r in rows
    ]
    headers = ["device", "model", "beams", "points", "scan ms", "1 thread", "backend ms", "Embree ms"]
    headers += ["ratio", f"<= {TARGET_RATIO:g}x", "1 thread / Embree"]
    right = [False, False, True, True, True, True, True, True, True, False, True]
    print(text_table(headers, table, right=right), file=out)
    print(
        f"scan: run_scan whole, its casts over {rows[0]['threads'] if rows else 1} thread(s) (the cores "
        "here); 1 thread: the same scan on one (as a dataset worker scans); backend: its backend.cast of "
        "the scan's rays on one thread (Embree, then float64 settling and refinement); Embree: embreex's "
        "scene.run alone, one thread; ratio: scan / Embree (the goal's); 1 thread / Embree: both on one "
        "thread, like for like",
        file=out,
    )
    return rows
