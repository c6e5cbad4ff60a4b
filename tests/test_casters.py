"""The float32 ray casters behind the backend protocol (raycast/select.py): Embree's buffers
filled from numpy (raycast/embree_buffers.py) give Embree the very bytes embreex's upload gives,
ray by ray; Open3D's scans are embree's PLY bytes after the float64 settling; and the casters
suite (bench/casters.py) measures every candidate and says which are missing. No timing is
judged here (the machine is shared)."""

from __future__ import annotations

import hashlib
import io
import sys

import numpy as np
import pytest

from wildscan.core.io.ply import read_ply, write_scan_files
from wildscan.core.scan import run_scan
from wildscan.core.sensors import SensorConfig, device_named
from wildscan.raycast import embree_buffers, select
from wildscan.raycast.embree_backend import EmbreeBackend, sealed
from wildscan.raycast.open3d_backend import Open3DBackend

from tests.helpers.backend_scenes import random_dirs


@pytest.fixture(scope="module")
def world():
    """Seed 0's default-biome porous world at low detail (whole), its first valid pose, and
    the sealed triangles every caster here shares."""
    from wildscan.bench.devices import world_and_pose

    geometry, pose, z_start = world_and_pose(0, "low")
    _, settler = sealed(geometry)
    return geometry, pose, z_start, settler


def _rays(geometry, pose, count=60_000):
    """Rays from 1.5 m above the pose and from scattered points around it (offset-local)."""
    dirs = random_dirs(count, "casters")
    centre = np.array([pose.x, pose.y, 0.0]) - geometry.offset
    low, high = geometry.bounds()
    centre[2] = 0.5 * (low[2] + high[2]) - geometry.offset[2]
    rng = np.random.default_rng(3)
    origins = centre + rng.uniform(-20, 20, (count, 3)) * [1, 1, 0.2]
    return origins, dirs


def test_buffers_upload_gives_embree_the_bytes_of_embreex_upload_ray_by_ray(world):
    geometry, pose, _, settler = world
    fast = EmbreeBackend(geometry, settler=settler)
    slow = EmbreeBackend(geometry, settler=settler, upload="embreex")
    assert (fast.upload, slow.upload) == ("buffers", "embreex")
    origins, dirs = _rays(geometry, pose)
    a = fast._first_hits(origins, dirs, 40.0)
    b = slow._first_hits(origins, dirs, 40.0)
    assert (a[0] >= 0).sum() > 10_000  # most rays hit something
    assert np.array_equal(a[0], b[0])
    for x, y in ((a[1], b[1]), (a[2][0], b[2][0]), (a[2][1], b[2][1])):
        assert x.dtype == np.float32 and x.tobytes() == y.tobytes()


def test_a_scene_it_cannot_prove_is_filled_by_embreex_instead(world, monkeypatch):
    geometry, pose, _, settler = world

    def refuse(*_args):
        raise ImportError("another embreex layout")

    monkeypatch.setattr(embree_buffers, "scene_handle", refuse)
    backend = EmbreeBackend(geometry, settler=settler)
    assert backend.upload == "embreex"
    origins, dirs = _rays(geometry, pose, 2000)
    monkeypatch.undo()
    assert np.array_equal(
        backend._first_hits(origins, dirs, 40.0)[0],
        EmbreeBackend(geometry, settler=settler)._first_hits(origins, dirs, 40.0)[0],
    )


def test_scene_handle_is_refused_for_another_device_or_flags():
    from embreex import rtcore, rtcore_scene

    device, other = rtcore.EmbreeDevice(), rtcore.EmbreeDevice()
    scene = rtcore_scene.EmbreeScene(device=device, robust=True)
    handle = embree_buffers.scene_handle(scene, device, robust=True)
    assert handle and scene.is_committed == 0  # the field used to find the layout is put back
    with pytest.raises(ImportError):
        embree_buffers.scene_handle(scene, other, robust=True)
    with pytest.raises(ImportError):
        embree_buffers.scene_handle(scene, device, robust=False)


def _ply(result, directory, name):
    """The PLY bytes (metadata naming the same backend) and the vertex records' bytes."""
    metadata = dict(result.metadata, backend="embree")
    ply, _ = write_scan_files(directory / f"{name}.ply", result.cloud, metadata)
    records, _ = read_ply(ply)
    return hashlib.sha256(ply.read_bytes()).hexdigest(), records.tobytes()


