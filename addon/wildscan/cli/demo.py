"""`wildscan demo`: the default world, its aerial map, and one labeled scan per zone with a
preview image each — the paper's section V in one command (`make demo`)."""

from __future__ import annotations

import argparse

from . import options
from .options import ArgumentParser

HELP = "build the default world, its map, and scan every zone"
DESCRIPTION = (
    "Build the world of a seed with its aerial map, then scan one valid pose in every zone (hills by the "
    "power line, forest, park, lake shore, cave, trail), writing a PLY and an oblique preview image per scan."
)


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    options.add(p, "seed", default="1", help=f"{options.SEED_HELP} (default 1)")
    options.add(
        p,
        "out",
        required=False,
        default="out/demo",
        metavar="DIR",
        help="directory for the world, its map, and a PLY + preview PNG per zone (default out/demo; "
        "created if missing)",
    )
    options.add(
        p,
        "rh",
        default=1.0,
        help="horizontal resolution r_h in degrees, 180/r_h whole (default 1, as the paper)",
    )
    options.add(p, "backend", help="ray caster (default auto, the fastest available)")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    from ..app import demo
    from ..core.classes import CLASSES
    from .output import StageProgress
    from .world import print_saved_world

    out, sensor = demo.prepare(args.out, args.rh)
    world = demo.make_demo_world(args.seed, out, StageProgress())
    print_saved_world(world)

    print(f"\nscans at r_h = {args.rh:g} deg ({sensor.beam_count:,} beams each), leveled frame:")
    print(f"  {'zone':<7} {'pose (x, y, yaw)':<28} {'points':>8} {'paper':>8}  classes")
    scans = []
    for scan in demo.scan_zones(args.seed, world, sensor, args.backend):
        scans.append(scan)
        paper = f"{demo.PAPER_POINTS[scan.zone]:,}" if scan.zone in demo.PAPER_POINTS else "-"
        where = demo.pose_label(scan.pose, scan.z_start)
        print(f"  {scan.zone:<7} {where:<28} {len(scan.cloud):>8,} {paper:>8}  {', '.join(scan.classes)}")
    absent = demo.classes_in_no_scan(scans)
    print(
        f"\nall {len(CLASSES)} classes across the scans"
        if not absent
        else f"\nclasses in no scan: {', '.join(absent)}"
    )
    missing = [f"{s.zone}: {name}" for s in scans for name in s.missing]
    if missing:
        print("expected but not seen: " + "; ".join(missing))
    print(f"files in {out}: world.blend, world.json, map.png, scan_<zone>.ply/.json/.png")
    return 0 if not missing else 1
