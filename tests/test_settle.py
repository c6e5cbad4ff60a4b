"""raycast/settle.py: where the float32 caster could report one triangle or another (its
answer depends on the instruction set Embree picks), the float64 geometry decides."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.raycast.embree_backend import EmbreeBackend
from wildscan.raycast.geometry import from_triangles
from wildscan.raycast.settle import position_ids

# Two objects meeting along the diagonal of the unit square at z = 0 (separate vertex
# copies, as two meshes have), and a floor 1 m below.
HALF_A = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]]  # below the diagonal y = x
HALF_B = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]]  # above it
FLOOR = [[-5.0, -5.0, -1.0], [5.0, -5.0, -1.0], [0.0, 5.0, -1.0]]
DOWN = np.array([[0.0, 0.0, -1.0]])


def scene():
    return from_triangles([HALF_A, HALF_B, FLOOR], instance=[1, 2, 3], class_id=[1, 9, 1])


class ForcedChoice(EmbreeBackend):
    """Embree, except that rays hitting the square are reported on triangle `pick`: what
    Embree on another CPU may answer where the grown triangles overlap."""

    pick = 0

    def _first_hits(self, local, dirs, max_range):
        triangle, rough, _ = super()._first_hits(local, dirs, max_range)
        triangle[np.isin(triangle, (0, 1))] = self.pick
        return triangle, rough, None  # barycentrics then come from the distance, in float64


@pytest.mark.parametrize("offset", [1e-6, -1e-6, 3e-6, -2.5e-5])
def test_which_of_two_overlapping_triangles_the_caster_reports_does_not_matter(offset):
    """A ray a micrometre beside the shared edge lands where both grown triangles are: each
    choice gives the same result, that of the triangle the point is really in."""
    origin = np.array([0.4 + offset, 0.4 - offset, 2.0])  # y < x for offset > 0: half A
    results = []
    for pick in (0, 1):
        backend = ForcedChoice(scene())
        backend.pick = pick
        hits = backend.cast(origin, DOWN, 10.0)
        results.append((hits.instance[0], hits.class_id[0], hits.distance.tobytes()))
    assert results[0] == results[1]
    assert results[0][0] == (1 if offset > 0 else 2)


def test_a_ray_beside_a_silhouette_goes_on_to_what_is_behind():
    """Embree hits the grown triangle 2 um outside its edge; the float64 geometry says the
    ray passes it, so it is cast again from beyond and finds the floor."""
    geometry = from_triangles([HALF_A, FLOOR], instance=[1, 3])
    backend = EmbreeBackend(geometry)
    outside = backend.cast(np.array([1.0 + 2e-6, 0.5, 2.0]), DOWN, 10.0)
    inside = backend.cast(np.array([1.0 - 2e-6, 0.5, 2.0]), DOWN, 10.0)
    assert outside.instance[0] == 3 and outside.distance[0] == 3.0
    assert inside.instance[0] == 1 and inside.distance[0] == 2.0
    raw = EmbreeBackend(geometry)._first_hits(
        np.array([[1.0 + 2e-6, 0.5, 2.0]]) - geometry.offset, DOWN, 10.0
    )
    assert raw[0][0] == 0  # what settling corrected: Embree alone hits the grown triangle


def test_rays_at_shared_edges_and_vertices_still_never_slip_through():
    """Aimed exactly at the diagonal and the corners, every ray hits the square, not the floor."""
    backend = EmbreeBackend(scene())
    points = [[t, t] for t in np.linspace(0.0, 1.0, 41)] + [[0, 1], [1, 0], [0.5, 0.5]]
    origins = np.array([[x, y, 2.0] for x, y in points])
    hits = backend.cast(origins, np.tile(DOWN, (len(origins), 1)), 10.0)
    assert set(hits.instance.tolist()) <= {1, 2} and np.all(hits.distance == 2.0)


def test_the_settling_leaves_clear_hits_alone_and_is_cheap():
    """Only hits near an edge are looked at again: few rays of a scan-like fan."""
    backend = EmbreeBackend(scene())
    rng = np.random.default_rng(0)
    targets = np.column_stack([rng.uniform(0, 1, 20_000), rng.uniform(0, 1, 20_000), np.zeros(20_000)])
    origin = np.array([0.5, 0.5, 3.0])
    dirs = targets - origin
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    local = np.broadcast_to(origin - backend.geometry.offset, dirs.shape)
    triangle, rough, bary = backend._first_hits(local, dirs, 10.0)
    band = backend._settler.in_band(triangle, bary, local, dirs, rough)
    assert 0 < band.sum() < 0.01 * len(dirs)


def test_vertices_at_one_position_get_one_id_as_numpy_unique_groups_them():
    """settle.position_ids groups exactly as np.unique(axis=0) (what it replaces, five times
    slower): equal x with other y or z kept apart, 0.0 and -0.0 one position."""
    rng = np.random.default_rng(4)
    grid = rng.integers(0, 4, size=(3000, 3)).astype(np.float64) - 1.5  # many shared x, some repeats
    spread = rng.normal(size=(3000, 3))  # x all different
    signed_zero = np.array([[0.0, 1.0, 2.0], [-0.0, 1.0, 2.0], [0.0, -0.0, 0.0], [-0.0, 0.0, -0.0]])
    vertices = rng.permutation(np.vstack([grid, spread, spread[:50], signed_zero]))
    ids = position_ids(vertices)
    _, expected = np.unique(vertices, axis=0, return_inverse=True)
    expected = expected.reshape(-1)
    assert ids.max() + 1 == expected.max() + 1 < len(vertices)
    assert len(np.unique(np.stack([ids, expected], axis=1), axis=0)) == expected.max() + 1  # one-to-one


def test_nearest_per_ray_picks_what_a_lexsort_by_ray_t_and_candidate_picks():
    from wildscan.raycast.settle import nearest_per_ray, sorted_unique

    rng = np.random.default_rng(0)
    for _ in range(200):
        n = int(rng.integers(1, 400))
        keys = rng.integers(0, 30, n) * 100 + rng.integers(0, 20, n)
        assert np.array_equal(sorted_unique(keys), np.unique(keys))
        keys = np.unique(keys)
        ray, cand = keys // 100, keys % 100
        t = rng.choice([0.0, -0.0, 0.5, 1.0, 2.0], len(ray))  # ties on purpose
        order = np.lexsort((cand, t, ray))
        r, c = ray[order], cand[order]
        firsts = np.flatnonzero(np.r_[True, r[1:] != r[:-1]])
        got_ray, got_cand = nearest_per_ray(ray, cand, t)
        assert np.array_equal(got_ray, r[firsts]) and np.array_equal(got_cand, c[firsts])


def test_unique_inverse_is_numpys_unique_with_inverse():
    from wildscan.raycast.settle import unique_inverse

    rng = np.random.default_rng(1)
    for keys in (rng.integers(0, 50, 300), rng.integers(0, 1 << 31, 500), np.zeros(0, dtype=np.int64)):
        got, inverse = unique_inverse(keys)
        expected, expected_inverse = np.unique(keys, return_inverse=True)
        assert np.array_equal(got, expected) and np.array_equal(inverse, expected_inverse)
        assert np.array_equal(got[inverse], keys)
