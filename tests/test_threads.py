"""core/runtime/threads.py: a batch of rays cast in parts from several threads gives the bytes one
cast gives, in ray order; how many threads, from the environment."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from wildscan.core.backend import THREADS
from wildscan.core.errors import UserError
from wildscan.core.runtime import threads
from wildscan.raycast.embree_backend import EmbreeBackend
from wildscan.raycast.geometry import from_triangles


def sphere_of_facets(count: int = 400, seed: int = 3) -> np.ndarray:
    """Random small triangles around the origin: many rays hit, some pass between them."""
    rng = np.random.default_rng(seed)
    centres = rng.normal(size=(count, 3))
    centres *= (2.0 + rng.random(count))[:, None] / np.linalg.norm(centres, axis=1)[:, None]
    return centres[:, None, :] + 0.3 * rng.normal(size=(count, 3, 3))


def rays(count: int = 5000, seed: int = 4) -> np.ndarray:
    d = np.random.default_rng(seed).normal(size=(count, 3))
    return d / np.linalg.norm(d, axis=1)[:, None]


def test_parts_cover_every_ray_once_in_order():
    for count, n_threads, chunk in [
        (0, 2, None),
        (7, 2, None),
        (230_001, 2, None),
        (130_000, 1, None),
        (10, 4, 3),
    ]:
        pieces = threads.parts(count, n_threads, chunk)
        covered = np.concatenate([np.arange(count)[p] for p in pieces])
        assert np.array_equal(covered, np.arange(count))
    assert len(threads.parts(400_000, 2)) == 8  # a few parts a thread
    assert len(threads.parts(400_000, 1)) == 1


@pytest.mark.parametrize("normals", [False, True])
def test_threaded_cast_gives_the_bytes_of_one_cast(monkeypatch, normals):
    backend = EmbreeBackend(from_triangles(sphere_of_facets(), instance=np.arange(400)))
    assert THREADS in backend.capabilities
    dirs = rays()
    whole = backend.cast(np.zeros(3), dirs, 10.0, normals=normals)
    assert 0 < whole.hit.sum() < len(dirs)
    used = set()

    def cast(o, d, r):
        used.add(threading.current_thread().name)
        return backend.cast(o, d, r, normals=normals)

    monkeypatch.setenv(threads.THREADS_ENV, "2")
    monkeypatch.setattr(threads, "MIN_PART", 500)
    seen = []
    joined = threads.cast_parts(backend, cast, np.zeros(3), dirs, 10.0, done=lambda k, n: seen.append((k, n)))
    assert used and all(name.startswith("wildscan-cast") for name in used)  # the pool's threads
    assert seen[-1] == (len(dirs), len(dirs)) and [k for k, _ in seen] == sorted(k for k, _ in seen)
    for field in ("distance", "class_id", "instance", "normal"):
        a, b = getattr(whole, field), getattr(joined, field)
        assert (a is None and b is None) or a.tobytes() == b.tobytes(), field


def test_per_ray_origins_go_with_their_rays(monkeypatch):
    backend = EmbreeBackend(from_triangles(sphere_of_facets(), instance=np.arange(400)))
    dirs = rays(3000)
    origins = 0.1 * np.random.default_rng(5).normal(size=(len(dirs), 3))
    monkeypatch.setenv(threads.THREADS_ENV, "2")
    monkeypatch.setattr(threads, "MIN_PART", 500)
    joined = threads.cast_parts(backend, backend.cast, origins, dirs, 10.0)
    assert joined.distance.tobytes() == backend.cast(origins, dirs, 10.0).distance.tobytes()


def test_thread_count_from_the_environment(monkeypatch):
    monkeypatch.delenv(threads.THREADS_ENV, raising=False)
    monkeypatch.setenv("OMP_NUM_THREADS", "1")  # what Dask gives each dataset worker
    assert threads.cast_threads() == 1
    monkeypatch.setenv(threads.THREADS_ENV, "3")
    assert threads.cast_threads() == 3
    monkeypatch.setenv(threads.THREADS_ENV, "two")
    with pytest.raises(UserError, match="must be a whole number of threads from 1, got 'two'") as caught:
        threads.cast_threads()
    assert caught.value.setting == threads.THREADS_ENV  # the CLI names it once, before the message


def test_work_in_parts_runs_on_the_threads_it_is_given(monkeypatch):
    """in_parts: the parts in order; on the caller's thread alone when given 1 thread (a dataset
    worker's backend says 1), on the pool's when given more."""
    monkeypatch.setenv(threads.THREADS_ENV, "2")

    def where(part):
        return part.start, part.stop, threading.current_thread().name

    alone = threads.in_parts(where, 10, 3, threads=1)
    assert [(a, b) for a, b, _ in alone] == [(0, 3), (3, 6), (6, 9), (9, 10)]
    assert {name for _, _, name in alone} == {threading.current_thread().name}
    pooled = threads.in_parts(where, 10, 3, threads=2)
    assert [(a, b) for a, b, _ in pooled] == [(0, 3), (3, 6), (6, 9), (9, 10)]
    assert all(name.startswith("wildscan-cast") for _, _, name in pooled)


def test_a_part_on_a_pool_thread_splits_nothing_further(monkeypatch):
    """A part run on the pool (a realistic scan's block of beams) casts and computes inline:
    its own casts and parts stay on its thread (every pool thread waiting on parts queued
    behind it would wait for ever), with the bytes of a split cast."""
    monkeypatch.setenv(threads.THREADS_ENV, "2")
    backend = EmbreeBackend(from_triangles(sphere_of_facets()))
    dirs = rays(40_000)

    def block(part):
        seen = []

        def cast(origin, d, max_range):
            seen.append(threading.current_thread().name)
            return backend.cast(origin, d, max_range)

        hits = threads.cast_parts(backend, cast, np.zeros(3), dirs[part], 10.0)
        inner = threads.in_parts(lambda p: threading.current_thread().name, 10, 3)
        return hits, set(seen), set(inner), threading.current_thread().name

    split = threads.cast_parts(backend, backend.cast, np.zeros(3), dirs, 10.0)
    assert not threads.in_worker()
    half = len(dirs) // 2
    parts = threads.in_parts(block, len(dirs), half, threads=2)
    for k, (hits, cast_on, inner_on, mine) in enumerate(parts):
        assert mine.startswith("wildscan-cast") and cast_on == inner_on == {mine}
        assert hits.distance.tobytes() == split.distance[k * half : (k + 1) * half].tobytes()
        assert hits.class_id.tobytes() == split.class_id[k * half : (k + 1) * half].tobytes()


def test_started_work_gives_its_value_on_the_pool_or_inline(monkeypatch):
    monkeypatch.setenv(threads.THREADS_ENV, "2")
    pooled = threads.started(lambda: threading.current_thread().name, threads=2)
    inline = threads.started(lambda: threading.current_thread().name, threads=1)
    assert pooled().startswith("wildscan-cast")
    assert inline() == threading.current_thread().name


def test_a_process_casting_on_threads_keeps_its_freed_memory_where_glibc_runs_it():
    """heap.keep_freed_memory: glibc's malloc asked to keep freed memory (a Linux with glibc
    agrees; elsewhere nothing is asked), once a process, by the first pool made."""
    import platform

    from wildscan.core.runtime import heap

    threads._pool_of(2)
    assert heap.keep_freed_memory.cache_info().currsize == 1
    glibc = platform.system() == "Linux" and platform.libc_ver()[0] == "glibc"
    assert heap.keep_freed_memory() is glibc
