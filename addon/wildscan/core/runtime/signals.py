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
from contextlib import contextmanager


class Terminated(BaseException):
    """SIGTERM, turned into an exception so the run stops as on Ctrl-C."""


_depth = 0  # deferred() blocks entered and not left
_pending: list[int] = []  # signals received inside them


def raise_for(signum: int):
    if signum == signal.SIGTERM:
        raise Terminated()
    raise KeyboardInterrupt


def on_signal(signum, frame):
    if _depth:
        _pending.append(signum)
        return
    raise_for(signum)


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
