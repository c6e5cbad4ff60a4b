"""`wildscan world` and `blender -b -P blender_scripts/world.py -- …`."""

from __future__ import annotations

import argparse

from . import options
from .options import ArgumentParser

HELP = "build a world from a seed and save it"
DESCRIPTION = (
    "Build the natural world of a seed, tagged for the scanner, and save it as a .blend with a JSON sidecar "
    "listing valid scan poses, and optionally an aerial map. Endless layout (the default): a --region of a "
    "landscape without edges (forest, meadow, scrub, wetland, rock, trails, clearings), its poses per land "
    "cover. Paper layout: the paper's 150 m island of six zones (hills, forest, park with power line, "
    "trail, lake, cave), its poses per zone."
)


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    options.add(
        p,
        "seed",
        required=True,
        help=f"{options.SEED_HELP}; every seed gives another world",
    )
    options.add(p, "layout")
    options.add(
        p, "region", help=f"{options.REGION_HELP}; the paper layout's world is always the whole island"
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
    options.add(p, "poses", help="valid scan poses listed per zone (endless: per land cover) in the sidecar")
    p.add_argument("--quiet", action="store_true", help="print only the files written")
    options.add_cache_arguments(p, "the endless world's tiles (for the poses)")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    from ..app.world import make_world
    from ..core.errors import UserError
    from ..core.world.region import DEFAULT_REGION
    from .output import StageProgress

    region = options.region_of(args)
    if args.layout == "paper" and region != DEFAULT_REGION:
        raise UserError(
            "applies to {layout} endless: the paper layout's world is the whole island (extract and "
            "poses take a region of it)",
            setting="region",
            related=("layout",),
        )
    cache = options.cache_of(args, "wildscan world") if args.layout == "endless" else None
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
        layout=args.layout,
        region=region,
        cache=cache,
    )
    print_saved_world(saved, args.quiet, region if args.layout == "endless" else None)
    return 0


def print_saved_world(saved, quiet: bool = False, region=None) -> None:
    """What `wildscan world` (and the demo) say about a world built and saved (`region`: of
    the endless layout; None: the paper's island)."""
    if not quiet:
        counts = saved.plan.counts()
        where = (
            "the paper layout's island" if region is None else f"the endless layout, region {region.text()}"
        )
        plan = saved.plan
        print(
            f"world of seed {plan.seed}, {where} ({plan.detail.name} detail, {plan.vegetation} "
            f"vegetation, {plan.biome} biome): {counts['objects']:,} "
            f"objects sharing {counts['meshes']} meshes, {counts['triangles']:,} triangles, "
            f"built and saved in {saved.seconds:.1f} s"
        )
    print(f"wrote {saved.blend}")
    print(f"wrote {saved.sidecar}")
    if saved.map is not None:
        print(f"wrote {saved.map}")
