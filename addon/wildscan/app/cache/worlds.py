"""A dataset worker's world, built once and kept in the world cache (store.py), numpy only.

What a worker needs of a world before its first scan is a pure function of (seed, detail,
vegetation, biome) and the code (key.py): the triangles (`SceneGeometry`), what the sealed
ray caster and the float64 settling read (each triangle's plane, its padded copy, the
settling's band and vertex-neighbour index: raycast/settle.py), the instances, the open
ground and the open sky of the bird's-eye grid (core/truth/open_ground.py, core/truth/open_sky.py: the
open sky is a pass over every triangle, 0.1-0.3 s of CPU a porous world, that a warm load
no longer makes), the ground the robot stands on (terrain grid and trail flooring:
core/world/ground.py) and the ground cover. One entry
(`world-<key>.npz`) holds them all; a warm load reads it and skips the plan altogether
(the plan is what the triangles, the ground and the cover are made from, and nothing else
of it is read by a scan). The poses are a second, small entry (`poses-<key>.npz`), keyed
also on the spec's [poses] and scans_per_world: sampling them again needs the plan, so a
world loaded from the cache with poses it has never had is planned once more for them.

Not cached: the ray caster's own acceleration structure (Embree's BVH cannot be saved), so
a warm load still uploads the padded triangles and builds the BVH; the offset-local
corners of the triangles, a gather from the vertices that costs less than reading them; and
the neighbour index's CSR offsets, counted again from the corners' position ids (stored, with
the neighbours, as int32: the index's values are vertex and triangle numbers).

Every array is stored bit for bit and used as it is, so a scan of a world loaded from the
cache gives the same bytes as a scan of one just built (tests/test_world_cache.py).
"""

from __future__ import annotations

import json
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field

import numpy as np

from ...core.classes import class_by_name
from ...core.errors import PoseRejected
from ...core.placement import place
from ...core.posesampler import NoPose, ScanPose, sample_poses
from ...core.truth.open_ground import OpenGround, no_open_ground, open_ground
from ...core.truth.open_sky import open_sky
from ...core.truth.traversability import ROBOT_HEIGHT
from ...core.world import EXTENT, WorldPlan, plan_world
from ...core.world.cover import CoverGrid
from ...core.world.ground import StandingGround
from ...core.world.terrain_grid import TerrainGrid
from ...raycast.geometry import SceneGeometry
from ...raycast.sealing import local_corners, sealed_settler
from ...raycast.settle import Settler
from .key import entry_key
from .store import DiskCache

TERRAIN_ID = class_by_name("terrain").id
WORLD, POSES = "world", "poses"
GEOMETRY_ARRAYS = ("vertices", "faces", "class_id", "instance", "object_index", "reflectivity", "offset")


@dataclass
class PreparedWorld:
    """Everything a dataset worker makes of a world before casting a ray."""

    inputs: dict  # seed, detail, vegetation, biome
    geometry: SceneGeometry
    settler: Settler  # planes, padded triangles, band and neighbour index, all made
    instances: np.ndarray
    z_range: tuple[float, float]
    open_ground: OpenGround
    ground: StandingGround
    cover: CoverGrid | None
    open_sky: OpenGround | None = None  # where an upward ray from a robot's height meets nothing
    plan: WorldPlan | None = None  # when just built; None when loaded (world_plan plans it again)
    from_cache: bool = False
    seconds: float = 0.0
    timings: dict[str, tuple[float, float]] = field(default_factory=dict)  # step -> (wall, CPU) s

    def world_plan(self) -> WorldPlan:
        """The plan (only poses not in the cache need it: the sampler reads its sites and zones)."""
        if self.plan is None:
            self.plan = _plan(self.inputs)
        return self.plan


def _plan(inputs: dict) -> WorldPlan:
    i = inputs
    return plan_world(i["seed"], i["detail"], vegetation=i["vegetation"], biome=i["biome"])


def world_inputs(seed: int, detail: str, vegetation: str, biome: str) -> dict:
    return {"seed": int(seed), "detail": detail, "vegetation": vegetation, "biome": biome}


