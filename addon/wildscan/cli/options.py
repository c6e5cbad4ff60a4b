"""The options the commands share, declared once: flag (from app/settings.py), help, default,
and the check that turns what a user typed into a value.

argparse only parses; once it has, `apply_checks` runs the check of every option the
command declared, in order, and each raises UserError naming its setting, so every
command words a mistake the same way ("--seed must be a whole number ...").
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from collections.abc import Callable
from typing import Any, NamedTuple

from ..app.poses import DEFAULT_POSES_PER_ZONE, MAX_POSE_COUNT
from ..app.settings import SETTINGS, command_line_help, flag
from ..core.checks import DECIMAL, decimal, whole_number
from ..core.errors import UserError
from ..core.io.files import check_input_file, check_output_path
from ..core.sensors import SensorConfig, sweep_count
from ..core.sensors.config import DEFAULT_MODEL, REALISTIC_SETTINGS, SENSOR_SETTINGS
from ..core.spatial.frames import FRAMES
from ..core.world import (
    BIOMES,
    DEFAULT_BIOME,
    DEFAULT_VEGETATION,
    ZONES,
    check_biome,
    check_seed,
    check_vegetation,
    check_zone,
    detail_level,
)
from ..core.world.region import DEFAULT_LAYOUT, DEFAULT_REGION, LAYOUTS, MAX_REGION_SIDE, check_layout
from ..raycast.select import BACKEND_NAMES

EXIT_USER_ERROR = 2

# argparse takes "-1e3" for an option (it only knows -1 and -1.5 as numbers), and "-1,5"
# too, ending in "expected 3 arguments" for --pose: anything that starts like a negative
# number is a value, and its type says what is wrong with it.
NEGATIVE_NUMBER = re.compile(r"^-(\.?\d|inf(inity)?$|nan$)", re.IGNORECASE)


class ArgumentParser(argparse.ArgumentParser):
    """argparse that reports a mistake in one line (not usage + error) and exits 2, and
    keeps the checks of the options added with `add`."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER
        self.checks: list[tuple[str, Callable[[Any], Any]]] = []

    def error(self, message: str):
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        sys.exit(EXIT_USER_ERROR)


# ---------------------------------------------------------------------------------------
# argparse types: text to numbers


def finite_float(text: str) -> float:
    if not DECIMAL.fullmatch(text.strip(" ")):
        if DECIMAL.fullmatch(text.strip(" ").replace(",", ".", 1)):
            dotted = text.strip(" ").replace(",", ".", 1)
            raise argparse.ArgumentTypeError(
                f"expected a number with a decimal point, got {text!r} (write {dotted})"
            )
        raise argparse.ArgumentTypeError(
            f"expected a number (digits 0-9, a point for decimals), got {text!r}"
        )
    value = decimal(text.strip(" "))
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def non_negative_int(text: str) -> int:
    try:
        return whole_number(text, "", 0, 2**63 - 1)
    except UserError as e:
        raise argparse.ArgumentTypeError(e.message) from None


# ---------------------------------------------------------------------------------------
# the shared options


class Option(NamedTuple):
    setting: str  # its name in app/settings.py, which gives the flag
    kwargs: dict  # for add_argument; a command may override any of them
    check: Callable[[Any], Any] | None = None  # the parsed value -> the checked value


def input_file(setting: str, suffix: str) -> Callable[[str], str]:
    """The check of a path option naming a file to read: core/io/files.user_path reads it
    (`~` expanded, name lengths checked) and the file must exist and be readable."""
    return lambda text: str(check_input_file(text, (suffix,), setting))


def output_file(setting: str, suffix: str) -> Callable[[str], str]:
    """The check of a path option naming a file to write, the same one the app repeats."""
    return lambda text: str(check_output_path(text, suffix, setting))


def detail_name(name: str) -> str:
    detail_level(name)
    return name


