"""`wildscan world`, `wildscan poses` and `wildscan bench-world` (registered in cli.py).

world        build the world of a seed in Blender, save it (.blend), its JSON sidecar
             (zones, extents, features, valid scan poses) and optionally an aerial map.
poses        print scan poses the placement accepts, per zone (no Blender needed: the
             plan's own triangles are ray cast, the same geometry Blender gets).
bench-world  build the world at each detail level and print the time of every stage,
             the object / triangle counts and the terrain's measured height error.

Every user mistake raises UserError before anything is written; files are
written to hidden temporary names beside their targets and renamed at the end.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from contextlib import contextmanager
from pathlib import Path

from .core.checks import whole_number
from .core.errors import PoseRejected, UserError
from .core.io.files import atomic_outputs, check_output_path
from .core.io.ply import sidecar_path
from .core.worldplan import (
    DETAILS,
    ZONES,
    WorldPlan,
    candidate_sites,
    check_seed,
    check_zone,
    detail_level,
    model_errors,
    plan_world,
)

DEFAULT_POSES_PER_ZONE = 5
MAX_POSE_COUNT = 1000


# ---------------------------------------------------------------------------------------
# arguments


def add_world_arguments(p: argparse.ArgumentParser, in_blender: bool = False) -> None:
    p.add_argument(
        "--seed",
        required=True,
        metavar="S",
        help="world seed, a whole number from 0 to 2147483647; every seed gives another world with all six zones",
    )
    p.add_argument(
        "--detail",
        default="default",
        metavar="LEVEL",
        help="low | default | high: how finely shapes are modelled (terrain height tolerance "
        "0.15 / 0.05 / 0.02 m); the layout is the same at every level (default: default)",
    )
    p.add_argument(
        "--out",
        required=True,
        metavar="WORLD.blend",
        help="the Blender file to write; zones and scan poses go beside it as WORLD.json",
    )
    p.add_argument(
        "--map",
        metavar="MAP.png",
        help="also write an aerial map (classes in colour, zones, poses); "
        "needs matplotlib, which the bpy wheel's venv has and Debian's Blender does not",
    )
    p.add_argument(
        "--poses",
        type=str,
        default=str(DEFAULT_POSES_PER_ZONE),
        metavar="N",
        help=f"valid scan poses listed per zone in the sidecar (default {DEFAULT_POSES_PER_ZONE})",
    )
    p.add_argument("--quiet", action="store_true", help="print only the files written")


def add_poses_arguments(p: argparse.ArgumentParser, in_blender: bool = False) -> None:
    p.add_argument(
        "--seed", required=True, metavar="S", help="world seed, a whole number from 0 to 2147483647"
    )
    p.add_argument("--zone", metavar="NAME", help=f"only this zone: {', '.join(ZONES)} (default: all)")
    p.add_argument(
        "--count",
        default=str(DEFAULT_POSES_PER_ZONE),
        metavar="N",
        help=f"poses per zone, 1..{MAX_POSE_COUNT} (default {DEFAULT_POSES_PER_ZONE})",
    )
    p.add_argument(
        "--detail", default="default", metavar="LEVEL", help="low | default | high (default: default)"
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")


def add_bench_arguments(p: argparse.ArgumentParser, in_blender: bool = False) -> None:
    p.add_argument("--seed", default="0", metavar="S", help="world seed (default 0)")
    p.add_argument(
        "--detail",
        action="append",
        metavar="LEVEL",
        help="detail level to measure; repeat for several (default: low, default, high)",
    )


# ---------------------------------------------------------------------------------------
# checks


def positive_count(text, setting: str) -> int:
    return whole_number(text, setting, 1, MAX_POSE_COUNT)


@contextmanager
def quiet_stdout():
    """Silence what Blender's C code prints to file descriptor 1."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


# ---------------------------------------------------------------------------------------
# poses


def plan_geometry(plan: WorldPlan):
    """The plan's triangles as a SceneGeometry (what extract_scene gives for the built world)."""
    from .raycast.geometry import SceneGeometry, local_origin

    v, f, c, i, o, names = plan.triangles()
    geometry = SceneGeometry(v, f, c, i, o, names)
    geometry.offset = local_origin(v, f)
    return geometry


