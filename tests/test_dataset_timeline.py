"""Where a dataset run's workers waited (app/dataset/timeline.py)."""

import pytest

from wildscan.app.dataset.timeline import idle_time


def test_idle_time_splits_start_gaps_and_tail_per_worker():
    # worker 1: tasks 2-5 and 6-9; worker 2: one task 3-10; the run began at 1
    idle = idle_time(1.0, [(1, 6.0, 9.0), (2, 3.0, 10.0), (1, 2.0, 5.0)])
    assert idle.workers == 2
    assert idle.start == pytest.approx(1.0 + 2.0)
    assert idle.between == pytest.approx(1.0)
    assert idle.tail == pytest.approx(1.0 + 0.0)
    assert idle.total == pytest.approx(5.0)
    want = "workers idle 5.0 s (summed over 2: 3.0 s starting, 1.0 s between tasks, 1.0 s tail)"
    assert idle.line() == want


def test_a_run_without_tasks_waited_for_nothing():
    assert idle_time(0.0, []).total == 0.0
