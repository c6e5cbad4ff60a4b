"""Stage "poses": a few reserved scan sites per zone, each where that zone's classes are in
view, kept free of elements by the stages after it; and the checks a pose must pass.

Each zone offers its sites (the forest here, the other zones in their modules); a
site is kept when the sensor's four laser tips land on dry, gentle, even enough
terrain (`footprint_ok`) and it is not too near another site of its zone.
"""

from __future__ import annotations

import numpy as np

from ... import detmath as dm
from ...placement import ARM_X, ARM_Y, MAX_TILT_DEG, MAX_UNEVENNESS, Pose, laser_xy
from ...rng import stage_rng
from ..geometry2d import inset
from ..plan import Site, SiteOffer, WorldPlan, check_zone
from . import cave, lake, park, powerline, trail

STAGE = "poses"
ATTEMPTS = 200  # random offers tried per zone whose offers are random


def footprint_ok(
    plan: WorldPlan, x: float, y: float, yaw_deg: float, tilt_margin: float = 5.0, allow_pit: bool = False
) -> bool:
    """Numpy pre-check of a pose against the plan: the four laser tips on dry terrain, out of
    every zone's keep-out for poses, gentle and even enough (with margin) for
    `placement.place` to accept it."""
    tips = laser_xy(Pose(x, y, yaw_deg))
    x0, x1, y0, y1 = plan.extent
    if np.any(
        (tips[:, 0] < x0 + 0.5) | (tips[:, 0] > x1 - 0.5) | (tips[:, 1] < y0 + 0.5) | (tips[:, 1] > y1 - 0.5)
    ):
        return False
    z = plan.ground(tips[:, 0], tips[:, 1])
    for shape in plan.layout.zone_shapes().values():
        if np.any(shape.pose_keep_out(plan, tips[:, 0], tips[:, 1], allow_pit)):
            return False
    unevenness = abs((z[0] + z[1]) - (z[2] + z[3])) / 2
    sx, sy = (z[0] - z[1]) / (2 * ARM_X), (z[2] - z[3]) / (2 * ARM_Y)
    tilt = dm.degrees(dm.arctan(dm.hypot(sx, sy)))
    return unevenness <= MAX_UNEVENNESS / 2 and tilt <= MAX_TILT_DEG - tilt_margin


def forest_offers(plan: WorldPlan, rng: np.random.Generator):
    """Anywhere in the forest, clear of its border (endless: the stage takes what it needs)."""
    fx0, fx1, fy0, fy1 = inset(plan.layout.cells["forest"], 8.0)
    while True:
        yield SiteOffer(
            "forest",
            rng.uniform(fx0, fx1),
            rng.uniform(fy0, fy1),
            rng.uniform(0, 360),
            "forest",
            min_gap=10.0,
        )


# Who offers each zone's sites, in the order this stage's stream draws them, and how many
# sites to keep of an endless random offer (None: every one of a zone's fixed offers is tried).
OFFERS = (
    (forest_offers, 6),
    (park.pose_offers, 6),
    (powerline.pose_offers, 6),
    (lake.pose_offers, None),
    (cave.pose_offers, None),
    (trail.pose_offers, None),
)


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    sites: list[Site] = []
    for offers, wanted in OFFERS:
        _take(plan, sites, offers(plan, rng), wanted)
    plan.sites = sites


def _take(plan: WorldPlan, sites: list[Site], offers, wanted: int | None) -> None:
    if wanted is None:
        for offer in offers:
            _reserve(plan, sites, offer)
        return
    taken = 0
    for _ in range(ATTEMPTS):
        if taken >= wanted:
            return
        taken += _reserve(plan, sites, next(offers))


def _reserve(plan: WorldPlan, sites: list[Site], offer: SiteOffer) -> bool:
    # rounded first, so the pose a user copies from the sidecar is the pose checked
    x, y, yaw = round(float(offer.x), 3), round(float(offer.y), 3), round(float(offer.yaw_deg) % 360.0, 1)
    if not footprint_ok(plan, x, y, yaw, allow_pit=offer.allow_pit):
        return False
    if any(s.zone == offer.zone and dm.hypot(s.x - x, s.y - y) < offer.min_gap for s in sites):
        return False
    sites.append(Site(offer.zone, float(x), float(y), float(yaw), offer.kind, offer.z_start))
    return True


def candidate_sites(plan: WorldPlan, zone: str, count: int) -> list[Site]:
    """The reserved sites of a zone, then (if more are asked) random footprint-checked
    candidates from the stream 'world.poses.extra.<zone>' (same seed, same list)."""
    zone = check_zone(zone)
    out = [s for s in plan.sites if s.zone == zone]
    rng = stage_rng(plan.seed, f"world.poses.extra.{zone}")
    x0, x1, y0, y1 = inset(plan.layout.cells[zone], 1.0)
    tries = 0
    while len(out) < count and tries < 50 * count:
        tries += 1
        x, y = round(float(rng.uniform(x0, x1)), 3), round(float(rng.uniform(y0, y1)), 3)
        yaw = round(float(rng.uniform(0, 360)), 1)
        if footprint_ok(plan, x, y, yaw):
            out.append(Site(zone, float(x), float(y), yaw, "random"))
    return out
