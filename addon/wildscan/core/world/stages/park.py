"""Stage "park": a fenced lawn on a flattened plateau, with a couple of gates, picnic
tables with their benches (near each park scan site and elsewhere) and a few lone benches."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import detmath as dm
from ..geometry2d import Rect, yaw_towards
from ..heightfield import Flatten, Heightfield, RectWindow
from ..plan import SITE_CLEARANCE, Clearance, SiteOffer, WorldPlan, ZoneShape, rounded
from ..shapes.furniture import bench, fence_post, fence_section, table

STAGE = "park"
LAWN_INSET = 3.5  # m: the lawn is the fenced area more than this far inside the fence


@dataclass(frozen=True)
class ParkParams:
    fence_section: float = 2.5  # m
    gates: int = 2
    lone_benches: int = 4


@dataclass
class Park(ZoneShape):
    rect: Rect  # the fenced area

    def on_lawn(self, x, y):
        x0, x1, y0, y1 = self.rect
        return (x > x0 + LAWN_INSET) & (x < x1 - LAWN_INSET) & (y > y0 + LAWN_INSET) & (y < y1 - LAWN_INSET)

    def keep_out(self, plan: WorldPlan, x, y, need: Clearance) -> np.ndarray:
        """The fence line, and the lawn for all but what may grow on it (grass)."""
        x0, x1, y0, y1 = self.rect
        inside = (x > x0) & (x < x1) & (y > y0) & (y < y1)
        edge = np.where(
            inside,
            np.minimum.reduce([x - x0, x1 - x, y - y0, y1 - y]),
            dm.hypot(np.maximum.reduce([x0 - x, x - x1, 0 * x]), np.maximum.reduce([y0 - y, y - y1, 0 * y])),
        )
        bad = edge < need.radius + 0.4  # the fence line
        if not need.park_interior:
            bad |= inside & (edge > LAWN_INSET)
        return bad

    def features(self, plan: WorldPlan) -> dict:
        return {"fenced_area": [rounded(v) for v in self.rect]}


def draw(rng: np.random.Generator, cell: Rect) -> Park:
    """The fenced area: the cell less 4-7 m on each side."""
    return Park(
        (
            cell[0] + rng.uniform(4, 7),
            cell[1] - rng.uniform(4, 7),
            cell[2] + rng.uniform(4, 7),
            cell[3] - rng.uniform(4, 7),
        )
    )


def shape_terrain(hf: Heightfield, park: Park, cell: Rect) -> None:
    """Flatten the park and a few metres around it (called by the terrain stage)."""
    px0, px1, py0, py1 = park.rect
    window = RectWindow(px0 - 3, px1 + 3, py0 - 3, py1 + 3, 6.0)
    hf.features.append(Flatten(window, hf.mean_over(window, cell)))


def pose_offers(plan: WorldPlan, rng: np.random.Generator):
    """4-8 m inside the fence facing the middle, where tables, benches and the fence are all
    in range (endless: the poses stage takes what it needs)."""
    px0, px1, py0, py1 = plan.layout.park.rect
    while True:
        side = rng.integers(4)
        d = rng.uniform(4.5, 8.0)
        if side < 2:
            x = px0 + d if side == 0 else px1 - d
            y = rng.uniform(py0 + 6, py1 - 6)
        else:
            y = py0 + d if side == 2 else py1 - d
            x = rng.uniform(px0 + 6, px1 - 6)
        yield SiteOffer(
            "park", x, y, yaw_towards(x, y, (px0 + px1) / 2, (py0 + py1) / 2), "near fence", min_gap=10.0
        )


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.park
    plan.add_prototype("fence_section", fence_section(p.fence_section))
    plan.add_prototype("fence_post", fence_post())
    plan.add_prototype("table", table())
    plan.add_prototype("bench", bench())
    counter: dict = {}
    _fence(plan, rng, counter)
    groups = _picnic_tables(plan, rng, counter)
    _lone_benches(plan, rng, counter, groups)


def _corners(plan: WorldPlan) -> list[tuple[float, float]]:
    x0, x1, y0, y1 = plan.layout.park.rect
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _add(
    plan: WorldPlan, counter: dict, wildscan_class: str, proto: str, pt, yaw: float, radius: float
) -> None:
    loc = (float(pt[0]), float(pt[1]), float(plan.ground(*pt)))
    plan.add_element(STAGE, "park", wildscan_class, proto, counter, location=loc, yaw=yaw, radius=radius)


def _fence(plan: WorldPlan, rng: np.random.Generator, counter: dict) -> None:
    """Sections round the park, centred on each side, with a gate in the middle of some."""
    p = plan.params.park
    corners = _corners(plan)
    gate_sides = set(rng.choice(4, size=min(p.gates, 4), replace=False).tolist())
    for side in range(4):
        a, b = np.array(corners[side]), np.array(corners[(side + 1) % 4])
        length = float(dm.hypot(*(b - a)))
        n = int(length // p.fence_section)
        start = a + (b - a) / length * (length - n * p.fence_section) / 2
        yaw = dm.arctan2(b[1] - a[1], b[0] - a[0])
        gate = set(range(n // 2 - 1, n // 2 + 1)) if side in gate_sides else set()
        for k in range(n):
            pt = start + (b - a) / length * p.fence_section * k
            if k in gate:
                continue
            _add(plan, counter, "fence", "fence_section", pt, yaw, p.fence_section / 2)
            if k + 1 in gate or k == n - 1:  # close the run with a post
                end = pt + (b - a) / length * p.fence_section
                _add(plan, counter, "fence", "fence_post", end, yaw, 0.1)


def _free(plan: WorldPlan, inner: Rect, groups: list[np.ndarray], pt: np.ndarray, r: float) -> bool:
    """On the lawn, 6 m from other furniture and clear of the scan sites."""
    if not (inner[0] < pt[0] < inner[1] and inner[2] < pt[1] < inner[3]):
        return False
    if any(dm.hypot(*(pt - g)) < 6.0 for g in groups):
        return False
    return not any(dm.hypot(s.x - pt[0], s.y - pt[1]) < r + SITE_CLEARANCE for s in plan.sites)


def _inner(plan: WorldPlan) -> Rect:
    x0, x1, y0, y1 = plan.layout.park.rect
    return (x0 + 5.0, x1 - 5.0, y0 + 5.0, y1 - 5.0)


def _picnic_tables(plan: WorldPlan, rng: np.random.Generator, counter: dict) -> list[np.ndarray]:
    """A table with a bench on each side, 4-6.5 m from each park scan site, and three more
    anywhere on the lawn; returns where the tables stand."""
    inner = _inner(plan)
    groups: list[np.ndarray] = []
    park_sites = [s for s in plan.sites if s.zone == "park"]
    targets = [np.array([s.x, s.y]) for s in park_sites] + [None] * 3
    for target in targets:
        for _ in range(60):
            if target is None:
                pt = np.array([rng.uniform(inner[0], inner[1]), rng.uniform(inner[2], inner[3])])
            else:
                ang = rng.uniform(0, 2 * math.pi)
                sin, cos = dm.sincos(ang)
                pt = target + rng.uniform(4.0, 6.5) * np.array([cos, sin])
            if _free(plan, inner, groups, pt, 2.2):
                groups.append(pt)
                break
    for g in groups:
        yaw = rng.uniform(0, math.pi)
        s, c = dm.sincos(yaw)
        _add(plan, counter, "table", "table", g, yaw, 1.0)
        for side, turn in ((1, math.pi), (-1, 0.0)):
            b = g + side * 0.95 * np.array([-s, c])
            _add(plan, counter, "bench", "bench", b, yaw + turn, 0.8)
    return groups


def _lone_benches(plan: WorldPlan, rng: np.random.Generator, counter: dict, groups: list[np.ndarray]) -> None:
    """Benches 5.5 m inside the fence, facing along it."""
    inner = _inner(plan)
    corners = _corners(plan)
    for _ in range(plan.params.park.lone_benches):
        for _ in range(60):
            side = int(rng.integers(4))
            t = rng.uniform(0.15, 0.85)
            a, b = np.array(corners[side]), np.array(corners[(side + 1) % 4])
            inward = np.array([-(b - a)[1], (b - a)[0]]) / dm.hypot(*(b - a))
            pt = a + t * (b - a) + inward * 5.5
            if _free(plan, inner, groups, pt, 1.0):
                groups.append(pt)
                _add(plan, counter, "bench", "bench", pt, dm.arctan2(b[1] - a[1], b[0] - a[0]), 0.8)
                break
