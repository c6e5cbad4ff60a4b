"""Suite "lod" (`wildscan bench --suite lod`): levels of detail against full detail on the
endless world.

Per device preset, at poses spread over the endless world kilometres from the origin, a
scan with levels of detail (the default, `--lod on`) and one with every tile at full detail
(`--lod off`) of the same pose, both cold: a fresh tile memory and no world cache, so each
builds every tile it reaches, as a scan at a place never visited does. The scan's time
includes its tiles' building (app/scan.py endless_scan_geometry, then scan_current_scene, as
`wildscan scan --seed` runs); both start from the same process state: what a process draws
once for all its tiles (the landscape's anchor cells round the pose, the shared meshes) is
drawn before either is timed (prime); each is run COLD_RUNS times, interleaved, its best
kept (the machine is shared: a load spike in one run says nothing of either mode).
Agreement is per beam, noise off, so only the geometry differs: labels, the share of beams
(returned by either scan) given the same class; ranges, the share whose ranges differ by at
most the device's range noise sigma (a beam returned by one scan only counts as a
disagreement in both).

Then the goals of the issue that are not per device: a cold Hokuyo (r_h = 1 deg) scan at a
fresh pose with its tile builds; a warm one (its tiles in memory) beside today's scan of the
150 m paper-layout world (its triangles built beforehand, as a warm world is); and the peak
memory of a process that scans POSES_FOR_MEMORY poses spread over 2 km (a child process,
its own peak resident set).
"""

from __future__ import annotations

import statistics
import sys
import time

import numpy as np

from .report import text_table

LABEL_TARGET = 0.995  # labels agreeing, LOD against full detail
RANGE_TARGET = 0.99  # ranges within the device's noise sigma
SPEEDUP_TARGET = 2.0  # cold LOD scan against cold full detail, devices reaching FAR_DEVICE_M or more
FAR_DEVICE_M = 100.0
# m: devices reaching farther are compared to this range (their --lod off scan would build
# every tile past app/scan.py FULL_DETAIL_REACH_M at full detail, tens of GB: it is refused)
COMPARE_RANGE_M = 120.0
COLD_TARGET_S = 1.5  # one cold Hokuyo r_h = 1 deg scan at a fresh pose, tile builds included
WARM_TARGET = 1.3  # warm against today's scan of the 150 m world
MEMORY_TARGET_GB = 1.5
SPREAD_M = 2000.0  # poses spread over a square of this side around the origin
POSES, QUICK_POSES = 3, 1
# cold runs of each scan a pose, LOD and --lod off interleaved, the best of each kept: on a
# shared machine a load spike in one run says nothing of either mode
COLD_RUNS, QUICK_COLD_RUNS = 2, 1
POSES_FOR_MEMORY, QUICK_POSES_FOR_MEMORY = 100, 10
POSE_SEARCH_M = 40.0  # side of the small region a pose is looked for in around each spread point
BIOME = None  # the default biome (core/world.DEFAULT_BIOME)


def spread_points(seed: int, count: int) -> np.ndarray:
    """(count, 2) points spread uniformly over the SPREAD_M square (a generator of the seed)."""
    from ..core.rng import stage_rng

    rng = stage_rng(seed, "bench.lod.points")
    return rng.uniform(-SPREAD_M / 2, SPREAD_M / 2, (count, 2))


def find_poses(seed: int, count: int, world) -> list:
    """`count` valid poses, one near each of the first spread points that has one."""
    from ..app.poses import endless_poses
    from ..app.tile_memory import TileMemory
    from ..core.placement import Pose
    from ..core.world.region import region_around

    found = []
    for x, y in spread_points(seed, 4 * count):
        if len(found) == count:
            break
        region = region_around(float(x), float(y), POSE_SEARCH_M)
        poses = endless_poses(world, region, 1, memory=TileMemory())
        if poses:
            found.append(Pose(poses[0]["x"], poses[0]["y"], poses[0]["yaw"]))
    return found


def cold_scan(world, pose, sensor, lod: bool, memory=None):
    """(ScanResult, seconds, tile counts): the tiles built (a fresh memory unless given, no
    world cache) and the scan, timed together."""
    from ..app.scan import endless_scan_geometry, scan_current_scene
    from ..app.tile_memory import TileMemory

    memory = TileMemory() if memory is None else memory
    t0 = time.perf_counter()
    geometry, counts = endless_scan_geometry(
        world.seed, pose, sensor, lod, world.biome, world.vegetation, world.detail, None, memory
    )
    result = scan_current_scene(
        pose, sensor, "leveled", None, "embree", notify=lambda _t: None, geometry=geometry
    )
    return result, time.perf_counter() - t0, counts


