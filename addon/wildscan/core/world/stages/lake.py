"""Stage "lake": a basin in the terrain, filled with water up to just below its rim."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import detmath as dm
from ...classes import WATER
from ..geometry2d import Rect, float_range, long_axis, yaw_towards
from ..heightfield import Basin, Ellipse, EllipseWindow, Flatten, Heightfield
from ..plan import Clearance, SiteOffer, WorldPlan, ZoneShape, rounded

STAGE = "lake"


@dataclass
class Lake(ZoneShape):
    basin: Ellipse
    depth: float  # m below the flattened shore (before the field is normalised)

    def water_at(self, plan: WorldPlan, x, y, margin: float = 0.0):
        """True where the terrain lies under the water (or less than `margin` above it)."""
        return (self.basin.radius(x, y) < 1.3) & (plan.ground(x, y) < plan.water_z + margin)

    def keep_out(self, plan: WorldPlan, x, y, need: Clearance) -> np.ndarray:
        return self.water_at(plan, x, y, need.water_margin)

    def pose_keep_out(self, plan: WorldPlan, x, y, allow_pit: bool) -> np.ndarray:
        return self.water_at(plan, x, y, 0.2)

    def features(self, plan: WorldPlan) -> dict:
        e = self.basin
        return {
            "centre": [rounded(e.cx), rounded(e.cy)],
            "semi_axes": [rounded(e.a), rounded(e.b)],
            "water_z": rounded(plan.water_z),
        }


def draw(rng: np.random.Generator, cell: Rect) -> Lake:
    """An ellipse along the cell's long axis, shrunk until its flattened shore fits the cell."""
    ax = long_axis(cell)
    angle = (0.0 if ax == 0 else math.pi / 2) + rng.uniform(-0.35, 0.35)
    a, b = rng.uniform(12.0, 17.0), rng.uniform(8.0, 11.0)
    reach = 1.6  # normalised radius the lake's flattening reaches
    half_w, half_h = (cell[1] - cell[0]) / 2 - 1.0, (cell[3] - cell[2]) / 2 - 1.0
    s, c = (abs(v) for v in dm.sincos(angle))
    ex, ey = reach * dm.hypot(a * c, b * s), reach * dm.hypot(a * s, b * c)
    shrink = min(1.0, half_w / ex, half_h / ey)
    a, b, ex, ey = a * shrink, b * shrink, ex * shrink, ey * shrink
    cx = rng.uniform(cell[0] + 1.0 + ex, cell[1] - 1.0 - ex) if half_w > ex else (cell[0] + cell[1]) / 2
    cy = rng.uniform(cell[2] + 1.0 + ey, cell[3] - 1.0 - ey) if half_h > ey else (cell[2] + cell[3]) / 2
    return Lake(Ellipse(cx, cy, a, b, angle), rng.uniform(2.5, 3.5))


def shape_terrain(hf: Heightfield, lake: Lake, cell: Rect) -> None:
    """A gently flattened shore around the basin (called by the terrain stage)."""
    window = EllipseWindow(lake.basin, 1.2, 1.6)
    hf.features.append(Flatten(window, hf.mean_over(window, cell), 0.85))
    hf.features.append(Basin(lake.basin, lake.depth, 0.4, 1.15))


def water_level(plan: WorldPlan, lake: Lake) -> float:
    """Water fills the basin up to just below the lowest point of its rim (on the terrain
    mesh, so no water spills over a low spot of the grid)."""
    e = lake.basin
    sin, cos = dm.sincos(np.linspace(0, 2 * np.pi, 180, endpoint=False))
    rim = [plan.ground(*e.to_world(r * e.a * cos, r * e.b * sin)) for r in (1.15, 1.25, 1.35)]
    return float(np.min(rim)) - 0.15


def pose_offers(plan: WorldPlan, rng: np.random.Generator):
    """On the shore, a metre and a half from the water, facing it: one per direction."""
    e = plan.layout.lake.basin
    for ang in np.linspace(0, 2 * np.pi, 10, endpoint=False) + rng.uniform(0, 0.6):
        sin, cos = dm.sincos(float(ang))
        for r in np.arange(0.0, 2.2, 0.02):  # from the middle outwards to the waterline
            x, y = e.to_world(r * e.a * cos, r * e.b * sin)
            if plan.ground(x, y) > plan.water_z + 0.25:
                x, y = e.to_world((r * e.a + 1.5) * cos, (r * e.b + 1.5) * sin)
                yield SiteOffer(
                    "lake", float(x), float(y), yaw_towards(x, y, e.cx, e.cy), "shore", min_gap=8.0
                )
                break


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    """The water surface: 2 m cells at the water level wherever the terrain dips below it
    (the part of a cell beyond the shore is under the terrain, a metre or two at most)."""
    e = plan.layout.lake.basin
    reach = 1.2 * max(e.a, e.b)
    cell = 2.0
    xs = float_range(e.cx - reach, e.cx + reach, cell)
    ys = float_range(e.cy - reach, e.cy + reach, cell)
    gx, gy = np.meshgrid(xs, ys)
    sub = np.linspace(0, cell, 4)
    low = np.zeros(gx.shape, dtype=bool)
    for dx in sub:
        for dy in sub:
            low |= plan.ground(gx + dx, gy + dy) < plan.water_z + 0.02
    low &= e.radius(gx + cell / 2, gy + cell / 2) < 1.25
    j, i = np.nonzero(low)
    x0, y0 = xs[i], ys[j]
    corners = np.stack(
        [
            np.stack([x0, y0], -1),
            np.stack([x0 + cell, y0], -1),
            np.stack([x0 + cell, y0 + cell], -1),
            np.stack([x0, y0 + cell], -1),
        ],
        1,
    )  # (n,4,2)
    verts = np.concatenate([corners.reshape(-1, 2), np.full((4 * len(x0), 1), plan.water_z)], axis=1)
    base = 4 * np.arange(len(x0))[:, None]
    faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]])
    plan.add_prototype("water", (verts, faces.astype(np.int32)))
    plan.add_element(STAGE, "lake", WATER.name, "water", {}, radius=max(e.a, e.b))
