"""Ray backend benchmarks (to be wired as `wildscan bench`; runs on the bpy wheel).

What is measured, per scene and pose, side by side for each backend:
  - extraction time (scene -> numpy triangles), apart from everything else;
  - build time (Embree scene / BVHTree from the triangles);
  - the time of one full scan's ray casting at r_h (median of `runs`);
  - per-ray agreement with the reference backend (scene.ray_cast): same class and
    instance, and ranges within 1e-4 m; every disagreement is judged against the
    exact float64 brute force (geometry.check_hits) to say whose answer is wrong.
scene.ray_cast is slow (30-700 us a ray here), so by default it casts an evenly
spread subset of each scan's rays and its full-scan time is extrapolated from that
(the table marks it '~'); agreement is computed on the same subset. Timings run with
the garbage collector paused, as timeit does.

    python -c "from wildscan.bench import run_bench; run_bench(csv_path='bench.csv')"

`run_bench()` builds synthetic scenes with many objects (terrain plus N rocks and
trees, each its own mesh, as a generated world has) in a scene of its own, to show
which backends' scan time stays flat as the number of objects grows, then removes them.
"""
from __future__ import annotations

import csv
import gc
import math
import statistics
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

RANGE_TOLERANCE = 1e-4  # metres
DEFAULT_POSES = ((0.0, 0.0, 0.0), (8.0, -6.0, 30.0), (-12.0, 10.0, 90.0))
CSV_FIELDS = (
    "scene", "objects", "triangles", "pose", "backend", "extract_s", "build_s", "scan_s", "us_per_ray",
    "rays_timed", "estimated", "speedup_vs_reference", "label_agreement", "range_agreement", "max_range_diff_m",
    "disagreements", "reference_wrong", "backend_wrong",
)


# -- timing helpers ---------------------------------------------------------------------------


def timed(fn: Callable, *args, **kwargs):
    """(result, seconds) of one call, with the garbage collector kept out (as timeit does)."""
    gc.collect()
    gc.disable()
    try:
        start = time.perf_counter()
        result = fn(*args, **kwargs)
        return result, time.perf_counter() - start
    finally:
        gc.enable()


def median_time(fn: Callable, runs: int, *args) -> tuple[object, float]:
    """(last result, median seconds) over `runs` calls of fn(*args)."""
    times, result = [], None
    for _ in range(max(1, runs)):
        result, seconds = timed(fn, *args)
        times.append(seconds)
    return result, statistics.median(times)


def spread_subset(count: int, size: int | None) -> np.ndarray:
    """Indices of `size` rays spread evenly over `count` (all of them when size is None)."""
    if size is None or size >= count:
        return np.arange(count)
    return np.unique(np.linspace(0, count - 1, size).round().astype(np.int64))


def agreement(hits, reference) -> dict:
    """Per-ray agreement of two RayHits over the same rays."""
    same = (hits.class_id == reference.class_id) & (hits.instance == reference.instance)
    both = same & hits.hit & reference.hit
    diff = np.abs(hits.distance[both] - reference.distance[both])
    within = same.copy()
    within[both] = diff <= RANGE_TOLERANCE
    return {
        "label_agreement": float(same.mean()) if len(same) else 1.0,
        "range_agreement": float(within.mean()) if len(same) else 1.0,
        "max_range_diff_m": float(diff.max()) if len(diff) else 0.0,
    }


# -- the benchmark ----------------------------------------------------------------------------


def scan_rays(backend, pose, rh_deg: float):
    """(optical centre (3,), world beam directions (N,3)) of a scan from `pose`, placed by
    the lead's placement code (the same origin for every backend)."""
    from .core.placement import Pose, place
    from .core.sensor import beam_directions

    if not isinstance(pose, Pose):
        pose = Pose(*pose)
    placement = place(backend, pose)
    dirs, _, _ = beam_directions(rh_deg)
    return placement.optical_centre, dirs @ placement.rotation.T


