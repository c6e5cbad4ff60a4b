"""Open sky (core/truth/open_sky.py): the bird's-eye cells whose upward ray a dataset worker answers
from a raster instead of casting must get what the cast gives, on a whole world."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.core.truth.open_sky import _block_minimum, _NodeIndex, open_sky
from wildscan.core.world.terrain_grid import TerrainGrid

EXTENT = (-10.0, 10.0, -5.0, 5.0)
START = 1.1  # m above the ground where the upward rays start


def sloped_grid() -> TerrainGrid:
    """A grid over more than EXTENT rising 0.2 m a metre along x, its nodes unevenly spaced."""
    xs = np.concatenate([np.linspace(-11.0, 0.0, 23), np.linspace(0.3, 11.0, 30)])
    ys = np.linspace(-6.0, 6.0, 41)
    return TerrainGrid(xs, ys, np.tile(0.2 * xs, (len(ys), 1)))


def box_at(x: float, y: float, half: float, z: float):
    """A horizontal square (two triangles) of side 2 half centred on (x, y) at height z."""
    corners = [(x - half, y - half), (x + half, y - half), (x + half, y + half), (x - half, y + half)]
    v = np.array([[cx, cy, z] for cx, cy in corners])
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def soup(*parts):
    vertices, faces, base = [], [], 0
    for v, f in parts:
        vertices.append(v)
        faces.append(f + base)
        base += len(v)
    return np.concatenate(vertices), np.concatenate(faces)


def test_a_low_surface_leaves_the_sky_open_and_a_high_one_closes_it():
    grid = sloped_grid()
    low = box_at(-4.0, 1.0, 0.3, 0.2 * -4.0 + 0.8)  # a table top 0.8 m over the ground: below the rays
    high = box_at(4.0, -1.0, 0.3, 0.2 * 4.0 + 1.2)  # 1.2 m over it: the rays starting at 1.1 m meet it
    sky = open_sky(*soup(low, high, _grid_triangles(grid)), grid, START, EXTENT)
    assert sky.contains(np.array([-4.0, -3.75, 0.0]), np.array([1.0, 1.25, 0.0])).all()
    assert not sky.contains(np.array([4.0, 4.25, 3.75]), np.array([-1.0, -0.75, -1.25])).any()
    assert sky.is_open.mean() > 0.9  # the grid's own triangles close nothing


def test_the_ground_under_a_surface_is_its_lowest_node_around_it_so_a_slope_counts():
    grid = sloped_grid()
    # 1.05 m over the ground at its centre, where the rays start 1.1 m up, but its box reaches
    # 0.5 m downhill, where the ground is 0.1 m lower: a ray starting there meets it
    v, f = box_at(2.0, 0.0, 0.5, 0.2 * 2.0 + 1.05)
    assert not open_sky(v, f, grid, START, EXTENT).contains(np.array([2.0]), np.array([0.0]))[0]


def test_block_minimum_and_node_index_against_brute_force():
    rng = np.random.default_rng(3)
    z = rng.normal(size=(9, 12))
    m = _block_minimum(z)
    for j in range(9):
        for i in range(12):
            assert m[j, i] == z[j : j + 4, i : i + 4].min()
    nodes = np.cumsum(rng.uniform(0.14, 1.5, 40))
    low = rng.uniform(nodes[0] - 1, nodes[-1] + 1, 5000)
    high = low + rng.uniform(0, 2, 5000)
    before, after = _NodeIndex(nodes).around(low, high)
    inside_low = low >= nodes[0]
    assert (nodes[before][inside_low] <= low[inside_low]).all()
    inside_high = high <= nodes[-1]
    assert (nodes[after][inside_high] >= high[inside_high]).all()
    assert (after - before <= np.searchsorted(nodes, high) - np.searchsorted(nodes, low, "right") + 5).all()


def _grid_triangles(grid: TerrainGrid):
    v, f = grid.mesh()
    return np.asarray(v, dtype=np.float64), np.asarray(f)


@pytest.mark.slow
def test_open_sky_gives_the_distance_the_cast_gives_everywhere_in_a_world():
    from wildscan.app.dataset import spec_from_dict
    from wildscan.app.dataset.worker import build_world
    from wildscan.core.truth.traversability import ROBOT_HEIGHT
    from wildscan.core.world import EXTENT as world_extent

    spec = spec_from_dict(
        {"layout": "paper", "seeds": [2], "scans_per_world": 1, "detail": "low", "vegetation": "porous"}
    )
    context = build_world(spec, 2)
    rng = np.random.default_rng(11)
    x0, x1, y0, y1 = world_extent
    x, y = rng.uniform(x0, x1, 200_000), rng.uniform(y0, y1, 200_000)
    origins = np.column_stack([x, y, context.ground(x, y) + ROBOT_HEIGHT])
    up = np.broadcast_to(np.array([0.0, 0.0, 1.0]), origins.shape)
    assert np.array_equal(context.cast_up(origins, 10.0), context.backend.cast(origins, up, 10.0).distance)
    opened = context.open_sky.contains(x, y)
    assert 0.4 < opened.mean() < 0.95  # it saves casts, and not by opening everything
