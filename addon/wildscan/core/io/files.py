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
from ..runtime.pause import pause_here
from ..runtime.signals import check_host_break

DEFAULT_NAME_MAX = 255  # bytes in one file name, where the file system does not say
# Room kept in a temporary name for what a writer adds to it (Blender saves NAME@, then renames).
TEMP_NAME_SLACK = 1


# ---------------------------------------------------------------------------------------
# paths as users type them: every path option goes through user_path


def user_path(text, setting: str, what: str = "a file name") -> Path:
    """The absolute path a user means by `text` (`~` and `~user` expanded, relative to the
    working directory), or UserError naming `setting`: empty, or a name in it longer than
    the file system allows. Every path option of every command reads its value here."""
    if not str(text).strip():
        raise UserError(f"needs {what}, got an empty one", setting=setting)
    path = Path(os.path.expanduser(os.fspath(text)))
    try:
        path = path.resolve()
    except (OSError, RuntimeError):  # a symlink loop: keep the absolute path, checks below say why
        path = Path(os.path.abspath(path))
    for part in path.parts[1:]:
        if len(os.fsencode(part)) > name_max(path.parent):
            raise UserError(
                f"{path}: the name {_short(part)} is {len(os.fsencode(part))} bytes, longer than "
                f"the {name_max(path.parent)} the file system allows",
                setting=setting,
            )
    return path


def name_max(directory: Path) -> int:
    """The longest file name (bytes) allowed in `directory` (or its nearest existing parent)."""
    for d in (directory, *directory.parents):
        try:
            return os.pathconf(d, "PC_NAME_MAX")
        except (OSError, ValueError):
            continue
    return DEFAULT_NAME_MAX


def _short(name: str) -> str:
    return repr(name) if len(name) <= 40 else repr(name[:20] + "…" + name[-12:])


def check_input_file(text, suffixes: tuple[str, ...], setting: str) -> Path:
    """An existing, readable file a path option names (for --world, --geometry, a spec)."""
    path = user_path(text, setting)

    def fail(why: str) -> UserError:
        return UserError(f"{path}: {why}", setting=setting)

    try:
        if path.is_dir():
            raise fail(f"is a directory, not a {' or '.join(suffixes)} file")
        if not path.is_file():
            raise fail("no such file")
        if not os.access(path, os.R_OK):
            raise fail("cannot read it (permission denied)")
    except OSError as e:
        raise fail(f"cannot read it ({e.strerror or e})") from None
    return path


def check_output_path(
    path,
    suffix: str,
    setting: str = "out",
    companions: tuple[str, ...] = (),
    foreign_sidecar_key: str | tuple[str, ...] | None = None,
) -> Path:
    """The resolved output path, or UserError (naming `setting`) saying why it cannot be written.

    Called before any work so a typo in an output option costs nothing.
    `companions` are suffixes of files written beside it (a sidecar .json);
    an existing .json companion holding `foreign_sidecar_key` belongs to another
    kind of output (a world's, beside a scan named after it) and is not replaced.
    """
    out = user_path(path, setting, f"a file name ending in {suffix}")
    if _names_a_directory(path):  # resolving drops the slash: "x.npz/" would write x.npz
        raise UserError(
            f"{os.fspath(path)}: ends in a slash, which names a directory; "
            f"give a file name ending in {suffix}",
            setting=setting,
        )
    try:
        return _check_output_file(out, suffix, setting, companions, foreign_sidecar_key)
    except OSError as e:  # the OS refuses to even look (a too-long path, a loop): say so, no traceback
        raise UserError(f"{out}: {e.strerror or e}", setting=setting) from None


def _names_a_directory(text) -> bool:
    """Whether a typed path can only be a directory: it ends in a separator (or "/.")."""
    typed = os.fspath(text)
    ends = tuple(f"{sep}{dot}" for sep in {"/", os.sep} for dot in ("", ".", ".."))
    return isinstance(typed, str) and typed.endswith(ends)