def plan_backend(plan: WorldPlan, notify=None):
    """The fastest ray backend over the plan's own triangles (embree, else mathutils' BVH)."""
    from .raycast.select import make_backend

    return make_backend("auto", geometry=plan_geometry(plan), notify=notify)


def valid_poses(
    plan: WorldPlan, backend, count: int = DEFAULT_POSES_PER_ZONE, zones=ZONES
) -> dict[str, list[dict]]:
    """Up to `count` poses per zone that `placement.place` accepts: the zone's reserved
    sites first (chosen where its classes are in view), then random candidates."""
    from .core.placement import place

    out: dict[str, list[dict]] = {}
    for zone in zones:
        accepted: list[dict] = []
        tried = 0
        asked = count
        while len(accepted) < count:
            pool = candidate_sites(plan, zone, asked)  # a longer ask keeps the same prefix
            if len(pool) <= tried:
                break
            for site in pool[tried:]:
                if len(accepted) >= count:
                    break
                try:
                    placement = place(backend, site.pose, site.z_start)
                except PoseRejected:
                    continue
                entry = site.to_dict()
                entry["tilt_deg"] = round(float(placement.to_dict()["tilt_deg"]), 2)
                entry["optical_centre_z"] = round(float(placement.optical_centre[2]), 3)
                accepted.append(entry)
            tried = len(pool)
            asked = tried + 2 * (count - len(accepted)) + 2
        out[zone] = accepted
    return out


def run_poses(args, in_blender: bool = False) -> int:
    seed = check_seed(args.seed)
    detail_level(args.detail)
    zones = (check_zone(args.zone),) if args.zone is not None else ZONES
    count = positive_count(args.count, "count")
    plan = plan_world(seed, args.detail)
    poses = valid_poses(plan, plan_backend(plan), count, zones)
    if args.json:
        print(json.dumps({"seed": seed, "detail": args.detail, "poses": poses}, indent=1))
        return 0
    print("# zone      x         y         yaw     z_start  kind   (scan with: --pose X Y YAW [--z-start Z])")
    for zone in zones:
        for p in poses[zone]:
            z = f"{p['z_start']:8.3f}" if "z_start" in p else "       -"
            print(f"{zone:<8} {p['x']:9.3f} {p['y']:9.3f} {p['yaw']:7.1f} {z}  {p['kind']}")
    return 0


# ---------------------------------------------------------------------------------------
# world


class StageProgress:
    """One line per stage on stderr: 'world: terrain        0.241 s'."""

    def __init__(self, quiet: bool = False, stream=None):
        self.quiet = quiet
        self.stream = stream or sys.stderr

    def __call__(self, stage: str, seconds: float) -> None:
        if not self.quiet:
            self.stream.write(f"world: {stage:<16} {seconds:7.3f} s\n")
            self.stream.flush()


def save_blend(tmp: Path, final: Path) -> None:
    """Save the current file as a copy at `tmp`; Blender reports failure as RuntimeError."""
    import bpy

    try:
        with quiet_stdout():  # Blender's own "Info: Saved copy as ..." line
            bpy.ops.wm.save_as_mainfile(filepath=str(tmp), check_existing=False, copy=True, compress=True)
    except RuntimeError as e:
        reason = str(e).strip().splitlines()[0] if str(e).strip() else "Blender could not save it"
        raise UserError(f"cannot write {final}: {reason.replace(str(tmp), str(final))}") from None


