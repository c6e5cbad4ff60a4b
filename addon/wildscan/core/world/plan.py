"""The procedural world as plain data: `WorldPlan`, what its stages add to it, and its hash.

The stages (stages/, run in order by pipeline.py) fill a WorldPlan in: the
layout (each zone's cell and shape), the terrain, the reserved scan sites, then
the elements. The plan answers the questions every stage asks (the ground's
height, where an element may stand) by asking each zone's shape, so the plan
itself knows no zone in particular (numpy only).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any, Callable

import numpy as np

from .. import detmath as dm
from ..checks import one_of, whole_number
from ..placement import Pose
from .biomes import PAPER
from .cover import CoverGrid
from .detail import DetailLevel
from .elements import Element, ElementSet, Prototype
from .geometry2d import cell_area, darts
from .ground import StandingGround
from .heightfield import GridFit, Heightfield

HALF = 75.0
EXTENT = (-HALF, HALF, -HALF, HALF)
MAX_RELIEF = 20.0
ZONES = ("hills", "forest", "park", "lake", "cave", "trail")
WORLD_ZONE = "world"  # what belongs to no single zone (the terrain)

# Instance ids are allocated in blocks per element stage, so one stage placing more or fewer
# elements never renumbers another's.
ELEMENT_STAGES = (
    "terrain",
    "trail",
    "lake",
    "cave",
    "trees",
    "bushes",
    "rocks",
    "grass",
    "park",
    "powerline",
    "deadwood",
)
STAGE_INSTANCE_BASE = {name: 10_000 * k for k, name in enumerate(ELEMENT_STAGES)}
STAGE_INSTANCE_BLOCK = 10_000

# ground_under's six directions (sin, cos): the same values each call, made once
_RIM = tuple(zip(*dm.sincos(np.linspace(0, 2 * np.pi, 6, endpoint=False))))
SITE_CLEARANCE = 1.0  # m kept free of elements around every reserved pose site

# How vegetation is modelled (a world option, orthogonal to the detail level): "porous"
# crowns, bushes and high grass a beam can pass through (skeletons carrying leaf clusters,
# separate blades; the default), or "solid" closed shells (the paper's look, exactly the
# worlds WildScan built before porous vegetation existed).
VEGETATION = ("porous", "solid")
DEFAULT_VEGETATION = "porous"

# Seeds are stored on the world in Blender (ID properties are 32-bit) and in the
# add-on's seed field, so they stay within a signed 32-bit int.
MAX_SEED = 2**31 - 1


def check_seed(seed) -> int:
    """A seed is a whole number from 0 to MAX_SEED (given as int or text)."""
    return whole_number(seed, "seed", 0, MAX_SEED)


def check_zone(zone: str) -> str:
    return one_of(zone, "zone", ZONES)


def check_vegetation(vegetation: str) -> str:
    return one_of(vegetation, "vegetation", VEGETATION)


Density = tuple[tuple[str, float], ...]  # (zone, elements per 1000 m^2)


def density_of(density: Density, zone: str) -> float:
    return dict(density).get(zone, 0.0)


def rounded(v) -> float:
    """A number as world.json writes it (millimetres)."""
    return round(float(v), 3)


# ---------------------------------------------------------------------------------------
# keep-outs and sites


@dataclass(frozen=True)
class Clearance:
    """What an element about to be scattered asks of every keep-out area."""

    radius: float  # m, its footprint
    water_margin: float = 0.15  # m of dry ground it needs above the water level
    park_interior: bool = False  # may it stand on the park's lawn (grass may)


class ZoneShape:
    """The shape a zone's stage draws in the layout (the lake's basin, the cave's pit, the
    trail...). It answers for its zone where elements and scan poses must keep out and how
    world.json describes it; the plan's queries are the union over every zone's shape."""

    def keep_out(self, plan: WorldPlan, x, y, need: Clearance) -> np.ndarray:
        """True where an element asking `need` must not stand."""
        raise NotImplementedError

    def pose_keep_out(self, plan: WorldPlan, x, y, allow_pit: bool) -> np.ndarray:
        """True where a laser tip of a scan pose must not fall (default: anywhere may)."""
        return np.zeros(np.broadcast(x, y).shape, dtype=bool)

    def features(self, plan: WorldPlan) -> dict:
        """The zone's features in world.json."""
        raise NotImplementedError


