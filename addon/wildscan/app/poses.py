"""Scan poses the placement accepts, per zone (no Blender needed: the plan's own triangles
are ray cast, the same geometry Blender gets). `wildscan poses` prints them, `wildscan world`
lists them in the world's sidecar, the demo and the benchmark scan from them."""

from __future__ import annotations

from ..core.backend import RayBackend
from ..core.errors import PoseRejected
from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION, ZONES, WorldPlan, candidate_sites, plan_world

DEFAULT_POSES_PER_ZONE = 5
MAX_POSE_COUNT = 1000
# A zone's search ends after this many candidates for each pose asked (besides its reserved
# sites): where placement rejects every pose (a caster that misses every ray, issue 31, kept
# `wildscan world` at "valid poses" for good) the zone gets fewer poses instead of a search
# without end. Seeds 0-3 accept a pose within the first few candidates.
CANDIDATES_PER_POSE = 100


def plan_backend(plan: WorldPlan, notify=None) -> RayBackend:
    """The fastest ray backend over the plan's own triangles (embree, else mathutils' BVH)."""
    from ..raycast.from_plan import plan_geometry
    from ..raycast.select import make_backend

    return make_backend("auto", geometry=plan_geometry(plan), notify=notify)


def valid_poses(
    plan: WorldPlan, backend: RayBackend, count: int = DEFAULT_POSES_PER_ZONE, zones=ZONES
) -> dict[str, list[dict]]:
    """Up to `count` poses per zone that `placement.place` accepts: the zone's reserved
    sites first (chosen where its classes are in view), then random candidates, at most
    CANDIDATES_PER_POSE a pose asked."""
    from ..core.placement import place

    out: dict[str, list[dict]] = {}
    for zone in zones:
        accepted: list[dict] = []
        tried = 0
        asked = count
        budget = sum(site.zone == zone for site in plan.sites) + CANDIDATES_PER_POSE * count
        while len(accepted) < count and tried < budget:
            pool = candidate_sites(plan, zone, min(asked, budget))  # a longer ask keeps the same prefix
            if len(pool) <= tried:
                break
            for site in pool[tried:]:
                if len(accepted) >= count:
                    break
                try:
                    placement = place(backend, site.pose, site.z_start)
                except PoseRejected:
                    continue
                entry = site.to_dict()
                entry["tilt_deg"] = round(float(placement.to_dict()["tilt_deg"]), 2)
                entry["optical_centre_z"] = round(float(placement.optical_centre[2]), 3)
                accepted.append(entry)
            tried = len(pool)
            # at least twice as many each time: the pool is drawn again from its start
            asked = max(tried + 2 * (count - len(accepted)) + 2, 2 * tried)
        out[zone] = accepted
    return out


def poses_of_seed(
    seed: int,
    detail: str = "default",
    count: int = DEFAULT_POSES_PER_ZONE,
    zones=ZONES,
    vegetation: str = DEFAULT_VEGETATION,
    biome: str = DEFAULT_BIOME,
) -> dict[str, list[dict]]:
    """Valid poses of the world of `seed`, planned (not built): `wildscan poses`."""
    plan = plan_world(seed, detail, vegetation=vegetation, biome=biome)
    return valid_poses(plan, plan_backend(plan), count, zones)
