"""`wildscan poses`: valid scan poses of a world, per zone or land cover, as a table or JSON."""

from __future__ import annotations

import argparse
import json

from . import options
from .options import ArgumentParser

HELP = "print valid scan poses of a world"
DESCRIPTION = (
    "Print scan poses that the placement accepts (no Blender scene needed). Endless layout (the default): "
    "--count poses anywhere in --region, each with its land cover (--zone: only that cover). Paper layout: "
    "--count poses per zone of the island."
)


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    options.add(p, "seed", required=True)
    options.add(p, "layout")
    options.add(p, "region")
    options.add(p, "zone")
    options.add(p, "count", help="poses to list (paper layout: per zone), 1..1000 (default 5)")
    options.add(p, "detail")
    options.add(p, "vegetation")
    options.add(p, "biome")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")
    options.add_cache_arguments(p, "the tiles built")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    region, zone = options.region_of(args), options.zone_of(args)
    if args.layout == "endless":
        return _endless(args, region, zone)
    from ..app.poses import poses_of_seed
    from ..core.world import ZONES

    zones = (zone,) if zone is not None else ZONES
    poses = poses_of_seed(args.seed, args.detail, args.count, zones, args.vegetation, args.biome, region)
    if args.json:
        doc = {"seed": args.seed, "layout": "paper", "detail": args.detail, "vegetation": args.vegetation}
        doc.update(region=region.to_dict(), poses=poses)
        print(json.dumps(doc, indent=1))
        return 0
    print("# zone      x         y         yaw     z_start  kind   (scan with: --pose X Y YAW [--z-start Z])")
    for name in zones:
        for p in poses[name]:
            z = f"{p['z_start']:8.3f}" if "z_start" in p else "       -"
            print(f"{name:<8} {p['x']:9.3f} {p['y']:9.3f} {p['yaw']:7.1f} {z}  {p['kind']}")
    return 0


def _endless(args: argparse.Namespace, region, zone: str | None) -> int:
    from ..app.poses import endless_poses
    from ..app.tile_memory import process_memory
    from ..app.tiles import TiledWorld

    world = TiledWorld(args.seed, args.biome, args.detail, args.vegetation)
    cache = options.cache_of(args, "wildscan poses")
    covers = None if zone is None else (zone,)
    progress = PosesProgress()
    poses = endless_poses(world, region, args.count, covers, cache, process_memory(), progress=progress)
    progress.end()
    if args.json:
        doc = {"seed": args.seed, "layout": "endless", "detail": args.detail, "vegetation": args.vegetation}
        doc.update(biome=args.biome, region=region.to_dict(), poses=poses)
        print(json.dumps(doc, indent=1))
        return 0
    print("# cover        x          y        yaw   tilt  (scan with: --pose X Y YAW)")
    for p in poses:
        print(f"{p['cover']:<9} {p['x']:10.3f} {p['y']:10.3f} {p['yaw']:7.1f} {p['tilt_deg']:6.2f}")
    if len(poses) < args.count:
        print(f"# {len(poses)} of {args.count} found: little ground of that cover in the region fits a pose")
    return 0


class PosesProgress:
    """The pose search's progress on stderr (stdout keeps the table or JSON): on a terminal one
    updating line; in a log a line each time a pose is found or TILES_A_LINE more tiles are
    made, e.g. 'poses: 2 of 5 found, 31 candidates checked, 12 tiles (10 built, 2 from the
    cache) in 24.1 s'."""

    TILES_A_LINE = 4

    def __init__(self, stream=None):
        import sys

        self.stream = stream or sys.stderr
        self.tty = self.stream.isatty()
        self.said = (-1, 0)  # (found, tiles) at the last line written
        self.text = ""

    def __call__(self, found: int, count: int, checked: int, tiles) -> None:
        made = tiles.built + tiles.cache
        self.text = (
            f"poses: {found} of {count} found, {checked} candidates checked, {made} tiles ({tiles.built} "
            f"built, {tiles.cache} from the cache) in {tiles.seconds:.1f} s"
        )
        if self.tty:
            self.stream.write("\r" + self.text)
        elif found > self.said[0] or made >= self.said[1] + self.TILES_A_LINE:
            self.stream.write(self.text + "\n")
            self.said = (found, made)
        else:
            return
        self.stream.flush()

    def end(self) -> None:
        if self.tty and self.text:
            self.stream.write("\n")
            self.stream.flush()
