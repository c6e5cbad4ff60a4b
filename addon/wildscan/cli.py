"""The `wildscan` command (runs on the bpy wheel) and the argument handling that
`blender -b -P blender_scripts/*.py -- …` shares with it.

A user mistake ends with one line on stderr and exit code 2; nothing is written.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import traceback

from . import __version__
from .core import sensor as S
from .core.errors import UserError
from .core.scan import FRAMES
from .raycast.select import BACKEND_NAMES

EXIT_USER_ERROR = 2


# argparse takes "-1e3" for an option (it only knows -1 and -1.5 as numbers).
NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


class ArgumentParser(argparse.ArgumentParser):
    """argparse that reports a mistake in one line (not usage + error) and exits 2."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = NEGATIVE_NUMBER

    def error(self, message: str):
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        sys.exit(EXIT_USER_ERROR)


def finite_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def non_negative_int(text: str) -> int:
    from .core.checks import whole_number

    try:
        return whole_number(text, "", 0, 2**63 - 1)
    except UserError as e:
        raise argparse.ArgumentTypeError(str(e).strip()) from None


def world_seed(text: str) -> int:
    from .core.worldplan import check_seed

    try:
        return check_seed(text)
    except UserError as e:
        raise argparse.ArgumentTypeError(str(e).removeprefix("--seed ")) from None


def add_scan_arguments(p: argparse.ArgumentParser, in_blender: bool) -> None:
    source = p.add_mutually_exclusive_group(required=not in_blender)
    source.add_argument(
        "--world", metavar="FILE.blend", help="scan this saved world (or any .blend with tagged objects)"
    )
    source.add_argument(
        "--seed",
        type=world_seed,
        metavar="S",
        help="build the world from this seed (integer from 0 to 2147483647) and scan it",
    )
    p.add_argument(
        "--pose",
        nargs=3,
        type=finite_float,
        required=True,
        metavar=("X", "Y", "YAW"),
        help="where the robot stands: X, Y in metres (world frame, origin at the world centre) and "
        "YAW in degrees counter-clockwise from +X (the heading of the structure's X arm)",
    )
    p.add_argument(
        "--z-start",
        type=finite_float,
        metavar="Z",
        help="world height in metres where the four downward placement lasers start; give one under an "
        "overhang (e.g. inside the cave). Default: found by a probe from above (the first terrain surface)",
    )
    p.add_argument(
        "--rh",
        type=finite_float,
        default=S.DEFAULT_RH_DEG,
        metavar="DEG",
        help=f"horizontal resolution r_h in degrees, at least {S.MIN_RH_DEG:g}; 180/r_h must be whole (default {S.DEFAULT_RH_DEG:g}: "
        "180 2D scans, 194,400 beams)",
    )
    p.add_argument(
        "--min-range",
        type=finite_float,
        default=S.DEFAULT_MIN_RANGE,
        metavar="M",
        help=f"shortest range kept, metres (default {S.DEFAULT_MIN_RANGE:g})",
    )
    p.add_argument(
        "--max-range",
        type=finite_float,
        default=S.DEFAULT_MAX_RANGE,
        metavar="M",
        help=f"longest range kept, metres, at most {S.MAX_RANGE_LIMIT:g} (default {S.DEFAULT_MAX_RANGE:g}, the "
        "UTM-30LX-EW under sunlight)",
    )
    p.add_argument(
        "--noise",
        type=finite_float,
        default=S.DEFAULT_NOISE_SIGMA,
        metavar="SIGMA",
        help=f"standard deviation of the Gaussian range noise, metres, 0 (off) to {S.MAX_NOISE_SIGMA:g} (default {S.DEFAULT_NOISE_SIGMA:g})",
    )
    p.add_argument(
        "--noise-seed",
        type=non_negative_int,
        default=0,
        metavar="N",
        help="seed of the range noise, independent of the world seed (default 0)",
    )
    p.add_argument(
        "--frame",
        choices=FRAMES,
        default="leveled",
        help="coordinate frame of the points: leveled (origin at the optical centre, Z vertical, X along the "
        "heading; as the paper), sensor (tilted with the structure) or world (default leveled)",
    )
    p.add_argument(
        "--backend",
        choices=BACKEND_NAMES,
        default="auto",
        help="ray caster: blender (scene.ray_cast, the reference), bvh (mathutils BVH tree), embree (embreex), "
        "or auto, the fastest available (default auto)",
    )
    p.add_argument("--ascii", action="store_true", help="write an ASCII PLY instead of binary little-endian")
    p.add_argument(
        "--out",
        required=True,
        metavar="SCAN.ply",
        help="the labeled point cloud to write; its metadata goes beside it as SCAN.json",
    )
    p.add_argument("--quiet", action="store_true", help="print only the files written, no progress")


