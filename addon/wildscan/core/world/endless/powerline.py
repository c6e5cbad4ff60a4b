"""Power lines across the endless landscape (numpy only): a line runs along a row of anchor
cells (anchors.Anchors.row_line), a pole every POLE_SPACING metres at x = k POLE_SPACING, three
catenary wires per span (stages/powerline.py's shapes).

Each tile adds the poles that stand in it and the pieces of the wires over it: a span is cut
at the tile's edges (the catenary sampled at the detail level's wire step and at each cut), so
two tiles meet at the same point of the same curve, whichever is built first. Pole heights
come from the analytic terrain, not a tile's mesh, so both ends of a span agree.
"""

from __future__ import annotations

import math

import numpy as np

from ... import detmath as dm
from ...rng import stage_rng
from ..detail import detail_level
from ..shapes.powerline import POLE_ATTACHMENTS, catenary
from ..shapes.primitives import transform, tube
from . import anchors as A
from . import fields as F

WIRE_RADIUS = 0.015  # m (stages/powerline.py PowerlineParams)
SAG_RATIO = (0.025, 0.04)  # mid-span sag / span (stages/powerline.py)


def pole_top(land: F.Landscape, x: float, y: float) -> np.ndarray:
    """The three wire attachments of the pole at (x, y): on the analytic ground's lowest point
    under the pole's foot."""
    sin, cos = dm.sincos(np.linspace(0, 2 * math.pi, 6, endpoint=False))
    z = float(np.min(land.height(x + 0.15 * cos, y + 0.15 * sin)))
    return transform((POLE_ATTACHMENTS, None), (x, y, z), 0.0), z


def span_sag(seed: int, line_y: float, k: int) -> float:
    rng = stage_rng(seed, f"endless.powerline.sag.{line_y:.3f}.{k}")
    return A.POLE_SPACING * rng.uniform(*SAG_RATIO)


def add_powerline(tile, land: F.Landscape, lib, detail: str) -> None:
    d = detail_level(detail)
    x0, x1, y0, y1 = tile.rect
    for line in land.anchors.lines_over(y0, y1):
        if not y0 <= line < y1 + 0.0:
            continue
        k0, k1 = math.floor(x0 / A.POLE_SPACING), math.floor(x1 / A.POLE_SPACING)
        for k in range(k0, k1 + 1):
            px = k * A.POLE_SPACING
            if x0 <= px < x1:
                _, z = pole_top(land, px, line)
                tile.add("scrub", "pole", "pole", location=(px, line, z), yaw=0.0, radius=0.15)
            _span(tile, land, d, line, k)


def _span(tile, land: F.Landscape, d, line: float, k: int) -> None:
    """The wires of span k (pole k to k+1) over the tile's x range."""
    x0, x1 = tile.rect[0], tile.rect[1]
    a, b = k * A.POLE_SPACING, (k + 1) * A.POLE_SPACING
    lo, hi = max(a, x0), min(b, x1)
    if lo >= hi:
        return
    top_a, _ = pole_top(land, a, line)
    top_b, _ = pole_top(land, b, line)
    sag = span_sag(land.seed, line, k)
    samples = max(4, int(math.ceil(A.POLE_SPACING / d.wire_step))) + 1
    for j in range(len(POLE_ATTACHMENTS)):
        path = catenary(top_a[j], top_b[j], sag, samples)
        piece = _cut(path, lo, hi)
        if len(piece) >= 2:
            key = tile.own(f"wire{line:.0f}_{k}_{j}", tube(piece, WIRE_RADIUS, d.wire_sides, caps=False))
            tile.add("scrub", "wire", key, radius=WIRE_RADIUS)


def _cut(path: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """The part of a polyline (x increasing) with lo <= x <= hi, its ends interpolated."""
    x = path[:, 0]
    inner = path[(x > lo) & (x < hi)]
    ends = [np.array([np.interp(v, x, path[:, c]) for c in range(3)]) for v in (lo, hi)]
    return np.vstack([ends[0][None], inner, ends[1][None]])