def prime(world, pose, sensor) -> None:
    """What a process draws once for every tile it will build, never a tile: the landscape's
    fields, the anchor cells round the pose (lakes, caves, clearings, the trails laid on
    gentle land) and the shared meshes. Drawn before the timing, so neither of two scans of
    one pose (LOD, then --lod off) pays for the other's start."""
    from ..app.scan import crop_radius
    from ..core.world.endless import landscape
    from ..core.world.endless.library import library

    library(world.seed, world.detail, world.vegetation)
    r = crop_radius(sensor) + 50.0  # a tile's features are read this far round it at most
    landscape(world.seed, world.biome).anchors.trails_over(pose.x - r, pose.x + r, pose.y - r, pose.y + r)


def beam_keys(cloud) -> np.ndarray:
    """One integer per point naming its beam (ring, firing within the sweep, column)."""
    key = cloud.ring.astype(np.int64) * (1 << 20) + cloud.sweep.astype(np.int64)
    column = cloud.extra.get("column")
    if column is not None:
        key = key + column.astype(np.int64) * (1 << 36)
    return key


def agreement(a, b, sigma: float) -> tuple[float, float, int]:
    """(labels agreeing, ranges within sigma, beams compared) of two scans of one pose: over
    the beams either returned; a beam only one returned disagrees in both."""
    ka, kb = beam_keys(a), beam_keys(b)
    both, ia, ib = np.intersect1d(ka, kb, assume_unique=True, return_indices=True)
    beams = len(np.union1d(ka, kb))
    if beams == 0:
        return 1.0, 1.0, 0
    same_label = int(np.count_nonzero(a.label[ia] == b.label[ib]))
    near = int(np.count_nonzero(np.abs(a.range[ia].astype(np.float64) - b.range[ib]) <= sigma))
    return same_label / beams, near / beams, beams


def device_row(name: str, world, poses, runs: int = COLD_RUNS) -> dict:
    from ..core.sensors import SensorConfig, device_named

    device = device_named(name)
    sigma = SensorConfig.for_device(device).validate().max_noise_sigma
    bounded = {"max_range": COMPARE_RANGE_M} if device.ranges.max_m > COMPARE_RANGE_M else {}
    sensor = SensorConfig.for_device(device, noise_sigma=0.0, **bounded).validate()
    lod_s, off_s, labels, ranges, beams, tiles = [], [], [], [], 0, []
    for pose in poses:
        prime(world, pose, sensor)
        t_on = t_off = float("inf")
        for _ in range(runs):
            on, seconds, counts = cold_scan(world, pose, sensor, True)
            t_on = min(t_on, seconds)
            off, seconds, _ = cold_scan(world, pose, sensor, False)
            t_off = min(t_off, seconds)
        lab, rng, n = agreement(on.cloud, off.cloud, sigma)
        lod_s.append(t_on)
        off_s.append(t_off)
        labels.append(lab * n)
        ranges.append(rng * n)
        beams += n
        tiles.append(counts.built)
    lod_t, off_t = statistics.median(lod_s), statistics.median(off_s)
    row = {
        "device": name,
        "max_range": float(device.ranges.max_m),
        "compared_m": sensor.max_range,
        "sigma": sigma,
        "lod_s": lod_t,
        "off_s": off_t,
        "speedup": off_t / lod_t if lod_t > 0 else float("inf"),
        "labels": sum(labels) / beams if beams else 1.0,
        "ranges": sum(ranges) / beams if beams else 1.0,
        "tiles": statistics.median(tiles),
    }
    far = device.ranges.max_m >= FAR_DEVICE_M
    row["met"] = (
        row["labels"] >= LABEL_TARGET
        and row["ranges"] >= RANGE_TARGET
        and (not far or row["speedup"] >= SPEEDUP_TARGET)
    )
    return row


def print_devices(rows: list[dict], poses, out, runs: int = COLD_RUNS) -> None:
    where = ", ".join(f"({p.x:.0f}, {p.y:.0f})" for p in poses)
    print(
        f"LOD (levels of detail, the default) against --lod off (every tile at full detail), cold (every "
        f"tile built), the best of {runs} interleaved run(s) a pose, median over {len(poses)} pose(s): "
        f"{where}",
        file=out,
    )
    table = [
        [
            r["device"],
            f"{r['max_range']:g}" + (f" ({r['compared_m']:g})" if r["compared_m"] < r["max_range"] else ""),
            f"{1000 * r['sigma']:.0f}",
            f"{r['tiles']:.0f}",
            f"{r['lod_s']:.2f}",
            f"{r['off_s']:.2f}",
            f"{r['speedup']:.2f}x",
            f"{100 * r['labels']:.2f}",
            f"{100 * r['ranges']:.2f}",
            "met" if r["met"] else "NOT met",
        ]
        for r in rows
    ]
    headers = ["device", "range m", "sigma mm", "tiles", "LOD s", "off s", "speed-up"]
    headers += ["labels %", "ranges %", "goal"]
    print(text_table(headers, table, right=[False] + [True] * 8 + [False]), file=out)
    print(
        f"goal: labels >= {100 * LABEL_TARGET:g} %, ranges within sigma >= {100 * RANGE_TARGET:g} % (of "
        f"the beams either scan returned, noise off), and for devices reaching {FAR_DEVICE_M:g} m or more "
        f"the LOD scan >= {SPEEDUP_TARGET:g}x faster cold; tiles: built by the LOD scan; range (in "
        f"brackets): compared to {COMPARE_RANGE_M:g} m, as far as --lod off builds every tile",
        file=out,
    )


