"""Stage "powerline": poles along a route over the hills, three catenary wires per span."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import detmath as dm
from ..geometry2d import Rect, long_axis, polyline_distance
from ..plan import Clearance, SiteOffer, WorldPlan, ZoneShape, rounded
from ..shapes.powerline import POLE_ATTACHMENTS, catenary, pole, wire
from ..shapes.primitives import transform

STAGE = "powerline"


@dataclass(frozen=True)
class PowerlineParams:
    sag_ratio: tuple[float, float] = (0.025, 0.04)  # mid-span sag / span
    wire_radius: float = 0.015


@dataclass
class PowerLine(ZoneShape):
    poles: np.ndarray  # (n, 2) where the poles stand, in order along the line

    def corridor_clear(self, x, y, half_width: float):
        """True farther than `half_width` from the line (trees leave a corridor under it)."""
        return polyline_distance(self.poles, np.column_stack([x, y])) > half_width

    def keep_out(self, plan: WorldPlan, x, y, need: Clearance) -> np.ndarray:
        bad = np.zeros(np.broadcast(x, y).shape, dtype=bool)
        for px, py in self.poles:
            bad |= dm.hypot(x - px, y - py) < need.radius + 1.0
        return bad

    def features(self, plan: WorldPlan) -> dict:
        return {
            "poles": [[rounded(x), rounded(y)] for x, y in self.poles],
            "wires_per_span": len(POLE_ATTACHMENTS),
        }


def draw(rng: np.random.Generator, cell: Rect, spacing: float) -> PowerLine:
    """A straight-ish route along the cell's long axis, a pole every `spacing` metres or so."""
    ax = long_axis(cell)
    lo, hi = (cell[0], cell[1]) if ax == 0 else (cell[2], cell[3])
    clo, chi = (cell[2], cell[3]) if ax == 0 else (cell[0], cell[1])
    length = hi - lo - 8.0
    n = max(3, int(round(length / spacing)) + 1)
    along = np.linspace(lo + 4.0, hi - 4.0, n)
    across0 = rng.uniform(clo + 0.3 * (chi - clo), chi - 0.3 * (chi - clo))
    across1 = rng.uniform(clo + 0.3 * (chi - clo), chi - 0.3 * (chi - clo))
    across = np.linspace(across0, across1, n) + rng.uniform(-1.5, 1.5, n)
    return PowerLine(np.column_stack([along, across]) if ax == 0 else np.column_stack([across, along]))


def pose_offers(plan: WorldPlan, rng: np.random.Generator):
    """A few metres beside a span, heading along the line (endless: the poses stage takes
    what it needs)."""
    poles = plan.layout.powerline.poles
    while True:
        k = int(rng.integers(len(poles) - 1))
        a, b = poles[k], poles[k + 1]
        d = b - a
        t = rng.uniform(0.2, 0.8)
        normal = np.array([-d[1], d[0]]) / dm.hypot(d[0], d[1])
        pt = a + t * d + normal * rng.choice([-1, 1]) * rng.uniform(2.5, 5.5)
        yield SiteOffer(
            "hills", pt[0], pt[1], dm.degrees(dm.arctan2(d[1], d[0])) % 360, "near power line", min_gap=8.0
        )


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    p, d = plan.params.powerline, plan.detail
    poles = plan.layout.powerline.poles
    plan.add_prototype("pole", pole(d))
    counter: dict = {}
    heading = np.gradient(poles, axis=0)
    tops = []
    for (x, y), h in zip(poles, heading):
        yaw = dm.arctan2(h[1], h[0])
        loc = (float(x), float(y), float(plan.ground_under(x, y, 0.15)))
        plan.add_element(STAGE, "hills", "pole", "pole", counter, location=loc, yaw=yaw, radius=0.15)
        tops.append(transform((POLE_ATTACHMENTS, None), loc, yaw))
    for k in range(len(poles) - 1):
        span = float(dm.hypot(*(poles[k + 1] - poles[k])))
        sag = span * rng.uniform(*p.sag_ratio)
        samples = max(4, int(math.ceil(span / d.wire_step))) + 1
        for j in range(len(POLE_ATTACHMENTS)):
            path = catenary(tops[k][j], tops[k + 1][j], sag, samples)
            key = plan.add_prototype(f"wire{k}_{j}", wire(path, p.wire_radius, d.wire_sides))
            plan.add_element(STAGE, "hills", "wire", key, counter, radius=p.wire_radius)