COMMAND_HELP = {
    "scan": (
        "scan a world from a pose and write a labeled PLY",
        "Stand the emulated Hokuyo UTM-30LX-EW on the ground at a pose, turn it 180 deg in steps of r_h, "
        "and write every returned point with its class to a PLY (plus a JSON sidecar).",
    ),
}
ADD_ARGUMENTS = {"scan": add_scan_arguments}


def _register_world_commands() -> None:
    from . import demo, world_cli

    for name, (add, run, short) in world_cli.COMMANDS.items():
        COMMAND_HELP[name] = (short, world_cli.DESCRIPTIONS[name])
        ADD_ARGUMENTS[name] = add
        COMMANDS[name] = run
    COMMAND_HELP["demo"] = (
        "build the default world, its map, and scan every zone",
        "Build the world of a seed with its aerial map, then scan one valid pose in every zone (hills by the "
        "power line, forest, park, lake shore, cave, trail), writing a PLY and an oblique preview image per scan.",
    )
    ADD_ARGUMENTS["demo"] = demo.add_demo_arguments
    COMMANDS["demo"] = demo.run_demo


def _register_bench_command() -> None:
    from . import bench

    COMMAND_HELP["bench"] = (
        "time and check every ray backend against scene.ray_cast",
        "Measure scan time (median of several runs, side by side) and accuracy of every ray backend on the test "
        "world, analytic primitives and the default world at each detail level, print ratios against "
        "scene.ray_cast and scaling tables, and write a CSV and a chart of time against error.",
    )
    ADD_ARGUMENTS["bench"] = bench.add_bench_arguments
    COMMANDS["bench"] = bench.run_bench_command


def _register_dataset_commands() -> None:
    from . import cli_dataset

    for name, (short, long, add, run) in cli_dataset.COMMANDS.items():
        COMMAND_HELP[name], ADD_ARGUMENTS[name], COMMANDS[name] = (short, long), add, run


ALL_COMMANDS = ("world", "scan", "poses", "demo", "bench", "bench-world", "dataset", "bench-dataset")


