"""The lock a `wildscan dataset` run holds on its output folder (LOCK, an exclusive flock the
OS releases if the run dies), and how readers of the folder (`--verify`, `bench --suite
learn`) recognise a dataset that is being written: they test the lock, never the file's
presence (a killed run leaves the file, but not the lock)."""

from __future__ import annotations

import errno
import fcntl
import os
from pathlib import Path

from ...core.errors import UserError
from .layout import LOCK


def lock(root: Path) -> int:
    """An exclusive lock on the folder for this run (released by the OS if the run dies); the
    file holds the run's process id, for the readers' message."""
    fd = os.open(root / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        raise UserError(f"--out {root}: another wildscan dataset run is writing into it") from None
    os.ftruncate(fd, 0)
    os.write(fd, f"{os.getpid()}\n".encode())
    return fd


def unlock(root: Path, fd: int) -> None:
    try:
        os.unlink(root / LOCK)
    except OSError:
        pass
    os.close(fd)


def writer_pid(root: Path) -> int | None:
    """The process id of the run writing into `root` now, 0 when it is not known, or None when
    no run holds the folder's lock."""
    try:
        fd = os.open(Path(root) / LOCK, os.O_RDONLY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError as e:
        if e.errno not in (errno.EWOULDBLOCK, errno.EAGAIN):
            raise
        text = os.pread(fd, 32, 0).decode("ascii", "replace").strip()
        return int(text) if text.isdigit() else 0
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def refuse_while_written(root: Path, what: str) -> None:
    """One line (exit 2) when a run is writing into `root`: its files change under `what`."""
    pid = writer_pid(root)
    if pid is not None:
        by = f" (process {pid})" if pid else ""
        raise UserError(
            f"{root}: the dataset is being written by a wildscan dataset run{by}; {what} it once the run has "
            f"finished (or stop the run: the same command resumes it)"
        )
