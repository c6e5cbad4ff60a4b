"""Suite "default world": at each detail level, from a fixed set of poses (the first valid
pose of each zone), scan time (median of runs), per-ray agreement with scene.ray_cast,
and the terrain's height error against the analytic heightfield (the terrain fit)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..core.errors import PoseRejected, UserError
from .config import BENCH_COLLECTION, PHASES, QUICK_ZONES, REFERENCE, SCAN_RH, BenchConfig
from .measure import (
    bench_scene,
    fast_backend,
    finite_median,
    pose_text,
    reference_backend,
    scene_context,
    subset_reference,
    sum_agreements,
    timed,
)
from .report import Report, backend_title, fmt_s, format_phases, metres, percent, ratio, text_table
from .scaling import bench_beams
from .testworld import measure_phases, phase_rows

# =============================================================================================
# the default world at each detail level


def fixed_poses(seed: int, zones: int | None = None) -> list[tuple[str, object, float | None]]:
    """(zone, Pose, z_start): the first valid pose of each zone of the default-detail world.
    The same poses are used at every detail level (the layout does not change with it)."""
    from ..app.poses import plan_backend, valid_poses
    from ..core.placement import Pose
    from ..core.world import ZONES, plan_world

    plan = plan_world(seed, "default")
    chosen = ZONES[:zones] if zones else ZONES
    found = valid_poses(plan, plan_backend(plan), 1, chosen)
    return [
        (zone, Pose(p["x"], p["y"], p["yaw"]), p.get("z_start")) for zone in chosen for p in found[zone][:1]
    ]


def bench_world_levels(cfg: "BenchConfig", report: "Report", tmp: Path) -> None:
    poses = fixed_poses(cfg.seed, QUICK_ZONES if cfg.quick else None)
    if not poses:
        raise UserError(f"{cfg.seed}: the world has no valid scan pose to benchmark", setting="seed")
    report.poses = poses
    report.say(
        f"\n== Default world, seed {cfg.seed}: {len(poses)} poses (first valid pose per zone): "
        + "; ".join(f"{z} ({pose_text(p)}{'' if zs is None else f', z-start {zs:g}'})" for z, p, zs in poses)
    )
    for detail in cfg.details:
        bench_level(cfg, report, detail, poses, tmp)
    report.say(format_levels(report.level_rows, cfg))


def bench_level(cfg, report: "Report", detail: str, poses, tmp: Path) -> None:
    from ..blender.builder import build_world
    from ..raycast.blender_backend import scene_depsgraph
    from ..raycast.extract import extract_scene

    with bench_scene(f"WildScanBench {detail}") as scene:
        with scene_context(scene):
            plan, build_world_s = timed(build_world, cfg.seed, detail, collection_name=BENCH_COLLECTION)
        whole, extract_s = timed(extract_scene, scene_depsgraph(scene))
        objects = plan.counts()["objects"]
        report.say(
            f"-- {detail}: {objects:,} objects, {whole.triangle_count:,} triangles; world built in "
            f"{build_world_s:.2f} s, extracted in {extract_s:.3f} s"
        )
        base = {
            "world": "default world",
            "detail": detail,
            "seed": cfg.seed,
            "objects": objects,
            "triangles": whole.triangle_count,
            "build_world_s": build_world_s,
            "extract_s": extract_s,
        }
        reference = reference_backend(scene)
        per_pose: list[dict] = []
        for zone, pose, z_start in poses:
            # the headline (a full scene.ray_cast scan) and the beam scaling: from the first pose
            # the placement accepts at the headline detail
            first = detail == cfg.headline_detail and not report.beam_rows
            try:
                rows = bench_pose(
                    cfg,
                    report,
                    base,
                    whole,
                    scene,
                    reference,
                    zone,
                    pose,
                    z_start,
                    first and cfg.full_reference,
                    tmp,
                )
            except PoseRejected as e:
                report.say(f"   {zone}: skipped at {detail} detail ({e})")
                continue
            per_pose += rows
            if first:
                bench_beams(cfg, report, base, whole, reference, pose, z_start, rows, tmp)
        terrain = bench_terrain(cfg, plan, whole, reference)
    report.add_rows(per_pose)
    summary = level_summary(cfg, base, per_pose, terrain, plan)
    report.add_rows(summary)
    report.level_rows += summary


def bench_pose(
    cfg, report, base, whole, scene, reference, zone, pose, z_start, full: bool, tmp: Path
) -> list[dict]:
    """Every backend from one pose: fast ones in full (median of runs); scene.ray_cast in
    full when `full`, else on --reference-rays rays of the first fast backend's scan."""
    if full:
        report.say(
            f"   {zone}: full r_h = {SCAN_RH:g} deg scan with scene.ray_cast, the measured reference (slow: "
            f"one Python call a ray, each costing more the more objects the scene has) ..."
        )
    measured = measure_phases(cfg, whole, scene, pose, z_start, tmp, full_reference=full)
    runs, geometry = measured["runs"], measured["geometry"]
    first = runs[cfg.fast_backends[0]][0]
    if full:
        ref_run = runs[REFERENCE][0]
        ref = {"scan_s": ref_run.total, "estimated": False, **ref_run.row()}
    else:
        ref = subset_reference(cfg, reference, first, geometry, runs, measured["backends"])
    rows = []
    for name in cfg.all_backends:
        row = dict(
            base,
            section="pose",
            zone=zone,
            pose=pose_text(pose),
            backend=name,
            crop_triangles=geometry.triangle_count,
        )
        if name == REFERENCE:
            row.update(ref)
            row.update(extract_s=0.0, crop_s=0.0, build_s=0.0)
        else:
            run, build_s, agree, extra = runs[name]
            row.update(
                run.row(),
                estimated=False,
                build_s=build_s,
                crop_s=measured["crop_s"],
                agreement=agree,
                **extra,
            )
            row.update(agree.row())
        row["speedup_vs_ray_cast"] = ref["scan_s"] / row["scan_s"]
        rows.append(row)
    if full:
        report.headline = {
            "pose": pose,
            "zone": zone,
            "detail": base["detail"],
            "objects": base["objects"],
            "runs": runs,
            "extract_s": base["extract_s"],
            "triangles": base["triangles"],
        }
        report.say(
            format_phases(
                phase_rows(
                    measured,
                    "default world",
                    base["objects"],
                    base["triangles"],
                    base["extract_s"],
                    cfg.seed,
                    pose,
                    base["detail"],
                    zone,
                ),
                f"default world, {base['detail']} detail, {zone} pose",
                base["extract_s"],
            )
        )
    return rows


