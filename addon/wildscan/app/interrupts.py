"""Stopping a command on Ctrl-C or SIGTERM the same way, at any moment.

`stopping_on_signals()` (cli.dispatch wraps every command in it) makes SIGINT raise
KeyboardInterrupt and SIGTERM raise Terminated where the work is, so the code that
removes temporary files runs (core/io/files.atomic_outputs) and the command reports what
it completed and exits 130 (Ctrl-C) or 143 (SIGTERM). It replaces Blender's own SIGINT
handler too (in `blender -b`, Blender's ignores the first Ctrl-C and exits 2 on the
second, our user-mistake code, leaving a partial file).

Some moments must not be cut: while the bpy module loads (an exception inside its
start-up is swallowed or crashes the interpreter) and while Blender reads or writes a
file (it swallows exceptions raised in its Python handlers). There `deferred()`
(core/runtime/signals.py) notes the signal and raises it as soon as the moment is over.

A process that runs one command (the `wildscan` script, blender_scripts/*.py) calls
`defer_until_dispatch()` before its slow imports, so a Ctrl-C in its first second is
noted and ends the run the same way once the command starts.
"""

from __future__ import annotations

import signal
import sys
from contextlib import contextmanager

from ..core.runtime.pause import pause_here
from ..core.runtime.signals import (
    Terminated,
    check_host_break,
    deferred,
    enter,
    forget_pending,
    leave,
    note_lost_signal,
    on_signal,
    signal_pending,
    watch_host_break,
)

__all__ = ["Terminated", "deferred", "defer_until_dispatch", "started", "stopping_on_signals"]

EXIT_INTERRUPTED = 130  # 128 + SIGINT
EXIT_TERMINATED = 143  # 128 + SIGTERM


class Interrupted(Exception):
    """A run stopped by Ctrl-C or SIGTERM: `message` says what was completed, `code` the exit code."""

    def __init__(self, message: str, code: int):
        super().__init__(message)
        self.code = code


def raise_terminated(signum, frame):
    raise Terminated()


@contextmanager
def sigterm_raises():
    """Inside the block SIGTERM raises Terminated (left as it is outside the main thread)."""
    try:
        previous = signal.signal(signal.SIGTERM, raise_terminated)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        _restore(signal.SIGTERM, previous)


def _restore(signum: int, previous) -> None:
    """Put back the handler from before; one installed from C (Blender's own) reads as None
    and cannot be put back: the default takes its place."""
    signal.signal(signum, signal.SIG_DFL if previous is None else previous)


# ---------------------------------------------------------------------------------------
# every command: both signals raise, except inside deferred() (core/runtime/signals.py)

# The handlers from before defer_until_dispatch(), while it holds; None otherwise.
_early: dict | None = None
_owns_process = False  # the process is this command's own (the console script, a Blender script)


def defer_until_dispatch() -> None:
    """Call first thing in a process that runs one command: from here until the command
    starts (`started()`), a signal is noted, not raised, so a Ctrl-C during the slow imports
    and the parsing ends the run as at any other moment (Python would print a traceback
    from inside an import; Blender's own handler ignores the first Ctrl-C)."""
    global _early, _owns_process
    host_break = None
    if signal.getsignal(signal.SIGINT) is None:  # installed from C: Blender's own, read before ours
        from .host_break import break_flag_reader

        host_break = break_flag_reader()
    try:
        _early = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:  # not the main thread
        return
    _owns_process = True
    enter()
    if host_break is not None:  # a Ctrl-C while Blender started, which its handler only noted
        watch_host_break(host_break)
        check_host_break()
    pause_here("starting", until=signal_pending)


def started() -> None:
    """The command has begun under stopping_on_signals: a signal noted since
    defer_until_dispatch() is raised here, inside the command's error handling."""
    global _early
    check_host_break()
    if _early is not None:
        _early = None
        leave()


def stop_code(stop: BaseException) -> int:
    return EXIT_TERMINATED if isinstance(stop, Terminated) else EXIT_INTERRUPTED


@contextmanager
def stopping_on_signals():
    """Inside the block SIGINT raises KeyboardInterrupt and SIGTERM Terminated (deferred
    while bpy loads); the handlers before it are restored after it."""
    try:
        previous = _early or {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:  # not the main thread (the add-on's operators): leave signals alone
        yield
        return
    finder = _DeferBpyImport()
    sys.meta_path.insert(0, finder)
    hook = sys.unraisablehook
    sys.unraisablehook = lambda unraisable: note_lost_signal(unraisable, hook)
    try:
        yield
    finally:
        sys.unraisablehook = hook
        sys.meta_path.remove(finder)
        for s, handler in previous.items():
            if _owns_process:  # the command is over and has said what it wrote: a signal
                signal.signal(s, signal.SIG_IGN)  # now (bpy's teardown) would only hide it
            else:
                _restore(s, handler)
        forget_pending()


class _DeferBpyImport:
    """Finds bpy as the other finders do, with a loader that defers signals while it loads."""

    def find_spec(self, name, path, target=None):
        if name != "bpy":
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(name, path, target)
            if spec is not None:
                spec.loader = _DeferredLoader(spec.loader)
                return spec
        return None


class _DeferredLoader:
    """Signals wait from the start of create_module to the end of exec_module."""

    def __init__(self, loader):
        self._loader = loader

    def create_module(self, spec):
        enter()
        try:
            pause_here("bpy-import", until=signal_pending)
            return self._loader.create_module(spec)
        except BaseException:
            leave()
            raise

    def exec_module(self, module):
        try:
            self._loader.exec_module(module)
        finally:
            leave()