def bench_backends(
    poses: Sequence = DEFAULT_POSES,
    backends: Sequence[str] = ("blender", "bvh", "embree"),
    *,
    rh_deg: float = 1.0,
    max_range: float = 15.0,
    runs: int = 3,
    reference: str = "blender",
    reference_rays: int | None = 20_000,
    reference_runs: int = 1,
    depsgraph=None,
    scene=None,
    scene_label: str = "scene",
    objects: int | None = None,
    csv_path: str | Path | None = None,
    out: Callable[[str], None] | None = print,
) -> list[dict]:
    """Benchmark `backends` on the scene behind `depsgraph` (default: the active one) for
    each pose (x, y, yaw_deg). Returns one row per (pose, backend); prints a table and
    writes CSV when asked."""
    from .raycast.extract import extract_scene
    from .raycast.geometry import scan_radius
    from .raycast.select import make_backend

    depsgraph = _depsgraph(depsgraph, scene)
    whole, extract_s = timed(extract_scene, depsgraph)
    placer = make_backend("auto", geometry=whole, notify=None)
    rows = []
    for pose in poses:
        origin, dirs = scan_rays(placer, pose, rh_deg)
        geometry, crop_s = timed(extract_scene, depsgraph, center=origin, radius=scan_radius(max_range))
        results = {}
        for name in backends:
            subset = spread_subset(len(dirs), reference_rays if name == reference else None)
            backend, build_s = timed(_build, name, geometry, depsgraph, scene)
            n_runs = reference_runs if name == reference else runs
            rays = np.ascontiguousarray(dirs[subset])
            hits, scan_s = median_time(backend.cast, n_runs, origin, rays, max_range)
            results[name] = (subset, hits)
            rows.append({
                "scene": scene_label,
                "objects": objects if objects is not None else len(whole.object_names),
                "triangles": geometry.triangle_count,
                "pose": " ".join(f"{v:g}" for v in pose),
                "backend": name,
                "extract_s": 0.0 if name == "blender" else crop_s,
                "build_s": build_s,
                "scan_s": scan_s * len(dirs) / len(subset),
                "us_per_ray": 1e6 * scan_s / len(subset),
                "rays_timed": len(subset),
                "estimated": len(subset) < len(dirs),
            })
        _add_agreement(rows[-len(backends):], results, reference, geometry, origin, dirs, max_range)
    for row in rows:
        row["whole_scene_extract_s"] = extract_s
    if out is not None:
        out(format_table(rows, rh_deg, extract_s))
    if csv_path is not None:
        write_csv(rows, csv_path)
    return rows


def _depsgraph(depsgraph, scene):
    import bpy

    if depsgraph is not None:
        return depsgraph
    if scene is None or scene == bpy.context.scene:
        return bpy.context.evaluated_depsgraph_get()
    # A scene outside any window has no depsgraph until one is asked for in its context.
    with bpy.context.temp_override(scene=scene, view_layer=scene.view_layers[0]):
        return bpy.context.evaluated_depsgraph_get()


def _build(name: str, geometry, depsgraph, scene):
    if name == "blender":
        from .raycast.blender_backend import BlenderRayCastBackend

        return BlenderRayCastBackend(scene=scene, depsgraph=depsgraph)
    from .raycast.select import make_backend

    return make_backend(name, geometry=geometry, notify=None)


def _add_agreement(rows: list[dict], results: dict, reference: str, geometry, origin, dirs, max_range) -> None:
    """Fill agreement and speed-up columns, comparing on the rays the reference cast. Where
    a backend and the reference disagree, both answers are judged against the exact
    float64 brute force (geometry.check_hits) to tell whose error it is."""
    from .raycast.geometry import check_hits

    ref_row = next((r for r in rows if r["backend"] == reference), None)
    for row in rows:
        if ref_row is None:
            row.update(label_agreement=math.nan, range_agreement=math.nan, max_range_diff_m=math.nan,
                       speedup_vs_reference=math.nan)
            continue
        ref_subset, ref_hits = results[reference]
        subset, hits = results[row["backend"]]
        mine = _take(hits, np.searchsorted(subset, ref_subset))
        row.update(agreement(mine, ref_hits))
        row["speedup_vs_reference"] = ref_row["scan_s"] / row["scan_s"] if row["scan_s"] > 0 else math.inf
        differ = np.flatnonzero(_disagree(mine, ref_hits))
        row["disagreements"] = len(differ)
        rays = dirs[ref_subset[differ]]
        for key, answer in (("reference_wrong", ref_hits), ("backend_wrong", mine)):
            ok = check_hits(geometry, origin, rays, max_range, _take(answer, differ), range_tol=RANGE_TOLERANCE)
            row[key] = int(np.count_nonzero(~ok))


