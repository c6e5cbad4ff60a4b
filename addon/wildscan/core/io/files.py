"""Writing output files all-or-nothing (numpy-free, bpy-free).

Every file WildScan writes goes to a hidden temporary name beside its target
and is renamed into place only when everything it belongs with is written, so
a failed or interrupted command never leaves a partial cloud, map or world.
"""

from __future__ import annotations

import json
import os
from contextlib import contextmanager
from pathlib import Path

from ..errors import UserError


def check_output_path(
    path,
    suffix: str,
    setting: str = "out",
    companions: tuple[str, ...] = (),
    foreign_sidecar_key: str | None = None,
) -> Path:
    """The resolved output path, or UserError (naming `setting`) saying why it cannot be written.

    Called before any work so a typo in an output option costs nothing.
    `companions` are suffixes of files written beside it (a sidecar .json);
    an existing .json companion holding `foreign_sidecar_key` belongs to another
    kind of output (a world's, beside a scan named after it) and is not replaced.
    """
    if not str(path).strip():
        raise UserError(f"needs a file name ending in {suffix}, got an empty one", setting=setting)
    out = Path(path).expanduser().resolve()

    def fail(why: str) -> UserError:
        return UserError(f"{out}: {why}", setting=setting)

    if out.suffix.lower() != suffix:
        raise fail(f"the file name must end in {suffix}")
    if out.is_dir():
        raise fail(f"it is a directory; give a file name ending in {suffix}")
    for companion in companions:
        if out.with_suffix(companion).is_dir():
            raise fail(f"its sidecar {out.with_suffix(companion)} is a directory")
        if foreign_sidecar_key and _json_has_key(out.with_suffix(companion), foreign_sidecar_key):
            raise fail(
                f"{out.with_suffix(companion)} beside it describes another kind of output; "
                "choose another name so it is not replaced"
            )
    parent = out.parent
    if not parent.exists():
        raise fail(f"directory {parent} does not exist")
    if not parent.is_dir():
        raise fail(f"{parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise fail(f"directory {parent} is not writable")
    if out.exists() and not os.access(out, os.W_OK):
        raise fail("the file exists and is not writable")
    return out


def temp_path(final: Path) -> Path:
    """Beside the target (so os.replace is an atomic rename), hidden from globs like *.ply,
    and ending in the target's own suffix (Blender and matplotlib pick formats by it)."""
    return final.with_name(f".{final.stem}.tmp-{os.getpid()}{final.suffix}")


def remove_quietly(paths) -> None:
    for p in paths:
        try:
            os.unlink(p)
        except OSError:
            pass  # already gone, or cleanup failing: never hide the original error


def fsync_dir(directory: Path) -> None:
    """Make renames durable where the platform allows it."""
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _json_has_key(path: Path, key: str) -> bool:
    try:
        return key in json.loads(path.read_text())
    except (OSError, ValueError, TypeError):
        return False


def output_directory(text, setting: str = "out") -> Path:
    """A directory to write into, created (with its parents) if missing, or UserError."""
    if not str(text).strip():
        raise UserError("needs a directory name, got an empty one", setting=setting)
    out = Path(str(text)).expanduser().resolve()
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: it is a file; give a directory", setting=setting)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"{out}: cannot create the directory ({e.strerror or e})", setting=setting) from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise UserError(f"{out}: directory is not writable", setting=setting)
    return out


@contextmanager
def atomic_outputs(*finals: Path):
    """Yield one temporary path per target; rename them all into place when the block
    succeeds, and leave none of them (temporary or final) when anything fails."""
    finals = tuple(Path(p) for p in finals)
    temps = [temp_path(p) for p in finals]
    placed: list[Path] = []
    try:
        yield temps
        for tmp, final in zip(temps, finals, strict=True):
            os.replace(tmp, final)
            placed.append(final)
    except OSError as e:  # a full disk, a path the OS refuses: the user's to fix
        remove_quietly([*temps, *placed])
        raise UserError(f"cannot write {_target_of(e.filename, temps, finals)}: {e.strerror or e}") from None
    except BaseException:  # KeyboardInterrupt too
        remove_quietly([*temps, *placed])
        raise
    for directory in {p.parent for p in finals}:
        fsync_dir(directory)


def _target_of(filename, temps, finals) -> Path:
    """The file the user asked for, when an error names its temporary stand-in."""
    for tmp, final in zip(temps, finals):
        if filename is not None and Path(filename) == tmp:
            return final
    return Path(filename) if filename else finals[0]


def write_durably(path: Path, write) -> None:
    """Open `path`, let `write(f)` fill it, and fsync before the caller renames it."""
    with open(path, "wb") as f:
        write(f)
        f.flush()
        os.fsync(f.fileno())
