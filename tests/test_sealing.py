"""raycast/sealing.py makes a sealed caster's planes, padded triangles and settling bands in
one pass: the same bits as the separate steps it replaces (geometry._planes,
padding.pad_triangles, settle._band), on triangles of every awkward kind and on a world's
own triangles; settle.stable_order is numpy's stable argsort."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.raycast import sealing
from wildscan.raycast.blocks import BLOCK_ROWS
from wildscan.raycast.from_plan import world_geometry
from wildscan.raycast.geometry import from_triangles
from wildscan.raycast.padding import edge_pad
from wildscan.raycast.settle import Settler, stable_order


def reference(geometry):
    """The arrays as the separate steps make them."""
    corners = geometry.local_triangles()
    settler = Settler.sealing(geometry, geometry.local_planes(corners), corners)
    return settler.normal, settler.d, settler.padded, settler.band


def awkward_triangles(rng, count: int) -> np.ndarray:
    """Random triangles with degenerate ones mixed in: repeated corners, collinear corners,
    slivers, zero-area points, negative zeros and far coordinates."""
    tris = rng.normal(scale=20.0, size=(count, 3, 3))
    tris[::7, 1] = tris[::7, 0]  # two corners the same
    tris[1::7, 2] = 0.5 * (tris[1::7, 0] + tris[1::7, 1])  # collinear
    tris[2::7, 2] = tris[2::7, 1] + 1e-9 * rng.normal(size=(len(tris[2::7]), 3))  # slivers
    tris[3::7] = tris[3::7, :1]  # all three at one point
    tris[4::7] = -0.0 * np.abs(tris[4::7])  # negative zeros
    tris[5::7] += 1e4  # far from the origin
    return tris


def assert_same_bits(got, want):
    for g, w in zip(got, want, strict=True):
        assert g.dtype == w.dtype and g.shape == w.shape
        assert g.tobytes() == w.tobytes()


@pytest.mark.parametrize("count", [0, 1, 5, BLOCK_ROWS + 3])
def test_one_pass_equals_the_separate_steps_bit_for_bit(count):
    geometry = from_triangles(awkward_triangles(np.random.default_rng(count), count))
    settler = sealing.sealed_settler(geometry)
    assert_same_bits((settler.normal, settler.d, settler.padded, settler.band), reference(geometry))
    assert settler.corners.tobytes() == geometry.local_triangles().tobytes()


def test_one_pass_equals_the_separate_steps_on_a_world():
    geometry = world_geometry(4, "low", vegetation="porous")
    settler = sealing.sealed_settler(geometry)
    assert_same_bits((settler.normal, settler.d, settler.padded, settler.band), reference(geometry))


def test_the_pad_is_the_geometry_pad():
    tris = awkward_triangles(np.random.default_rng(3), 50)
    for scale in (1e-3, 1.0, 1e5):
        assert sealing.edge_pad(tris * scale) == edge_pad(tris * scale)
        assert sealing.edge_pad(-tris * scale) == edge_pad(-tris * scale)
    assert sealing.edge_pad(np.zeros((0, 3, 3))) == edge_pad(np.zeros((0, 3, 3)))


@pytest.mark.parametrize("high", [3, 70_000, 2**32 - 1, 2**40])
def test_stable_order_is_numpys_stable_argsort(high):
    keys = np.random.default_rng(high).integers(0, high, size=100_000)
    assert np.array_equal(stable_order(keys), np.argsort(keys, kind="stable"))
    assert np.array_equal(stable_order(keys[:0]), np.argsort(keys[:0], kind="stable"))