def _check_output_file(out: Path, suffix, setting, companions, foreign_sidecar_key) -> Path:
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
    and ending in the target's own suffix (Blender and matplotlib pick formats by it).
    A long target's stem is shortened so the temporary name is legal whenever the target's
    is: a name that passed the checks never fails at the end of the work."""
    tail = f".tmp-{os.getpid()}{final.suffix}"
    room = name_max(final.parent) - TEMP_NAME_SLACK - len(os.fsencode("." + tail))
    stem = os.fsencode(final.stem)[: max(room, 1)].decode(errors="ignore")
    return final.with_name(f".{stem}{tail}")


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


# The keys that tell a world's sidecar (the paper island's lists its zones, a region of the
# endless world its region) from a scan's: a scan never replaces one.
WORLD_SIDECAR_KEYS = ("zones", "region")


def _json_has_key(path: Path, keys: str | tuple[str, ...]) -> bool:
    """Whether the JSON object at `path` has `keys` (one key, or any of several)."""
    try:
        data = json.loads(path.read_text())
        return any(key in data for key in ((keys,) if isinstance(keys, str) else keys))
    except (OSError, ValueError, TypeError):
        return False


def output_directory(text, setting: str = "out") -> Path:
    """A directory to write into, created (with its parents) if missing, or UserError."""
    out = user_path(text, setting, "a directory name")
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: it is a file; give a directory", setting=setting)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise UserError(f"{out}: cannot create the directory ({e.strerror or e})", setting=setting) from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise UserError(f"{out}: directory is not writable", setting=setting)
    return out


# ---------------------------------------------------------------------------------------
# writing

_records: list[list[Path]] = []  # one list per recording_written() block


@contextmanager
def recording_written():
    """A list that receives every file an atomic_outputs group placed inside the block, so
    an interrupted command can say truly what it completed."""
    written: list[Path] = []
    _records.append(written)
    try:
        yield written
    finally:
        _records.remove(written)


@contextmanager
def writing_to(final: Path):
    """Inside the block an OSError (a full disk, a refused write) is reported as failing to
    write `final`, the file the user asked for, whatever temporary name the writer used."""
    try:
        yield
    except OSError as e:
        raise UserError(f"cannot write {final}: {e.strerror or e}") from None


@contextmanager
def atomic_outputs(*finals: Path, durable: bool = True):
    """Yield one temporary path per target; rename them all into place when the block
    succeeds, and leave none of them (temporary or final) when anything fails or a
    signal stops the run. `durable`: flush the folders' renames to disk before returning
    (off for a dataset's scans: its next run re-checks every file against the manifest)."""
    finals = tuple(Path(p) for p in finals)
    temps = [temp_path(p) for p in finals]
    placed: list[Path] = []
    try:
        yield temps
        pause_here("writing")
        check_host_break()  # a Ctrl-C Blender's own handler took: the files are not placed
        with _renaming_in(finals):
            for tmp, final in zip(temps, finals, strict=True):
                os.replace(tmp, final)
                placed.append(final)
                pause_here("renamed")
    except OSError as e:  # a full disk, a path the OS refuses: the user's to fix
        remove_quietly([*temps, *placed])
        raise UserError(f"cannot write {_target_of(e.filename, temps, finals)}: {e.strerror or e}") from None
    except BaseException:  # KeyboardInterrupt too
        remove_quietly([*temps, *placed])
        raise
    for directory in {p.parent for p in finals} if durable else ():
        fsync_dir(directory)
    for written in _records:
        written.extend(finals)


@contextmanager
def _renaming_in(finals: tuple[Path, ...]):
    """Hold an exclusive lock on every folder the group lands in while it is renamed, so two
    commands writing the same outputs at once place their groups one after the other: a PLY
    never lands beside the other command's sidecar. The lock is the folder's own (flock on
    its descriptor), so no lock file is left; where flock is missing (Windows) no lock."""
    try:
        import fcntl
    except ImportError:
        yield
        return
    descriptors = []
    try:
        for folder in sorted({str(p.parent) for p in finals}):  # one order: no deadlock
            descriptors.append(os.open(folder, os.O_RDONLY))
            fcntl.flock(descriptors[-1], fcntl.LOCK_EX)
        yield
    finally:
        for fd in descriptors:
            os.close(fd)  # closing releases the lock


def _target_of(filename, temps, finals) -> Path:
    """The file the user asked for, when an error names its temporary stand-in."""
    for tmp, final in zip(temps, finals):
        if filename is not None and Path(filename) == tmp:
            return final
    if filename:
        return Path(filename)
    return finals[0] if len(finals) == 1 else group_name(finals)  # the OS did not say which


def group_name(finals: tuple[Path, ...]) -> str:
    """Files written together, named in a few words: "one of the 7 files of 000003 in DIR
    (velodyne/000003.bin, labels/000003.label, ...)", not seven paths joined by "or"."""
    folder = Path(os.path.commonpath([str(p.parent) for p in finals]))
    stems = {p.stem for p in finals}
    of = f" of {stems.pop()}" if len(stems) == 1 else ""
    shown = ", ".join(str(p.relative_to(folder)) for p in finals[:2])
    return f"one of the {len(finals)} files{of} in {folder} ({shown}, ...)"


def write_durably(path: Path, write) -> None:
    """Open `path`, let `write(f)` fill it, and fsync before the caller renames it."""
    with open(path, "wb") as f:
        write(f)
        f.flush()
        os.fsync(f.fileno())
