"""Suite "scaling": scan time against beams (r_h 4 -> 0.25 deg), triangles (the detail
levels, measured by the default-world suite) and objects (synthetic scenes of N objects)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .config import BENCH_COLLECTION, DEFAULT_POSES, REFERENCE, SCAN_RH, BenchConfig
from .measure import (
    bench_scene,
    crop_for,
    fast_backend,
    median_scan,
    pose_text,
    reference_backend,
    subset_reference,
    timed,
)
from .report import Report, fmt_s, ratio

# =============================================================================================
# scaling: beams and objects


def bench_beams(cfg, report, base, whole, reference, pose, z_start, per_pose, tmp: Path) -> None:
    """Scan time against r_h from one pose: fast backends measured, scene.ray_cast
    extrapolated from its per-ray time at this pose (it grows as the beams do)."""
    geometry, crop_s = timed(crop_for, whole, pose)
    ref_row = next(r for r in per_pose if r["backend"] == REFERENCE)
    rows = []
    for name in cfg.fast_backends:
        backend, build_s = timed(fast_backend, name, geometry)
        for rh in cfg.beam_steps:
            run = median_scan(backend, pose, z_start, rh, tmp / f"{name}-rh.ply", cfg.runs)
            row = dict(
                base,
                section="beams",
                zone=ref_row["zone"],
                pose=pose_text(pose),
                backend=name,
                crop_triangles=geometry.triangle_count,
                crop_s=crop_s,
                build_s=build_s,
                estimated=False,
            )
            row.update(run.row())
            rows.append(row)
    for rh in cfg.beam_steps:
        beams = next(r["beams"] for r in rows if r["rh_deg"] == rh)
        fast = next(r for r in rows if r["rh_deg"] == rh)
        other = fast["scan_s"] - fast["ray_casting_s"]
        cast = ref_row["us_per_ray"] * 1e-6 * beams
        rows.append(
            dict(
                base,
                section="beams",
                zone=ref_row["zone"],
                pose=pose_text(pose),
                backend=REFERENCE,
                rh_deg=rh,
                beams=beams,
                estimated=True,
                ray_casting_s=cast,
                scan_s=cast + other,
                us_per_ray=ref_row["us_per_ray"],
                runs=1,
            )
        )
    for row in rows:
        ref = next(r for r in rows if r["backend"] == REFERENCE and r["rh_deg"] == row["rh_deg"])
        row["speedup_vs_ray_cast"] = ref["scan_s"] / row["scan_s"]
    report.add_rows(rows)
    report.beam_rows = rows


def bench_objects(cfg: "BenchConfig", report: "Report", tmp: Path) -> None:
    """Scan time against the number of objects: terrain plus N rocks and trees, each its own
    mesh object (build_many_objects_scene), one pose, full r_h = 1 deg scans."""
    from ..core.placement import Pose
    from ..raycast.blender_backend import scene_depsgraph
    from ..raycast.extract import extract_scene

    pose = Pose(*DEFAULT_POSES[0])
    rows = []
    for count in cfg.object_counts:
        with bench_scene(f"WildScanBench {count} objects") as scene:
            build_many_objects_scene(count, seed=cfg.seed, scene=scene)
            objects = len([o for o in scene.objects if o.type == "MESH"])
            whole, extract_s = timed(extract_scene, scene_depsgraph(scene))
            geometry, crop_s = timed(crop_for, whole, pose)
            base = {
                "section": "objects",
                "world": f"{count} rocks/trees",
                "seed": cfg.seed,
                "pose": pose_text(pose),
                "objects": objects,
                "triangles": whole.triangle_count,
                "crop_triangles": geometry.triangle_count,
                "extract_s": extract_s,
                "crop_s": crop_s,
            }
            runs, backends = {}, {}
            for name in cfg.fast_backends:
                backends[name], build_s = timed(fast_backend, name, geometry)
                runs[name] = (
                    median_scan(backends[name], pose, None, SCAN_RH, tmp / f"{name}-obj.ply", cfg.runs),
                    build_s,
                )
            ref = subset_reference(
                cfg, reference_backend(scene), runs[cfg.fast_backends[0]][0], geometry, runs, backends
            )
        rows.append(dict(base, backend=REFERENCE, **ref, speedup_vs_ray_cast=1.0))
        for name in cfg.fast_backends:
            run, build_s, agree, _ = runs[name]
            row = dict(base, backend=name, build_s=build_s, estimated=False, **run.row())
            row.update(agree.row(), speedup_vs_ray_cast=ref["scan_s"] / run.total)
            rows.append(row)
    report.add_rows(rows)
    report.object_rows = rows


def scaling_tables(report: "Report", cfg) -> list[tuple[str, list[str], list[list[str]]]]:
    """(title, headers, rows) of the beams, triangles and objects scaling tables."""
    tables = []
    fast = cfg.fast_backends
    if report.beam_rows:
        headers = (
            ["r_h (deg)", "beams"]
            + [f"{n} scan" for n in fast]
            + [f"{n} cast" for n in fast]
            + ["scene.ray_cast scan", f"{fast[0]} x ray_cast"]
        )
        body = []
        for rh in cfg.beam_steps:
            at = {r["backend"]: r for r in report.beam_rows if r["rh_deg"] == rh}
            body.append(
                [f"{rh:g}", f"{at[fast[0]]['beams']:,}"]
                + [fmt_s(at[n]["scan_s"]) for n in fast]
                + [fmt_s(at[n]["ray_casting_s"]) for n in fast]
                + [fmt_s(at[REFERENCE]["scan_s"], True), ratio(at[fast[0]]["speedup_vs_ray_cast"], True)]
            )
        h = report.beam_rows[0]
        tables.append(
            (
                f"Scan time against beams (default world, {h['detail']} detail, {h['zone']} pose; "
                "placement to PLY written; scene.ray_cast ~ from its per-ray time)",
                headers,
                body,
            )
        )
    if report.level_rows:
        headers = (
            ["detail", "triangles (world)", "triangles (crop)"]
            + [f"{n} scan" for n in fast]
            + [f"{n} cast" for n in fast]
            + ["scene.ray_cast us/ray"]
        )
        body = []
        for detail in cfg.details:
            at = {r["backend"]: r for r in report.level_rows if r["detail"] == detail}
            if not at:
                continue
            body.append(
                [detail, f"{at[fast[0]]['triangles']:,}", f"{at[fast[0]]['crop_triangles']:,.0f}"]
                + [fmt_s(at[n]["scan_s"]) for n in fast]
                + [fmt_s(at[n]["ray_casting_s"]) for n in fast]
                + [f"{at[REFERENCE]['us_per_ray']:.0f}"]
            )
        tables.append(
            (
                "Scan time against triangles (default world detail levels, medians over the poses)",
                headers,
                body,
            )
        )
    if report.object_rows:
        headers = (
            ["objects", "triangles"]
            + [f"{n} scan" for n in fast]
            + [f"{n} cast" for n in fast]
            + ["scene.ray_cast us/ray", "scene.ray_cast scan", f"{fast[0]} x ray_cast"]
        )
        body = []
        for count in cfg.object_counts:
            at = {r["backend"]: r for r in report.object_rows if r["world"] == f"{count} rocks/trees"}
            body.append(
                [f"{at[fast[0]]['objects']:,}", f"{at[fast[0]]['triangles']:,}"]
                + [fmt_s(at[n]["scan_s"]) for n in fast]
                + [fmt_s(at[n]["ray_casting_s"]) for n in fast]
                + [
                    f"{at[REFERENCE]['us_per_ray']:.0f}",
                    fmt_s(at[REFERENCE]["scan_s"], True),
                    ratio(at[fast[0]]["speedup_vs_ray_cast"], True),
                ]
            )
        tables.append(
            (
                "Scan time against objects (terrain + N rocks and trees, each its own mesh object; one pose, "
                "full r_h = 1 deg scan, placement to PLY written)",
                headers,
                body,
            )
        )
    return tables


# ---------------------------------------------------------------------------------------------
# synthetic scenes with many objects (the scaling-with-objects table)


def build_many_objects_scene(
    n_objects: int,
    seed: int = 0,
    half_size: float = 50.0,
    scene=None,
    collection_name: str = BENCH_COLLECTION,
):
    """Terrain plus `n_objects` rocks and trees (each its own tagged mesh object) in a
    generated collection of `scene` (default: the active scene). Returns the collection."""
    import bpy

    from ..blender.mesh import mesh_object, wildscan_collection
    from ..core.rng import stage_rng
    from ..core.world.shapes.primitives import cone, cylinder, grid_heightfield, merge, uv_sphere

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
            mesh_object(
                f"bench rock {i}", *uv_sphere(r, 8, 12, center=(x, y, z + 0.5 * r)), coll, "rock", i + 2
            )
        else:
            h = float(rng.uniform(2.0, 4.0))
            trunk = cylinder(0.15, h, 12, base=(x, y, z))
            mesh_object(f"bench trunk {i}", *trunk, coll, "trunk", i + 2)
            top = merge([cone(1.0, 2.0, 12, base=(x, y, z + h))])
            mesh_object(f"bench top {i}", *top, coll, "treetop", i + 2)
    return coll
