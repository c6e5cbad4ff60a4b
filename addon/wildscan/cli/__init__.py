"""The `wildscan` command (runs on the bpy wheel) and `blender -b -P blender_scripts/*.py -- …`,
which take the same arguments.

One registry of subcommands (COMMANDS); one module per command, each with its arguments
(`add_arguments`) and what it runs (`run`, calling app/ and bench/); the options they
share are declared once in options.py.

A user mistake ends with one line on stderr and exit code 2; nothing is written.
Ctrl-C (or SIGTERM) at any moment ends the run with exit code 130 (143), one line on
stderr saying which files it had completed (those stay; no temporary or partial file does).
"""

from __future__ import annotations

import os
import sys

# First of all, before any other import (argparse alone takes milliseconds, the rest a third
# of a second): a Ctrl-C from here on ends the run with one line and exit 130, not a
# traceback from inside an import. Only in the process of the `wildscan` script itself,
# never in one that imports this module (a test, an IDE). os and sys are loaded before any
# script runs; app/interrupts imports only the standard library's signal and contextlib.
if os.path.splitext(os.path.basename(sys.argv[0]))[0] == "wildscan":
    from ..app import interrupts

    interrupts.defer_until_dispatch()

import argparse  # noqa: E402
import errno  # noqa: E402
import shlex  # noqa: E402
import traceback  # noqa: E402
from collections.abc import Callable  # noqa: E402
from typing import NamedTuple  # noqa: E402

from .. import __version__  # noqa: E402
from ..app import interrupts  # noqa: E402
from ..app.interrupts import EXIT_INTERRUPTED, Interrupted, Terminated, stop_code, stopping_on_signals  # noqa: E402
from ..app.settings import command_line_message  # noqa: E402
from ..core.errors import UserError, shortened  # noqa: E402
from ..core.io.files import recording_written  # noqa: E402
from . import bench, dataset, demo, drive, extract, options, poses, scan, sensors, world  # noqa: E402
from .options import EXIT_USER_ERROR, ArgumentParser  # noqa: E402

__all__ = ["EXIT_INTERRUPTED", "blender_main", "build_parser", "main"]


MAX_LINE = 2000  # characters of an error line: a message quoting a huge value is cut, not printed whole

EPILOG = (
    "Paths: ~ expands in every path option (also in --opt=~/x), names longer than the file system "
    "allows are refused before any work. Exit codes: 0 done, 2 a mistake (one line, nothing written), "
    "130 Ctrl-C, 143 SIGTERM (one line saying which files were completed; no temporary or partial file), "
    "141 the reader of the output closed the pipe, 1 the output could not be written (e.g. a full disk)."
)


class Command(NamedTuple):
    help: str  # one line in `wildscan --help`
    description: str  # `wildscan COMMAND --help`
    add_arguments: Callable[[ArgumentParser, bool], None]  # (parser, in_blender)
    run: Callable[[argparse.Namespace, bool], int]  # (checked arguments, in_blender) -> exit code


COMMANDS: dict[str, Command] = {
    "world": Command(world.HELP, world.DESCRIPTION, world.add_arguments, world.run),
    "scan": Command(scan.HELP, scan.DESCRIPTION, scan.add_arguments, scan.run),
    "poses": Command(poses.HELP, poses.DESCRIPTION, poses.add_arguments, poses.run),
    "extract": Command(extract.HELP, extract.DESCRIPTION, extract.add_arguments, extract.run),
    "demo": Command(demo.HELP, demo.DESCRIPTION, demo.add_arguments, demo.run),
    "bench": Command(bench.HELP, bench.DESCRIPTION, bench.add_arguments, bench.run),
    "bench-world": Command(
        bench.WORLD_HELP, bench.WORLD_DESCRIPTION, bench.add_world_arguments, bench.run_world
    ),
    "sensors": Command(sensors.HELP, sensors.DESCRIPTION, sensors.add_arguments, sensors.run),
    "drive": Command(drive.HELP, drive.DESCRIPTION, drive.add_arguments, drive.run),
    "dataset": Command(dataset.HELP, dataset.DESCRIPTION, dataset.add_arguments, dataset.run),
    "bench-dataset": Command(
        dataset.BENCH_HELP, dataset.BENCH_DESCRIPTION, dataset.add_bench_arguments, dataset.run_bench
    ),
}


