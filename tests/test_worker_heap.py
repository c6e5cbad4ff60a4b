"""app/dataset/heap.py: a dataset worker process starts with glibc told to keep the memory it
frees (one arena, no mmap, no trim), in place of Dask's trim threshold; the local cluster
hands that environment to its nannies."""

from __future__ import annotations

import pytest

from wildscan.app.dataset import heap

dask = pytest.importorskip("dask")
pytest.importorskip("distributed")


def test_the_worker_environment_keeps_dasks_and_the_users_settings(monkeypatch):
    monkeypatch.setenv("GLIBC_TUNABLES", "glibc.malloc.tcache_count=0")
    env = heap.worker_environ({"MALLOC_TRIM_THRESHOLD_": 65536, "OMP_NUM_THREADS": 1})
    assert "MALLOC_TRIM_THRESHOLD_" not in env and env["OMP_NUM_THREADS"] == 1
    tunables = env["GLIBC_TUNABLES"].split(":")
    assert tunables[0] == "glibc.malloc.tcache_count=0"  # the user's first: ours win where both set
    assert {"glibc.malloc.arena_max=1", "glibc.malloc.mmap_max=0"} <= set(tunables)
    monkeypatch.delenv("GLIBC_TUNABLES")
    assert heap.worker_environ({})["GLIBC_TUNABLES"] == heap.WORKER_TUNABLES
    monkeypatch.setenv("GLIBC_TUNABLES", heap.WORKER_TUNABLES)  # a second cluster of one run
    assert heap.worker_environ({})["GLIBC_TUNABLES"] == heap.WORKER_TUNABLES


def test_the_local_cluster_starts_its_workers_with_it(monkeypatch):
    import distributed

    from wildscan.app.dataset.engine import Engine

    seen = {}

    def cluster(**kwargs):
        seen.update(dask.config.get(heap.NANNY_ENVIRON))
        return "cluster"

    monkeypatch.setattr(distributed, "LocalCluster", cluster)
    engine = Engine.__new__(Engine)
    engine.workers = 2
    assert engine._local_cluster() == "cluster"
    assert heap.WORKER_TUNABLES in seen["GLIBC_TUNABLES"] and "MALLOC_TRIM_THRESHOLD_" not in seen
    assert heap.WORKER_TUNABLES not in str(dask.config.get(heap.NANNY_ENVIRON))  # only while starting
