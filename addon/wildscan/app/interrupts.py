"""Stopping a long command on Ctrl-C or SIGTERM the same way: SIGTERM becomes an exception
where the work is, so the code that removes partial files runs as it does on Ctrl-C, and
the command reports what it completed and exits 130 (Ctrl-C) or 143 (SIGTERM)."""

from __future__ import annotations

import signal
from contextlib import contextmanager


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
        signal.signal(signal.SIGTERM, previous)