def build_parser(prog: str = "wildscan") -> ArgumentParser:
    """The `wildscan` parser: one sub-command per entry of COMMANDS."""
    parser = ArgumentParser(
        prog=prog,
        description="WildScan: labeled synthetic 3D laser scans of natural worlds, built in Blender.",
    )
    parser.add_argument("--version", action="version", version=f"wildscan {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=ArgumentParser)
    sub.required = True
    parser.command_parsers = {}
    for name, command in COMMANDS.items():
        p = sub.add_parser(name, help=command.help, description=command.description, epilog=EPILOG)
        command.add_arguments(p, False)
        parser.command_parsers[name] = p
    return parser


def build_blender_parser(command: str) -> ArgumentParser:
    """The parser of `blender -b [file.blend] -P blender_scripts/<command>.py -- ARGS`."""
    parser = ArgumentParser(
        prog=f"blender -b [file.blend] -P blender_scripts/{command}.py --",
        description=COMMANDS[command].description,
        epilog=EPILOG,
    )
    COMMANDS[command].add_arguments(parser, True)
    parser.set_defaults(command=command)
    parser.command_parsers = {command: parser}
    return parser


def dispatch(parser: ArgumentParser, argv: list[str], in_blender: bool) -> int:
    args = parser.parse_args(argv)  # a malformed command line exits 2 here, in one line
    where = f"blender_scripts/{args.command}.py" if in_blender else f"wildscan {args.command}"
    args.command_line = typed_command(argv, where, in_blender)  # `bench --markdown` records it
    with stopping_on_signals(), recording_written() as written:
        try:
            interrupts.started()  # a signal since the process began ends the run here
            options.apply_checks(parser.command_parsers[args.command], args)
            return COMMANDS[args.command].run(args, in_blender)
        except UserError as e:  # one line, however long a value it quotes (core/errors.shortened)
            sys.stderr.write(f"{where}: error: {shortened(command_line_message(e), MAX_LINE)}\n")
            return EXIT_USER_ERROR
        except Interrupted as e:  # a command that says itself what it completed
            sys.stderr.write(f"{where}: {e}\n")
            return e.code
        except (KeyboardInterrupt, Terminated) as stop:
            sys.stderr.write(f"{where}: {stopped_message(stop, written)}\n")
            return stop_code(stop)


def typed_command(argv: list[str], where: str, in_blender: bool) -> str:
    """The command as the user typed it (shell-quoted)."""
    if in_blender:
        return f"blender -b -P {where} -- {shlex.join(argv)}".rstrip()
    return shlex.join(["wildscan", *argv])


def stopped_message(stop: BaseException, written: list) -> str:
    """`interrupted; nothing written`, or which files were completed before the signal."""
    what = "terminated" if isinstance(stop, Terminated) else "interrupted"
    written = list(dict.fromkeys(written))  # a file rewritten (a dataset's bookkeeping) counts once
    if not written:
        return f"{what}; nothing written"
    folders = {p.parent for p in written}
    names = ", ".join(p.name if len(folders) == 1 else str(p) for p in written)
    where = f" in {written[0].parent}" if len(folders) == 1 else ""
    files = f"{len(written)} file{'s' if len(written) > 1 else ''}"
    return f"{what}; completed {files}{where} ({names}), nothing else"


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    where = f"wildscan {argv[0]}" if argv and argv[0] in COMMANDS else "wildscan"
    return with_stdout_checked(lambda: dispatch(build_parser(), argv, in_blender=False), where)


EXIT_PIPE_CLOSED = 141  # 128 + SIGPIPE: what a shell reports for a tool the closed pipe stopped


def with_stdout_checked(run: Callable[[], int], where: str) -> int:
    """`run()` with what it printed flushed, for every command in one place: a reader that
    closed the pipe (`wildscan poses | head -1`) ends the command quietly, as it does a Unix
    tool; a standard output that cannot take the text (`> /dev/full`) is one line, exit 1."""
    try:
        code = run()
        sys.stdout.flush()
        return code
    except BrokenPipeError:
        _silence_stdout()
        return EXIT_PIPE_CLOSED
    except OSError as e:
        if e.errno in (errno.EPIPE, errno.EBADF) or not _is_stdout_error(e):
            raise
        _silence_stdout()
        sys.stderr.write(f"{where}: error: cannot write to standard output: {e.strerror or e}\n")
        return 1


def _is_stdout_error(e: OSError) -> bool:
    """An error of writing the standard output (Python names no file for it), not of a file."""
    return e.filename is None and e.errno in (errno.ENOSPC, errno.EIO, errno.EDQUOT, errno.EFBIG)


def _silence_stdout() -> None:
    """Point the standard output at /dev/null, so the interpreter's own flush at exit finds
    nothing to write into the closed pipe (it would print 'Exception ignored ...')."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


def blender_main(command: str) -> int:
    """Entry for `blender -b [file.blend] -P blender_scripts/<command>.py -- ARGS`.

    Blender would print an escaping exception and still exit 0, so a bug ends
    here with its traceback and exit code 1."""
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else []
    where = f"blender_scripts/{command}.py"
    try:
        return with_stdout_checked(lambda: dispatch(build_blender_parser(command), argv, True), where)
    except Exception:
        traceback.print_exc()
        return 1
