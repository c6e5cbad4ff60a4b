"""Park furniture in the clearings (numpy only): picnic tables with a bench each side, lone
benches facing the middle and a run of fence along part of the rim.

A clearing's furniture is drawn whole from its anchor cell's own generator
(`stage_rng(seed, "endless.clearing.<ci>.<cj>")`), wherever it is asked from; each tile adds
the pieces that stand in it, so a clearing across a seam is whole and never doubled.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ... import detmath as dm
from ...rng import stage_rng
from . import anchors as A
from . import fields as F
from .library import FENCE_SECTION

Piece = tuple[str, str, float, float, float]  # class, prototype, x, y, yaw


@functools.lru_cache(maxsize=1024)
def furniture(seed: int, ci: int, cj: int, cx: float, cy: float, radius: float) -> tuple[Piece, ...]:
    """Every piece of a clearing's furniture."""
    rng = stage_rng(seed, f"endless.clearing.{ci}.{cj}")
    pieces: list[Piece] = []
    spots: list[tuple[float, float]] = []
    for _ in range(int(rng.integers(1, 4))):  # picnic tables, each with two benches
        for _ in range(30):
            r, a = rng.uniform(3.0, radius - 4.0), rng.uniform(0, 2 * math.pi)
            s, c = dm.sincos(a)
            x, y = cx + r * c, cy + r * s
            if all(math.hypot(x - px, y - py) > 5.0 for px, py in spots):
                break
        spots.append((x, y))
        yaw = rng.uniform(0, math.pi)
        s, c = dm.sincos(yaw)
        pieces.append(("table", "table", x, y, yaw))
        for side, turn in ((1, math.pi), (-1, 0.0)):
            pieces.append(("bench", "bench", x - side * 0.95 * s, y + side * 0.95 * c, yaw + turn))
    for _ in range(2):  # lone benches near the rim, facing the middle
        a = rng.uniform(0, 2 * math.pi)
        s, c = dm.sincos(a)
        x, y = cx + (radius - 2.5) * c, cy + (radius - 2.5) * s
        pieces.append(("bench", "bench", x, y, a + 0.5 * math.pi))
    start, arc = rng.uniform(0, 2 * math.pi), rng.uniform(0.6, 1.4)  # a fence along the rim
    r = radius - 1.0
    n = max(2, int(arc * r / FENCE_SECTION))
    for k in range(n):
        a0 = start + k * FENCE_SECTION / r
        s0, c0 = dm.sincos(a0)
        s1, c1 = dm.sincos(a0 + FENCE_SECTION / r)
        x0, y0, x1, y1 = cx + r * c0, cy + r * s0, cx + r * c1, cy + r * s1
        pieces.append(("fence", "fence_section", x0, y0, dm.arctan2(y1 - y0, x1 - x0)))
        if k == n - 1:
            pieces.append(("fence", "fence_post", x1, y1, dm.arctan2(y1 - y0, x1 - x0)))
    return tuple(pieces)


def add_clearings(tile, land: F.Landscape, lib) -> None:
    """The pieces of every clearing that stand in the tile."""
    x0, x1, y0, y1 = tile.rect
    for c in land.anchors.cells_over(x0, x1, y0, y1, 0.5 * A.ANCHOR_M):
        if not c.clearing:
            continue
        for cls, proto, x, y, yaw in furniture(land.seed, c.ci, c.cj, c.node[0], c.node[1], c.clearing):
            if x0 <= x < x1 and y0 <= y < y1:
                z = float(tile.grid.height_at(np.array([x]), np.array([y]))[0])
                tile.add("clearing", cls, proto, location=(x, y, z), yaw=yaw, radius=lib.radius[proto])
