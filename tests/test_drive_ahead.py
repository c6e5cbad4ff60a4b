"""A long drive's work overlapped (app/drive/ahead.py, run.py's _Behind): the next piece's
world made while the current one is used, a sweep's files written while the next one is
cast; in order, errors raised where their values would have come, nothing left running."""

from __future__ import annotations

import threading

import pytest

from wildscan.app.drive.ahead import one_ahead
from wildscan.app.drive.run import _Behind

WAIT_S = 30.0  # a bound on waiting for an event, never a sleep


def test_the_next_piece_is_made_while_the_caller_uses_this_one_and_they_come_in_order():
    begun = {k: threading.Event() for k in range(3)}
    threads = []

    def make(k):
        begun[k].set()
        threads.append(threading.current_thread().name)
        return k * 10

    values = one_ahead(make, [0, 1, 2])
    assert next(values) == 0
    assert begun[1].wait(WAIT_S)  # made before the caller asked for it
    assert list(values) == [10, 20]
    assert all(name.startswith("wildscan-drive-ahead") for name in threads)
    assert list(one_ahead(make, [])) == []


def test_an_error_in_making_a_piece_is_raised_where_its_value_would_come():
    def make(k):
        if k == 1:
            raise ValueError("piece 1")
        return k

    values = one_ahead(make, [0, 1, 2])
    assert next(values) == 0
    with pytest.raises(ValueError, match="piece 1"):
        next(values)


def test_closing_early_waits_for_the_piece_being_made():
    release, done = threading.Event(), threading.Event()

    def make(k):
        if k == 1:
            assert release.wait(WAIT_S)
            done.set()
        return k

    values = one_ahead(make, [0, 1, 2])
    assert next(values) == 0
    release.set()
    values.close()
    assert done.is_set()  # the pool was shut down after piece 1, not left running


def test_writes_behind_run_one_at_a_time_in_order_and_an_error_comes_back():
    order, inside = [], []

    def write(k):
        def run():
            inside.append(k)
            assert len(inside) == 1  # never two at once
            order.append(k)
            inside.remove(k)

        return run

    with _Behind() as behind:
        for k in range(20):
            behind(write(k))
    assert order == list(range(20))

    def fail():
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        with _Behind() as behind:
            behind(fail)
            behind(write(99))  # waits for the failed write first, and raises its error
    assert 99 not in order
