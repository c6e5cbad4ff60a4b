"""The ground `hag` and the bird's-eye `terrain_z` measure from (core/world/ground.py): points
lying exactly on the world's own triangles, on the terrain and on the trail's flooring, are
at height 0 above it at the low detail level, where the terrain grid departs most from the
analytic field and the flooring stands highest above the grid."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.app.cache.worlds import ground_arrays, ground_from_arrays
from wildscan.core.truth.groundtruth import height_above_ground
from wildscan.core.world import plan_world
from wildscan.core.world.ground import FloorTops
from wildscan.core.world.plan import STAGE_INSTANCE_BASE
from wildscan.raycast.from_plan import plan_geometry

SAMPLES = 4000


@pytest.fixture(scope="module")
def low_world():
    plan = plan_world(3, "low", vegetation="solid")
    return plan, plan_geometry(plan)


def points_on(geometry, instance: int, rng: np.random.Generator) -> np.ndarray:
    """Random points on the triangles of one element that face up (not its skirts)."""
    tri = geometry.vertices[geometry.faces[geometry.instance == instance]]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    tri = tri[np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]) > 1e-6]
    pick = rng.integers(0, len(tri), SAMPLES)
    u, v = rng.random(SAMPLES), rng.random(SAMPLES)
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    t = tri[pick]
    return t[:, 0] + u[:, None] * (t[:, 1] - t[:, 0]) + v[:, None] * (t[:, 2] - t[:, 0])


def dataset_ground(plan):
    """The ground the dataset worker measures `hag` and `terrain_z` from: the plan's, as its
    world cache keeps it and reads it back (app/cache/worlds.py)."""
    ground = plan.standing_ground()
    return ground_from_arrays(ground_arrays(ground), len(ground.floors))


def test_points_on_the_trail_flooring_are_at_height_zero(low_world):
    plan, geometry = low_world
    assert plan.params.trail.lift + plan.grid_fit.error.max > 0.05  # the flooring stands well above the grid
    points = points_on(geometry, STAGE_INSTANCE_BASE["trail"] + 1, np.random.default_rng(0))
    hag = height_above_ground(points, dataset_ground(plan))
    assert np.abs(hag).max() < 1e-3


def test_points_on_the_terrain_are_at_height_zero_off_the_trail(low_world):
    plan, geometry = low_world
    points = points_on(geometry, STAGE_INSTANCE_BASE["terrain"] + 1, np.random.default_rng(1))
    trail = plan.layout.trail
    off_trail = plan.trail_distance(points[:, 0], points[:, 1]) > trail.width / 2 + 1.0
    assert off_trail.sum() > SAMPLES * 0.9
    hag = height_above_ground(points[off_trail], dataset_ground(plan))
    assert np.abs(hag).max() < 1e-3


def test_the_ground_is_the_higher_of_the_terrain_and_the_flooring(low_world):
    plan, _ = low_world
    ground = plan.standing_ground()
    x, y = np.meshgrid(np.linspace(-75, 75, 301), np.linspace(-75, 75, 301))
    z, terrain = ground(x, y), plan.ground(x, y)
    assert np.all(z >= terrain)
    trail = plan.layout.trail
    ends = np.min([np.hypot(x - ex, y - ey) for ex, ey in trail.path[[0, -1]]], axis=0)
    # inside the strip, away from the round caps the distance gives its square ends
    on_trail = (plan.trail_distance(x, y) < trail.width / 2 - 0.5) & (ends > trail.width)
    assert on_trail.sum() > 100 and np.all(z[on_trail] > terrain[on_trail] + plan.params.trail.lift / 2)
    off_trail = plan.trail_distance(x, y) > trail.width / 2 + 1.0
    np.testing.assert_array_equal(z[off_trail], terrain[off_trail])


def test_a_triangle_top_is_interpolated_and_nan_outside():
    tops = FloorTops(np.array([[0.0, 0, 1], [2, 0, 3], [0, 2, 1]]), np.array([[0, 1, 2]]))
    np.testing.assert_allclose(tops(np.array([0.5, 1.0, 3.0]), np.array([0.5, 1.0, 3.0])), [1.5, 2.0, np.nan])
