"""Stopping a command on Ctrl-C or SIGTERM the same way, at any moment.

`stopping_on_signals()` (cli.dispatch wraps every command in it) makes SIGINT raise
KeyboardInterrupt and SIGTERM raise Terminated where the work is, so the code that
removes temporary files runs (core/io/files.atomic_outputs) and the command reports what
it completed and exits 130 (Ctrl-C) or 143 (SIGTERM). It replaces Blender's own SIGINT
handler too (in `blender -b`, Blender's ignores the first Ctrl-C and exits 2 on the
second, our user-mistake code, leaving a partial file).

Some moments must not be cut: while the bpy module loads (an exception inside its
start-up is swallowed or crashes the interpreter). There `deferred()` notes the signal
and raises it as soon as the moment is over.
"""

from __future__ import annotations

import importlib.abc
import signal
import sys
from contextlib import contextmanager

from ..core.pause import pause_here

EXIT_INTERRUPTED = 130  # 128 + SIGINT
EXIT_TERMINATED = 143  # 128 + SIGTERM


class Terminated(BaseException):
    """SIGTERM, turned into an exception so the run stops as on Ctrl-C."""


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
# every command: both signals raise, except inside deferred()

_depth = 0  # deferred() blocks entered and not left
_pending: list[int] = []  # signals received inside them


def _raise_for(signum: int):
    if signum == signal.SIGTERM:
        raise Terminated()
    raise KeyboardInterrupt


def _on_signal(signum, frame):
    if _depth:
        _pending.append(signum)
        return
    _raise_for(signum)


def signal_pending() -> bool:
    return bool(_pending)


def _enter() -> None:
    global _depth
    _depth += 1


def _leave() -> None:
    global _depth
    _depth -= 1
    if not _depth and _pending:
        signum = _pending[0]
        _pending.clear()
        _raise_for(signum)


@contextmanager
def deferred():
    """A signal arriving inside the block is raised when the block ends."""
    _enter()
    try:
        yield
    finally:
        _leave()


def stop_code(stop: BaseException) -> int:
    return EXIT_TERMINATED if isinstance(stop, Terminated) else EXIT_INTERRUPTED


@contextmanager
def stopping_on_signals():
    """Inside the block SIGINT raises KeyboardInterrupt and SIGTERM Terminated (deferred
    while bpy loads); the handlers before it are restored after it."""
    try:
        previous = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    except ValueError:  # not the main thread (the add-on's operators): leave signals alone
        yield
        return
    finder = _DeferBpyImport()
    sys.meta_path.insert(0, finder)
    try:
        yield
    finally:
        sys.meta_path.remove(finder)
        for s, handler in previous.items():
            _restore(s, handler)
        _pending.clear()


class _DeferBpyImport(importlib.abc.MetaPathFinder):
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


class _DeferredLoader(importlib.abc.Loader):
    """Signals wait from the start of create_module to the end of exec_module."""

    def __init__(self, loader):
        self._loader = loader

    def create_module(self, spec):
        _enter()
        try:
            pause_here("bpy-import", until=signal_pending)
            return self._loader.create_module(spec)
        except BaseException:
            _leave()
            raise

    def exec_module(self, module):
        try:
            self._loader.exec_module(module)
        finally:
            _leave()