def bench_terrain(cfg, plan, whole, reference) -> dict:
    """Terrain height error of each backend's hits against the analytic heightfield: rays
    straight down at random points; only hits on the terrain mesh itself are compared (not
    water, plants, the trail or the cave roof above it)."""
    from ..core.classes import class_by_name
    from ..core.rng import stage_rng
    from ..core.world import EXTENT

    terrain = plan.elements_of("terrain", stage="terrain")[0].instance
    x0, x1, y0, y1 = EXTENT
    xy = stage_rng(cfg.seed, "bench.terrain").uniform(
        [x0 + 1, y0 + 1], [x1 - 1, y1 - 1], size=(cfg.terrain_rays, 2)
    )
    top = float(whole.vertices[:, 2].max()) + 1.0
    reach = top - float(whole.vertices[:, 2].min()) + 1.0
    origins = np.column_stack([xy, np.full(len(xy), top)])
    down = np.broadcast_to([0.0, 0.0, -1.0], origins.shape)
    truth = plan.heightfield(xy[:, 0], xy[:, 1])
    mesh = plan.grid.height_at(xy[:, 0], xy[:, 1])  # the triangulated grid: what a ray should hit
    terrain_id = class_by_name("terrain").id
    out = {}
    for name in cfg.all_backends:
        count = min(cfg.reference_rays, len(xy)) if name == REFERENCE else len(xy)
        backend = reference if name == REFERENCE else fast_backend(name, whole)
        hits = backend.cast(origins[:count], np.ascontiguousarray(down[:count]), reach)
        on = (hits.instance == terrain) & (hits.class_id == terrain_id)
        z = top - hits.distance[on]
        err = np.abs(z - truth[:count][on])
        out[name] = {
            "terrain_max_m": float(err.max(initial=0.0)),
            "terrain_rms_m": float(np.sqrt(np.mean(err**2))) if len(err) else math.nan,
            "terrain_rays": int(on.sum()),
            "terrain_mesh_max_m": float(np.abs(z - mesh[:count][on]).max(initial=0.0)),
        }
    return out