def run_world(args, in_blender: bool = False) -> int:
    seed = check_seed(args.seed)
    detail_level(args.detail)
    count = positive_count(args.poses, "poses")
    # A scan's sidecar names its PLY file; a world beside it must not replace it.
    out = check_output_path(args.out, ".blend", "out", companions=(".json",), foreign_sidecar_key="ply_file")
    sidecar = sidecar_path(out)
    map_path = check_output_path(args.map, ".png", "map") if args.map is not None else None
    if map_path is not None:
        from .viz import require_matplotlib

        require_matplotlib()

    from .world.builder import build_world
    from .world.scene_io import empty_scene

    quiet = getattr(args, "quiet", False)
    progress = StageProgress(quiet)
    t_start = time.perf_counter()
    if not in_blender:
        empty_scene()
    plan = build_world(seed, args.detail, progress=progress)

    t0 = time.perf_counter()
    poses = valid_poses(plan, plan_backend(plan), count)
    progress("valid poses", time.perf_counter() - t0)

    finals = (out, sidecar, map_path) if map_path is not None else (out, sidecar)
    try:
        with atomic_outputs(*finals) as temps:
            t0 = time.perf_counter()
            save_blend(temps[0], out)
            progress("save .blend", time.perf_counter() - t0)
            if map_path is not None:
                from .core.worldplan import Site
                from .viz.aerial_map import render_map

                t0 = time.perf_counter()
                crosses = [Site(z, p["x"], p["y"], p["yaw"], p["kind"]) for z in ZONES for p in poses[z]]
                render_map(plan, str(temps[2]), poses=crosses)
                progress("aerial map", time.perf_counter() - t0)
            description = plan.describe(poses)
            description["blend"] = str(out)
            description["map"] = str(map_path) if map_path else None
            temps[1].write_text(json.dumps(description, indent=1) + "\n")
    except OSError as e:
        raise UserError(f"cannot write the world files: {e.strerror or e}") from None

    counts = plan.counts()
    if not quiet:
        print(
            f"world of seed {seed} ({args.detail} detail): {counts['objects']:,} objects sharing "
            f"{counts['meshes']} meshes, {counts['triangles']:,} triangles, built and saved in "
            f"{time.perf_counter() - t_start:.1f} s"
        )
    print(f"wrote {out}")
    print(f"wrote {sidecar}")
    if map_path is not None:
        print(f"wrote {map_path}")
    return 0


# ---------------------------------------------------------------------------------------
# benchmark


def terrain_error_table(plan: WorldPlan, spacings=(0.25, 0.5, 1.0, 2.0, 4.0)) -> list[dict]:
    """Uniform grids of several spacings vs the adaptive grid the plan chose: max/RMS height
    error against the analytic field at the same 100,000 random points, and triangle counts."""
    from .core.heightfield import error_sample_points, grid_error, uniform_grid
    from .core.rng import stage_rng
    from .core.worldplan import EXTENT

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
    from .world.builder import build_world
    from .world.scene_io import empty_scene

    stream = stream or sys.stdout
    results = []
    for detail in details:
        detail_level(detail)
        empty_scene()
        t0 = time.perf_counter()
        plan = build_world(seed, detail)
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
            f"  objects {counts['objects']:,}, shared meshes {counts['meshes']}, triangles {counts['triangles']:,} "
            f"(terrain {fit.grid.triangle_count:,}: {len(fit.grid.xs)} x {len(fit.grid.ys)} lines)\n"
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


def run_bench(args, in_blender: bool = False) -> int:
    seed = check_seed(args.seed)
    details = args.detail or list(DETAILS)
    for d in details:
        detail_level(d)
    bench_world(seed, details)
    return 0


# ---------------------------------------------------------------------------------------
# the commands, as cli.py registers them in `wildscan`

COMMANDS = {
    "world": (add_world_arguments, run_world, "build a world from a seed and save it"),
    "poses": (add_poses_arguments, run_poses, "print valid scan poses of a world"),
    "bench-world": (add_bench_arguments, run_bench, "time every world-building stage at each detail level"),
}
DESCRIPTIONS = {
    "world": "Build the natural world of a seed (hills, forest, park with power line, trail, lake, cave), tagged "
    "for the scanner, save it as a .blend with a JSON sidecar listing zones and valid scan poses, and "
    "optionally an aerial map.",
    "poses": "Print scan poses that the placement accepts, per zone (no Blender scene needed).",
    "bench-world": "Build the world at each detail level and print the time of every stage, object and triangle "
    "counts, and the terrain's height error against the analytic heightfield.",
}
