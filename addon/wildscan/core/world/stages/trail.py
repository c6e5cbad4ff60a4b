"""Stage "trail": a strip of flooring winding along the trail's cell, following the terrain."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ... import detmath as dm
from ..geometry2d import (
    Rect,
    catmull_rom,
    long_axis,
    polyline_distance,
    polyline_length,
    polyline_near,
    resample,
)
from ..plan import Clearance, SiteOffer, WorldPlan, ZoneShape, rounded

STAGE = "trail"


@dataclass(frozen=True)
class TrailParams:
    lift: float = 0.03  # m of flooring above the terrain grid (plus the grid's measured error)


@dataclass
class Trail(ZoneShape):
    path: np.ndarray  # (n, 2) centre line, 0.5 m steps
    width: float

    def distance(self, x, y):
        """Distance from each point to the centre line."""
        return polyline_distance(self.path, np.column_stack([np.ravel(x), np.ravel(y)])).reshape(np.shape(x))

    def keep_out(self, plan: WorldPlan, x, y, need: Clearance) -> np.ndarray:
        pts = np.column_stack([np.ravel(x), np.ravel(y)])
        return polyline_near(self.path, pts, self.width / 2 + need.radius + 0.3).reshape(np.shape(x))

    def features(self, plan: WorldPlan) -> dict:
        return {"width": rounded(self.width), "length": rounded(polyline_length(self.path))}


def draw(rng: np.random.Generator, cell: Rect) -> Trail:
    """A smooth curve along the cell's long axis, swinging across it."""
    ax = long_axis(cell)
    lo, hi = (cell[0], cell[1]) if ax == 0 else (cell[2], cell[3])
    clo, chi = (cell[2], cell[3]) if ax == 0 else (cell[0], cell[1])
    along = np.linspace(lo + 1.0, hi - 1.0, 6)
    mid, swing = (clo + chi) / 2, (chi - clo) / 2 - 8.0
    across = mid + rng.uniform(-swing, swing, 6)
    ctrl = np.column_stack([along, across]) if ax == 0 else np.column_stack([across, along])
    path = catmull_rom(ctrl, 0.5)
    # keep it inside the cell (the spline may overshoot a little)
    path[:, 0] = np.clip(path[:, 0], cell[0] + 0.5, cell[1] - 0.5)
    path[:, 1] = np.clip(path[:, 1], cell[2] + 0.5, cell[3] - 0.5)
    return Trail(path, rng.uniform(2.0, 2.6))


def pose_offers(plan: WorldPlan, rng: np.random.Generator):
    """On the flooring, heading along it."""
    path = plan.layout.trail.path
    for s in np.linspace(0.1, 0.9, 6):
        i = int(s * (len(path) - 2))
        d = path[i + 1] - path[i]
        yield SiteOffer(
            "trail",
            path[i, 0],
            path[i, 1],
            dm.degrees(dm.arctan2(d[1], d[0])) % 360,
            "on trail",
            min_gap=8.0,
        )


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    """Flooring that follows the terrain: a strip a few cm above the terrain mesh, with
    short skirts down into the ground so no grazing beam sees under its edges."""
    trail, d = plan.layout.trail, plan.detail
    path = resample(trail.path, d.trail_step)
    tangent = np.gradient(path, axis=0)
    tangent /= dm.hypot(tangent[:, 0], tangent[:, 1])[:, None]
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    across = np.linspace(-trail.width / 2, trail.width / 2, d.trail_across)
    xy = path[:, None, :] + across[None, :, None] * normal[:, None, :]  # (K, A, 2)
    lift = plan.params.trail.lift + plan.grid_fit.error.max
    z = plan.ground(xy[..., 0], xy[..., 1]) + lift
    top = np.concatenate([xy, z[..., None]], axis=-1)
    skirt_l = top[:, :1].copy()
    skirt_r = top[:, -1:].copy()
    skirt_l[..., 2] -= lift + 0.1
    skirt_r[..., 2] -= lift + 0.1
    rows = np.concatenate([skirt_l, top, skirt_r], axis=1)  # (K, A+2, 3)
    k, a = rows.shape[:2]
    idx = np.arange(k * a).reshape(k, a)
    v00, v01, v10, v11 = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    faces = np.concatenate(
        [np.stack([v00, v10, v11], -1).reshape(-1, 3), np.stack([v00, v11, v01], -1).reshape(-1, 3)]
    )
    plan.add_prototype("trail", (rows.reshape(-1, 3), faces.astype(np.int32)))
    plan.add_element(STAGE, "trail", "terrain", "trail", {}, radius=trail.width / 2)
