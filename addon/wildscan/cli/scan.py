"""`wildscan scan` and `blender -b [world.blend] -P blender_scripts/scan.py -- …`."""

from __future__ import annotations

import argparse

from ..core.errors import UserError
from . import options
from .effects import effect_values
from .options import ArgumentParser

HELP = "scan a world from a pose and write a labeled PLY (or LAS, SemanticKITTI)"
DESCRIPTION = (
    "Stand the emulated Hokuyo UTM-30LX-EW (or the --sensor device: `wildscan sensors` lists the presets) "
    "on the ground at a pose, turn it 180 deg in steps of r_h (a spinning lidar: one revolution), and write "
    "every returned point with its class to a PLY (plus a JSON sidecar), or in another format with --format."
)


def _format_help() -> str:
    from ..core.io.formats import DEFAULT_FORMAT, WRITERS

    files = "; ".join(
        f"{name}: {' + '.join('SCAN' + f.suffix for f in w.scan_files)}" for name, w in WRITERS.items()
    )
    return (
        f"file format (default {DEFAULT_FORMAT}); --out names the first file, the others go beside it: "
        f"{files}. SemanticKITTI's .label carries SemanticKITTI's class ids, LAS the ASPRS classes and "
        "WildScan's ids"
    )


def add_arguments(p: ArgumentParser, in_blender: bool) -> None:
    source = p.add_mutually_exclusive_group(required=not in_blender)
    options.add(
        p,
        "world",
        group=source,
        help="scan this saved world (or any .blend with tagged objects)",
    )
    options.add(
        p,
        "seed",
        group=source,
        help="scan the world of this seed (integer from 0 to 2147483647): on the endless layout (the "
        "default) the tiles within the sensor's reach, anywhere, built or read from the world cache; "
        "with --layout paper the paper's island, built in Blender",
    )
    options.add(
        p,
        "geometry",
        group=source,
        help="scan a geometry file saved by `wildscan extract` (no Blender needed; backend embree or bvh)",
    )
    options.add(p, "vegetation", default=None, help=f"with --seed: {options.VEGETATION_HELP}")
    options.add(p, "biome", default=None, help=f"with --seed: {options.BIOME_HELP}")
    options.add(p, "layout", default=None, help=f"with --seed: {options.LAYOUT_HELP}")
    options.add(p, "lod", default=None, help=f"with --seed on the endless layout: {options.LOD_HELP}")
    options.add_cache_arguments(p, "the endless world's tiles")
    from .sensors import add_sensor

    for name in ("pose", "z_start"):
        options.add(p, name)
    add_sensor(p)
    for name in (*options.SENSOR_OPTIONS, "frame", "backend"):
        options.add(p, name)
    from .effects import add_effects

    add_effects(p)
    from ..core.io.formats import DEFAULT_FORMAT, FORMATS

    p.add_argument("--format", choices=FORMATS, default=DEFAULT_FORMAT, help=_format_help())
    p.add_argument("--ascii", action="store_true", help="write an ASCII PLY instead of binary little-endian")
    options.add(
        p,
        "out",
        metavar="SCAN.ply",
        help="the labeled point cloud to write, ending in the format's suffix (.ply, .las, .bin); a PLY's "
        "metadata goes beside it as SCAN.json",
    )
    p.add_argument(
        "--range-image",
        metavar="IMAGE.npz",
        help="also write the scan's range image on its native grid (rows: rings, the beams of a "
        "column; columns: 2D scans or firings; docs/formats.md)",
    )
    p.add_argument("--quiet", action="store_true", help="print only the files written, no progress")


def _layout_of(args: argparse.Namespace) -> str | None:
    """The layout of the --seed world (default endless); None for a saved world or geometry,
    where --layout, --lod are a mistake."""
    if args.seed is None:
        for name in ("layout", "lod"):
            if getattr(args, name) is not None:
                raise UserError("applies to a world built from {seed} only", setting=name, related=("seed",))
        return None
    from ..core.world.region import DEFAULT_LAYOUT

    if args.lod is not None and args.layout == "paper":
        raise UserError(
            "applies to {layout} endless only (the paper's island is built whole)",
            setting="lod",
            related=("layout",),
        )
    return args.layout or DEFAULT_LAYOUT


