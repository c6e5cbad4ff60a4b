"""Scan poses the placement accepts, per zone (no Blender needed: the plan's own triangles
are ray cast, the same geometry Blender gets). `wildscan poses` prints them, `wildscan world`
lists them in the world's sidecar, the demo and the benchmark scan from them."""

from __future__ import annotations

import numpy as np

from ..core.backend import RayBackend
from ..core.errors import PoseRejected
from ..core.rng import stage_rng
from ..core.world import DEFAULT_BIOME, DEFAULT_VEGETATION, ZONES, WorldPlan, candidate_sites, plan_world

DEFAULT_POSES_PER_ZONE = 5
MAX_POSE_COUNT = 1000
# A zone's search ends after this many candidates for each pose asked (besides its reserved
# sites): where placement rejects every pose (a caster that misses every ray, kept
# `wildscan world` at "valid poses" for good) the zone gets fewer poses instead of a search
# without end. Seeds 0-3 accept a pose within the first few candidates.
CANDIDATES_PER_POSE = 100


def plan_backend(plan: WorldPlan, notify=None) -> RayBackend:
    """The fastest ray backend over the plan's own triangles (embree, else mathutils' BVH)."""
    from ..raycast.from_plan import plan_geometry
    from ..raycast.select import make_backend

    return make_backend("auto", geometry=plan_geometry(plan), notify=notify)


def valid_poses(
    plan: WorldPlan, backend: RayBackend, count: int = DEFAULT_POSES_PER_ZONE, zones=ZONES, region=None
) -> dict[str, list[dict]]:
    """Up to `count` poses per zone that `placement.place` accepts: the zone's reserved
    sites first (chosen where its classes are in view), then random candidates, at most
    CANDIDATES_PER_POSE a pose asked; only those inside `region` (core/world/region.py Region)
    when given."""
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
                if region is not None and not _inside(region, site.x, site.y):
                    continue
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


def _inside(region, x: float, y: float) -> bool:
    return region.xmin <= x <= region.xmax and region.ymin <= y <= region.ymax


def poses_of_seed(
    seed: int,
    detail: str = "default",
    count: int = DEFAULT_POSES_PER_ZONE,
    zones=ZONES,
    vegetation: str = DEFAULT_VEGETATION,
    biome: str = DEFAULT_BIOME,
    region=None,
) -> dict[str, list[dict]]:
    """Valid poses of the paper layout's world of `seed`, planned (not built), inside `region`
    when given: `wildscan poses --layout paper`."""
    plan = plan_world(seed, detail, vegetation=vegetation, biome=biome)
    return valid_poses(plan, plan_backend(plan), count, zones, region)


# ---------------------------------------------------------------------------------------
# the endless layout: poses anywhere in a region, by land cover

ENDLESS_TRIES = 40  # candidates tried per pose asked before giving up (a region with little of a cover)
EDGE_MARGIN = 2.0  # m kept from the region's edge: the placement's lasers reach ~1 m around the pose


BACKENDS_KEPT = 4  # tile sets a pose search keeps at hand (a region's neighbourhoods, read once each)


class TileBackends:
    """The full-detail tiles around a pose and a ray caster over the triangles near it. A
    pose's placement reaches a metre or two, so each candidate is placed on a caster over only
    the triangles within the scan's placement radius (app/tiles.py placement_caster: a few
    thousand, built in milliseconds), the same triangles a scan's placement meets on its own
    tiles: the pose the search accepts is the one the scan stands at. The tiles come from the
    process's TileMemory and the world cache (built when first asked for); the last
    BACKENDS_KEPT sets are kept at hand, so a region's poses are checked tile by tile, never
    against the whole region at once."""

    def __init__(self, world, cache=None, memory=None, backend: str = "auto"):
        from collections import OrderedDict

        from .tile_memory import TileCounts

        self.world, self.cache, self.memory, self.backend_name = world, cache, memory, backend
        self.kept: OrderedDict = OrderedDict()
        self.counts = TileCounts()  # the tiles asked for so far, and their seconds

    def key(self, x: float, y: float) -> tuple:
        """The tiles whose elements can come within the placement radius of (x, y)."""
        from .tiles import ELEMENT_OVERHANG_M, PLACEMENT_RADIUS_M, endless

        reach = PLACEMENT_RADIUS_M + ELEMENT_OVERHANG_M  # an element of a tile nearby may stand over the pose
        return tuple(sorted(endless().tiles_in_disc(float(x), float(y), reach)))

    def parts(self, key: tuple) -> list:
        """The full-detail TileParts of the tiles `key` names, in its (sorted) order."""
        if key in self.kept:
            self.kept.move_to_end(key)
            return self.kept[key]
        from .tiles import tile_parts

        parts, counts = tile_parts(self.world, {t: 0 for t in key}, self.cache, self.memory)
        self.counts.built += counts.built
        self.counts.cache += counts.cache
        self.counts.memory += counts.memory
        self.counts.seconds += counts.seconds
        self.kept[key] = parts
        while len(self.kept) > BACKENDS_KEPT:
            self.kept.popitem(last=False)
        return parts

    def caster(self, x: float, y: float) -> RayBackend:
        """A ray caster over the triangles a placement at (x, y) can meet, its local origin at
        placement_centre (the dataset scan's: the same bits)."""
        from .tiles import placement_caster

        centre = placement_centre(self.world, x, y)
        return placement_caster(self.parts(self.key(x, y)), centre, self.backend_name)