@pytest.mark.parametrize(
    "sensor",
    [
        SensorConfig(rh_deg=2.0),
        SensorConfig.for_device(device_named("os1-64")),
        SensorConfig(rh_deg=4.0, model="realistic"),
    ],
    ids=["hokuyo", "os1-64", "realistic"],
)
def test_open3d_scans_are_embrees_ply_bytes(world, sensor, tmp_path):
    geometry, pose, z_start, settler = world
    scans = {}
    for backend in (EmbreeBackend(geometry, settler=settler), Open3DBackend(geometry, settler=settler)):
        result = run_scan(backend, pose, sensor.validate(), "leveled", z_start)
        assert len(result.cloud) > 1000
        scans[backend.name] = _ply(result, tmp_path, backend.name)
    assert scans["open3d"] == scans["embree"]


def test_open3d_is_a_backend_that_make_backend_gives(world):
    geometry, pose, _, _ = world
    backend = select.make_backend(
        "open3d", geometry=geometry, center=(pose.x, pose.y), radius=40.0, notify=None
    )
    assert isinstance(backend, Open3DBackend) and backend.geometry.triangle_count < geometry.triangle_count
    local, dirs = _rays(backend.geometry, pose, 3000)
    origins = local + backend.geometry.offset  # cast takes world coordinates
    embree = EmbreeBackend(backend.geometry)
    a, b = backend.cast(origins, dirs, 30.0, normals=True), embree.cast(origins, dirs, 30.0, normals=True)
    assert a.hit.sum() > 1000
    for field in ("distance", "class_id", "instance", "normal"):
        assert getattr(a, field).tobytes() == getattr(b, field).tobytes(), field
    assert a.untagged_objects == b.untagged_objects


def test_without_open3d_the_open3d_backend_falls_back_and_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "open3d", None)
    assert select.missing_reason("open3d") is not None
    lines = []
    assert select.resolve_backend("open3d", notify=lines.append) == "bvh"
    assert len(lines) == 1 and "'open3d'" in lines[0] and "pip install open3d" in lines[0]


# -- the suite ------------------------------------------------------------------------------


@pytest.mark.slow
def test_the_casters_suite_measures_every_candidate_side_by_side():
    from wildscan.bench.caster_table import CANDIDATES, missing
    from wildscan.bench.casters import bench_casters

    printed = io.StringIO()
    rows = bench_casters(seed=0, quick=True, stream=printed)
    text = printed.getvalue()
    assert [r["name"] for r in rows] == [c.name for c in CANDIDATES]
    for candidate, row in zip(CANDIDATES, rows):
        line = next(ln for ln in text.splitlines() if ln.startswith(candidate.name + " "))
        why = missing(candidate)
        if why is not None:  # not installed here (or no GPU): the row says so and how to get it
            assert row["error"] == why and candidate.hint in why
            assert line.rstrip().endswith("no: " + why.split(" (")[0])
            continue
        assert "error" not in row, row
        assert 0 < row["upload_s"] <= row["build_s"]
        for rays in ("hokuyo", "os1-64"):
            assert row[rays]["rays"] > 60_000 and row[rays]["one_s"] > 0
        assert row["same"] == {"hokuyo": True, "os1-64": True, "realistic": True}, candidate.name
        assert line.rstrip().endswith("yes")
    shipped = {r["name"] for r in rows if "error" not in r}
    assert {"embreex", "embree", "embree-packets", "open3d"} <= shipped


def test_the_casters_suite_is_dispatched_with_seed_and_quick(monkeypatch):
    from wildscan import cli
    from wildscan.bench import casters

    calls = []
    monkeypatch.setattr(casters, "bench_casters", lambda seed, quick: calls.append((seed, quick)))
    assert cli.main(["bench", "--suite", "casters", "--seed", "2", "--quick"]) == 0
    assert calls == [(2, True)]


def test_backend_options_are_refused_for_the_casters_suite(capsys):
    from wildscan import cli

    assert cli.main(["bench", "--suite", "casters", "--backends", "embree"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--backends applies to --suite backends only" in err[0], err
