"""The wind's moving scene (raycast/wind.py): the still scene and the swaying objects at rest,
each built once, answer every 2D scan's rays as one scene of the objects posed at its time would."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.core.effects import Effects, Wind
from wildscan.core.motion.timing import head_angles_rad
from wildscan.core.sensors import SensorConfig, directions_at
from wildscan.core.world import plan_world
from wildscan.raycast.from_plan import plan_geometry
from wildscan.raycast.geometry import concatenate
from wildscan.raycast.select import make_backend
from wildscan.raycast.wind import SEPARATION, MovingScene, moving_scene, sphere_layers

SENSOR = SensorConfig(rh_deg=3.0)
KS = np.arange(0, 60)  # 2D scans: the head turns 3 deg each, a half turn in all


def make(geometry):
    return make_backend("embree", geometry=geometry, notify=None)


@pytest.fixture(scope="module")
def forest():
    """A crop of seed 1's world (low detail: treetops, bushes and grass) around a point of
    its trail, and the scan origin 1.2 m above the ground there."""
    plan = plan_world(1, "low")
    geometry = plan_geometry(plan)
    x, y = plan.layout.trail.path[40]
    crop = geometry.cropped((x, y), 18.0)
    ground = make(crop).cast(np.array([x, y, 500.0]), np.array([[0.0, 0.0, -1.0]]), 1000.0).distance[0]
    return crop, np.array([x, y, 500.0 - ground + 1.2])


def fans(ks: np.ndarray) -> np.ndarray:
    """(K * 1080, 3) the beams of 2D scans ks, the sensor level (Eq. 1 directions)."""
    device = SENSOR.device
    return directions_at(head_angles_rad(ks, SENSOR.rh_deg, "stepped", device.timing), device).reshape(-1, 3)


def scene(crop, amplitude_deg: float) -> MovingScene:
    out = moving_scene(crop, Effects((Wind(amplitude_deg, 5),)), make, SENSOR)
    assert isinstance(out, MovingScene) and len(out.layers) > 1  # overlapping crowns: several layers
    return out


def test_at_rest_the_split_scene_answers_as_one_scene(forest):
    """No sway: the still scene and the layers answer every ray as one caster of all triangles."""
    crop, origin = forest
    dirs = fans(KS)
    whole = make(crop).cast(origin, dirs, 30.0)
    split = scene(crop, 0.0).cast_scans(origin, dirs, 30.0, KS)
    moving = np.isin(whole.class_id, Wind.moving_classes)
    assert moving.sum() > 1000  # the test sees foliage
    assert np.array_equal(split.class_id, whole.class_id)
    assert np.array_equal(split.instance, whole.instance)
    np.testing.assert_allclose(split.distance, whole.distance, rtol=0, atol=1e-9)


@pytest.mark.parametrize("amplitude", [3.0, 10.0])
def test_each_2d_scan_sees_the_objects_posed_at_its_time(forest, amplitude):
    """With wind, each 2D scan's rays hit what one scene of the foliage posed at that scan's
    start time (the vertices turned, `Sway.posed`) hits, class, instance and range."""
    crop, origin = forest
    moving = scene(crop, amplitude)
    ks = KS[::7]
    dirs = fans(ks).reshape(len(ks), -1, 3)
    # the robot drives on at 1 m/s: each beam from where the sensor is at its time
    n = dirs.shape[1]
    along = (ks[:, None] + np.arange(n)[None, :] / 1440) * 0.025
    origins = origin + along[:, :, None] * np.array([0.6, 0.8, 0.0])
    split = moving.cast_scans(origins.reshape(-1, 3), dirs.reshape(-1, 3), 30.0, ks)
    swaying = moving.swaying
    vertex_object = np.zeros(len(swaying.vertices), dtype=np.int64)
    vertex_object[swaying.faces.ravel()] = np.repeat(swaying.object_index, 3)
    differs = 0
    for row, k in enumerate(ks):
        posed = swaying.subset(np.ones(swaying.triangle_count, dtype=bool))
        posed.vertices = moving.sway.posed(swaying.vertices, vertex_object, k * moving.period)
        whole = make(concatenate([moving.static.geometry, posed])).cast(origins[row], dirs[row], 30.0)
        mine = split.rows(slice(row * n, (row + 1) * n))
        assert np.array_equal(mine.class_id, whole.class_id)
        assert np.array_equal(mine.instance, whole.instance)
        np.testing.assert_allclose(mine.distance, whole.distance, rtol=0, atol=1e-9)
        rest = moving.cast(origins[row], dirs[row], 30.0)
        differs += int(np.sum(rest.distance != whole.distance))
    assert differs > 50  # the wind moved what the scans see


def test_spheres_of_one_layer_keep_apart():
    rng = np.random.default_rng(3)
    centre = rng.uniform(0, 10, (200, 3))
    radius = rng.uniform(0.1, 2.0, 200)
    layer = sphere_layers(centre, radius)
    for n in np.unique(layer):
        mine = np.flatnonzero(layer == n)
        gap = (
            np.linalg.norm(centre[mine, None] - centre[None, mine], axis=2)
            - radius[mine, None]
            - radius[None, mine]
        )
        np.fill_diagonal(gap, np.inf)
        assert gap.min() >= SEPARATION
    assert layer.max() > 0


@pytest.mark.parametrize("amplitude", [0.0, 6.0])
def test_a_sweeps_chunks_on_two_threads_answer_as_on_one(forest, monkeypatch, amplitude):
    """The sweep casts its chunks of 2D scans on the cast's threads (core/runtime/threads.py) when the
    caster allows it, the still one and the wind's alike: the same answers as on one thread."""
    from wildscan.core.backend import THREADS
    from wildscan.core.motion.sweep import cast_in_chunks

    crop, origin = forest
    backend = scene(crop, amplitude) if amplitude else make(crop)
    assert THREADS in backend.capabilities
    ks = np.arange(130)  # three chunks
    dirs = fans(ks)
    answers, told = [], []
    for threads in ("1", "2"):
        monkeypatch.setenv("WILDSCAN_CAST_THREADS", threads)
        answers.append(cast_in_chunks(backend, origin, dirs, 30.0, ks, told.append))
    one, two = answers
    assert told == [64_800, 64_800, 10_800] * 2
    assert np.array_equal(one.class_id, two.class_id) and np.array_equal(one.instance, two.instance)
    assert one.distance.tobytes() == two.distance.tobytes()
