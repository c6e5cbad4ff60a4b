"""`wildscan poses`: valid scan poses of a world, per zone, as a table or JSON."""

from __future__ import annotations

import argparse
import json

from . import options
from .options import ArgumentParser

HELP = "print valid scan poses of a world"
DESCRIPTION = "Print scan poses that the placement accepts, per zone (no Blender scene needed)."


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    options.add(p, "seed", required=True)
    options.add(p, "zone")
    options.add(p, "count")
    options.add(p, "detail")
    options.add(p, "vegetation")
    options.add(p, "biome")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    from ..app.poses import poses_of_seed
    from ..core.world import ZONES

    zones = (args.zone,) if args.zone is not None else ZONES
    poses = poses_of_seed(args.seed, args.detail, args.count, zones, args.vegetation, args.biome)
    if args.json:
        doc = {"seed": args.seed, "detail": args.detail, "vegetation": args.vegetation, "poses": poses}
        print(json.dumps(doc, indent=1))
        return 0
    print("# zone      x         y         yaw     z_start  kind   (scan with: --pose X Y YAW [--z-start Z])")
    for zone in zones:
        for p in poses[zone]:
            z = f"{p['z_start']:8.3f}" if "z_start" in p else "       -"
            print(f"{zone:<8} {p['x']:9.3f} {p['y']:9.3f} {p['yaw']:7.1f} {z}  {p['kind']}")
    return 0