def prepared_world(inputs: dict, cache: DiskCache | None) -> PreparedWorld:
    """The world of `inputs`, from the cache when it holds it, else built (and stored)."""
    t0 = time.perf_counter()
    timings: dict[str, tuple[float, float]] = {}
    key = entry_key(WORLD, inputs)
    with step(timings, "read and verify the entry"):
        entry = cache.get(WORLD, key) if cache is not None else None
    if entry is not None:
        with step(timings, "unpack (corners gathered)"):
            world = from_entry(inputs, entry.meta, entry.arrays)
        world.from_cache = True
    else:
        timings.clear()
        world = build_prepared(inputs, timings)
        if cache is not None:
            with step(timings, "write the entry"):
                cache.put(WORLD, key, *to_entry(world))
    world.seconds = time.perf_counter() - t0
    world.timings = timings
    return world


@contextmanager
def step(timings: dict[str, tuple[float, float]], name: str):
    """Add the wall and CPU seconds of the block to timings[name] (wall, cpu)."""
    wall, cpu = time.perf_counter(), time.process_time()
    yield
    before = timings.get(name, (0.0, 0.0))
    timings[name] = (before[0] + time.perf_counter() - wall, before[1] + time.process_time() - cpu)


def build_prepared(inputs: dict, timings: dict | None = None) -> PreparedWorld:
    """Plan the world, make its triangles and everything the sealed caster reads."""
    from ...raycast.from_plan import plan_geometry

    timings = {} if timings is None else timings
    with step(timings, "plan"):
        plan = _plan(inputs)
    with step(timings, "triangles"):
        geometry = plan_geometry(plan)
    with step(timings, "planes, padding and bands"):
        settler = sealed_settler(geometry)
    with step(timings, "settling index"):
        settler.neighbours  # made now, so it is stored with the rest  # noqa: B018
    with step(timings, "open ground, ground, instances"):
        low, high = geometry.bounds()
        world = PreparedWorld(
            inputs=inputs,
            geometry=geometry,
            settler=settler,
            instances=np.array([e.instance for e in plan.elements], dtype=np.int64),
            z_range=(float(low[2]), float(high[2])),
            open_ground=world_open_ground(plan, geometry),
            ground=plan.standing_ground(),
            cover=plan.cover,
            plan=plan,
        )
    with step(timings, "open sky"):
        world.open_sky = world_open_sky(geometry, world.ground)
    return world


def world_open_sky(geometry, ground: StandingGround) -> OpenGround:
    """Where an upward ray from ROBOT_HEIGHT above the standing ground meets nothing (the
    bird's-eye grid's `overhead`: core/truth/open_sky.py)."""
    return open_sky(geometry.vertices, geometry.faces, ground.terrain, ROBOT_HEIGHT, EXTENT)


def world_open_ground(plan: WorldPlan, geometry) -> OpenGround:
    """Where only the terrain lies under a bird's-eye cell; none unless the terrain grid
    covers the extent (what makes an open cell's answer the terrain: core/truth/open_ground.py)."""
    xs, ys = plan.grid.xs, plan.grid.ys
    x0, x1, y0, y1 = EXTENT
    if not (xs[0] <= x0 and xs[-1] >= x1 and ys[0] <= y0 and ys[-1] >= y1):
        return no_open_ground(EXTENT)
    xy = np.ascontiguousarray(geometry.vertices[:, :2])  # one copy: take() copies a strided view each call
    return open_ground(xy, geometry.faces[geometry.class_id != TERRAIN_ID], EXTENT)


# ---------------------------------------------------------------------------------------
# to and from an entry


def to_entry(world: PreparedWorld) -> tuple[dict, dict[str, np.ndarray]]:
    g, s, og, ground = world.geometry, world.settler, world.open_ground, world.ground
    arrays = {name: getattr(g, name) for name in GEOMETRY_ARRAYS}
    corner_pos, starts, owners = s.neighbours
    arrays.update(
        padded=s.padded,
        normal=s.normal,
        d=s.d,
        band=s.band,
        # int32 (indices of vertices and triangles, which int32 faces bound) and no CSR
        # offsets (a count away: neighbour_index): a sixth of the entry's bytes
        corner_pos=corner_pos.astype(np.int32),
        owners=owners.astype(np.int32),
        instances=world.instances,
        open_ground=og.is_open,
        open_sky=world.open_sky.is_open,
        **ground_arrays(ground),
    )
    if world.cover is not None:
        arrays.update(world.cover.to_arrays())
        arrays["cover_nodes"] = world.cover.node_ground()
    meta = {
        "inputs": world.inputs,
        "object_names": list(g.object_names),
        "z_range": list(world.z_range),
        "open_ground": [og.x0, og.y0, og.cell],
        "open_sky": [world.open_sky.x0, world.open_sky.y0, world.open_sky.cell],
        "floors": len(ground.floors),
        "positions": len(starts) - 1,
        "cover": world.cover is not None,
    }
    return meta, arrays


