"""`wildscan demo`: the default world, its aerial map, and one labeled scan per
zone with a preview image each — the paper's section V in one command."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from .core.io.files import output_directory
from .raycast.select import BACKEND_NAMES

# Point counts of the paper's r_h = 1 deg scans (Figs. 8-12), for comparison.
PAPER_POINTS = {"hills": 83_056, "lake": 63_998, "park": 60_669, "cave": 80_307, "forest": 85_479}
# What each zone's scan must show (the world issue's acceptance list).
EXPECTED_CLASSES = {
    "hills": ("pole", "wire"),
    "forest": ("trunk", "treetop", "bush"),
    "park": ("table", "bench", "fence"),
    "lake": ("terrain",),
    "cave": ("terrain",),
    "trail": ("terrain",),
}


def add_demo_arguments(p: argparse.ArgumentParser, in_blender: bool = False) -> None:
    from .cli import finite_float

    p.add_argument(
        "--seed", default="1", metavar="S", help="world seed, a whole number from 0 to 2147483647 (default 1)"
    )
    p.add_argument(
        "--out",
        default="out/demo",
        metavar="DIR",
        help="directory for the world, its map, and a PLY + preview PNG per zone (default out/demo; "
        "created if missing)",
    )
    p.add_argument(
        "--rh",
        type=finite_float,
        default=1.0,
        metavar="DEG",
        help="horizontal resolution r_h in degrees, 180/r_h whole (default 1, as the paper)",
    )
    p.add_argument(
        "--backend",
        choices=BACKEND_NAMES,
        default="auto",
        help="ray caster (default auto, the fastest available)",
    )


def first_pose_per_zone(world_json: Path) -> dict[str, dict]:
    zones = json.loads(world_json.read_text())["zones"]
    return {zone["name"]: zone["poses"][0] for zone in zones if zone["poses"]}


def run_demo(args, in_blender: bool = False) -> int:
    from .core.classes import BY_ID, CLASSES
    from .core.io.ply import write_scan_files
    from .core.placement import Pose
    from .core.sensor import SensorConfig
    from .core.worldplan import check_seed
    from .raycast.extract import extract_scene
    from .scanning import scan_current_scene
    from .viz.preview import render_preview
    from .world_cli import run_world

    seed = check_seed(args.seed)
    sensor = SensorConfig(rh_deg=args.rh).validate()  # wildscan scan's defaults: same poses, same bytes
    out = output_directory(args.out)

    world_args = argparse.Namespace(
        seed=str(seed),
        detail="default",
        out=str(out / "world.blend"),
        map=str(out / "map.png"),
        poses="3",
        quiet=False,
    )
    run_world(world_args, in_blender)
    poses = first_pose_per_zone(out / "world.json")
    geometry = extract_scene()  # once for all six scans

    print(f"\nscans at r_h = {args.rh:g} deg ({sensor.beam_count:,} beams each), leveled frame:")
    print(f"  {'zone':<7} {'pose (x, y, yaw)':<28} {'points':>8} {'paper':>8}  classes")
    seen: set[int] = set()
    missing = []
    for zone, p in poses.items():
        pose = Pose(p["x"], p["y"], p["yaw"])
        result = scan_current_scene(
            pose, sensor, "leveled", p.get("z_start"), args.backend, notify=print, geometry=geometry
        )
        cloud = result.cloud
        ply = out / f"scan_{zone}.ply"
        metadata = dict(result.metadata, seed=seed, world=str(out / "world.blend"), zone=zone)
        write_scan_files(ply, cloud, metadata)
        title = f"{zone}: {len(cloud):,} points, seed {seed}, pose ({pose.x:.1f}, {pose.y:.1f}, {pose.yaw_deg:.0f} deg)"
        render_preview(cloud, ply.with_suffix(".png"), title=title)
        present = {BY_ID[c].name for c in cloud.class_counts()}
        seen |= set(cloud.class_counts())
        missing += [f"{zone}: {name}" for name in EXPECTED_CLASSES.get(zone, ()) if name not in present]
        paper = f"{PAPER_POINTS[zone]:,}" if zone in PAPER_POINTS else "-"
        where = f"({pose.x:.1f}, {pose.y:.1f}, {pose.yaw_deg:.0f})" + (" z_start" if "z_start" in p else "")
        print(f"  {zone:<7} {where:<28} {len(cloud):>8,} {paper:>8}  {', '.join(sorted(present))}")
    absent = [c.name for c in CLASSES if c.id not in seen]
    print(
        f"\nall {len(CLASSES)} classes across the scans"
        if not absent
        else f"\nclasses in no scan: {', '.join(absent)}"
    )
    if missing:
        print("expected but not seen: " + "; ".join(missing))
    print(f"files in {out}: world.blend, world.json, map.png, scan_<zone>.ply/.json/.png")
    return 0 if not missing else 1