def _disagree(hits, reference) -> np.ndarray:
    same = (hits.class_id == reference.class_id) & (hits.instance == reference.instance)
    with np.errstate(invalid="ignore"):
        far = np.abs(hits.distance - reference.distance) > RANGE_TOLERANCE
    return ~same | (same & hits.hit & far)


def _take(hits, index: np.ndarray):
    from .raycast.base import RayHits

    return RayHits(hits.distance[index], hits.class_id[index], hits.instance[index], hits.untagged_objects)


def format_table(rows: list[dict], rh_deg: float, extract_s: float | None = None) -> str:
    head = (f"{'scene':<14}{'objects':>8}{'tris':>9}  {'pose':<12}{'backend':<9}{'us/ray':>9}"
            f"{'scan s':>9}{'build s':>9}{'x ref':>9}{'labels':>10}{'ranges':>10}{'max dr m':>10}"
            f"{'diff':>6}{'refX':>6}{'ownX':>6}")
    lines = [f"full scan at r_h = {rh_deg:g} deg; scan s = ray casting only (median); "
             "'~' = extrapolated from a subset of rays; diff = rays disagreeing with the reference, "
             "refX / ownX = of those, where the reference / this backend is wrong by exact float64 brute force",
             head, "-" * len(head)]
    for r in rows:
        approx = "~" if r["estimated"] else " "
        lines.append(
            f"{r['scene']:<14}{r['objects']:>8}{r['triangles']:>9}  {r['pose']:<12}{r['backend']:<9}"
            f"{r['us_per_ray']:>9.3f}{approx}{r['scan_s']:>8.3f}{r['build_s']:>9.3f}"
            f"{r['speedup_vs_reference']:>9.1f}{100 * r['label_agreement']:>9.3f}%"
            f"{100 * r['range_agreement']:>9.3f}%{r['max_range_diff_m']:>10.1e}"
            f"{r.get('disagreements', 0):>6}{r.get('reference_wrong', 0):>6}{r.get('backend_wrong', 0):>6}"
        )
    if extract_s is not None:
        lines.append(f"extraction of the whole scene: {extract_s:.3f} s; "
                     "per-pose cropped extraction is in the CSV (extract_s)")
    return "\n".join(lines)


def write_csv(rows: list[dict], path: str | Path) -> Path:
    path = Path(path)
    fields = list(CSV_FIELDS) + sorted({k for r in rows for k in r} - set(CSV_FIELDS))
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: row.get(k, "") for k in fields})
    return path


def bench_scan_to_ply(backend, pose=(0.0, 0.0, 0.0), rh_deg: float = 0.25, runs: int = 3,
                      out_dir: str | Path | None = None) -> dict:
    """Median seconds for placement + full scan + PLY/JSON written, with a ready backend
    (extraction and build excluded), using the lead's run_scan and writer."""
    from .core.placement import Pose
    from .core.ply import write_scan_files
    from .core.scan import run_scan
    from .core.sensor import SensorConfig

    sensor = SensorConfig(rh_deg=rh_deg)
    with tempfile.TemporaryDirectory() as tmp:
        target = Path(out_dir or tmp) / "bench_scan.ply"

        def once():
            result = run_scan(backend, Pose(*pose), sensor)
            write_scan_files(target, result.cloud, result.metadata)
            return result

        result, seconds = median_time(once, runs)
    return {"backend": backend.name, "rh_deg": rh_deg, "beams": result.beams, "points": len(result.cloud),
            "seconds": seconds}


# -- synthetic scenes -------------------------------------------------------------------------


