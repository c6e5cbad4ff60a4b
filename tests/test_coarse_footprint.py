"""Coarse to fine (core/realism/coarse_footprint.py): which ring sub-rays a realistic scan casts, and
that the ones it computes on their axis's plane are the hits a cast would give."""

import numpy as np
import pytest

from wildscan.core import sensors as S
from wildscan.core.hits import RayHits
from wildscan.core.placement import Pose
from wildscan.core.realism import coarse_footprint as C
from wildscan.core.realism import realistic
from wildscan.core.realism.footprint import subray_directions
from wildscan.core.scan import run_scan

from tests.helpers.analytic import AnalyticBackend, Patch

TERRAIN, TREETOP, ROCK, WIRE = 1, 3, 9, 11


def flat_axis_hits(grid: C.BeamGrid, distance=10.0, cls=TERRAIN, instance=1):
    """Axis hits of every beam of `grid` on one plane facing them (each at `distance`)."""
    n = len(grid)
    dirs = np.tile([0.0, 0.0, -1.0], (n, 1))
    hits = RayHits(
        distance=np.full(n, distance),
        class_id=np.full(n, cls, dtype=np.int16),
        instance=np.full(n, instance, dtype=np.int32),
        normal=np.tile([0.0, 0.0, 1.0], (n, 1)),
    )
    return hits, dirs


def sides_of(grid):
    """Ring sub-ray k points to side k (before, after, column before, after) at every beam."""
    return np.broadcast_to(np.arange(4, dtype=np.int8)[:, None, None], (4,) + grid.shape)


def test_a_footprint_inside_one_plane_is_computed_and_one_at_the_grids_edge_is_cast():
    grid = C.BeamGrid(np.arange(20.0), columns=12)
    hits, dirs = flat_axis_hits(grid)
    cast = C.rings_to_cast(hits, dirs, grid, sides_of(grid))
    on_grid = cast.reshape(4, 12, 20)
    assert not on_grid[:, 1:-1, 1:-1].any()
    assert on_grid[0, :, 0].all() and on_grid[1, :, -1].all()  # no neighbour before / after
    assert on_grid[2, 0].all() and on_grid[3, -1].all()  # no column before / after
    assert not on_grid[0, :, -1].any()  # the side that has a neighbour is computed


def test_a_sub_ray_facing_another_element_a_step_or_porous_leaves_is_cast():
    grid = C.BeamGrid(np.arange(20.0), columns=12)
    hits, dirs = flat_axis_hits(grid)
    instance = grid.view(hits.instance)
    instance[:, 10:] = 2  # another element from beam 10 on
    distance = grid.view(hits.distance)
    distance[6, :] += 0.05  # a 5 cm step at column 6
    cls = grid.view(hits.class_id)
    cls[2, :] = TREETOP
    cast = C.rings_to_cast(hits, dirs, grid, sides_of(grid)).reshape(4, 12, 20)
    assert cast[1, 4, 9] and cast[0, 4, 10]  # facing across the boundary
    assert not cast[0, 4, 9] and not cast[1, 4, 10]  # facing away from it
    assert cast[3, 5, 5] and cast[2, 7, 5] and cast[2:, 6, 5].all()  # across the step
    assert not cast[2, 5, 5] and not cast[:2, 6, 5].any()  # along it: the same plane
    assert cast[:, 2].all()  # porous: cast whatever the neighbours


def test_the_sky_is_computed_unless_an_axis_met_something_near_and_thin_elements_widen_the_cast():
    grid = C.BeamGrid(np.arange(40.0), columns=30)
    hits, dirs = flat_axis_hits(grid)
    hits.distance[:] = np.inf
    hits.class_id[:] = -1
    cast = C.rings_to_cast(hits, dirs, grid, sides_of(grid)).reshape(4, 30, 40)
    assert not cast.any()
    grid.view(hits.distance)[15, 20] = 10.0  # a wire, met by one axis
    grid.view(hits.class_id)[15, 20] = WIRE
    cast = C.rings_to_cast(hits, dirs, grid, sides_of(grid)).reshape(4, 30, 40)
    rows, cols = C.EMPTY_REACH
    assert cast[:, 15 - cols : 15 + cols + 1, 20 - rows : 20 + rows + 1].all()
    assert not cast[:, 15 + cols + 1 :].any() and not cast[:, :, : 20 - rows].any()