def level_summary(cfg, base: dict, per_pose: list[dict], terrain: dict, plan) -> list[dict]:
    """One row per backend: medians over poses, agreement summed over every compared ray."""
    rows = []
    ref_scan = finite_median(r["scan_s"] for r in per_pose if r["backend"] == REFERENCE)
    for name in cfg.all_backends:
        mine = [r for r in per_pose if r["backend"] == name]
        if not mine:
            continue
        row = dict(
            base,
            section="detail",
            backend=name,
            zone="all",
            pose=f"{len(mine)} poses",
            rh_deg=SCAN_RH,
            beams=mine[0]["beams"],
            runs=mine[0]["runs"],
            estimated=any(r["estimated"] for r in mine),
        )
        for key in (
            "scan_s",
            *(f"{p}_s" for p in PHASES),
            "us_per_ray",
            "crop_triangles",
            "crop_s",
            "build_s",
        ):
            row[key] = finite_median(r.get(key, math.nan) for r in mine)
        row["speedup_vs_ray_cast"] = ref_scan / row["scan_s"]
        if name != REFERENCE:
            row.update(sum_agreements(r["agreement"] for r in mine).row())
        row.update(terrain.get(name, {}))
        rows.append(row)
    for row in rows:
        row["terrain_fit_max_m"] = plan.grid_fit.error.max
        row["terrain_fit_rms_m"] = plan.grid_fit.error.rms
    return rows


def format_levels(rows: list[dict], cfg) -> str:
    headers = [
        "detail",
        "objects",
        "triangles",
        "crop tris",
        "backend",
        "scan",
        "cast",
        "us/ray",
        "x ray_cast",
        "rays cmp",
        "labels same",
        "ranges ok",
        "max |dr| m",
        "ref/own wrong",
        "terrain max m",
        "terrain RMS m",
    ]
    body = []
    for r in rows:
        ref = r["backend"] == REFERENCE
        est = bool(r["estimated"])
        body.append(
            [
                r["detail"],
                f"{r['objects']:,}",
                f"{r['triangles']:,}",
                f"{r['crop_triangles']:,.0f}",
                backend_title(r["backend"]),
                fmt_s(r["scan_s"], est),
                fmt_s(r["ray_casting_s"], est),
                f"{r['us_per_ray']:.2f}",
                "1 (ref)" if ref else ratio(r["speedup_vs_ray_cast"], _est_ref(rows, r)),
                "-" if ref else f"{r['rays_compared']:,}",
                "-" if ref else percent(r["label_agreement"]),
                "-" if ref else percent(r["range_agreement"]),
                "-" if ref else metres(r["max_range_diff_m"]),
                "-" if ref else f"{r['reference_wrong']}/{r['backend_wrong']} of {r['disagreements']}",
                f"{r['terrain_max_m']:.4f}",
                f"{r['terrain_rms_m']:.4f}",
            ]
        )
    fits = {r["detail"]: (r["terrain_fit_max_m"], r["terrain_fit_rms_m"]) for r in rows}
    return "\n".join(
        [
            f"\nfull r_h = {SCAN_RH:g} deg scans, placement to PLY written, medians over the poses "
            f"(each the median of {cfg.runs} runs); '~' = scene.ray_cast extrapolated from "
            f"{cfg.reference_rays:,} rays a pose, other phases as the first fast backend measured them; "
            "'rays cmp' = rays compared with scene.ray_cast (subsets, and every beam of the one full "
            "reference scan); ref/own wrong = of the disagreeing rays, where scene.ray_cast / this "
            "backend is wrong by exact float64 brute force",
            text_table(headers, body, [False, True, True, True, False] + [True] * 11),
            "terrain error = |hit height - analytic heightfield| straight down at "
            f"{cfg.terrain_rays:,} random points ({min(cfg.reference_rays, cfg.terrain_rays):,} for "
            "scene.ray_cast); the mesh alone (fit_grid, 100k points): "
            + ", ".join(f"{d} max {m:.4f} / RMS {s:.4f} m" for d, (m, s) in fits.items()),
            "hit height vs the triangulated terrain mesh itself (the backends' own error): max "
            + ", ".join(
                f"{backend_title(r['backend'])} {r['detail']} {r['terrain_mesh_max_m']:.1e} m" for r in rows
            ),
        ]
        + terrain_tolerance_notes(rows)
    )


def terrain_tolerance_notes(rows: list[dict]) -> list[str]:
    """Say so where the measured terrain error exceeds the level's tolerance."""
    from ..core.world import DETAILS

    notes = []
    for detail in dict.fromkeys(r["detail"] for r in rows):
        worst = max(r["terrain_max_m"] for r in rows if r["detail"] == detail)
        tol = DETAILS[detail].terrain_tolerance
        if worst > tol:
            notes.append(
                f"note: at {detail} detail the terrain mesh is {worst:.4f} m off the analytic field "
                f"somewhere (tolerance {tol:g} m): fit_grid checks its tolerance on a sample of points, and "
                "the rays found a place it missed (the backends agree with the mesh itself, see above)"
            )
    return notes


def _est_ref(rows, r) -> bool:
    return any(x["estimated"] for x in rows if x["backend"] == REFERENCE and x["detail"] == r["detail"])