def hokuyo_lines(world, poses, seed: int, out) -> dict:
    """The cold and warm Hokuyo scans beside today's scan of the 150 m world."""
    from ..app.scan import scan_current_scene
    from ..app.tile_memory import TileMemory
    from ..bench.devices import world_and_pose
    from ..core.sensors import SensorConfig

    sensor = SensorConfig(rh_deg=1.0).validate()
    memory = TileMemory()
    cold = [cold_scan(world, p, sensor, True, memory)[1] for p in poses]  # fresh poses: every tile built
    warm = [min(cold_scan(world, p, sensor, True, memory)[1] for _ in range(3)) for p in poses]
    geometry, pose, z_start = world_and_pose(seed, "default")

    def today():
        t0 = time.perf_counter()
        scan_current_scene(
            pose, sensor, "leveled", z_start, "embree", notify=lambda _t: None, geometry=geometry
        )
        return time.perf_counter() - t0

    today()  # the first builds the settling's index
    paper = min(today() for _ in range(3))
    cold_s, warm_s = max(cold), statistics.median(warm)
    cold_met = "met" if cold_s <= COLD_TARGET_S else "NOT met"
    print(
        f"Hokuyo UTM-30LX-EW, r_h = 1 deg: cold {cold_s:.2f} s at worst over {len(poses)} fresh pose(s), "
        f"tile builds included (goal <= {COLD_TARGET_S:g} s: {cold_met}); "
        f"warm {warm_s:.3f} s, {warm_s / paper:.2f}x today's scan of the 150 m world ({paper:.3f} s, paper "
        f"layout, seed {seed}, its first valid pose; goal <= {WARM_TARGET:g}x: "
        f"{'met' if warm_s <= WARM_TARGET * paper else 'NOT met'})",
        file=out,
    )
    return {"cold_s": cold_s, "warm_s": warm_s, "paper_s": paper}


def memory_line(seed: int, count: int, out) -> float:
    """Peak memory (GB) of a child process that scans `count` poses spread over 2 km."""
    import multiprocessing

    context = multiprocessing.get_context("spawn")
    with context.Pool(1) as pool:
        peak_gb, scanned, seconds = pool.apply(scan_spread, (seed, count))
    met = "met" if peak_gb <= MEMORY_TARGET_GB else "NOT met"
    print(
        f"memory: a process that scanned {scanned} poses spread over {SPREAD_M / 1000:g} km (Hokuyo, r_h = 1 "
        f"deg, {seconds:.0f} s) peaked at {peak_gb:.2f} GB resident (goal <= {MEMORY_TARGET_GB:g} GB: {met})",
        file=out,
    )
    return peak_gb


def scan_spread(seed: int, count: int) -> tuple[float, int, float]:
    """In a child: scan `count` poses over the spread square (a rejected pose is skipped for the
    next point), tiles kept in the process's bounded memory as `wildscan` keeps them; (peak
    resident GB, poses scanned, seconds)."""
    from ..app.scan import endless_scan_geometry, scan_current_scene
    from ..app.tile_memory import process_memory
    from ..app.tiles import TiledWorld
    from ..core.errors import PoseRejected
    from ..core.placement import Pose
    from ..core.sensors import SensorConfig
    from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION

    world = TiledWorld(seed, DEFAULT_BIOME, "default", DEFAULT_VEGETATION)
    sensor = SensorConfig(rh_deg=1.0).validate()
    scanned, t0 = 0, time.perf_counter()
    for x, y in spread_points(seed + 1, 3 * count):
        if scanned == count:
            break
        pose = Pose(float(x), float(y), 0.0)
        geometry, _ = endless_scan_geometry(
            seed, pose, sensor, True, world.biome, world.vegetation, cache=None, memory=process_memory()
        )
        try:
            scan_current_scene(
                pose, sensor, "leveled", None, "embree", notify=lambda _t: None, geometry=geometry
            )
        except PoseRejected:
            continue
        scanned += 1
    return peak_resident_kb() / 1e6, scanned, time.perf_counter() - t0


