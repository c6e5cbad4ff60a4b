"""Open ground (core/truth/open_ground.py): the bird's-eye cells a dataset worker answers from a
raster instead of casting must get the class the cast gives, on a whole world."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from wildscan.core.truth.open_ground import MARGIN, RASTER_CELL, open_ground

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

EXTENT = (-10.0, 10.0, -5.0, 5.0)


def square_xy(x, y, half):
    """Two triangles (2, 3, 2) covering the square of side 2 half centred on (x, y)."""
    a, b, c, d = (x - half, y - half), (x + half, y - half), (x + half, y + half), (x - half, y + half)
    return np.array([[a, b, c], [a, c, d]], dtype=np.float64)


def soup_ground(triangles_xy):
    """open_ground of a triangle soup (T, 3, 2)."""
    tris = np.asarray(triangles_xy, dtype=np.float64).reshape(-1, 3, 2)
    return open_ground(tris.reshape(-1, 2), np.arange(3 * len(tris)).reshape(-1, 3), EXTENT)


def test_a_cell_is_open_only_beyond_every_grown_bounding_box():
    ground = soup_ground(square_xy(2.0, 1.0, 0.5))
    edge = 2.5 + MARGIN
    assert not ground.contains(np.array([2.0, edge - 1e-6, 2.0]), np.array([1.0, 1.0, 1.0 + 0.5])).any()
    assert ground.contains(np.array([edge + RASTER_CELL, 0.0, -7.3]), np.array([1.0, -3.0, 2.2])).all()


def test_the_border_and_everything_off_the_raster_are_never_open():
    ground = soup_ground(np.zeros((0, 3, 2)))
    assert ground.contains(np.array([0.0]), np.array([0.0]))[0]
    xs = np.array([-10.0, -9.95, 10.0, 10.05, -10.5, 11.0, 0.0, 0.0])  # the terrain's edge is at x = 10
    ys = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -5.0, 40.0])
    assert not ground.contains(xs, ys).any()


def test_a_thin_long_triangle_marks_its_whole_bounding_box():
    wire = np.array([[[-8.0, -4.0], [8.0, 4.0], [8.0, 4.001]]])
    ground = soup_ground(wire)
    assert not ground.contains(np.array([-8.0, 0.0, 7.9]), np.array([-4.0, 0.0, -3.9])).any()
    assert ground.contains(np.array([0.0]), np.array([4.5]))[0]


@pytest.fixture(scope="module")
def context():
    from wildscan.app.dataset import spec_from_dict
    from wildscan.app.dataset.worker import build_world

    spec = spec_from_dict(
        {"layout": "paper", "seeds": [2], "scans_per_world": 1, "detail": "low", "vegetation": "porous"}
    )
    return build_world(spec, 2)


def test_open_ground_gives_the_class_the_cast_gives_everywhere_in_a_world(context):
    from wildscan.core.truth.open_ground import no_open_ground
    from wildscan.core.world import EXTENT as world_extent

    assert context.open_ground.is_open.any()  # the worker found its terrain covering the extent
    rng = np.random.default_rng(7)
    x0, x1, y0, y1 = world_extent
    points = np.column_stack(
        [rng.uniform(x0, x1, 200_000), rng.uniform(y0, y1, 200_000), np.full(200_000, context.z_range[1] + 1)]
    )
    depth = context.z_range[1] - context.z_range[0] + 2
    cast_all = dataclasses.replace(context, open_ground=no_open_ground(world_extent))
    assert np.array_equal(context.top_classes(points, depth), cast_all.top_classes(points, depth))
    opened = context.open_ground.contains(points[:, 0], points[:, 1])
    assert 0.4 < opened.mean() < 0.95  # it saves casts, and not by opening everything
