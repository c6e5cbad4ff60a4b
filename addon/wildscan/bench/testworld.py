"""Suite "test world": one full r_h = 1 deg scan of the test world (world.testworld) per
backend, placement to PLY written, split into phases, each compared beam by beam with
scene.ray_cast's scan. Also the full-scan measurement the default-world suite reuses."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..core.backend import RayBackend
from .config import BENCH_COLLECTION, REFERENCE, SCAN_RH, BenchConfig
from .measure import (
    Agreement,
    ScanRun,
    agreement_counts,
    bench_scene,
    crop_for,
    fast_backend,
    median_scan,
    noise_free,
    pose_text,
    reference_backend,
    scene_context,
    timed,
    wrong_answers,
)
from .report import Report, format_phases

# =============================================================================================
# the test world: one full scan per backend, by phase


def bench_test_world(cfg: "BenchConfig", report: "Report", tmp: Path) -> None:
    from ..blender.testworld import build_test_world
    from ..core.placement import Pose
    from ..raycast.blender_backend import scene_depsgraph
    from ..raycast.extract import extract_scene

    pose = Pose(0.0, 0.0, 0.0)
    with bench_scene("WildScanBench test world") as scene:
        with scene_context(scene):
            build_test_world(cfg.seed, collection_name=BENCH_COLLECTION)
        objects = len([o for o in scene.objects if o.type == "MESH"])
        whole, extract_s = timed(extract_scene, scene_depsgraph(scene))
        report.say(
            f"\n== Test world (world.testworld, seed {cfg.seed}: {objects} objects, {whole.triangle_count:,} "
            f"triangles), pose (0, 0, 0): one full r_h = {SCAN_RH:g} deg scan with scene.ray_cast ..."
        )
        runs = measure_phases(cfg, whole, scene, pose, None, tmp)
    rows = phase_rows(
        runs,
        world="test world",
        objects=objects,
        triangles=whole.triangle_count,
        extract_s=extract_s,
        seed=cfg.seed,
        pose=pose,
    )
    report.add_rows(rows)
    report.test_world = rows
    report.say(format_phases(rows, f"test world, seed {cfg.seed}", extract_s))


def measure_phases(cfg, whole, scene, pose, z_start, tmp: Path, full_reference: bool = True) -> dict:
    """Full r_h = 1 deg scans from `pose` with scene.ray_cast (once, when asked) and each fast
    backend (median of runs); with each one's build time and agreement with the reference."""
    geometry, crop_s = timed(crop_for, whole, pose)
    runs: dict[str, tuple] = {}
    backends = {}
    if full_reference:
        runs[REFERENCE] = (
            median_scan(reference_backend(scene), pose, z_start, SCAN_RH, tmp / "ref.ply", 1),
            0.0,
        )
    for name in cfg.fast_backends:
        backend, build_s = timed(fast_backend, name, geometry)
        backends[name] = backend
        run = median_scan(backend, pose, z_start, SCAN_RH, tmp / f"{name}.ply", cfg.runs)
        runs[name] = (run, build_s)
        if full_reference:
            runs[name] += compare_runs(geometry, backend, run, runs[REFERENCE][0])
    return {"runs": runs, "geometry": geometry, "crop_s": crop_s, "backends": backends}


def compare_runs(geometry, backend: RayBackend, run: ScanRun, ref: ScanRun) -> tuple[Agreement, dict]:
    """A full scan against the full reference scan, beam by beam, two ways:
    same rays   the backend re-casts the reference's own rays (its placement): the backends
                compared as ray casters; disagreements judged by exact float64 brute force;
    end to end  each scan with its own placement, as the two PLY files would differ. The
                placements differ by float32 round-off (scene.ray_cast's lasers), which
                moves a grazing beam's range by far more than the 1e-4 m tolerance."""
    max_range = noise_free(run.rh_deg).max_range
    dirs = ref.directions()
    again = backend.cast(ref.origin, dirs, max_range)
    counts = agreement_counts(again, ref.hits)
    idx = counts["disagree"]
    same = Agreement().add(
        counts,
        wrong_answers(geometry, ref.origin, dirs, max_range, ref.hits, idx),
        wrong_answers(geometry, ref.origin, dirs, max_range, again, idx),
    )
    e2e = agreement_counts(run.hits, ref.hits)
    n = max(e2e["rays"], 1)
    return same, {
        "e2e_label_agreement": e2e["labels_same"] / n,
        "e2e_range_agreement": e2e["ranges_ok"] / n,
        "e2e_max_range_diff_m": e2e["max_range_diff_m"],
        "placement_diff_m": float(np.linalg.norm(run.origin - ref.origin)),
    }


def phase_rows(
    measured: dict,
    world: str,
    objects: int,
    triangles: int,
    extract_s: float,
    seed: int,
    pose,
    detail: str = "",
    zone: str = "",
) -> list[dict]:
    runs = measured["runs"]
    ref_total = runs[REFERENCE][0].total if REFERENCE in runs else math.nan
    rows = []
    for name, entry in runs.items():
        run, build_s = entry[0], entry[1]
        row = {
            "section": "phases",
            "world": world,
            "detail": detail,
            "seed": seed,
            "zone": zone,
            "pose": pose_text(pose),
            "backend": name,
            "objects": objects,
            "triangles": triangles,
            "crop_triangles": measured["geometry"].triangle_count,
            "estimated": False,
            "extract_s": 0.0 if name == REFERENCE else extract_s,
            "build_s": build_s,
            "crop_s": 0.0 if name == REFERENCE else measured["crop_s"],
            "speedup_vs_ray_cast": ref_total / run.total,
        }
        row.update(run.row())
        if len(entry) > 2:
            row.update(entry[2].row(), **entry[3])
        rows.append(row)
    return rows