def placement_centre(world, x: float, y: float) -> tuple[float, float, float]:
    """The local origin of the casters a pose at (x, y) of the endless `world` is placed on:
    (x, y) and the landscape's analytic terrain height there (the geometry rounds it to whole
    metres). A float32 caster's answers are settled in float64 relative to its origin
    (raycast/refine.py), so two casters over the same triangles near the pose agree to the
    bit only when their origins do: the pose search's caster (TileBackends.caster) and a
    dataset scan's world (app/dataset/land.py LandWorld.for_scan) both take this one, so the
    pose the search accepts is placed by the scan at the same x, y, z, roll and pitch."""
    from .tiles import endless

    z = endless().height_at(world.seed, world.biome, np.array([float(x)]), np.array([float(y)]))
    return (float(x), float(y), float(np.asarray(z).ravel()[0]))


def endless_poses(
    world,
    region,
    count: int = DEFAULT_POSES_PER_ZONE,
    covers: tuple[str, ...] | None = None,
    cache=None,
    memory=None,
    backends: TileBackends | None = None,
    progress=None,
) -> list[dict]:
    """Up to `count` poses in `region` of the endless world `world` (app/tiles.py TiledWorld)
    that the placement accepts, on the land covers `covers` (None: any), each listed with
    its land cover. Candidates are drawn uniformly over the region from a generator of the
    seed, the region and the covers, a batch at a time; a batch is checked tile by tile
    (TileBackends) and its accepted poses taken in the order drawn, so the same request lists
    the same poses. `backends`: shared when a caller asks for several covers of one region.
    `progress(found, count, checked, tiles)` after each candidate checked (`tiles`: the
    backends' TileCounts so far): a command's progress lines."""
    from .tiles import endless

    E = endless()
    backends = TileBackends(world, cache, memory) if backends is None else backends
    wanted = None if covers is None else {E.LAND_COVERS.index(c) for c in covers}
    rng = stage_rng(world.seed, f"poses.endless:{region.text()}:{','.join(covers or ())}")
    accepted: list[dict] = []
    checked = [0, 0]  # candidates checked, and accepted, in this batch and the ones before

    def tell(entry) -> None:
        checked[0] += 1
        checked[1] += entry is not None
        if progress is not None:
            progress(min(checked[1], count), count, checked[0], backends.counts)

    for _ in range(ENDLESS_TRIES):
        if len(accepted) >= count:
            break
        batch = 2 * count + 2
        x = rng.uniform(region.xmin + EDGE_MARGIN, region.xmax - EDGE_MARGIN, batch)
        y = rng.uniform(region.ymin + EDGE_MARGIN, region.ymax - EDGE_MARGIN, batch)
        yaw = rng.uniform(0.0, 360.0, batch)
        cover = np.asarray(E.land_cover_at(world.seed, world.biome, x, y))
        tried = [k for k in range(batch) if wanted is None or int(cover[k]) in wanted]
        found = placed_poses(
            backends,
            [(round(float(x[k]), 3), round(float(y[k]), 3), round(float(yaw[k]), 1)) for k in tried],
            tell,
        )
        for k, entry in zip(tried, found):
            if entry is not None and len(accepted) < count:
                accepted.append(dict(entry, cover=E.LAND_COVERS[int(cover[k])]))
    return accepted


def placed_poses(backends: TileBackends, poses: list[tuple], checked=None) -> list[dict | None]:
    """Each (x, y, yaw) placed (its entry) or rejected (None), checked grouped by the tiles
    around it (each set read once), each on a caster over the triangles near it.
    `checked(entry or None)` after each."""
    from ..core.placement import Pose, place

    keys = [backends.key(x, y) for x, y, _ in poses]
    out: list[dict | None] = [None] * len(poses)
    for k in sorted(range(len(poses)), key=lambda k: keys[k]):
        pose = Pose(*poses[k])
        try:
            placement = place(backends.caster(pose.x, pose.y), pose)
        except PoseRejected:
            if checked is not None:
                checked(None)
            continue
        out[k] = {
            "x": pose.x,
            "y": pose.y,
            "yaw": pose.yaw_deg,
            "tilt_deg": round(float(placement.to_dict()["tilt_deg"]), 2),
            "optical_centre_z": round(float(placement.optical_centre[2]), 3),
        }
        if checked is not None:
            checked(out[k])
    return out
