"""The Dask side: a LocalCluster (one single-threaded worker process per core, or N), or an
existing scheduler by address; batches submitted as tasks, results handed back as they
finish.

A task is one world seed with a batch of its scan indices, so a world is planned once per
batch (and once per worker: workers keep their last worlds). A worker that dies mid-task
is replaced by its nanny and the scheduler runs the task again elsewhere (up to
`distributed.scheduler.allowed-failures` times, 3 by default); a task that kills every
worker it touches ends the run with a message. A worker that dies while the cluster starts,
an address where no scheduler answers and a scheduler that goes away are cluster.py's.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import logging
import math
import os
import uuid
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import dataclass, field

from ... import __version__
from ...core.errors import UserError
from .cluster import RunFailed, connect_scheduler, start_local_cluster

# what waiting on futures raises once the scheduler is gone (Dask's FuturesCancelledError
# is a concurrent.futures.CancelledError; a closed comm an OSError)
_LOST = (asyncio.CancelledError, concurrent.futures.CancelledError, OSError)
MAX_BATCH = 50  # scans per task: bounds the work a killed run redoes
POLL_SECONDS = 0.5


@dataclass
class Batch:
    seed: int
    indices: list[int]
    order: int
    label: str = ""


def make_batches(pending: dict[int, list[int]], worker_count: int) -> list[Batch]:
    """Each world's pending scans in contiguous batches: one per world when there are enough
    worlds to keep every worker busy, more when there are fewer worlds than workers; with
    several workers the last world in TAIL_PARTS per worker (tail_parts)."""
    worlds = [seed for seed, indices in pending.items() if indices]
    per_world = max(1, math.ceil(worker_count / max(1, len(worlds))))
    batches: list[Batch] = []
    for seed in worlds:
        indices = pending[seed]
        parts = max(per_world, math.ceil(len(indices) / MAX_BATCH))
        if seed == worlds[-1]:
            parts = max(parts, tail_parts(worker_count))
        size = math.ceil(len(indices) / parts)
        for start in range(0, len(indices), size):
            batches.append(Batch(seed, indices[start : start + size], len(batches)))
    return batches


TAIL_PARTS = 2  # parts of the last world per worker


def tail_parts(worker_count: int) -> int:
    """The parts the last world is cut into: with one world a task, a run ends when the
    worker that drew the last world finishes it, while the others have had nothing to do
    since their own last world (on average half a world's time: its build and 50 scans, 2.5%
    of a 2-worker bench-dataset run). In parts taken by whichever worker is free, the others
    help with it; each pays a load of that world (from the world cache, or a build while its
    first worker still builds it): simulated over 20 worlds of 9 +- 2.5 s on 2 workers, 4
    parts shorten a run by 1.8 s cold and 1.6 s warm, 2 parts by 1.3 and 1.1 s. One worker:
    one part (it holds the world)."""
    return 1 if worker_count <= 1 else TAIL_PARTS * worker_count


@dataclass
class Engine:
    workers: int | None = None
    scheduler: str | None = None
    client: object = None
    cluster: object = None
    ticks: dict[str, int] = field(default_factory=dict)
    cache: dict | None = None  # the world cache the workers use (app/cache/config.py), None: none
    token: str = field(default_factory=lambda: uuid.uuid4().hex[:8])  # keeps two runs' tasks apart
    _quiet: ExitStack = field(default_factory=ExitStack)

    def start(self) -> None:
        from distributed import Client
        from distributed.utils import silence_logging_cmgr

        # Dask logs (at ERROR, with tracebacks) what this run reports itself in one line: a
        # worker's heartbeat racing the scheduler's shutdown after a run that went well, a
        # client reconnecting to a scheduler that died; a failed task reaches the user
        # through its future (_result), a dying worker through Dask's retries.
        self._quiet.enter_context(silence_logging_cmgr(logging.CRITICAL))
        if self.scheduler:
            self.client = connect_scheduler(self.scheduler)
            return
        self.cluster = start_local_cluster(self._local_cluster)
        self.client = Client(self.cluster)

    def _local_cluster(self):
        import dask
        from distributed import LocalCluster

        from .heap import NANNY_ENVIRON, worker_environ

        # Workers sample their task's stack for the dashboard's profile, which a local
        # cluster here does not serve: time taken from the scans for nothing. Their memory
        # stays theirs (heap.py).
        # A worker is handed its next task when it finishes one (saturation 1.0), not one
        # ahead (Dask's 1.1 rounds up to two tasks a one-thread worker): the last world goes
        # to whichever worker is free first, not to one still busy with its own (the tail,
        # timeline.py).
        settings = {
            "distributed.worker.profile.enabled": False,
            "distributed.scheduler.worker-saturation": 1.0,
        }
        settings[NANNY_ENVIRON] = worker_environ(dask.config.get(NANNY_ENVIRON, {}))
        with dask.config.set(settings):
            return LocalCluster(
                n_workers=self.workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                # Without a dashboard Dask still serves its health routes, on port 8787 by
                # default, and warns on stderr when another run holds it: a free port of
                # this machine's own, no warning.
                scheduler_kwargs={"dashboard_address": "127.0.0.1:0"},
                silence_logs=logging.CRITICAL,
            )

    def worker_count(self) -> int:
        threads = self.client.nthreads()
        return max(1, sum(threads.values()))

    def run(
        self, spec_json: dict, out: str, batches: list[Batch], on_batch: Callable, on_poll: Callable
    ) -> None:
        """Submit every batch; call on_batch(batch, result) as each finishes and on_poll()
        twice a second. Raises UserError/RunFailed when a task fails."""
        from distributed import wait

        from .worker import scan_batch

        topic = f"wildscan-dataset-{self.token}"
        self.client.subscribe_topic(topic, self._tick)
        futures = {}
        placed = self._place_poses(spec_json, batches, futures)
        for b in batches:
            f = self.client.submit(
                scan_batch, spec_json, out, b.seed, b.indices, __version__, topic, b.label, self.cache,
                placed.get(b.seed), key=b.label, pure=False, priority=-2 * b.order,
            )  # fmt: skip
            futures[f] = b
        pending = set(futures)
        while pending:
            try:
                done, pending = wait(pending, timeout=POLL_SECONDS, return_when="FIRST_COMPLETED")
            except TimeoutError:
                done = set()
            except _LOST as e:  # Dask cancels every future when the client loses its scheduler
                raise self._lost(e) from None
            for f in done:
                result = self._result(f, futures[f])
                on_batch(futures[f], result)  # a batch cut short records its whole scans first
                f.release()
                if "failure" in result:
                    raise UserError(result["failure"])
            on_poll()

    def _place_poses(self, spec_json: dict, batches: list[Batch], futures: dict) -> dict:
        """seed -> the future of an endless world's pose task (worker.py world_poses_task), one
        per world, which the world's scan tasks take as an argument: Dask runs it first (just
        before the world's first batch, by priority) and its batches wait on it, on a local
        cluster and on a scheduler alike; no worker places a world's poses beside another.
        The task is recorded in `futures` as a batch without scans (its facts are the run's)."""
        from .spec import spec_from_json
        from .worker import world_poses_task

        if spec_from_json(spec_json).layout != "endless":
            return {}
        placed = {}
        for b in batches:
            if b.seed not in placed:
                label = f"{b.label}-poses"
                placed[b.seed] = self.client.submit(
                    world_poses_task, spec_json, b.seed, __version__, self.cache,
                    key=label, pure=False, priority=1 - 2 * b.order,
                )  # fmt: skip
                futures[placed[b.seed]] = Batch(b.seed, [], b.order, label)
        return placed

    def _lost(self, error: BaseException) -> RunFailed:
        where = f"the Dask scheduler at {self.scheduler}" if self.scheduler else "the local Dask scheduler"
        return RunFailed(
            f"lost the connection to {where} ({type(error).__name__}): it stopped, or the network failed"
        )

    def _result(self, future, batch: Batch):
        if future.status == "cancelled":
            raise self._lost(asyncio.CancelledError())
        if future.status == "error":
            exc = future.exception()
            if isinstance(exc, UserError):
                raise UserError(str(exc))
            if type(exc).__name__ == "KilledWorker":
                raise RunFailed(
                    f"world seed {batch.seed}: its task killed every worker that ran it ({exc}); "
                    "is a worker running out of memory?"
                )
        return future.result()

    def _tick(self, event) -> None:
        _, label = event
        self.ticks[label] = self.ticks.get(label, 0) + 1

    def close(self) -> None:
        for closer in (self.client, self.cluster):
            if closer is not None:
                try:
                    closer.close(timeout=10) if closer is self.cluster else closer.close()
                except Exception:  # closing after an interrupt: never hide the reason we stop
                    pass
        self.client = self.cluster = None
        self._quiet.close()