def _count(setting: str, help: str) -> Option:
    """A number of poses per zone, 1..MAX_POSE_COUNT."""
    return Option(
        setting,
        dict(
            default=str(DEFAULT_POSES_PER_ZONE),
            metavar="N",
            help=f"{help} (default {DEFAULT_POSES_PER_ZONE})",
        ),
        lambda text: whole_number(text, setting, 1, MAX_POSE_COUNT),
    )


SEED_HELP = "world seed, a whole number from 0 to 2147483647"
DETAIL_HELP = "low | default | high"
VEGETATION_HELP = (
    "porous: tree crowns, bushes and high grass a beam can pass through (branches carrying leaf "
    "clusters, separate blades) in a closed-canopy forest; solid: closed shells in an open stand, the "
    "paper's look (exactly the worlds WildScan built before porous vegetation). Default porous"
)
BIOME_HELP = (
    f"{' | '.join(BIOMES)}: the mix of vegetation, ground cover (a sward a beam stops in) and "
    "deadwood; the zones are the same in every biome. paper: the world from before biomes, bare "
    f"ground, byte for byte (docs/ground.md). Default {DEFAULT_BIOME}"
)


LAYOUT_HELP = (
    f"{' | '.join(LAYOUTS)}: endless, a landscape without edges (forest, meadow, scrub, wetland, rock, "
    "trails, clearings in any order, built in tiles where they are needed); paper, the paper's 150 m "
    f"island of six zones (with --biome paper: the worlds of before, byte for byte). Default {DEFAULT_LAYOUT}"
)
REGION_HELP = (
    "the part of the world to build, metres in the world frame; each side at most "
    f"{MAX_REGION_SIDE:g} m (default: the {DEFAULT_REGION.xmax - DEFAULT_REGION.xmin:g} m square "
    f"around the origin, {DEFAULT_REGION.text()})"
)
LOD_HELP = (
    "on: tiles far from the sensor coarser, as fine as its beams resolve there, and the triangles none of "
    "its beams can meet left out (the same points; docs/scanning.md); off: every tile at full detail, "
    "every triangle cast against (default on)"
)


def _declared(setting: str) -> Option:
    """The option of a setting declared in full in app/settings.py: its type, default,
    allowed names, placeholder and help from there. A setting the device decides defaults to
    None (sensor_of gives the --sensor device's own), and its limits are the device's, so
    they are checked once the device is known (SensorConfig.validate), not here."""
    known = SETTINGS[setting]
    kwargs: dict[str, Any] = dict(default=known.default, help=command_line_help(setting))
    if known.choices is not None:
        return Option(setting, dict(kwargs, choices=known.choices))
    kwargs["metavar"] = known.metavar
    if known.kind is int:
        return Option(setting, kwargs, lambda text: whole_number(text, setting, 0, 2**63 - 1))
    return Option(setting, dict(kwargs, type=finite_float))