def test_each_ring_sub_ray_is_judged_by_the_neighbour_it_points_at():
    sensor = S.SensorConfig(model="realistic").validate()
    grid, sides = C.scan_grid(sensor.device, 1.0, sensor.divergence_mrad)
    sub = subray_directions(1.0, sensor.divergence_mrad)
    axis = grid.view(sub[0])
    rng = np.random.default_rng(0)
    for _ in range(200):
        c, b = rng.integers(1, grid.shape[0] - 1), rng.integers(1, grid.shape[1] - 1)
        if abs(b - grid.shape[1] // 2) < 2:
            continue  # the beams along the head's axis, where every column meets
        neighbours = [axis[c, b - 1], axis[c, b + 1], axis[c - 1, b], axis[c + 1, b]]
        for k in range(4):
            offset = grid.view(sub[1 + k])[c, b] - axis[c, b]
            cosines = [np.dot(offset, v - axis[c, b]) / np.linalg.norm(v - axis[c, b]) for v in neighbours]
            assert sides[k, c, b] == int(np.argmax(cosines))


@pytest.fixture
def scene():
    """Terrain sloping gently, a rock face, a wire across, a crown's leaf patch."""
    return AnalyticBackend(
        [
            Patch((0, 0, 0), (0.1, 0.05, 1), TERRAIN),
            Patch((5, 0, 0), (-1, 0.2, 0.1), ROCK, instance=7, xy_box=(4, 6, -2, 2)),
            Patch((0, -4, 1.5), (0, 1, 0), WIRE, instance=9, xy_box=(-3, 3, -4.1, -3.9)),
            Patch((-3, 3, 2), (1, -1, 0.3), TREETOP, instance=4, xy_box=(-4, -2, 2, 4)),
        ]
    )


def test_coarse_to_fine_gives_the_full_footprints_echoes_on_planes(scene, monkeypatch):
    sensor = S.SensorConfig(model="realistic", rh_deg=2.0, noise_sigma=0.0)
    pose = Pose(0.2, 0.1, 15)
    fine = run_scan(scene, pose, sensor)
    monkeypatch.setattr(realistic, "scan_grid", lambda *a: None)
    full = run_scan(scene, pose, sensor)
    a, b = full.cloud, fine.cloud
    assert len(a) > 20_000 and len(a) == len(b)
    for field in ("label", "instance", "ring", "sweep"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    assert np.array_equal(a.extra["echo"], b.extra["echo"])
    assert np.abs(a.range - b.range).max() <= 1e-5  # float32 of ranges equal to round-off
    assert np.allclose(a.intensity, b.intensity, rtol=1e-5)
    stats = fine.metadata["echoes"]
    assert 0 < stats["ring_subrays_cast"] < 0.5 * 4 * sensor.beam_count


def test_computed_ring_hits_are_the_cast_ones_on_a_plane(scene):
    sensor = S.SensorConfig(model="realistic", rh_deg=2.0).validate()
    sub = subray_directions(2.0, sensor.divergence_mrad)
    origin = np.array([0.2, 0.1, 1.3])

    def cast(o, d, r, normals):
        return scene.cast(o, d, r, normals=normals)

    hits, fine = C.footprint_hits(cast, origin, sub, 30.0, *C.scan_grid(sensor.device, 2.0, 4.4))
    every = scene.cast(origin, sub.reshape(-1, 3), 30.0, normals=True)
    computed = np.flatnonzero(~fine.ravel()) + sub.shape[1]
    assert len(computed) > 0.5 * fine.size
    assert np.array_equal(hits.class_id[computed], every.class_id[computed])
    assert np.array_equal(hits.instance[computed], every.instance[computed])
    met = np.isfinite(every.distance[computed])
    assert np.array_equal(np.isfinite(hits.distance[computed]), met)
    assert np.allclose(hits.distance[computed][met], every.distance[computed][met], rtol=1e-12)


def test_the_same_bytes_with_one_or_two_cast_threads(scene, monkeypatch):
    from wildscan.core.runtime import threads

    sensor = S.SensorConfig(model="realistic", rh_deg=2.0)
    monkeypatch.setenv(threads.THREADS_ENV, "1")
    one = run_scan(scene, Pose(0.2, 0.1, 15), sensor).cloud
    monkeypatch.setenv(threads.THREADS_ENV, "2")
    two = run_scan(scene, Pose(0.2, 0.1, 15), sensor).cloud
    for field in ("xyz", "range", "intensity", "label", "instance"):
        assert getattr(one, field).tobytes() == getattr(two, field).tobytes(), field


@pytest.mark.parametrize("rows_per_block", [1, 3, 7, 40])
def test_rings_chosen_a_block_of_columns_at_a_time_are_those_chosen_at_once(rows_per_block):
    """footprint_hits chooses each block's rings from the axes within HALO columns of it: the
    same choice as from every axis (steps, other elements, porous and thin ones, the sky, the
    head's sweeps meeting, near every block's edges)."""
    rng = np.random.default_rng(5)
    grid = C.BeamGrid(rng.permutation(30).astype(float), columns=20, sweeps=2)
    hits, dirs = flat_axis_hits(grid)
    hits.distance += np.round(rng.random(len(grid)), 1) * 0.03  # steps of 0 to 3 cm
    hits.instance[:] = rng.integers(1, 3, len(grid))
    hits.class_id[:] = rng.choice([TERRAIN, TREETOP, ROCK, WIRE], len(grid), p=[0.85, 0.05, 0.07, 0.03])
    sky = grid.view(hits.distance)
    sky[:, 18:] = np.inf  # no axis met anything there: near the others or not
    sides = np.ascontiguousarray(sides_of(grid)[:, :, ::-1])
    every = C.rings_to_cast(hits, dirs, grid, sides)
    blocks = [
        C.rings_to_cast(hits, dirs, grid, sides, slice(a, min(a + rows_per_block, grid.shape[0])))
        for a in range(0, grid.shape[0], rows_per_block)
    ]
    assert every.any() and not every.all()
    assert np.array_equal(np.concatenate(blocks, axis=1), every)