def from_entry(inputs: dict, meta: dict, arrays: dict[str, np.ndarray]) -> PreparedWorld:
    cover = None
    if meta["cover"]:
        cover = CoverGrid.from_arrays(arrays)
        cover.use_node_ground(arrays["cover_nodes"])
    geometry = SceneGeometry(
        object_names=tuple(meta["object_names"]), cover=cover, **{n: arrays[n] for n in GEOMETRY_ARRAYS}
    )
    settler = Settler.restored(
        geometry,
        arrays["padded"],
        (arrays["normal"], arrays["d"]),
        local_corners(geometry),
        arrays["band"],
        neighbour_index(arrays["corner_pos"], arrays["owners"], meta["positions"]),
    )
    x0, y0, cell = meta["open_ground"]
    sky_x0, sky_y0, sky_cell = meta["open_sky"]
    return PreparedWorld(
        inputs=inputs,
        geometry=geometry,
        settler=settler,
        instances=arrays["instances"],
        z_range=(meta["z_range"][0], meta["z_range"][1]),
        open_ground=OpenGround(x0, y0, cell, arrays["open_ground"]),
        ground=ground_from_arrays(arrays, meta["floors"]),
        cover=cover,
        open_sky=OpenGround(sky_x0, sky_y0, sky_cell, arrays["open_sky"]),
    )


def neighbour_index(corner_pos: np.ndarray, owners: np.ndarray, positions: int):
    """Settler.neighbours from an entry: (corner_pos, starts, owners) as int64, the CSR offsets
    counted again over the `positions` vertex positions, as Settler.neighbours makes them."""
    corner_pos = corner_pos.astype(np.int64)
    starts = np.r_[0, np.cumsum(np.bincount(corner_pos.ravel(), minlength=positions))]
    return corner_pos, starts, owners.astype(np.int64)


def ground_arrays(ground: StandingGround) -> dict[str, np.ndarray]:
    """The standing ground as arrays: the terrain grid and each flooring's triangles."""
    arrays = {"terrain_xs": ground.terrain.xs, "terrain_ys": ground.terrain.ys, "terrain_z": ground.terrain.z}
    for k, floor in enumerate(ground.floors):
        arrays[f"floor{k}"] = floor.tri  # FloorTops of this triangle soup is the same again
    return arrays


def ground_from_arrays(arrays: dict[str, np.ndarray], floors: int) -> StandingGround:
    """The standing ground of ground_arrays (and `floors`, how many floorings it has)."""
    terrain = TerrainGrid(arrays["terrain_xs"], arrays["terrain_ys"], arrays["terrain_z"])
    soups = [arrays[f"floor{k}"] for k in range(floors)]
    return StandingGround(terrain, [(t.reshape(-1, 3), np.arange(3 * len(t)).reshape(-1, 3)) for t in soups])


# ---------------------------------------------------------------------------------------
# the poses


def world_poses(
    world: PreparedWorld, backend, count: int, poses_spec, cache: DiskCache | None
) -> tuple[list, bool]:
    """(The `count` scan poses of the world for the spec's [poses] (app/dataset/spec.py
    PoseSpec), whether they came from the cache). Sampled, when not cached, with the four-laser
    placement on `backend` as the check (core/posesampler.py)."""
    inputs = dict(world.inputs, scans=count, poses=json.loads(json.dumps(poses_spec.paper_dict())))
    key = entry_key(POSES, inputs)
    entry = cache.get(POSES, key) if cache is not None else None
    if entry is not None:
        return [pose_from_json(p) for p in entry.meta["poses"]], True

    def accept(candidate: ScanPose) -> bool:
        try:
            place(backend, candidate.pose, candidate.z_start)
        except PoseRejected:
            return False
        return True

    p = poses_spec
    poses = sample_poses(
        world.world_plan(), count, p.strategy, dict(p.zones), p.min_distance, accept, dict(p.min_scans_with)
    )
    if cache is not None:
        cache.put(POSES, key, {"inputs": inputs, "poses": [pose_to_json(p) for p in poses]}, {})
    return poses, False


def pose_to_json(p) -> dict:
    if isinstance(p, NoPose):
        return {"no_pose": {"zone": p.zone, "reason": p.reason}}
    return {"pose": asdict(p)}


def pose_from_json(d: dict):
    if "no_pose" in d:
        return NoPose(**d["no_pose"])
    return ScanPose(**d["pose"])