def build_parser(prog: str = "wildscan", commands=ALL_COMMANDS) -> ArgumentParser:
    """The `wildscan` parser: one sub-command per entry of `commands`."""
    parser = ArgumentParser(
        prog=prog,
        description="WildScan: labeled synthetic 3D laser scans of natural worlds, built in Blender.",
    )
    parser.add_argument("--version", action="version", version=f"wildscan {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=ArgumentParser)
    sub.required = True
    for command in commands:
        short, long = COMMAND_HELP[command]
        ADD_ARGUMENTS[command](sub.add_parser(command, help=short, description=long), False)
    return parser


def build_blender_parser(command: str) -> ArgumentParser:
    """The parser of `blender -b [file.blend] -P blender_scripts/<command>.py -- ARGS`."""
    parser = ArgumentParser(
        prog=f"blender -b [file.blend] -P blender_scripts/{command}.py --",
        description=COMMAND_HELP[command][1],
    )
    ADD_ARGUMENTS[command](parser, True)
    parser.set_defaults(command=command)
    return parser


class Progress:
    """Progress on stderr: one updating line on a terminal, a few lines in a log."""

    def __init__(self, label: str, quiet: bool = False):
        self.label = label
        self.quiet = quiet
        self.tty = sys.stderr.isatty()
        self.last_tenth = -1

    def __call__(self, done: int, total: int) -> None:
        if self.quiet or total <= 0:
            return
        tenth = (10 * done) // total
        if self.tty:
            sys.stderr.write(f"\r{self.label}: {100 * done // total:3d}% ({done:,}/{total:,})")
            if done >= total:
                sys.stderr.write("\n")
        elif tenth > self.last_tenth:
            sys.stderr.write(f"{self.label}: {100 * done // total}% ({done:,}/{total:,})\n")
        self.last_tenth = tenth
        sys.stderr.flush()


def say(args, text: str) -> None:
    if not getattr(args, "quiet", False):
        print(text, flush=True)


def print_class_counts(counts: dict[int, int]) -> None:
    from .core.classes import BY_ID

    for class_id in sorted(counts):
        print(f"  {class_id:2d} {BY_ID[class_id].name:<11} {counts[class_id]:>9,}")


def run_scan_command(args, in_blender: bool) -> int:
    from .core.placement import Pose, check_z_start
    from .core.ply import check_output_path, sidecar_path, write_scan_files
    from .core.sensor import SensorConfig
    from .scanning import scan_current_scene
    from .world.scene_io import scene_provenance

    sensor = SensorConfig(
        rh_deg=args.rh,
        min_range=args.min_range,
        max_range=args.max_range,
        noise_sigma=args.noise,
        noise_seed=args.noise_seed,
    ).validate()
    pose = Pose(*args.pose).validate()
    check_z_start(args.z_start)
    out = check_output_path(args.out)

    load_world_for_scan(args, in_blender)
    result = scan_current_scene(
        pose,
        sensor,
        args.frame,
        args.z_start,
        args.backend,
        progress=Progress("scanning", args.quiet),
        notify=print,  # a backend fallback is news, not an error: stderr stays for the one error line
    )
    seed, blend = scene_provenance()
    metadata = dict(result.metadata, seed=seed if args.seed is None else args.seed, world=blend)
    ply, sidecar = write_scan_files(out, result.cloud, metadata, ascii=args.ascii)
    assert sidecar == sidecar_path(out)

    p = result.placement
    say(
        args,
        f"placed at ({p.optical_centre[0]:.3f}, {p.optical_centre[1]:.3f}, {p.optical_centre[2]:.3f}) "
        f"roll {p.roll_deg:.2f} deg, pitch {p.pitch_deg:.2f} deg",
    )
    print(f"wrote {ply} ({len(result.cloud):,} points of {result.beams:,} beams, frame {args.frame})")
    print(f"wrote {sidecar}")
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


def load_world_for_scan(args, in_blender: bool) -> None:
    from .world.scene_io import empty_scene, open_world

    if args.world is not None:
        open_world(args.world)
    elif args.seed is not None:
        from .world.generate import generate_world
        from .world_cli import StageProgress

        empty_scene()
        say(args, f"building the world of seed {args.seed}")
        generate_world(args.seed, progress=StageProgress(args.quiet))
    elif not in_blender:
        raise UserError("give --world FILE.blend or --seed S")


COMMANDS = {"scan": run_scan_command}
_register_world_commands()
_register_bench_command()
_register_dataset_commands()


def dispatch(parser: ArgumentParser, argv: list[str], in_blender: bool) -> int:
    args = parser.parse_args(argv)
    where = f"blender_scripts/{args.command}.py" if in_blender else f"wildscan {args.command}"
    try:
        return COMMANDS[args.command](args, in_blender)
    except UserError as e:
        sys.stderr.write(f"{where}: error: {e}\n")
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        sys.stderr.write(f"{where}: interrupted; nothing written\n")
        return 130


def main(argv: list[str] | None = None) -> int:
    return dispatch(build_parser(), sys.argv[1:] if argv is None else argv, in_blender=False)


def blender_main(command: str) -> int:
    """Entry for `blender -b [file.blend] -P blender_scripts/<command>.py -- ARGS`.

    Blender would print an escaping exception and still exit 0, so a bug ends
    here with its traceback and exit code 1."""
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    try:
        return dispatch(build_blender_parser(command), argv, in_blender=True)
    except Exception:
        traceback.print_exc()
        return 1


if __name__ == "__main__":
    sys.exit(main())
