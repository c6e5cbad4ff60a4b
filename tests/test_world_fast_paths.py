"""The world build's shortcuts give what the general code gives, bit for bit: the terrain
height at one point (heightfield.interpolate's Python-float path), the cell of many points
(grid_height.cell_index's bucket table) and the trail's keep-out
(geometry2d.polyline_near, the distance only for points near the path)."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.core.world.geometry2d import polyline_distance, polyline_near
from wildscan.core.world.grid_height import cell_index, interpolate


def grid(rng):
    xs = np.sort(rng.uniform(-100.0, 100.0, 41))
    ys = np.linspace(-90.0, 110.0, 37)
    return xs, ys, rng.normal(scale=5.0, size=(len(ys), len(xs)))


def test_one_point_gives_the_bits_of_an_array_of_points():
    rng = np.random.default_rng(7)
    xs, ys, z = grid(rng)
    points = [*rng.uniform(-130.0, 130.0, (3000, 2))]  # inside, outside, on both sides
    points += [(xs[3], ys[5]), (xs[0], ys[0]), (xs[-1], ys[-1]), (-0.0, -0.0), (xs[4], 0.0), (0.0, ys[2])]
    for x, y in points:
        want = interpolate(xs, ys, z, np.array([x]), np.array([y]))
        for one in ((float(x), float(y)), (np.float64(x), np.float64(y)), (np.asarray(x), np.asarray(y))):
            got = interpolate(xs, ys, z, *one)
            assert got.shape == () and got.dtype == np.float64
            assert got.tobytes() == want.tobytes()


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_a_point_not_finite_takes_the_array_path(value):
    xs, ys, z = grid(np.random.default_rng(1))
    got = interpolate(xs, ys, z, value, 0.0)
    assert got.tobytes() == interpolate(xs, ys, z, np.array([value]), np.array([0.0])).tobytes()


@pytest.mark.parametrize("axis", ["uniform", "random", "clustered", "close"])
def test_the_bucketed_cell_index_is_searchsorted_exactly(axis):
    """grid_height.cell_index (a bucket table and steps) against the searchsorted it replaces:
    on every node, one ulp either side, between, off both ends, NaN and infinities."""
    rng = np.random.default_rng(3)
    nodes = {
        "uniform": np.linspace(-75.0, 75.0, 277),
        "random": np.unique(rng.uniform(-75.0, 75.0, 300)),
        "clustered": np.cumsum(rng.choice([0.129, 0.5, 1.47, 0.01], 300)) - 70.0,
        "close": np.cumsum(rng.choice([0.5, 1e-4], 300)) - 70.0,  # a table too large: searched
    }[axis]
    values = np.concatenate(
        [
            nodes,
            np.nextafter(nodes, -np.inf),
            np.nextafter(nodes, np.inf),
            (nodes[:-1] + nodes[1:]) / 2,
            rng.uniform(nodes[0] - 5.0, nodes[-1] + 5.0, 20_000),
            [np.nan, np.inf, -np.inf, 1e300, -1e300, -0.0],
        ]
    )
    want = np.clip(np.searchsorted(nodes, values, side="right") - 1, 0, len(nodes) - 2)
    with np.errstate(all="raise"):
        got = cell_index(nodes, values)
    assert np.array_equal(got, want)


def test_near_a_polyline_is_the_distance_below_the_limit():
    rng = np.random.default_rng(3)
    path = np.cumsum(rng.normal(scale=0.5, size=(300, 2)), axis=0) + [20.0, -10.0]
    pts = np.concatenate([rng.uniform(-60.0, 80.0, (20_000, 2)), path + 0.01, [[np.nan, 0.0]]])
    for limit in (0.1, 1.6, 4.0):
        near = polyline_near(path, pts, limit)
        assert np.array_equal(near, polyline_distance(path, pts) < limit)
        assert 0 < near.sum() < len(pts)
    assert not polyline_near(path, pts[:0], 1.0).size


def test_the_field_on_a_lattice_seen_before_is_the_field_made_afresh():
    """Heightfield keeps the last lattice's noise: evaluated again there with other features
    (the planner lowering its hills), it gives what a field without that memory gives."""
    from dataclasses import replace

    from wildscan.core.world.heightfield import Bumps, FractalNoise, Heightfield, RectWindow

    def field(gain):
        bumps = Bumps(((10.0, -5.0),), (6.0,), (15.0,), RectWindow(-50.0, 50.0, -50.0, 50.0, 10.0), gain)
        return Heightfield(FractalNoise(np.random.default_rng(5), 60.0, 4), 4.0, [bumps])

    gx, gy = np.meshgrid(np.linspace(-60.0, 60.0, 61), np.linspace(-60.0, 60.0, 47))
    kept = field(1.0)
    first = kept.raw(gx, gy)
    kept.features[0] = replace(kept.features[0], gain=0.5)
    assert kept.raw(gx, gy).tobytes() == field(0.5).raw(gx, gy).tobytes()
    assert kept.raw(gx + 1.0, gy).tobytes() == field(0.5).raw(gx + 1.0, gy).tobytes()  # other points
    assert first.tobytes() == field(1.0).raw(gx, gy).tobytes()
    assert not np.array_equal(first, kept.raw(gx, gy))
