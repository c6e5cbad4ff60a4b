"""`wildscan demo`: the paper's island, its aerial map, and one labeled scan per zone with a
preview image each (the paper's section V in one command), then the default endless world
scanned on each land cover (`make demo`); each part says which world it is."""

from __future__ import annotations

import argparse

from . import options
from .options import ArgumentParser

HELP = "scan the paper's island zone by zone, then the default endless world cover by cover"
DESCRIPTION = (
    "Two parts, each saying which world it is. 1: the paper's island (--layout paper --biome paper): build "
    "it with its aerial map and scan one valid pose in every zone (hills by the power line, forest, park, "
    "lake shore, cave, trail), the points beside the paper's counts. 2: the default world (--layout "
    "endless, the default biome: what `wildscan scan --seed` scans): one scan per land cover found around "
    "the origin. A PLY and an oblique preview image per scan."
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
    options.add_cache_arguments(p, "the endless world's tiles")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    from ..app import demo
    from ..core.classes import CLASSES
    from .output import StageProgress
    from .world import print_saved_world

    out, sensor = demo.prepare(args.out, args.rh)
    print(
        f"1. the paper's island: seed {args.seed}, --layout paper --biome paper (the paper's section V; "
        "`wildscan scan --seed` scans the endless world, part 2)"
    )
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
    covered = _endless_part(args, out / "endless", sensor)
    return 0 if not missing and covered else 1


def _endless_part(args: argparse.Namespace, out, sensor) -> bool:
    """Part 2: the default world, one scan per land cover; False when none was found."""
    from ..app import demo
    from ..core.io.files import output_directory
    from ..core.world import DEFAULT_BIOME

    out = output_directory(out)
    print(
        f"\n2. the default world: seed {args.seed}, --layout endless, biome {DEFAULT_BIOME} (what "
        "`wildscan scan --seed` scans), on each land cover the valid pose nearest the origin, levels of "
        "detail on:"
    )
    print(f"  {'cover':<9} {'pose (x, y, yaw)':<28} {'points':>8}  classes")
    cache = options.cache_of(args, "wildscan demo")
    scans = list(demo.scan_endless(args.seed, out, sensor, args.backend, cache=cache))
    for scan in scans:
        where = demo.pose_label(scan.pose, None)
        print(f"  {scan.cover:<9} {where:<28} {len(scan.cloud):>8,}  {', '.join(scan.classes)}")
    print(f"files in {out}: scan_<cover>.ply/.json/.png")
    return bool(scans)