def build_many_objects_scene(n_objects: int, seed: int = 0, half_size: float = 50.0, scene=None,
                             collection_name: str = "WildScanBench"):
    """Terrain plus `n_objects` rocks and trees (each its own tagged mesh object) in a
    generated collection of `scene` (default: the active scene). Returns the collection."""
    import bpy

    from .core.rng import stage_rng
    from .core.testworld_plan import cone, cylinder, grid_heightfield, merge, uv_sphere
    from .world.mesh import mesh_object, wildscan_collection

    scene = scene or bpy.context.scene
    coll = wildscan_collection(collection_name, parent=scene.collection)
    rng = stage_rng(seed, "bench scene")
    xs = ys = np.arange(-half_size, half_size + 0.5, 1.0)
    heights = 0.3 * np.sin(xs[None, :] / 7.0) * np.cos(ys[:, None] / 9.0)
    terrain = grid_heightfield(xs, ys, heights)
    mesh_object("bench terrain", *terrain, coll, "terrain", 1)
    xy = rng.uniform(-half_size + 2, half_size - 2, size=(4 * n_objects, 2))
    # keep the poses' surroundings free so every placement succeeds
    poses = np.array([p[:2] for p in DEFAULT_POSES])
    far = np.min(np.linalg.norm(xy[:, None, :] - poses[None], axis=2), axis=1) > 3.0
    xy = xy[far][:n_objects]
    for i, (x, y) in enumerate(xy.tolist()):
        z = 0.3 * math.sin(x / 7.0) * math.cos(y / 9.0)
        if i % 2:
            r = float(rng.uniform(0.2, 0.6))
            mesh_object(f"bench rock {i}", *uv_sphere(r, 8, 12, center=(x, y, z + 0.5 * r)), coll, "rock", i + 2)
        else:
            h = float(rng.uniform(2.0, 4.0))
            trunk = cylinder(0.15, h, 12, base=(x, y, z))
            mesh_object(f"bench trunk {i}", *trunk, coll, "trunk", i + 2)
            top = merge([cone(1.0, 2.0, 12, base=(x, y, z + h))])
            mesh_object(f"bench top {i}", *top, coll, "treetop", i + 2)
    return coll


def run_bench(object_counts: Sequence[int] = (200, 3000), poses: Sequence = DEFAULT_POSES, *, seed: int = 0,
              rh_deg: float = 1.0, runs: int = 3, reference_rays: int | None = 20_000,
              csv_path: str | Path | None = None, ply_rh_deg: float | None = 0.25,
              out: Callable[[str], None] | None = print) -> list[dict]:
    """Benchmark every available backend on synthetic scenes with each object count, in
    a scene of its own (the user's scenes are not touched; the bench scene is removed)."""
    import bpy

    from .raycast.select import available_backends, make_backend

    names = [n for n in ("blender", "bvh", "embree") if n in available_backends()]
    rows = []
    for count in object_counts:
        scene = bpy.data.scenes.new(f"WildScanBench {count}")
        try:
            build_many_objects_scene(count, seed=seed, scene=scene)
            depsgraph = _depsgraph(None, scene)
            rows += bench_backends(poses, names, rh_deg=rh_deg, runs=runs, reference_rays=reference_rays,
                                   depsgraph=depsgraph, scene=scene, scene_label=f"{count} objects",
                                   objects=count, out=out)
            if ply_rh_deg and out is not None:
                from .raycast.extract import extract_scene

                fast = make_backend("auto", geometry=extract_scene(depsgraph), notify=out)
                timing = bench_scan_to_ply(fast, poses[0], rh_deg=ply_rh_deg, runs=runs)
                out(f"{count} objects: placement + r_h={ply_rh_deg:g} scan ({timing['beams']} beams, "
                    f"{timing['points']} points) + PLY written with '{timing['backend']}': "
                    f"{timing['seconds']:.3f} s (median of {runs})")
        finally:
            _remove_bench_scene(scene)
    if csv_path is not None:
        write_csv(rows, csv_path)
    return rows


def _remove_bench_scene(scene) -> None:
    import bpy

    from .world.mesh import remove_generated

    remove_generated("WildScanBench")
    bpy.data.scenes.remove(scene)