@dataclass
class Site:
    """A reserved scan pose (kept free of elements); valid once `place()` accepts it."""

    zone: str
    x: float
    y: float
    yaw_deg: float
    kind: str
    z_start: float | None = None

    @property
    def pose(self) -> Pose:
        return Pose(self.x, self.y, self.yaw_deg)

    def to_dict(self) -> dict:
        out = {"x": round(self.x, 3), "y": round(self.y, 3), "yaw": round(self.yaw_deg, 1), "kind": self.kind}
        if self.z_start is not None:
            out["z_start"] = round(self.z_start, 3)
        return out

    def keep_out(self, plan: WorldPlan, x, y, need: Clearance) -> np.ndarray:
        return dm.hypot(x - self.x, y - self.y) < need.radius + SITE_CLEARANCE


@dataclass(frozen=True)
class SiteOffer:
    """A scan pose a zone offers; the poses stage reserves it if the sensor can stand there."""

    zone: str
    x: float
    y: float
    yaw_deg: float
    kind: str
    z_start: float | None = None
    allow_pit: bool = False  # may stand in the cave's pit (the sites inside the cave)
    min_gap: float = 6.0  # m from the zone's other sites


# ---------------------------------------------------------------------------------------
# the plan


@dataclass
class WorldPlan(ElementSet):
    seed: int
    detail: DetailLevel
    params: Any  # WorldParams (pipeline.py): one parameter dataclass per stage
    vegetation: str = DEFAULT_VEGETATION  # VEGETATION: porous or solid crowns, bushes, high grass
    biome: str = PAPER  # biomes.BIOMES: the mix of vegetation and ground cover (plan_world's default: mixed)
    layout: Any = None  # stages.layout.Layout: each zone's cell and shape, drawn first
    heightfield: Heightfield | None = None
    grid_fit: GridFit | None = None
    water_z: float = 0.0  # the lake's water level (set by the terrain stage)
    cave_level: float = 0.0  # the cave's plateau, where its roof rests (set by the terrain stage)
    sites: list[Site] = field(default_factory=list)
    prototypes: dict[str, Prototype] = field(default_factory=dict)
    elements: list[Element] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    cover: CoverGrid | None = None  # the sward layer (stages/cover.py); None: bare ground (paper)
    # (xmin, xmax, ymin, ymax) m the world covers: the paper's 150 m square, or an endless
    # region's tiles (core/world/endless)
    extent: tuple[float, float, float, float] = EXTENT

    # -- terrain queries ----------------------------------------------------------------

    @property
    def porous(self) -> bool:
        return self.vegetation == "porous"

    @property
    def grid(self):
        return self.grid_fit.grid

    def ground(self, x, y):
        """Height of the terrain mesh (not the analytic field): what elements stand on."""
        return self.grid.height_at(x, y)

    def standing_ground(self) -> StandingGround:
        """The ground the robot stands on (ground.py): the terrain mesh and, on the trail, the
        top of its flooring, which stands `params.trail.lift` plus the grid's error above it.
        What `hag` and the bird's-eye `terrain_z` measure from (docs/datasets.md)."""
        floors = [
            (self.element_vertices(el), self.prototypes[el.proto].faces)
            for el in self.elements
            if el.stage == "trail"
        ]
        return StandingGround(self.grid, floors)

    def ground_under(self, x, y, radius: float):
        """Lowest terrain height under a disc, so nothing floats on a slope."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        zs = [self.ground(x, y)] + [self.ground(x + radius * c, y + radius * s) for s, c in _RIM]
        return np.min(zs, axis=0)

    def in_water(self, x, y, margin: float = 0.0):
        return self.layout.lake.water_at(self, x, y, margin)

    def trail_distance(self, x, y):
        return self.layout.trail.distance(x, y)

    # -- where elements may stand -------------------------------------------------------

    def blocked(self, x, y, need: Clearance):
        """True where an element asking `need` must not stand: inside any zone's keep-out
        (water, trail, the cave's pit, ramp and roof, the park's fence line, the power-line
        poles) or too near a reserved pose site."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        bad = np.zeros(np.broadcast(x, y).shape, dtype=bool)
        for area in [*self.layout.zone_shapes().values(), *self.sites]:
            bad |= area.keep_out(self, x, y, need)
        return bad

    def scatter(
        self,
        rng: np.random.Generator,
        zone: str,
        density: float,
        min_dist: float,
        need: Clearance,
        extra_ok: Callable | None = None,
    ) -> np.ndarray:
        """Points (N,2) for `density` elements per 1000 m^2 of a zone, at least `min_dist`
        apart, inside the zone by their radius, wherever they are not blocked and
        `extra_ok(x, y)` holds."""
        rect = self.layout.cells[zone]
        radius = need.radius
        count = int(round(density * cell_area(rect) / 1000.0))
        if count <= 0:
            return np.zeros((0, 2))

        def ok(x, y):
            good = ~self.blocked(x, y, need)
            good &= (
                (x > rect[0] + radius)
                & (x < rect[1] - radius)
                & (y > rect[2] + radius)
                & (y < rect[3] - radius)
            )
            if extra_ok is not None:
                good &= extra_ok(x, y)
            return good

        return darts(rng, rect, count, min_dist, ok)

    # -- elements -----------------------------------------------------------------------

    def add_element(
        self, stage: str, zone: str, wildscan_class: str, proto: str, counter: dict, name: str = "", **kw
    ) -> Element:
        """A new element named `<zone>.<class>.<n>` (or `<zone>.<class>.<name>`: one of its
        kind, which another stage's tally of the class in the zone cannot name too), its
        instance id from its stage's block; `counter` is the stage's own tally."""
        k = counter.get("n", 0) + 1
        counter["n"] = k
        if k >= STAGE_INSTANCE_BLOCK:
            raise RuntimeError(f"stage {stage} placed more than {STAGE_INSTANCE_BLOCK - 1} elements")
        per = counter.setdefault((zone, wildscan_class), 0) + 1
        counter[(zone, wildscan_class)] = per
        name = f"{zone}.{wildscan_class.replace(' ', '_')}.{name or f'{per:04d}'}"
        el = Element(name, wildscan_class, STAGE_INSTANCE_BASE[stage] + k, zone, stage, proto, **kw)
        self.elements.append(el)
        return el

    # -- description --------------------------------------------------------------------

    def cover_facts(self) -> dict:
        """world.json's ground cover: the grid's cell and the share of the ground under each class."""
        if self.cover is None:
            return {}
        return {"cell": self.cover.cell, "shares": {k: round(v, 4) for k, v in self.cover.shares().items()}}

    def zone_features(self, zone: str) -> dict:
        shape = self.layout.zone_shapes().get(zone)
        return shape.features(self) if shape is not None else {}

    def describe(self, poses: dict[str, list[dict]] | None = None) -> dict:
        """The JSON sidecar: zones with extents, features and scan poses (an endless region's
        layout describes itself: endless/region.py)."""
        if getattr(self.layout, "endless", False):
            return self.layout.describe(self, poses)
        fit = self.grid_fit
        zones = []
        for name in ZONES:
            x0, x1, y0, y1 = self.layout.cells[name]
            entry = {
                "name": name,
                "extent": {"xmin": x0, "xmax": x1, "ymin": y0, "ymax": y1},
                "features": self.zone_features(name),
            }
            if poses is not None:
                entry["poses"] = poses.get(name, [])
            zones.append(entry)
        return {
            "seed": self.seed,
            "detail": self.detail.name,
            "vegetation": self.vegetation,
            **({} if self.biome == PAPER else {"biome": self.biome, "cover": self.cover_facts()}),
            "extent": {"xmin": EXTENT[0], "xmax": EXTENT[1], "ymin": EXTENT[2], "ymax": EXTENT[3]},
            "terrain": {
                "relief": round(float(self.grid.z.max() - self.grid.z.min()), 3),
                "grid": [len(fit.grid.xs), len(fit.grid.ys)],
                "spacing_min": round(fit.spacing_min, 3),
                "spacing_max": round(fit.spacing_max, 3),
                "tolerance": fit.tolerance,
                "error": {
                    k: round(v, 4) if isinstance(v, float) else v for k, v in fit.error.to_dict().items()
                },
            },
            "zones": zones,
            "counts": self.counts(),
            "hash": plan_hash(self),
            "params": json.loads(json.dumps(asdict(self.params))),
        }


def plan_hash(plan: WorldPlan, stage: str | None = None) -> str:
    """SHA-256 over every element's world vertices, faces and tags (optionally one stage's),
    and the ground cover's grid where there is one (stage "cover")."""
    h = hashlib.sha256()
    if plan.cover is not None and stage in (None, "cover"):
        h.update(plan.cover.class_id.tobytes())
        h.update(np.round(plan.cover.height.astype(np.float64), 5).tobytes())
    for el in sorted(plan.elements, key=lambda e: e.name):
        if stage is not None and el.stage != stage:
            continue
        h.update(f"{el.name}|{el.wildscan_class}|{el.instance}|{el.zone}|{el.stage}".encode())
        h.update(np.round(plan.element_vertices(el), 5).astype(np.float64).tobytes())
        h.update(plan.prototypes[el.proto].faces.astype(np.int32).tobytes())
    return h.hexdigest()
