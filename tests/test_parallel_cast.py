"""core/runtime/threads.py over the embree backend: a large cast split over threads answers exactly
what one thread does (every ray's answer is its own), and a dataset worker's backend keeps
one thread."""

from __future__ import annotations

import os

import numpy as np
import pytest

pytest.importorskip("embreex")


def _rough_ground_and_litter():
    """A bumpy grid (shared edges and vertices: the settling has work) with small tilted
    triangles floating above it."""
    from wildscan.raycast.geometry import SceneGeometry

    rng = np.random.default_rng(5)
    n = 40
    xs = np.linspace(-20.0, 20.0, n)
    gx, gy = np.meshgrid(xs, xs)
    vertices = np.column_stack([gx.ravel(), gy.ravel(), 0.3 * rng.standard_normal(n * n)])
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1))
    a = (j * n + i).ravel()
    faces = np.concatenate([np.column_stack([a, a + 1, a + n + 1]), np.column_stack([a, a + n + 1, a + n])])
    litter = rng.uniform(-15, 15, (300, 1, 3)) + rng.uniform(-0.5, 0.5, (300, 3, 3))
    litter[:, :, 2] += 3.0
    start = len(vertices)
    vertices = np.concatenate([vertices, litter.reshape(-1, 3)])
    faces = np.concatenate([faces, start + np.arange(900).reshape(-1, 3)])
    count = len(faces)
    class_id = np.where(np.arange(count) < count - 300, 1, 3)
    return SceneGeometry(vertices, faces, class_id, np.arange(count) // 7, np.zeros(count))


@pytest.mark.parametrize("normals", [False, True])
def test_a_cast_over_threads_is_the_same_bytes_as_one(normals):
    from wildscan.core.runtime.threads import cast_parts
    from wildscan.raycast.embree_backend import EmbreeBackend

    backend = EmbreeBackend(_rough_ground_and_litter())
    rng = np.random.default_rng(1)
    dirs = rng.standard_normal((70_000, 3))
    dirs[:, 2] = -np.abs(dirs[:, 2])  # down, where the ground and the litter are
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    origin = np.array([0.3, -0.2, 6.0])

    def cast(o, d, reach):
        return backend.cast(o, d, reach, normals)

    backend.threads = 1
    one = cast_parts(backend, cast, origin, dirs, 40.0)
    backend.threads = 3
    three = cast_parts(backend, cast, origin, dirs, 40.0)
    many_origins = cast_parts(backend, cast, np.broadcast_to(origin, dirs.shape).copy(), dirs, 40.0)

    assert one.hit.sum() > 50_000
    for hits in (three, many_origins):
        assert hits.distance.tobytes() == one.distance.tobytes()
        assert hits.class_id.tobytes() == one.class_id.tobytes()
        assert hits.instance.tobytes() == one.instance.tobytes()
        if normals:
            assert hits.normal.tobytes() == one.normal.tobytes()


def test_a_small_cast_stays_on_one_thread(monkeypatch):
    from wildscan.core.runtime import threads
    from wildscan.raycast.embree_backend import EmbreeBackend

    backend = EmbreeBackend(_rough_ground_and_litter())
    backend.threads = 4
    monkeypatch.setattr(threads, "_pool_of", None)  # would fail if a pool were asked for
    dirs = np.tile([0.0, 0.0, -1.0], (1000, 1))
    hits = threads.cast_parts(backend, backend.cast, np.array([0.0, 0.0, 6.0]), dirs, 10.0)
    assert hits.hit.all()


def test_a_commands_backend_uses_the_cores_and_a_dataset_workers_one(monkeypatch):
    from wildscan.app.dataset.context import embree_backend as _embree
    from wildscan.core.runtime.threads import THREADS_ENV, backend_threads
    from wildscan.raycast.select import make_backend

    monkeypatch.delenv(THREADS_ENV, raising=False)
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    geometry = _rough_ground_and_litter()
    command = make_backend("embree", geometry=geometry, notify=None)
    assert backend_threads(command) == len(os.sched_getaffinity(0))
    assert backend_threads(_embree(geometry)) == 1