def peak_resident_kb() -> int:
    """This process's own peak resident set (kB; core/runtime/peak.py says why not ru_maxrss)."""
    from ..core.runtime.peak import peak_resident_bytes

    return peak_resident_bytes() // 1024


def bench_lod(seed: int = 0, quick: bool = False, stream=None) -> dict:
    from ..app.tiles import TiledWorld
    from ..core.sensors import preset_names
    from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION

    out = stream or sys.stdout
    world = TiledWorld(seed, DEFAULT_BIOME, "default", DEFAULT_VEGETATION)
    poses = find_poses(seed, QUICK_POSES if quick else POSES, world)
    runs = QUICK_COLD_RUNS if quick else COLD_RUNS
    rows = []
    for name in preset_names():
        rows.append(device_row(name, world, poses, runs))
        r = rows[-1]
        print(  # a line as each device is done: a run stopped midway shows where it was
            f"lod: {name}: LOD {r['lod_s']:.2f} s, off {r['off_s']:.2f} s ({r['speedup']:.2f}x), labels "
            f"{100 * r['labels']:.2f} %, ranges {100 * r['ranges']:.2f} %",
            file=sys.stderr,
            flush=True,
        )
    print_devices(rows, poses, out, runs)
    fresh = find_poses(seed + 1000, QUICK_POSES if quick else POSES, world)
    hokuyo = hokuyo_lines(world, fresh, seed, out)
    horizon = horizon_line(out, 1 if quick else 5)
    peak = memory_line(seed, QUICK_POSES_FOR_MEMORY if quick else POSES_FOR_MEMORY, out)
    return {"devices": rows, "hokuyo": hokuyo, "horizon": horizon, "memory_gb": peak}


# the bar: the beams aimed just below the horizon return, far from the origin
HORIZON_BAND_DEG = (-3.0, -0.5)  # elevations of the rings counted (device file), degrees
HORIZON_TARGET = 0.80  # median share of those beams returning
HORIZON_REGION = (1000.0, 1000.0, 1300.0, 1300.0)
HORIZON_SEED = 1


def horizon_share(result, device) -> float:
    """The share of the beams aimed within HORIZON_BAND_DEG (rings by the device file's
    elevations, ring 0 the lowest) that returned a point: the range image's mask."""
    from ..core.io.rangeimage import cells_of, grid_shape, range_image

    cloud = result.cloud
    row, column = cells_of(cloud)
    n = len(cloud)
    image = range_image(
        row, column, grid_shape(result.metadata), cloud.range, np.zeros(n), cloud.label, cloud.instance
    )
    elevation = np.sort(np.asarray(device.beams.elevation_deg, dtype=np.float64))
    rings = (elevation >= HORIZON_BAND_DEG[0]) & (elevation <= HORIZON_BAND_DEG[1])
    return float(image["mask"][rings].mean())


def horizon_line(out, count: int = 5) -> float:
    """`wildscan poses --seed 1 --region 1000 1000 1300 1300 --count 5`, then an OS1-64 scan
    (leveled frame) at each: the median share of its near-horizon beams that returned."""
    from ..app.poses import endless_poses
    from ..app.scan import endless_scan_geometry, scan_current_scene
    from ..app.tile_memory import process_memory
    from ..app.tiles import TiledWorld
    from ..core.placement import Pose
    from ..core.sensors import SensorConfig, device_named
    from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION
    from ..core.world.region import Region

    world = TiledWorld(HORIZON_SEED, DEFAULT_BIOME, "default", DEFAULT_VEGETATION)
    poses = endless_poses(world, Region(*HORIZON_REGION), count, memory=process_memory())
    device = device_named("os1-64")
    sensor = SensorConfig.for_device(device).validate()
    shares = []
    for p in poses:
        pose = Pose(p["x"], p["y"], p["yaw"])
        geometry, _ = endless_scan_geometry(world.seed, pose, sensor, True, memory=process_memory())
        result = scan_current_scene(
            pose, sensor, "leveled", None, "embree", notify=lambda _t: None, geometry=geometry
        )
        shares.append(horizon_share(result, device))
    median = statistics.median(shares) if shares else 0.0
    met = "met" if len(shares) == count and median >= HORIZON_TARGET else "NOT met"
    region = " ".join(f"{v:g}" for v in HORIZON_REGION)
    each = ", ".join(f"{100 * s:.0f} %" for s in shares)
    low, high = -HORIZON_BAND_DEG[0], -HORIZON_BAND_DEG[1]
    print(
        f"near the horizon: OS1-64 at the {len(shares)} poses of `wildscan poses --seed {HORIZON_SEED} "
        f"--region {region} --count {count}`, beams aimed {high:g} to {low:g} deg below the horizon "
        f"returning: {each}, median {100 * median:.0f} % (goal >= {100 * HORIZON_TARGET:g} %: {met})",
        file=out,
    )
    return median
