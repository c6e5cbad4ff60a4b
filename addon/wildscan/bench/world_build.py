"""Suite "world" (`wildscan bench --suite world`, or `wildscan bench-world`): build the world
at each detail level in Blender and print the time of every stage, the object, mesh and
triangle counts, and the terrain's height error against the analytic heightfield (the
adaptive grid the plan chose beside uniform grids of several spacings)."""

from __future__ import annotations

import sys
import time

from ..app.poses import DEFAULT_POSES_PER_ZONE, plan_backend, valid_poses
from ..core.world import DETAILS, WorldPlan, detail_level, model_errors


def terrain_error_table(plan: WorldPlan, spacings=(0.25, 0.5, 1.0, 2.0, 4.0)) -> list[dict]:
    """Uniform grids of several spacings vs the adaptive grid the plan chose: max/RMS height
    error against the analytic field at the same 100,000 random points, and triangle counts."""
    from ..core.rng import stage_rng
    from ..core.world import EXTENT
    from ..core.world.terrain_grid import error_sample_points, grid_error, uniform_grid

    points = error_sample_points(EXTENT, 100_000, stage_rng(plan.seed, "world.bench.error"))
    rows = []
    for s in spacings:
        grid = uniform_grid(plan.heightfield, EXTENT, s)
        e = grid_error(plan.heightfield, grid, points)
        rows.append(
            {"grid": f"uniform {s:g} m", "triangles": grid.triangle_count, "max": e.max, "rms": e.rms}
        )
    fit = plan.grid_fit
    e = grid_error(plan.heightfield, fit.grid, points)
    rows.append(
        {
            "grid": f"adaptive {fit.spacing_min:.2f}-{fit.spacing_max:.2f} m (tol {fit.tolerance:g})",
            "triangles": fit.grid.triangle_count,
            "max": e.max,
            "rms": e.rms,
        }
    )
    return rows


def bench_world(seed: int = 0, details=tuple(DETAILS), stream=None) -> list[dict]:
    """Build the world of `seed` in Blender at each detail level; print and return, per level,
    each stage's time, the totals, object/mesh/triangle counts and the terrain error."""
    from ..app.world import build_in_scene
    from ..blender.scene_io import empty_scene

    stream = stream or sys.stdout
    results = []
    for detail in details:
        detail_level(detail)
        empty_scene()
        t0 = time.perf_counter()
        plan = build_in_scene(seed, detail)
        total = time.perf_counter() - t0
        t1 = time.perf_counter()
        backend = plan_backend(plan)
        poses = valid_poses(plan, backend, DEFAULT_POSES_PER_ZONE)
        t_poses = time.perf_counter() - t1
        counts = plan.counts()
        fit = plan.grid_fit
        row = {
            "seed": seed,
            "detail": detail,
            "stages_s": dict(plan.timings),
            "build_s": total,
            "poses_s": t_poses,
            "objects": counts["objects"],
            "meshes": counts["meshes"],
            "triangles": counts["triangles"],
            "terrain_grid": [len(fit.grid.xs), len(fit.grid.ys)],
            "terrain_triangles": fit.grid.triangle_count,
            "terrain_error_max": fit.error.max,
            "terrain_error_rms": fit.error.rms,
            "valid_poses": {z: len(v) for z, v in poses.items()},
        }
        results.append(row)
        stream.write(
            f"\n== seed {seed}, detail {detail}: built in {total:.2f} s "
            f"(+{t_poses:.2f} s checking {sum(row['valid_poses'].values())} poses)\n"
        )
        for stage, seconds in plan.timings.items():
            stream.write(f"  {stage:<16} {seconds:7.3f} s\n")
        stream.write(
            f"  objects {counts['objects']:,}, shared meshes {counts['meshes']}, triangles "
            f"{counts['triangles']:,} (terrain {fit.grid.triangle_count:,}: "
            f"{len(fit.grid.xs)} x {len(fit.grid.ys)} lines)\n"
        )
        stream.write(
            f"  terrain height error vs the analytic field: max {fit.error.max * 100:.1f} cm, "
            f"rms {fit.error.rms * 100:.2f} cm (tolerance {fit.tolerance * 100:g} cm)\n"
        )
        errors = model_errors(DETAILS[detail])
        row["model_errors"] = errors
        stream.write(
            "  shape errors: "
            + ", ".join(f"{k} {v * 100:.2f} cm" for k, v in errors.items() if k != "terrain_tolerance")
            + "\n"
        )
    stream.write("\nterrain grid spacing vs height error (last level's field):\n")
    for r in terrain_error_table(plan):
        stream.write(
            f"  {r['grid']:<40} {r['triangles']:>9,} triangles  max {r['max'] * 100:6.2f} cm  "
            f"rms {r['rms'] * 100:5.2f} cm\n"
        )
    stream.flush()
    return results