_SHARED = (
    Option("seed", dict(metavar="S", help=SEED_HELP), check_seed),
    Option(
        "detail",
        dict(default="default", metavar="LEVEL", help=f"{DETAIL_HELP} (default: default)"),
        detail_name,
    ),
    Option(
        "zone",
        dict(
            metavar="NAME",
            help="only this land cover (endless layout: forest, meadow, scrub, wetland, rock, trail, "
            f"clearing) or zone (paper layout: {', '.join(ZONES)}) (default: all)",
        ),
    ),
    Option(
        "vegetation", dict(default=DEFAULT_VEGETATION, metavar="KIND", help=VEGETATION_HELP), check_vegetation
    ),
    Option("biome", dict(default=DEFAULT_BIOME, metavar="NAME", help=BIOME_HELP), check_biome),
    Option("layout", dict(default=DEFAULT_LAYOUT, metavar="NAME", help=LAYOUT_HELP), check_layout),
    Option(
        "region",
        dict(nargs=4, type=finite_float, metavar=("XMIN", "YMIN", "XMAX", "YMAX"), help=REGION_HELP),
    ),
    Option("lod", dict(choices=("on", "off"), default="on", help=LOD_HELP)),
    _count("poses", "valid scan poses listed per zone in the sidecar"),
    _count("count", f"poses per zone, 1..{MAX_POSE_COUNT}"),
    Option(
        "pose",
        dict(
            nargs=3,
            type=finite_float,
            required=True,
            metavar=("X", "Y", "YAW"),
            help="where the robot stands: X, Y in metres (world frame, origin at the world centre) and "
            "YAW in degrees counter-clockwise from +X (the heading of the structure's X arm)",
        ),
    ),
    Option(
        "z_start",
        dict(
            type=finite_float,
            metavar="Z",
            help="world height in metres where the four downward placement lasers start; give one under "
            "an overhang (e.g. inside the cave). Default: found by a probe from above (the first terrain "
            "surface)",
        ),
    ),
    *(_declared(setting) for setting in SENSOR_SETTINGS),
    Option(
        "frame",
        dict(
            choices=FRAMES,
            default="leveled",
            help="coordinate frame of the points: leveled (origin at the optical centre, Z vertical, X "
            "along the heading; as the paper), sensor (tilted with the structure) or world (default "
            "leveled)",
        ),
    ),
    Option(
        "backend",
        dict(
            choices=BACKEND_NAMES,
            default="auto",
            help="ray caster: blender (scene.ray_cast, the reference), bvh (mathutils BVH tree), embree "
            "(embreex), or auto, the fastest available (default auto)",
        ),
    ),
    Option("out", dict(required=True)),
    # files read or written besides --out: checked up front like every path option
    Option("world", dict(metavar="FILE.blend"), input_file("world", ".blend")),
    Option("geometry", dict(metavar="SCENE.npz"), input_file("geometry", ".npz")),
    Option("map", dict(metavar="MAP.png"), output_file("map", ".png")),
)
OPTIONS: dict[str, Option] = {option.setting: option for option in _SHARED}
SENSOR_OPTIONS = SENSOR_SETTINGS
REALISTIC_ONLY = REALISTIC_SETTINGS


DEFAULT_RH = SensorConfig().rh_deg  # the default device's (a command that takes no --sensor)


def rh_alone(value: float) -> float:
    """r_h checked as the default device checks it, for a command that takes no other sensor
    option (SensorConfig.validate checks it for the others)."""
    sweep_count(value)
    return value


def add(parser: ArgumentParser, option: str | Option, group=None, **overrides) -> None:
    """Add a shared option (by name) or a command's own `Option` to `parser` (inside
    `group` when given), with some of its add_argument keywords overridden."""
    option = OPTIONS[option] if isinstance(option, str) else option
    (group or parser).add_argument(flag(option.setting), **{**option.kwargs, **overrides})
    if option.check is not None:
        parser.checks.append((option.setting, option.check))


def apply_checks(parser: ArgumentParser, args: argparse.Namespace) -> argparse.Namespace:
    """Replace each checked option's value by its check's result (None stays None)."""
    for dest, check in parser.checks:
        value = getattr(args, dest)
        if value is not None:
            setattr(args, dest, check(value))
    return args


def vegetation_of(args: argparse.Namespace) -> str:
    """The vegetation of the --seed world (default porous); a mistake without --seed (a saved
    world or geometry file has the vegetation it was built with)."""
    if args.vegetation is not None and args.seed is None:
        raise UserError("applies to a world built from {seed} only", setting="vegetation", related=("seed",))
    return args.vegetation or DEFAULT_VEGETATION


def region_of(args: argparse.Namespace):
    """The checked --region (core/world/region.py Region) of the command's layout; the default
    region (the 150 m square around the origin) when none is given."""
    from ..core.world.region import check_region

    if getattr(args, "region", None) is None:
        return DEFAULT_REGION
    return check_region(args.region, getattr(args, "layout", DEFAULT_LAYOUT))


