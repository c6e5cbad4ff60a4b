"""Moments a signal must not cut (stdlib only; app/interrupts.py installs the handlers).

Inside `deferred()` a SIGINT or SIGTERM that reaches `on_signal` is noted and raised when
the block ends: while the bpy module loads (an exception inside its start-up is swallowed
or crashes the interpreter) and while Blender opens, resets or saves a file (it runs
Python handlers then, and prints and swallows any exception raised in them, so a Ctrl-C
landing there would be lost and the command would finish as if nothing had happened).
Outside those blocks `on_signal` raises at once.
"""

from __future__ import annotations

import signal
from collections.abc import Callable
from contextlib import contextmanager


class Terminated(BaseException):
    """SIGTERM, turned into an exception so the run stops as on Ctrl-C."""


_depth = 0  # deferred() blocks entered and not left
_pending: list[int] = []  # signals received inside them
# A host's own record of a Ctrl-C that reached its handler before ours was installed (Blender's
# G.is_break: app/host_break.py), read until it is found set once.
_host_break: list[Callable[[], bool]] = []
_lost: list[int] = []  # signals whose exception Python dropped (note_lost_signal)


def raise_for(signum: int):
    if signum == signal.SIGTERM:
        raise Terminated()
    raise KeyboardInterrupt


def on_signal(signum, frame):
    if _depth:
        _pending.append(signum)
        return
    raise_for(signum)


def note_lost_signal(unraisable, otherwise: Callable) -> None:
    """sys.unraisablehook while signals raise (app/interrupts.py): a signal that lands in a
    weakref callback, a __del__ or the garbage collector raises its exception there, where
    Python prints "Exception ignored" and drops it, so the command would finish as if nothing
    had happened (seen: a dataset's Ctrl-C inside WeakSet._remove). Note it for
    check_lost_signal; anything else goes to `otherwise`, the hook from before. (Raising
    again from here is no use: the hook is such a place too.)"""
    kind = unraisable.exc_type
    if kind is not None and issubclass(kind, (KeyboardInterrupt, Terminated)):
        _lost.append(signal.SIGTERM if issubclass(kind, Terminated) else signal.SIGINT)
        return
    otherwise(unraisable)


def check_lost_signal() -> None:
    """A signal note_lost_signal saw dropped, handled here as if it arrived now. Called where
    a long run polls (a dataset's progress) and before files are renamed into place."""
    if _lost:
        signum = _lost[0]
        _lost.clear()
        on_signal(signum, None)


def watch_host_break(reader: Callable[[], bool]) -> None:
    """Treat `reader()` turning true as a Ctrl-C (check_host_break)."""
    _host_break[:] = [reader]


def check_host_break() -> None:
    """A Ctrl-C the host's own handler took (before ours) as one that reached ours: noted
    inside deferred(), raised outside it. Called where a run begins and before files are
    renamed into place, so it never finishes as if nothing had happened."""
    check_lost_signal()
    if _host_break and _host_break[0]():
        _host_break.clear()
        on_signal(signal.SIGINT, None)


def signal_pending() -> bool:
    return bool(_pending)


def forget_pending() -> None:
    _pending.clear()


def enter() -> None:
    global _depth
    _depth += 1


def leave() -> None:
    """End one deferred moment; at the last, raise the first signal noted inside."""
    global _depth
    _depth -= 1
    if not _depth and _pending:
        signum = _pending[0]
        _pending.clear()
        raise_for(signum)


@contextmanager
def deferred():
    """A signal arriving inside the block is raised when the block ends."""
    enter()
    try:
        yield
    finally:
        leave()
