"""Opening and saving worlds (bpy). Thin: checks what a user could get wrong first."""

from __future__ import annotations

import os
import sys
from contextlib import contextmanager, nullcontext
from pathlib import Path

from ..core.errors import UserError
from ..core.io.files import check_input_file, remove_quietly
from ..core.runtime.signals import deferred

# First bytes of the .blend flavours Blender writes: plain, gzip, zstd.
BLEND_MAGICS = (b"BLENDER", b"\x1f\x8b", b"\x28\xb5\x2f\xfd")
# Blender keeps a file's path in a buffer of FILE_MAX = 1024 bytes, the final NUL included
# (BLI_path_util.h, 3.4 to 5.0): a longer path is cut short and the cut one "does not exist".
BLENDER_FILE_MAX = 1024


def check_blend_file(path: str) -> str:
    path = str(check_input_file(path, (".blend",), "world"))
    check_blender_path_length(path, "world")
    try:
        with open(path, "rb") as f:
            head = f.read(8)
    except OSError as e:
        raise UserError(f"{path}: cannot read it ({e.strerror})", setting="world") from None
    if not head.startswith(BLEND_MAGICS):
        raise UserError(f"{path}: not a Blender .blend file", setting="world")
    return path


@contextmanager
def quiet_stdout():
    """Silence what Blender's C code prints to file descriptor 1."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as devnull:
            os.dup2(devnull.fileno(), 1)
        yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def check_blender_path_length(path: str, setting: str, written_as: str | None = None) -> None:
    """UserError when Blender would cut `path` (absolute) short and not find the file;
    `written_as`: the longer name Blender really writes first (a temporary one)."""
    size, longest = len(os.fsencode(path)), len(os.fsencode(written_as or path))
    if longest >= BLENDER_FILE_MAX:
        raise UserError(
            f"{path}: the path is {size} bytes, too long for Blender, which reads and writes files by "
            f"paths of at most {BLENDER_FILE_MAX - 1 - (longest - size)} bytes here (its FILE_MAX): "
            "use a shorter path (move the file or link it from one)",
            setting=setting,
        )


def open_world(path: str, quiet: bool = False) -> None:
    """Open the .blend at `path`; `quiet`: without Blender's "Read blend: ..." line."""
    import bpy

    path = check_blend_file(path)
    try:
        # deferred: Blender swallows a KeyboardInterrupt raised in its load handlers
        with quiet_stdout() if quiet else nullcontext(), deferred():
            bpy.ops.wm.open_mainfile(filepath=path, load_ui=False)
    except RuntimeError as e:
        newer = newer_blender_than_this(path)
        if newer:
            raise UserError(f"{path}: {newer}", setting="world") from None
        first = str(e).strip().splitlines()[0] if str(e).strip() else "unknown error"
        raise UserError(f"{path}: Blender could not open it ({first})", setting="world") from None


def newer_blender_than_this(path: str) -> str | None:
    """Why this Blender could not open `path` when a newer Blender wrote it (Blender itself
    says only "not a blend file"), with how to make one it opens; None otherwise."""
    import bpy

    from .blend_header import blend_version

    written, running = blend_version(path), tuple(bpy.app.version[:2])
    if written is None or written <= running:
        return None
    return (
        f"written by Blender {written[0]}.{written[1]}, which this Blender {bpy.app.version_string} cannot "
        "open: build the world with this Blender itself (blender -b -P blender_scripts/world.py -- "
        "--seed S --out FILE.blend, run by this same blender binary), or scan this file with the newer "
        "Blender or the bpy wheel (wildscan scan --world FILE.blend)"
    )


def empty_scene() -> None:
    """Start from an empty factory scene so a seed-built world holds nothing else."""
    import bpy

    with deferred():  # Blender swallows a KeyboardInterrupt raised in its load handlers
        bpy.ops.wm.read_factory_settings(use_empty=True)


def scene_provenance() -> tuple[int | None, str | None]:
    """(seed, .blend path) of the world in the current file, for scan metadata: the
    seed WildScan recorded on its world collection, the file Blender has open."""
    import bpy

    from .mesh import WORLD_SEED_PROP, world_root

    root = world_root()
    seed = root.get(WORLD_SEED_PROP) if root is not None else None
    return (int(seed) if seed is not None else None), (bpy.data.filepath or None)


def save_blend(tmp: Path, final: Path) -> None:
    """Save the current file as a copy at `tmp`; Blender reports failure as RuntimeError.

    Blender writes `tmp@` and renames it to `tmp`: that file goes too when the save fails
    or a signal stops the run, and Blender's message is reworded to name `final`."""
    import bpy

    try:
        # quiet: Blender's own "Info: Saved copy as ..." line; deferred: Blender swallows a
        # KeyboardInterrupt raised in its save handlers
        with quiet_stdout(), deferred():
            bpy.ops.wm.save_as_mainfile(filepath=str(tmp), check_existing=False, copy=True, compress=True)
    except RuntimeError as e:
        raise UserError(f"cannot write {final}: {blender_save_reason(e, tmp)}") from None
    finally:
        remove_quietly([Path(f"{tmp}@")])


def blender_save_reason(error: RuntimeError, tmp: Path) -> str:
    """Why Blender could not save, without its temporary names or its "Error:" prefix."""
    lines = [line.strip() for line in str(error).strip().splitlines() if line.strip()]
    reason = (lines[0] if lines else "").removeprefix("Error:").strip()
    if str(tmp) in reason:  # "Cannot open file TMP@ for writing: REASON": keep the reason
        reason = reason.rsplit(":", 1)[-1].strip() if ":" in reason.split(str(tmp))[-1] else ""
    return reason or "Blender could not save it"
