"""`wildscan world` and `blender -b -P blender_scripts/world.py -- …`."""

from __future__ import annotations

import argparse

from . import options
from .options import ArgumentParser

HELP = "build a world from a seed and save it"
DESCRIPTION = (
    "Build the natural world of a seed (hills, forest, park with power line, trail, lake, cave), tagged "
    "for the scanner, save it as a .blend with a JSON sidecar listing zones and valid scan poses, and "
    "optionally an aerial map."
)


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    options.add(
        p,
        "seed",
        required=True,
        help=f"{options.SEED_HELP}; every seed gives another world with all six zones",
    )
    options.add(
        p,
        "detail",
        help=f"{options.DETAIL_HELP}: how finely shapes are modelled (terrain height tolerance "
        "0.15 / 0.05 / 0.02 m); the layout is the same at every level (default: default)",
    )
    options.add(
        p,
        "out",
        metavar="WORLD.blend",
        help="the Blender file to write; zones and scan poses go beside it as WORLD.json",
    )
    options.add(
        p,
        "map",
        help="also write an aerial map (classes in colour, zones, poses); "
        "needs matplotlib, which the bpy wheel's venv has and Debian's Blender does not",
    )
    options.add(p, "vegetation")
    options.add(p, "biome")
    options.add(p, "poses")
    p.add_argument("--quiet", action="store_true", help="print only the files written")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    from ..app.world import make_world
    from .output import StageProgress

    saved = make_world(
        args.seed,
        args.detail,
        args.out,
        args.map,
        args.poses,
        StageProgress(args.quiet),
        fresh=not in_blender,
        vegetation=args.vegetation,
        biome=args.biome,
    )
    print_saved_world(saved, args.quiet)
    return 0


def print_saved_world(saved, quiet: bool = False) -> None:
    """What `wildscan world` (and the demo) say about a world built and saved."""
    if not quiet:
        counts = saved.plan.counts()
        print(
            f"world of seed {saved.plan.seed} ({saved.plan.detail.name} detail, {saved.plan.vegetation} "
            f"vegetation, {saved.plan.biome} biome): {counts['objects']:,} "
            f"objects sharing {counts['meshes']} meshes, {counts['triangles']:,} triangles, "
            f"built and saved in {saved.seconds:.1f} s"
        )
    print(f"wrote {saved.blend}")
    print(f"wrote {saved.sidecar}")
    if saved.map is not None:
        print(f"wrote {saved.map}")
