"""Datasets over the endless landscape (SPEC.toml layout = "endless"): a world's poses over the
spec's region by land cover, and each scan's world, the tiles its sensor reaches.

Poses. Scan k of a world is given a land cover by the interleaved quotas of the [poses] cover
weights (core/posesampler.py scan_zones), or a class to be drawn near (min_scans_with: its share
of the indices, class_scan_indices; a class the region has none of leaves its indices to the
cover weights), and whether it stands in tall cover (tall_cover: that share of all indices,
spread evenly over those not drawn near a class; the others must not; a tall-cover scan whose
land cover is a lawn, a tread or rock draws over the covers tall cover grows in). A land
cover's candidates are uniform over the region (edge kept 2 m off), kept where the landscape's
land cover (fields.land_cover_at) is that one; a class's are 2-8 m from one of its elements
where the landscape places them (park furniture in the clearings, poles and wires along the
power lines, points along the trails of a tread's material: the anchors, no tile built) or
uniform over the covers it grows in. A candidate is kept when it is min_distance from the
poses kept, the placement accepts it on the full-detail triangles near it (app/poses.py
placed_poses, TileBackends: those the scan's own placement meets) and its tall cover is as
asked. Every draw comes from a stream of (seed, region, cover or class), so the same spec gives
the same poses on any worker.

Then the poses are numbered by place (PLACE_BLOCK_M squares in a serpentine), so the engine's
contiguous batches (engine.py make_batches) are neighbourhoods: a worker scans poses near each
other one after the other, and builds or reads each tile once (app/tile_memory.py TileMemory, the
world cache). A --limit prefix is therefore a part of the region, not a sample of all of it.

A scan's world (`LandWorld.for_scan`) is the tiles its sensor reaches at their levels of
detail (app/scan.py endless_scan_geometry, as `wildscan scan --seed` builds them; at least the
bird's-eye square around the pose, BEV_REACH_M, for a short-range sensor), its ground
the terrain lattice of those tiles (the endless world lays no trail flooring over its terrain:
the tread is the terrain's own material), its bird's-eye extent the square the crop reaches.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Iterator
from dataclasses import asdict, dataclass

import numpy as np

from ...core import detmath as dm
from ...core.classes import class_by_name
from ...core.posesampler import NEAR, NEAR_MAX, NEAR_MIN, NoPose, ScanPose, class_scan_indices, scan_zones
from ...core.rng import stage_rng
from ...core.truth.groundtruth import BEV_SIZE
from ...core.truth.open_ground import no_open_ground
from ...core.world.ground import StandingGround
from ...core.world.region import Region
from ...core.world.terrain_grid import TerrainGrid
from ..poses import BACKENDS_KEPT, EDGE_MARGIN, TileBackends, placed_poses, placement_centre
from ..tiles import TiledWorld, endless
from .pose_spec import LAND_COVERS

TALL_CLASSES = (class_by_name("high grass").id, class_by_name("bush").id)
TALL_REACH_M = 1.0  # m: tall grass, reeds or undergrowth this near (xy) puts a pose in tall cover
TALL_LAND = ("forest", "meadow", "scrub", "wetland")  # the land covers tall cover grows in
TALL = "tall"  # the candidates of a tall-cover scan whose own land cover has none: over TALL_LAND
PLACE_BLOCK_M = 100.0  # m: the squares the poses are numbered by (two tiles a side)
CANDIDATES_PER_SCAN = 200  # placements tried for one scan before its cover or class is given up
DRAWS_PER_SCAN = 20_000  # uniform points drawn (no tile built) before a cover is given up
BATCH = 256  # uniform points drawn at once
# m around a pose a scan's world holds at least: its bird's-eye square's corners (half its side
# times sqrt 2), plus the optical centre's offset from the pose on tilted ground and slack
BEV_REACH_M = BEV_SIZE / 2 * math.sqrt(2) + 2.0
# Where a class grows (core/world/endless/scatter.py, ground.py): a pose drawn near it is drawn
# over these covers. Park furniture, the power lines' poles and wires and the trails' treads
# are anchored instead (class_anchors).
CLASS_COVERS = {
    "terrain": LAND_COVERS,
    "trunk": ("forest",),
    "treetop": ("forest",),
    "leaf litter": ("forest",),
    "log": ("forest",),
    "bush": ("scrub", "forest"),
    "high grass": ("meadow", "wetland"),
    "low grass": ("meadow", "clearing"),
    "rock": ("rock",),
    "rock slab": ("rock",),
    "mud": ("wetland",),
}
FURNITURE = ("table", "bench", "fence")  # core/world/endless/clearing.py
POWER_LINE = ("pole", "wire")  # core/world/endless/powerline.py
# a tread's material -> the kind of trail laid with it (core/world/endless/anchors.py TRAIL_KINDS)
TREADS = {"gravel": "track", "soil": "footpath", "paved": "paved path"}
TREAD_STEP_M = 10.0  # m between the points a trail anchors along its path
ANCHORED = FURNITURE + POWER_LINE + tuple(TREADS)


# ---------------------------------------------------------------------------------------
# candidates


def _cover_candidates(world: TiledWorld, region: Region, covers: tuple[str, ...], key: str) -> Iterator:
    """(x, y, yaw) uniform over the region where the land cover is one of `covers`; stops after
    DRAWS_PER_SCAN draws in a row without one."""
    E = endless()
    wanted = np.array([LAND_COVERS.index(c) for c in covers])
    rng = stage_rng(world.seed, f"dataset.land:{region.text()}:{key}")
    misses = 0
    while misses < DRAWS_PER_SCAN:
        x = rng.uniform(region.xmin + EDGE_MARGIN, region.xmax - EDGE_MARGIN, BATCH)
        y = rng.uniform(region.ymin + EDGE_MARGIN, region.ymax - EDGE_MARGIN, BATCH)
        yaw = rng.uniform(0.0, 360.0, BATCH)
        hit = np.isin(np.asarray(E.land_cover_at(world.seed, world.biome, x, y)), wanted)
        misses = 0 if hit.any() else misses + BATCH
        for k in np.flatnonzero(hit):
            yield _rounded(x[k], y[k], yaw[k])


def _rounded(x, y, yaw) -> tuple[float, float, float]:
    # rounded as the sidecars print poses, so the pose a user copies is the pose scanned
    return round(float(x), 3), round(float(y), 3), round(float(yaw), 1) % 360.0


def class_anchors(world: TiledWorld, region: Region, name: str) -> list[tuple[float, float]]:
    """Where the landscape places the elements of an anchored class inside the region (the
    clearings' furniture, the power lines' poles, their wires' mid-spans, points along the
    trails laid with a tread's material), from its anchor cells alone
    (core/world/endless/anchors.py): no tile is built."""
    from ...core.world.endless import anchors as A
    from ...core.world.endless.clearing import furniture

    anchors = endless().landscape(world.seed, world.biome).anchors
    out: list[tuple[float, float]] = []
    if name in FURNITURE:
        for c in anchors.cells_over(region.xmin, region.xmax, region.ymin, region.ymax, 0.0):
            if c.clearing:
                pieces = furniture(world.seed, c.ci, c.cj, c.node[0], c.node[1], c.clearing)
                out += [(x, y) for cls, _, x, y, _ in pieces if cls == name]
    elif name in POWER_LINE:
        shift = 0.0 if name == "pole" else 0.5 * A.POLE_SPACING
        k0, k1 = math.floor(region.xmin / A.POLE_SPACING), math.ceil(region.xmax / A.POLE_SPACING)
        for line in anchors.lines_over(region.ymin, region.ymax):
            out += [(k * A.POLE_SPACING + shift, line) for k in range(k0, k1 + 1)]
    elif name in TREADS:
        r = region
        for path, kind in endless().trail_network(world.seed, world.biome, r.xmin, r.ymin, r.xmax, r.ymax):
            if kind == TREADS[name]:
                out += _along(path, TREAD_STEP_M)
    return [(x, y) for x, y in out if region.xmin <= x <= region.xmax and region.ymin <= y <= region.ymax]


def _along(path: np.ndarray, step: float) -> list[tuple[float, float]]:
    """Points every `step` metres along a polyline (K, 2), from its start."""
    seg = np.hypot(*np.diff(path, axis=0).T)
    at = np.concatenate([[0.0], np.cumsum(seg)])
    s = np.arange(0.0, at[-1], step)
    xs, ys = np.interp(s, at, path[:, 0]), np.interp(s, at, path[:, 1])
    return list(zip(xs.tolist(), ys.tolist(), strict=True))


def _near_candidates(world: TiledWorld, region: Region, name: str) -> Iterator:
    """(x, y, yaw) NEAR_MIN..NEAR_MAX m from an element of the class (core/posesampler.py's
    radii), or uniform over the covers it grows in when the landscape does not anchor it."""
    if name not in ANCHORED:
        yield from _cover_candidates(world, region, CLASS_COVERS[name], f"{NEAR}{name}")
        return
    anchors = class_anchors(world, region, name)
    if not anchors:
        return
    rng = stage_rng(world.seed, f"dataset.land:{region.text()}:{NEAR}{name}")
    lo, hi = region.xmin + EDGE_MARGIN, region.xmax - EDGE_MARGIN
    blo, bhi = region.ymin + EDGE_MARGIN, region.ymax - EDGE_MARGIN
    while True:
        ax, ay = anchors[int(rng.integers(len(anchors)))]
        r = float(rng.uniform(NEAR_MIN, NEAR_MAX))
        s, c = dm.sincos(float(rng.uniform(0.0, 2.0 * math.pi)))
        yield _rounded(min(max(ax + r * c, lo), hi), min(max(ay + r * s, blo), bhi), rng.uniform(0.0, 360.0))


# ---------------------------------------------------------------------------------------
# tall cover


class LandBackends(TileBackends):
    """TileBackends that also know where tall grass, reeds and undergrowth stand around a pose."""

    def __init__(self, world, cache=None, memory=None):
        super().__init__(world, cache, memory)
        self.tall: dict[tuple, tuple] = {}  # tiles -> (their merged cover grid, tall elements' xy)

    def in_tall_cover(self, x: float, y: float) -> bool:
        """Whether the sward at (x, y) is high grass or undergrowth (the tiles' cover grid), or a
        tall element (reeds, tufts of high grass, a bush) stands within TALL_REACH_M of it."""
        cover, xy = self._tall(self.key(x, y))
        if cover is not None:
            cls, _ = cover.at(np.array([x]), np.array([y]))
            if int(cls[0]) in TALL_CLASSES:
                return True
        return bool(np.any(dm.hypot(xy[:, 0] - x, xy[:, 1] - y) < TALL_REACH_M))

    def _tall(self, key: tuple) -> tuple:
        """The tiles' cover grid, merged as their join merges it, and the xy of every vertex
        of their tall elements' triangles."""
        if key not in self.tall:
            from ..tiles import merge_covers

            if len(self.tall) > 4 * BACKENDS_KEPT:
                self.tall.clear()
            parts = self.parts(key)
            covers = [p.cover for p in parts if p.cover is not None]
            xy = [_tall_xy(p.geometry) for p in parts]
            self.tall[key] = (merge_covers(covers) if covers else None, np.concatenate(xy))
        return self.tall[key]


def _tall_xy(geometry) -> np.ndarray:
    faces = geometry.faces[np.isin(geometry.class_id, TALL_CLASSES)]
    return geometry.vertices[np.unique(faces), :2]


def tall_indices(share: float, count: int, free: list[int]) -> set[int]:
    """The scan indices standing in tall cover: ceil(share x count) of the `free` ones (those
    not drawn near a class), spread evenly over them."""
    wanted = min(len(free), math.ceil(share * count - 1e-9))
    return {free[int((j + 0.5) * len(free) / wanted)] for j in range(wanted)}


# ---------------------------------------------------------------------------------------
# the poses


def sample_land_poses(world: TiledWorld, poses, count: int, cache=None, memory=None) -> list:
    """One entry per scan index 0..count-1 (before numbering by place): its pose or why there is
    none (module docstring). `poses`: the spec's PoseSpec."""
    region = Region(*poses.land_region())
    covers = scan_zones(dict(poses.cover), count, LAND_COVERS)
    near = class_scan_indices(dict(poses.min_scans_with), count)
    # a class the region holds none of (a square no power line crosses) leaves its scans to
    # the cover weights: the card's table of scans containing each class says it was not met
    absent = {n for n in set(near.values()) if n in ANCHORED and not class_anchors(world, region, n)}
    near = {k: n for k, n in near.items() if n not in absent}
    tall = tall_indices(poses.tall_cover, count, [k for k in range(count) if k not in near])
    backends = LandBackends(world, cache, memory)
    streams: dict[str, Iterator] = {}
    kept: list[ScanPose] = []
    out: list = []
    exhausted: dict[tuple, str] = {}
    for k in range(count):
        want = f"{NEAR}{near[k]}" if k in near else covers[k]
        if k in tall and want not in TALL_LAND:  # a mown lawn, a tread, bare rock: tall grows elsewhere
            want = TALL
        asked = (want, k in tall)
        if asked not in exhausted:
            if want not in streams:
                streams[want] = (
                    _near_candidates(world, region, near[k])
                    if k in near
                    else _cover_candidates(world, region, TALL_LAND if want == TALL else (want,), want)
                )
            found = _first_kept(streams[want], kept, poses.min_distance, k in tall, backends, want)
            if isinstance(found, ScanPose):
                kept.append(found)
                out.append(found)
                continue
            exhausted[asked] = found
        out.append(NoPose(want, exhausted[asked]))
    return out


def _first_kept(stream, kept, min_distance: float, tall: bool, backends: LandBackends, want: str):
    """The first candidate of `stream` kept (a ScanPose), or the reason there is none (a str)."""
    E = endless()
    where = "tall cover" if tall else "short cover"
    for _ in range(CANDIDATES_PER_SCAN):
        c = next(stream, None)
        if c is None:
            what = want[len(NEAR) :] if want.startswith(NEAR) else want
            return f"no {what} in the region ({DRAWS_PER_SCAN:,} uniform points in a row found none)"
        x, y, yaw = c
        if any(dm.hypot(x - p.x, y - p.y) < min_distance for p in kept):
            continue
        if backends.in_tall_cover(x, y) != tall or placed_poses(backends, [c])[0] is None:
            continue
        cover = LAND_COVERS[int(np.asarray(E.land_cover_at(backends.world.seed, backends.world.biome, x, y)))]
        kind = want if want.startswith(NEAR) else "tall cover" if tall else "random"
        return ScanPose(cover, x, y, yaw, kind)
    return (
        f"no valid pose for {want} in {where}: {CANDIDATES_PER_SCAN} candidates in a row were rejected "
        f"by the placement, stood in the other cover or closer than {min_distance:g} m to another scan"
    )


def by_place(poses: list) -> list:
    """The poses numbered by place: PLACE_BLOCK_M squares row by row, each row the other way
    round from the last (a serpentine, so consecutive squares touch), the poses of a square by
    their index; the scans without a pose last."""

    def place(k: int):
        p = poses[k]
        if isinstance(p, NoPose):
            return (1, 0, 0, k)
        row, col = math.floor(p.y / PLACE_BLOCK_M), math.floor(p.x / PLACE_BLOCK_M)
        return (0, row, col if row % 2 == 0 else -col, k)

    return [poses[k] for k in sorted(range(len(poses)), key=place)]


POSES = "poses"  # the world cache's kind (app/cache/worlds.py keeps the island's poses there too)


def land_poses(spec, seed: int, cache=None, memory=None) -> tuple[list, bool]:
    """(The spec's poses of world `seed`, numbered by place; whether the world cache held them)."""
    from ..cache.key import entry_key
    from ..cache.worlds import pose_from_json, pose_to_json

    world = TiledWorld(seed, spec.biome, spec.detail, spec.vegetation)
    inputs = {
        "layout": "endless",
        **asdict(world),
        "scans": spec.scans_per_world,
        "poses": json.loads(json.dumps(asdict(spec.poses))),
    }
    key = entry_key(POSES, inputs)
    entry = cache.get(POSES, key) if cache is not None else None
    if entry is not None:
        return [pose_from_json(p) for p in entry.meta["poses"]], True
    poses = by_place(sample_land_poses(world, spec.poses, spec.scans_per_world, cache, memory))
    if cache is not None:
        cache.put(POSES, key, {"inputs": inputs, "poses": [pose_to_json(p) for p in poses]}, {})
    return poses, False


# ---------------------------------------------------------------------------------------
# a scan's world


@dataclass
class LandWorld:
    """What a worker keeps of an endless world between scans: its poses; the tiles themselves
    are in the process's TileMemory and the world cache."""

    seed: int
    world: TiledWorld
    poses: list
    cache: object
    build_seconds: float
    from_cache: bool

    def for_scan(self, choice: ScanPose, sensor):
        """The WorldContext (worker.py) of one scan: the tiles its sensor reaches."""
        from ..scan import crop_radius, endless_scan_geometry
        from ..tile_memory import process_memory
        from .context import WorldContext, embree_backend

        t0 = time.perf_counter()
        w = self.world
        reach = max(crop_radius(sensor), BEV_REACH_M)
        geometry, _ = endless_scan_geometry(
            w.seed,
            choice.pose,
            sensor,
            True,
            w.biome,
            w.vegetation,
            w.detail,
            self.cache,
            process_memory(),
            None,
            reach,
        )
        extent = (choice.x - reach, choice.x + reach, choice.y - reach, choice.y + reach)
        low, high = geometry.bounds()
        cover = geometry.cover
        return WorldContext(
            seed=self.seed,
            # its origin the search's (placement_centre): the scan stands where the search placed it
            backend=embree_backend(geometry.cropped(placement_centre(w, choice.x, choice.y), reach)),
            poses=self.poses,
            instances=None,  # ranked among the scan's own: a landscape holds more than 16 bits of objects
            z_range=(float(low[2]), float(high[2])),
            open_ground=no_open_ground(extent),
            build_seconds=time.perf_counter() - t0,
            ground=StandingGround(TerrainGrid(cover.terrain_xs, cover.terrain_ys, cover.terrain_z), []),
            cover=cover,
            sky=no_open_ground(extent),
            extent=extent,
        )


def land_world(spec, seed: int, cache=None, placed: list | None = None) -> LandWorld:
    """The LandWorld of `seed`: its poses `placed` when given (pose_to_json's, as the run's
    pose task of the world placed them: worker.py world_poses_task), else land_poses."""
    from ..cache.worlds import pose_from_json
    from ..tile_memory import process_memory

    t0 = time.perf_counter()
    if placed is not None:
        poses, cached = [pose_from_json(p) for p in placed], True
    else:
        poses, cached = land_poses(spec, seed, cache, process_memory())
    world = TiledWorld(seed, spec.biome, spec.detail, spec.vegetation)
    return LandWorld(seed, world, poses, cache, time.perf_counter() - t0, cached)


def poses_before_the_workers(
    spec, seeds: list[int], workers: int, cache_config: dict | None, say=None
) -> float:
    """Place the poses of the endless worlds that more than one worker would scan, here, once,
    into the world cache, before the workers start (seconds spent; 0 when nothing to do): a
    worker that takes a batch of a world places all of that world's poses itself unless the
    cache holds them, so two workers on one seed's world (the default spec) both placed them,
    side by side, each at half speed, and each held the placement's tiles and ray casters
    (2 GB a worker). With as many worlds as workers or more, each worker places its own
    worlds' poses in parallel, as before. The poses are the same (land_poses, one cache
    entry); tiles built here go to the cache for the workers' scans. Needs a cache the
    workers share (a local engine's)."""
    from ..cache.config import open_cache
    from ..tile_memory import TileMemory

    if spec.layout != "endless" or cache_config is None or len(seeds) >= workers:
        return 0.0
    t0 = time.perf_counter()
    disk = open_cache(cache_config)
    memory = TileMemory()  # this step's own: freed when it ends
    for seed in seeds:
        if say is not None:
            say(
                f"placing the {spec.scans_per_world:,} poses of seed {seed} before the workers start "
                "(they share them)"
            )
        land_poses(spec, seed, disk, memory)
    return time.perf_counter() - t0
