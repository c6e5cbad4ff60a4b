"""Where a dataset run's workers waited: each task's wall-clock start and end (the worker's
facts), laid on the run's own timeline (the stdlib only).

Why: with N workers a run takes at least the summed work over N; what it takes beyond is
time a worker had nothing to do: before its first task (the cluster and the worker's
imports starting), between two tasks (the scheduler's round trip), and after its last
task while another worker still finished its own (the tail). `wildscan bench-dataset`
prints these beside the speed-up, so a speed-up short of N says whether the work was slow
or the workers waited.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Idle:
    """Seconds of worker time without a task, summed over the workers."""

    start: float  # from the run's start to each worker's first task
    between: float  # between one task's end and the worker's next task's start
    tail: float  # from each worker's last task's end to the run's last task's end
    workers: int

    @property
    def total(self) -> float:
        return self.start + self.between + self.tail

    def line(self) -> str:
        return (
            f"workers idle {self.total:.1f} s (summed over {self.workers}: {self.start:.1f} s "
            f"starting, {self.between:.1f} s between tasks, {self.tail:.1f} s tail)"
        )


def idle_time(run_start: float, tasks: list[tuple[int, float, float]]) -> Idle:
    """`tasks`: (worker pid, start, end) wall-clock seconds of every task of a run that began at
    `run_start`."""
    by_worker: dict[int, list[tuple[float, float]]] = {}
    for pid, start, end in tasks:
        by_worker.setdefault(pid, []).append((start, end))
    if not by_worker:
        return Idle(0.0, 0.0, 0.0, 0)
    last_end = max(end for _, _, end in tasks)
    start = between = tail = 0.0
    for spans in by_worker.values():
        spans.sort()
        start += max(0.0, spans[0][0] - run_start)
        between += sum(max(0.0, b[0] - a[1]) for a, b in zip(spans, spans[1:]))
        tail += last_end - spans[-1][1]
    return Idle(start, between, tail, len(by_worker))