def _endless_geometry(args, pose, sensor, biome: str, vegetation: str, lod: str):
    """The tiles a scan from `pose` reaches, and the metadata its files carry."""
    from ..app.geometry import GEOMETRY_BACKENDS
    from ..app.scan import endless_scan_geometry
    from ..app.tile_memory import process_memory
    from .output import Progress, say

    if args.backend not in GEOMETRY_BACKENDS:
        raise UserError(
            f"{args.backend} needs a Blender scene; the endless world is scanned from its tiles with "
            f"{', '.join(GEOMETRY_BACKENDS)} (or build a region with `wildscan world` and scan the .blend)",
            setting="backend",
            allowed=GEOMETRY_BACKENDS,
        )
    cache = options.cache_of(args, "wildscan scan")
    say(args, f"the endless world of seed {args.seed} around ({pose.x:g}, {pose.y:g}), level of detail {lod}")
    geometry, counts = endless_scan_geometry(
        args.seed,
        pose,
        sensor,
        lod == "on",
        biome,
        vegetation,
        cache=cache,
        memory=process_memory(),
        progress=Progress("tiles", args.quiet),
        backend=args.backend,
        z_start=args.z_start,
    )
    say(args, counts.text())
    return geometry, {"layout": "endless", "biome": biome, "vegetation": vegetation, "lod": lod}


def run(args: argparse.Namespace, in_blender: bool) -> int:
    from ..app.geometry import load_scan_geometry
    from ..app.scan import check_range_image, check_scan, open_scan_world, scan_current_scene, write_scan
    from ..blender.scene_io import scene_provenance
    from ..core.placement import Pose
    from .output import Progress, StageProgress, print_class_counts, print_echo_summary, say

    pose, sensor, vegetation = Pose(*args.pose), options.sensor_of(args), options.vegetation_of(args)
    biome, layout, lod = options.biome_of(args), _layout_of(args), args.lod or "on"
    out = check_scan(pose, sensor, args.z_start, args.out, args.format, args.ascii)
    range_image = check_range_image(args.range_image, out, args.format)
    geometry, provenance = None, {}
    if args.geometry is not None:
        geometry, provenance = load_scan_geometry(args.geometry, args.backend)
    elif layout == "endless":
        geometry, provenance = _endless_geometry(args, pose, sensor, biome, vegetation, lod)
    elif args.seed is not None:
        say(args, f"building the world of seed {args.seed} (paper layout)")
    if geometry is None:
        open_scan_world(
            args.world,
            args.seed,
            StageProgress(args.quiet),
            vegetation=vegetation,
            quiet=args.quiet,
            biome=biome,
        )
    if layout == "endless":
        seed, blend, extra = args.seed, None, provenance
    elif geometry is not None:
        seed, blend = provenance.get("seed"), provenance.get("world")
        extra = {"geometry": provenance["geometry"]}
    else:
        seed, blend = scene_provenance()
        extra = {}
    seed = seed if args.seed is None else args.seed
    result = scan_current_scene(
        pose,
        sensor,
        args.frame,
        args.z_start,
        args.backend,
        progress=Progress("scanning", args.quiet),
        notify=print,  # a backend fallback is news, not an error: stderr stays for the one error line
        geometry=geometry,
        weather=args.weather,
        effects=effect_values(args),
        world_seed=seed or 0,  # the surfaces' reflectances the detection step weighs
    )
    first, *beside = write_scan(
        out, result, seed, blend, ascii=args.ascii, fmt=args.format, range_image=range_image, **extra
    )

    p = result.placement
    say(
        args,
        f"placed at ({p.optical_centre[0]:.3f}, {p.optical_centre[1]:.3f}, {p.optical_centre[2]:.3f}) "
        f"roll {p.roll_deg:.2f} deg, pitch {p.pitch_deg:.2f} deg",
    )
    print(f"wrote {first} ({len(result.cloud):,} points of {result.beams:,} beams, frame {args.frame})")
    if sensor.realistic and not args.quiet:
        print_echo_summary(result.metadata["echoes"], len(result.cloud))
    for path in beside:
        print(f"wrote {path}")
    if not args.quiet:
        print_class_counts(result.cloud.class_counts())
    untagged = len(result.untagged_objects)
    if untagged:
        names = ", ".join(sorted(result.untagged_objects)[:5])
        print(
            f"untagged objects hit: {untagged} ({names}{', …' if untagged > 5 else ''}); their points are "
            "labeled 0 (unlabeled): add the wildscan_class property to tag them"
        )
    else:
        say(args, "untagged objects hit: 0")
    return 0