def add_cache_arguments(p: argparse.ArgumentParser, what: str = "each world a worker builds") -> None:
    """--cache DIR | --no-cache, and --cache-size GB: the world cache (app/cache/)."""
    from ..app.cache.config import DEFAULT_MAX_GB

    cache = p.add_mutually_exclusive_group()
    cache.add_argument(
        "--cache",
        metavar="DIR",
        help=f"keep {what} in DIR, for every later run (default: $XDG_CACHE_HOME/wildscan, or "
        "~/.cache/wildscan; docs/datasets.md says how to clear it)",
    )
    cache.add_argument("--no-cache", action="store_true", help="build everything, keep nothing")
    p.add_argument(
        "--cache-size",
        type=_cache_size,
        metavar="GB",
        help="most gigabytes the world cache holds; the least recently used entries go first "
        f"(default {DEFAULT_MAX_GB:g})",
    )


def _cache_size(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a number of gigabytes above 0, got {text!r}")
    return value


def cache_of(args: argparse.Namespace, where: str):
    """The world cache the command's --cache / --no-cache / --cache-size name (a DiskCache),
    or None; a default folder that cannot be written is a warning on stderr, not an error."""
    from ..app.cache.config import cache_from_options, open_cache

    def warn(text: str) -> None:
        sys.stderr.write(f"{where}: warning: {text}\n")

    config = cache_from_options(args.cache, args.no_cache, args.cache_size, None, warn)
    return open_cache(config)


def zone_of(args: argparse.Namespace) -> str | None:
    """The checked --zone: a land cover on the endless layout, a zone on the paper's."""
    if args.zone is None:
        return None
    if getattr(args, "layout", DEFAULT_LAYOUT) == "paper":
        return check_zone(args.zone)
    from ..core.checks import one_of
    from ..core.world.endless import LAND_COVERS

    if args.zone in ZONES and args.zone not in LAND_COVERS:
        raise UserError(
            f"{args.zone!r} is a zone of {{layout}} paper; the endless layout's land covers are "
            f"{', '.join(LAND_COVERS)}",
            setting="zone",
            related=("layout",),
        )
    return one_of(args.zone, "zone", LAND_COVERS)


def biome_of(args: argparse.Namespace) -> str:
    """The biome of the --seed world (default mixed); a mistake without --seed (a saved world
    has the biome it was built with)."""
    if getattr(args, "biome", None) is not None and args.seed is None:
        raise UserError("applies to a world built from {seed} only", setting="biome", related=("seed",))
    return getattr(args, "biome", None) or DEFAULT_BIOME


# SensorConfig's name of each sensor setting a command line may leave to the device
_CONFIG_NAMES = {
    "rh": "rh_deg",
    "min_range": "min_range",
    "max_range": "max_range",
    "divergence": "divergence_mrad",
    "echoes": "echoes",
    "echo_separation": "echo_separation",
    "mount_height": "mount_height",
    "returns": "returns",
}


def sensor_of(args: argparse.Namespace) -> SensorConfig:
    """The sensor the sensor options describe (validated where it is used): the --sensor
    device (default the UTM-30LX-EW) with its own defaults where an option is not given; the
    realistic model's own options are a mistake with the paper model."""
    model = getattr(args, "model", DEFAULT_MODEL)
    given = {}
    for setting in REALISTIC_ONLY:
        value = getattr(args, setting, None)
        if value is None:
            continue
        if model != "realistic":
            raise UserError("applies to {model} realistic only", setting=setting, related=("model",))
        given[_CONFIG_NAMES[setting]] = value
    for setting in ("rh", "min_range", "max_range", "mount_height"):
        if getattr(args, setting, None) is not None:
            given[_CONFIG_NAMES[setting]] = getattr(args, setting)
    device = getattr(args, "device", None) or SensorConfig().device
    return SensorConfig.for_device(
        device, noise_sigma=args.noise, noise_seed=args.noise_seed, model=model, **given
    )
