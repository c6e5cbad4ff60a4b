"""`wildscan extract` and `blender -b [world.blend] -P blender_scripts/extract.py -- …`."""

from __future__ import annotations

import argparse

from ..core.errors import UserError
from . import options
from .options import ArgumentParser

HELP = "save a world's scan geometry to a file (scan it later without Blender)"
DESCRIPTION = (
    "Turn a world into the triangles a scan casts against, with their classes and instances, and save "
    "them as a .npz file: a region of the world of a seed (built without Blender; the endless layout's "
    "tiles at full detail, every triangle that meets the region), a saved .blend, or inside "
    "`blender -b file.blend -P blender_scripts/extract.py` the open file. `wildscan scan --geometry FILE` "
    "scans it without Blender and gives the same points as scanning the world itself."
)


def add_arguments(p: ArgumentParser, in_blender: bool = False) -> None:
    source = p.add_mutually_exclusive_group(required=not in_blender)
    options.add(p, "world", group=source, help="extract this .blend (any scene with tagged objects)")
    options.add(p, "seed", group=source, help=f"{options.SEED_HELP}: extract the world of this seed")
    options.add(p, "layout", default=None, help=f"with --seed: {options.LAYOUT_HELP}")
    options.add(p, "region", help=f"with --seed: {options.REGION_HELP}")
    options.add(p, "detail", help=f"{options.DETAIL_HELP}, with --seed (default: default)")
    options.add(p, "vegetation", default=None, help=f"with --seed: {options.VEGETATION_HELP}")
    options.add(p, "biome", default=None, help=f"with --seed: {options.BIOME_HELP}")
    options.add(p, "out", metavar="SCENE.npz", help="the geometry file to write")
    p.add_argument("--quiet", action="store_true", help="print only the file written")
    options.add_cache_arguments(p, "the endless world's tiles")


def run(args: argparse.Namespace, in_blender: bool = False) -> int:
    from ..app.geometry import extract
    from ..core.world.region import DEFAULT_LAYOUT
    from .output import Progress, say

    vegetation = options.vegetation_of(args)
    if args.seed is None and (args.layout is not None or args.region is not None):
        raise UserError(
            "applies to a world built from {seed} only",
            setting="layout" if args.layout else "region",
            related=("seed",),
        )
    args.layout = args.layout or DEFAULT_LAYOUT
    region = options.region_of(args)
    cache = options.cache_of(args, "wildscan extract") if args.seed is not None else None
    path, geometry, _, counts = extract(
        args.out,
        args.world,
        args.seed,
        args.detail,
        vegetation,
        args.quiet,
        options.biome_of(args),
        args.layout,
        region,
        cache,
        Progress("tiles", args.quiet),
    )
    if counts is not None:
        say(args, counts.text())
    say(args, f"{geometry.triangle_count:,} triangles of {len(geometry.object_names):,} objects")
    print(f"wrote {path}")
    return 0
