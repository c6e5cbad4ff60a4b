"""Trails a robot can drive (core/world/endless/anchors.py): no trail of the endless world
crosses land steeper than MAX_TRAIL_SLOPE_DEG, and a trail that bends round steep land is
still decided from its anchor cell alone."""

from __future__ import annotations

import math

import numpy as np

from wildscan.core.world.endless import anchors as A
from wildscan.core.world.endless import fields as F

SEED = 1
# seed 1: the trail east from this anchor cell's node, as drawn, crosses land sloping 26 deg
STEEP_CELL = (-6, -4)


def test_no_trail_within_1500_m_crosses_land_steeper_than_18_deg():
    land = F.landscape(SEED, "mixed")
    trails = land.anchors.trails_over(-1500.0, 1500.0, -1500.0, 1500.0)
    assert len(trails) > 80
    grades = A.steepest_grades([t.path for t in trails], land.height)
    steepest = math.degrees(math.atan(float(grades.max())))
    assert steepest <= A.MAX_TRAIL_SLOPE_DEG, f"a trail crosses a {steepest:.1f} deg slope"
    assert {t.kind for t in trails} == set(range(len(A.TRAIL_KINDS)))


def test_a_trail_bent_round_steep_land_comes_from_its_anchor_cell_alone():
    """Every trail of the cells round STEEP_CELL, asked of two fresh anchor sets in opposite
    orders, is the same path; the steep one left its drawn bend for a gentle shape."""
    ci0, cj0 = STEEP_CELL
    ask = [
        (ci, cj, way) for ci in (ci0 - 1, ci0, ci0 + 1) for cj in (cj0 - 1, cj0, cj0 + 1) for way in (0, 1)
    ]
    land = F.landscape(SEED, "mixed")
    a = A.Anchors(SEED, land.base_height, land.height)
    b = A.Anchors(SEED, land.base_height, land.height)
    mine = [a.trail_way(*k) for k in ask]
    theirs = [b.trail_way(*k) for k in reversed(ask)][::-1]
    assert [t is None for t in mine] == [t is None for t in theirs]
    assert all(
        p is None or (np.array_equal(p.path, q.path) and p.kind == q.kind) for p, q in zip(mine, theirs)
    )
    drawn = [
        A._bent(
            a.cell(ci, cj).node, a.cell(ci + A.WAYS[w][0], cj + A.WAYS[w][1]).node, a.cell(ci, cj).bend[w]
        )
        for ci, cj, w in ask
    ]
    steep = ask.index((ci0, cj0, 0))
    assert A.steepest_grades([drawn[steep]], land.height)[0] > math.tan(math.radians(25.0))
    trail = mine[steep]
    assert trail is not None and not np.array_equal(trail.path, drawn[steep])
    assert A.steepest_grades([trail.path], land.height)[0] <= A.MAX_TRAIL_GRADE
