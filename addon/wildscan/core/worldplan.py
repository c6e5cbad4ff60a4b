"""The whole natural world as plain data: `plan_world(seed, detail) -> WorldPlan` (numpy only).

A 150 m x 150 m world centred on the origin with six zones (hills, forest,
park, lake, cave, trail) laid out on a seeded 3x2 or 2x3 grid of cells, a
terrain of at most 20 m relief, and every element of the paper's Table I
placed on it. Blender only realises the plan (world/builder.py); the aerial
map, pose lists and fast ray casting read it directly.

Stages and determinism
----------------------
Each stage draws from its own generator `stage_rng(seed, "world.<stage>")`:

    layout -> terrain -> poses -> trail, lake, cave, trees, bushes, rocks, grass, park, powerline

The element stages read only what comes before them in that chain (the
layout, the terrain and the reserved pose sites), never each other, so changing
one element stage's parameters leaves every other stage's geometry and tags
exactly as they were. Instance ids are allocated in blocks per stage
(STAGE_INSTANCE_BASE) for the same reason.

Detail levels (what each level means; `bench_world` in world_cli measures them)
-------------------------------------------------------------------------------
The world's layout and elements are the same at every level; only how finely
each shape is modelled changes. Errors are against the smooth shape a mesh
stands for (model_errors; terrain: fit_grid at 100,000 random points, seed 0):

| level   | terrain max / rms | 3 m crown | 0.3 m trunk | wire chord | tuft tris | world triangles |
|---------|-------------------|-----------|-------------|------------|-----------|-----------------|
| low     | 9.7 / 0.92 cm     | 19.8 cm   | 5.7 cm      | 2.8 cm     | 4         | ~97 k           |
| default | 3.4 / 0.27 cm     | 5.3 cm    | 3.0 cm      | 0.7 cm     | 9         | ~256 k          |
| high    | 1.8 / 0.12 cm     | 1.4 cm    | 1.5 cm      | 0.2 cm     | 16        | ~620 k          |

Terrain tolerances are 15, 5 and 2 cm (fit_grid keeps its sampled max within
75 % of them, because random samples miss the worst spot between them):
default is about three times the sensor's 1.5 cm range noise, high about the
noise itself. A 1M-point check over seeds 0-3 finds at most 13.6 / 3.9 / 2.2 cm;
high's 2.2 cm (seed 3) is where the 0.1 m minimum grid spacing stops the fit
around the steepest basin walls. Build time is under a second at every level on
this machine (2 cores, bpy 5.0.1), ~1,870 objects sharing 46 meshes.
"""

from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import asdict, dataclass, field, replace
from typing import Callable

import numpy as np

from . import shapes
from .checks import whole_number
from .classes import WATER, class_by_name
from .errors import UserError
from .heightfield import (
    Basin,
    Bumps,
    Ellipse,
    EllipseWindow,
    Flatten,
    FractalNoise,
    GridFit,
    Heightfield,
    Pit,
    RectWindow,
    fit_grid,
)
from .placement import ARM_X, ARM_Y, MAX_TILT_DEG, MAX_UNEVENNESS, Pose, laser_xy
from .rng import stage_rng

HALF = 75.0
EXTENT = (-HALF, HALF, -HALF, HALF)
MAX_RELIEF = 20.0
ZONES = ("hills", "forest", "park", "lake", "cave", "trail")
WORLD_ZONE = "world"  # what belongs to no single zone (the terrain)

STAGES = (
    "layout",
    "terrain",
    "poses",
    "trail",
    "lake",
    "cave",
    "trees",
    "bushes",
    "rocks",
    "grass",
    "park",
    "powerline",
)
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
)
STAGE_INSTANCE_BASE = {name: 10_000 * k for k, name in enumerate(ELEMENT_STAGES)}
STAGE_INSTANCE_BLOCK = 10_000

SITE_CLEARANCE = 1.0  # m kept free of elements around every reserved pose site


# ---------------------------------------------------------------------------------------
# detail levels


@dataclass(frozen=True)
class DetailLevel:
    name: str
    terrain_tolerance: float  # m, max height error of the terrain grid vs the analytic field
    trunk_sides: int
    branch_sides: int
    crown_sides: int
    crown_rings: int
    sphere_subdivisions: int
    bush_subdivisions: int
    rock_subdivisions: int
    tuft_planes: int
    tuft_blades: int
    wire_sides: int
    wire_step: float  # m between catenary samples
    trail_step: float  # m between trail cross-sections
    trail_across: int  # vertices across the trail


DETAILS: dict[str, DetailLevel] = {
    "low": DetailLevel("low", 0.15, 5, 3, 6, 5, 1, 1, 1, 2, 2, 3, 4.0, 3.0, 3),
    "default": DetailLevel("default", 0.05, 7, 4, 9, 7, 2, 1, 1, 3, 3, 4, 2.0, 1.5, 3),
    "high": DetailLevel("high", 0.02, 10, 6, 14, 10, 3, 2, 2, 4, 4, 6, 1.0, 0.75, 5),
}


def model_errors(d: DetailLevel) -> dict[str, float]:
    """How far each level's shapes are from the smooth shapes they stand for, metres, for
    reference sizes: a 3 m round crown (icosphere facets), a 0.3 m trunk (polygon sides),
    a 17 m wire span sagging 3 % (catenary chords). The terrain's is measured by fit_grid."""
    v, f = shapes.icosphere(d.sphere_subdivisions)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    plane = np.abs(np.einsum("ij,ij->i", n / np.linalg.norm(n, axis=1, keepdims=True), v[f[:, 0]]))
    a = shapes.catenary_parameter(17.0, 0.03 * 17.0)
    return {
        "crown_3m": float(3.0 * (1.0 - plane.min())),
        "trunk_0.3m": 0.3 * (1.0 - math.cos(math.pi / d.trunk_sides)),
        "wire_chord": d.wire_step**2 / (8.0 * a),
        "terrain_tolerance": d.terrain_tolerance,
    }


def detail_level(name: str) -> DetailLevel:
    if name not in DETAILS:
        raise UserError(f"--detail must be one of {', '.join(DETAILS)}, got {name!r}")
    return DETAILS[name]


# Seeds are stored on the world in Blender (ID properties are 32-bit) and in the
# add-on's seed field, so they stay within a signed 32-bit int.
MAX_SEED = 2**31 - 1


def check_seed(seed) -> int:
    """A seed is a whole number from 0 to MAX_SEED (given as int or text)."""
    return whole_number(seed, "--seed", 0, MAX_SEED)


def check_zone(zone: str) -> str:
    if zone not in ZONES:
        raise UserError(f"--zone must be one of {', '.join(ZONES)}, got {zone!r}")
    return zone


# ---------------------------------------------------------------------------------------
# parameters (one dataclass per stage; change one, the others stay as they were)

Density = tuple[tuple[str, float], ...]  # (zone, elements per 1000 m^2)


@dataclass(frozen=True)
class LayoutParams:
    boundary_jitter: float = 5.0
    pole_spacing: float = 17.0


@dataclass(frozen=True)
class TerrainParams:
    wavelength: float = 55.0  # m, largest noise feature
    octaves: int = 4  # the finest octave is wavelength / 8 (~7 m)
    amplitude: float = 2.5  # m
    hill_height: tuple[float, float] = (5.0, 11.0)


@dataclass(frozen=True)
class TrailParams:
    lift: float = 0.03  # m of flooring above the terrain grid (plus the grid's measured error)


@dataclass(frozen=True)
class TreeParams:
    density: Density = (
        ("forest", 18.0),
        ("trail", 3.0),
        ("lake", 2.0),
        ("hills", 1.2),
        ("cave", 1.0),
        ("park", 1.5),
    )
    min_spacing: float = 4.0
    variants: int = 2


@dataclass(frozen=True)
class BushParams:
    density: Density = (
        ("forest", 10.0),
        ("trail", 8.0),
        ("lake", 6.0),
        ("hills", 4.0),
        ("cave", 6.0),
        ("park", 3.0),
    )
    min_spacing: float = 1.6
    variants: int = 3


@dataclass(frozen=True)
class RockParams:
    density: Density = (
        ("hills", 8.0),
        ("cave", 9.0),
        ("lake", 5.0),
        ("trail", 4.0),
        ("forest", 3.0),
        ("park", 0.4),
    )
    min_spacing: float = 1.8
    size: tuple[float, float] = (0.25, 2.0)  # m, log-uniform
    variants: int = 4


@dataclass(frozen=True)
class GrassParams:
    low_density: Density = (
        ("forest", 45.0),
        ("park", 45.0),
        ("hills", 45.0),
        ("lake", 40.0),
        ("trail", 45.0),
        ("cave", 35.0),
    )
    high_density: Density = (
        ("hills", 16.0),
        ("lake", 30.0),
        ("trail", 20.0),
        ("forest", 10.0),
        ("cave", 8.0),
    )
    min_spacing: float = 0.8
    variants: int = 3


@dataclass(frozen=True)
class ParkParams:
    fence_section: float = 2.5  # m
    gates: int = 2
    lone_benches: int = 4


@dataclass(frozen=True)
class PowerlineParams:
    sag_ratio: tuple[float, float] = (0.025, 0.04)  # mid-span sag / span
    wire_radius: float = 0.015


@dataclass(frozen=True)
class WorldParams:
    layout: LayoutParams = LayoutParams()
    terrain: TerrainParams = TerrainParams()
    trail: TrailParams = TrailParams()
    trees: TreeParams = TreeParams()
    bushes: BushParams = BushParams()
    rocks: RockParams = RockParams()
    grass: GrassParams = GrassParams()
    park: ParkParams = ParkParams()
    powerline: PowerlineParams = PowerlineParams()

    def with_stage(self, stage: str, **changes) -> "WorldParams":
        """A copy with one stage's parameters changed."""
        return replace(self, **{stage: replace(getattr(self, stage), **changes)})


# ---------------------------------------------------------------------------------------
# plan data


@dataclass
class Prototype:
    """A mesh shared by every element that uses it (one Blender mesh, many objects)."""

    key: str
    vertices: np.ndarray
    faces: np.ndarray


@dataclass
class Element:
    """One tagged element: a prototype moved, turned (yaw, radians) and scaled."""

    name: str
    wildscan_class: str
    instance: int
    zone: str
    stage: str
    proto: str
    location: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    radius: float = 0.0  # m, top-view footprint (map, keep-outs)


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


@dataclass
class Layout:
    cells: dict[str, tuple[float, float, float, float]]
    grid_shape: tuple[int, int]
    bumps: list[tuple[float, float, float, float]]  # cx, cy, height, sigma
    poles: np.ndarray  # (n, 2)
    park_rect: tuple[float, float, float, float]
    lake: Ellipse
    lake_depth: float
    cave: Ellipse
    cave_depth: float
    ramp_length: float
    plateau_radius: float
    roof_u: tuple[float, float]  # pit-local extent of the roof along the pit's axis
    roof_v: tuple[float, float]
    trail: np.ndarray  # (n, 2) polyline, 0.5 m steps
    trail_width: float


@dataclass
class WorldPlan:
    seed: int
    detail: DetailLevel
    params: WorldParams
    layout: Layout | None = None
    heightfield: Heightfield | None = None
    grid_fit: GridFit | None = None
    water_z: float = 0.0
    cave_level: float = 0.0
    sites: list[Site] = field(default_factory=list)
    prototypes: dict[str, Prototype] = field(default_factory=dict)
    elements: list[Element] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)

    # -- terrain queries ----------------------------------------------------------------

    @property
    def grid(self):
        return self.grid_fit.grid

    def ground(self, x, y):
        """Height of the terrain mesh (not the analytic field): what elements stand on."""
        return self.grid.height_at(x, y)

    def ground_under(self, x, y, radius: float):
        """Lowest terrain height under a disc, so nothing floats on a slope."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        zs = [self.ground(x, y)] + [
            self.ground(x + radius * math.cos(a), y + radius * math.sin(a))
            for a in np.linspace(0, 2 * np.pi, 6, endpoint=False)
        ]
        return np.min(zs, axis=0)

    def in_water(self, x, y, margin: float = 0.0):
        lake = self.layout.lake
        return (lake.radius(x, y) < 1.3) & (self.ground(x, y) < self.water_z + margin)

    def trail_distance(self, x, y):
        return polyline_distance(self.layout.trail, np.column_stack([np.ravel(x), np.ravel(y)])).reshape(
            np.shape(x)
        )

    def blocked(self, x, y, radius: float, water_margin: float = 0.15, allow_park_interior: bool = False):
        """True where an element of this radius must not stand: water, trail, the cave's pit,
        ramp and roof, park fence line, power-line poles and reserved pose sites."""
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        lay = self.layout
        bad = self.in_water(x, y, water_margin)
        bad |= self.trail_distance(x, y) < lay.trail_width / 2 + radius + 0.3
        u, v = lay.cave.local(x, y)
        a, b = lay.cave.a + radius + 0.8, lay.cave.b + radius + 0.8
        bad |= (u / a) ** 2 + (v / b) ** 2 < 1.0
        bad |= (u > 0) & (u < lay.cave.a + lay.ramp_length + radius) & (np.abs(v) < 3.5 + radius)
        bad |= (
            (u > lay.roof_u[0] - radius)
            & (u < lay.roof_u[1] + radius)
            & (v > lay.roof_v[0] - radius)
            & (v < lay.roof_v[1] + radius)
        )
        x0, x1, y0, y1 = lay.park_rect
        inside = (x > x0) & (x < x1) & (y > y0) & (y < y1)
        edge = np.where(
            inside,
            np.minimum.reduce([x - x0, x1 - x, y - y0, y1 - y]),
            np.hypot(np.maximum.reduce([x0 - x, x - x1, 0 * x]), np.maximum.reduce([y0 - y, y - y1, 0 * y])),
        )
        bad |= edge < radius + 0.4  # the fence line
        if not allow_park_interior:
            bad |= inside & (edge > 3.5)
        for px, py in lay.poles:
            bad |= np.hypot(x - px, y - py) < radius + 1.0
        for s in self.sites:
            bad |= np.hypot(x - s.x, y - s.y) < radius + SITE_CLEARANCE
        return bad

    # -- elements -----------------------------------------------------------------------

    def add_prototype(self, key: str, mesh: shapes.Mesh) -> str:
        self.prototypes[key] = Prototype(
            key, np.asarray(mesh[0], dtype=np.float64), np.asarray(mesh[1], dtype=np.int32)
        )
        return key

    def add_element(
        self, stage: str, zone: str, wildscan_class: str, proto: str, counter: dict, **kw
    ) -> Element:
        k = counter.get("n", 0) + 1
        counter["n"] = k
        if k >= STAGE_INSTANCE_BLOCK:
            raise RuntimeError(f"stage {stage} placed more than {STAGE_INSTANCE_BLOCK - 1} elements")
        per = counter.setdefault((zone, wildscan_class), 0) + 1
        counter[(zone, wildscan_class)] = per
        name = f"{zone}.{wildscan_class.replace(' ', '_')}.{per:04d}"
        el = Element(name, wildscan_class, STAGE_INSTANCE_BASE[stage] + k, zone, stage, proto, **kw)
        self.elements.append(el)
        return el

    def elements_of(
        self, wildscan_class: str | None = None, zone: str | None = None, stage: str | None = None
    ):
        return [
            e
            for e in self.elements
            if (wildscan_class is None or e.wildscan_class == wildscan_class)
            and (zone is None or e.zone == zone)
            and (stage is None or e.stage == stage)
        ]

    def element_vertices(self, el: Element) -> np.ndarray:
        p = self.prototypes[el.proto]
        return shapes.transform((p.vertices, p.faces), el.location, el.yaw, el.scale)

    def triangles(self, elements=None):
        """The whole world as one indexed triangle mesh in world metres:
        (vertices (V,3), faces (T,3), class_id (T,), instance (T,), object_index (T,), names).
        Same geometry the Blender builder makes, for fast backends without Blender."""
        elements = self.elements if elements is None else elements
        verts, faces, cls, inst, obj = [], [], [], [], []
        n = 0
        for i, el in enumerate(elements):
            v = self.element_vertices(el)
            f = self.prototypes[el.proto].faces
            verts.append(v)
            faces.append(f + n)
            n += len(v)
            cls.append(np.full(len(f), class_by_name(el.wildscan_class).id, dtype=np.int16))
            inst.append(np.full(len(f), el.instance, dtype=np.int32))
            obj.append(np.full(len(f), i, dtype=np.int32))
        return (
            np.concatenate(verts),
            np.concatenate(faces).astype(np.int32),
            np.concatenate(cls),
            np.concatenate(inst),
            np.concatenate(obj),
            tuple(e.name for e in elements),
        )

    def triangle_count(self) -> int:
        return int(sum(len(self.prototypes[e.proto].faces) for e in self.elements))

    def counts(self) -> dict:
        by_class: dict[str, int] = {}
        for e in self.elements:
            by_class[e.wildscan_class] = by_class.get(e.wildscan_class, 0) + 1
        return {
            "objects": len(self.elements),
            "meshes": len({e.proto for e in self.elements}),
            "triangles": self.triangle_count(),
            "objects_by_class": dict(sorted(by_class.items())),
        }

    # -- description --------------------------------------------------------------------

    def zone_features(self, zone: str) -> dict:
        lay = self.layout
        r = lambda v: round(float(v), 3)  # noqa: E731
        if zone == "hills":
            return {"poles": [[r(x), r(y)] for x, y in lay.poles], "wires_per_span": 3}
        if zone == "park":
            return {"fenced_area": [r(v) for v in lay.park_rect]}
        if zone == "lake":
            e = lay.lake
            return {"centre": [r(e.cx), r(e.cy)], "semi_axes": [r(e.a), r(e.b)], "water_z": r(self.water_z)}
        if zone == "cave":
            e = lay.cave
            return {
                "pit_centre": [r(e.cx), r(e.cy)],
                "pit_semi_axes": [r(e.a), r(e.b)],
                "axis_deg": r(math.degrees(e.angle)),
                "floor_z": r(self.cave_level - self.cave_depth_scaled),
                "roof_z": r(self.cave_level),
            }
        if zone == "trail":
            return {"width": r(lay.trail_width), "length": r(polyline_length(lay.trail))}
        return {}

    @property
    def cave_depth_scaled(self) -> float:
        return self.layout.cave_depth * self.heightfield.scale

    def describe(self, poses: dict[str, list[dict]] | None = None) -> dict:
        """The JSON sidecar: zones with extents, features and scan poses."""
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


# ---------------------------------------------------------------------------------------
# geometry helpers


def polyline_length(path: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(path, axis=0), axis=1).sum())


def polyline_distance(path: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Distance from each point (N,2) to the polyline (K,2)."""
    a, b = path[:-1], path[1:]
    ab = b - a
    L2 = np.maximum((ab**2).sum(1), 1e-12)
    best = np.full(len(pts), np.inf)
    for start in range(0, len(a), 256):  # chunks keep memory small
        aa, dd, ll = a[start : start + 256], ab[start : start + 256], L2[start : start + 256]
        t = np.clip(((pts[:, None, :] - aa[None]) * dd[None]).sum(-1) / ll[None], 0, 1)
        proj = aa[None] + t[..., None] * dd[None]
        best = np.minimum(best, np.sqrt(((pts[:, None, :] - proj) ** 2).sum(-1)).min(1))
    return best


def catmull_rom(ctrl: np.ndarray, step: float) -> np.ndarray:
    """A smooth curve through control points, resampled every `step` metres."""
    p = np.vstack([2 * ctrl[0] - ctrl[1], ctrl, 2 * ctrl[-1] - ctrl[-2]])
    pts = []
    for i in range(1, len(p) - 2):
        t = np.linspace(0, 1, 40, endpoint=False)[:, None]
        p0, p1, p2, p3 = p[i - 1], p[i], p[i + 1], p[i + 2]
        pts.append(
            0.5
            * (
                (2 * p1)
                + (-p0 + p2) * t
                + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t**2
                + (-p0 + 3 * p1 - 3 * p2 + p3) * t**3
            )
        )
    pts.append(ctrl[-1:])
    dense = np.vstack(pts)
    return resample(dense, step)


def resample(path: np.ndarray, step: float) -> np.ndarray:
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    n = max(2, int(math.ceil(s[-1] / step)) + 1)
    t = np.linspace(0, s[-1], n)
    return np.column_stack([np.interp(t, s, path[:, k]) for k in range(path.shape[1])])


def cell_area(rect) -> float:
    return (rect[1] - rect[0]) * (rect[3] - rect[2])


def inset(rect, d):
    return (rect[0] + d, rect[1] - d, rect[2] + d, rect[3] - d)


def long_axis(rect) -> int:
    """0 when the cell is wider along X, 1 along Y."""
    return 0 if rect[1] - rect[0] >= rect[3] - rect[2] else 1


def darts(
    rng: np.random.Generator, rect, count: int, min_dist: float, ok: Callable, tries: int = 6
) -> np.ndarray:
    """Up to `count` points in `rect`, at least `min_dist` apart, where ok(x, y) holds
    (rejection sampling in batches; deterministic for a given generator)."""
    x0, x1, y0, y1 = rect
    cand = np.column_stack([rng.uniform(x0, x1, count * tries), rng.uniform(y0, y1, count * tries)])
    cand = cand[ok(cand[:, 0], cand[:, 1])]
    cell = max(min_dist, 1e-6)
    taken: dict[tuple[int, int], list] = {}
    out = []
    for x, y in cand:
        if len(out) >= count:
            break
        ix, iy = int(x // cell), int(y // cell)
        near = [p for dx in (-1, 0, 1) for dy in (-1, 0, 1) for p in taken.get((ix + dx, iy + dy), ())]
        if any((x - px) ** 2 + (y - py) ** 2 < min_dist**2 for px, py in near):
            continue
        taken.setdefault((ix, iy), []).append((x, y))
        out.append((x, y))
    return np.array(out, dtype=np.float64).reshape(-1, 2)


def density_of(density: Density, zone: str) -> float:
    return dict(density).get(zone, 0.0)


# ---------------------------------------------------------------------------------------
# stages


def stage_layout(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.layout
    cols, rows = (3, 2) if rng.random() < 0.5 else (2, 3)

    def bounds(n):
        b = np.linspace(-HALF, HALF, n + 1)
        b[1:-1] += rng.uniform(-p.boundary_jitter, p.boundary_jitter, n - 1)
        return b

    xb, yb = bounds(cols), bounds(rows)
    cells = [(xb[i], xb[i + 1], yb[j], yb[j + 1]) for j in range(rows) for i in range(cols)]
    order = rng.permutation(len(ZONES))
    cell_of = {ZONES[k]: tuple(float(v) for v in cells[order[k]]) for k in range(len(ZONES))}

    hills = cell_of["hills"]
    bumps = []
    for _ in range(int(rng.integers(3, 6))):
        sigma = rng.uniform(6.0, 10.0)
        hx0, hx1, hy0, hy1 = inset(hills, 1.6 * sigma)  # whole hills, not cut by the zone's edge
        bumps.append(
            (
                rng.uniform(hx0, hx1),
                rng.uniform(hy0, hy1),
                rng.uniform(*plan.params.terrain.hill_height),
                sigma,
            )
        )
    poles = _line_route(rng, hills, p.pole_spacing)

    park = cell_of["park"]
    park_rect = (
        park[0] + rng.uniform(4, 7),
        park[1] - rng.uniform(4, 7),
        park[2] + rng.uniform(4, 7),
        park[3] - rng.uniform(4, 7),
    )

    lake, lake_depth = _lake_shape(rng, cell_of["lake"])
    cave, cave_depth, ramp, plateau = _cave_shape(rng, cell_of["cave"])
    roof_u = (-cave.a - 1.5, -cave.a * rng.uniform(0.0, 0.2))
    roof_v = (-cave.b - 1.5, cave.b + 1.5)
    trail, width = _trail_path(rng, cell_of["trail"])
    plan.layout = Layout(
        cell_of,
        (cols, rows),
        bumps,
        poles,
        park_rect,
        lake,
        lake_depth,
        cave,
        cave_depth,
        ramp,
        plateau,
        roof_u,
        roof_v,
        trail,
        width,
    )


def _line_route(rng, cell, spacing) -> np.ndarray:
    ax = long_axis(cell)
    lo, hi = (cell[0], cell[1]) if ax == 0 else (cell[2], cell[3])
    clo, chi = (cell[2], cell[3]) if ax == 0 else (cell[0], cell[1])
    length = hi - lo - 8.0
    n = max(3, int(round(length / spacing)) + 1)
    along = np.linspace(lo + 4.0, hi - 4.0, n)
    across0 = rng.uniform(clo + 0.3 * (chi - clo), chi - 0.3 * (chi - clo))
    across1 = rng.uniform(clo + 0.3 * (chi - clo), chi - 0.3 * (chi - clo))
    across = np.linspace(across0, across1, n) + rng.uniform(-1.5, 1.5, n)
    return np.column_stack([along, across]) if ax == 0 else np.column_stack([across, along])


def _lake_shape(rng, cell) -> tuple[Ellipse, float]:
    ax = long_axis(cell)
    angle = (0.0 if ax == 0 else math.pi / 2) + rng.uniform(-0.35, 0.35)
    a, b = rng.uniform(12.0, 17.0), rng.uniform(8.0, 11.0)
    reach = 1.6  # normalised radius the lake's flattening reaches
    half_w, half_h = (cell[1] - cell[0]) / 2 - 1.0, (cell[3] - cell[2]) / 2 - 1.0
    c, s = abs(math.cos(angle)), abs(math.sin(angle))
    ex, ey = reach * math.hypot(a * c, b * s), reach * math.hypot(a * s, b * c)
    shrink = min(1.0, half_w / ex, half_h / ey)
    a, b, ex, ey = a * shrink, b * shrink, ex * shrink, ey * shrink
    cx = rng.uniform(cell[0] + 1.0 + ex, cell[1] - 1.0 - ex) if half_w > ex else (cell[0] + cell[1]) / 2
    cy = rng.uniform(cell[2] + 1.0 + ey, cell[3] - 1.0 - ey) if half_h > ey else (cell[2] + cell[3]) / 2
    return Ellipse(cx, cy, a, b, angle), rng.uniform(2.5, 3.5)


def _cave_shape(rng, cell) -> tuple[Ellipse, float, float, float]:
    a, b = rng.uniform(6.0, 8.0), rng.uniform(3.5, 4.5)
    ramp = 6.0
    plateau = a + ramp + 1.0
    reach = plateau + 3.0
    half_w, half_h = (cell[1] - cell[0]) / 2, (cell[3] - cell[2]) / 2
    mx, my = max(0.0, half_w - reach), max(0.0, half_h - reach)
    cx = (cell[0] + cell[1]) / 2 + rng.uniform(-mx, mx)
    cy = (cell[2] + cell[3]) / 2 + rng.uniform(-my, my)
    return Ellipse(cx, cy, a, b, rng.uniform(0, 2 * math.pi)), rng.uniform(3.0, 3.4), ramp, plateau


def _trail_path(rng, cell) -> tuple[np.ndarray, float]:
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
    return path, rng.uniform(2.0, 2.6)


def stage_terrain(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.terrain
    lay = plan.layout
    hf = Heightfield(FractalNoise(rng, p.wavelength, p.octaves), p.amplitude)
    x0, x1, y0, y1 = lay.cells["hills"]
    hf.features.append(
        Bumps(
            tuple((b[0], b[1]) for b in lay.bumps),
            tuple(b[2] for b in lay.bumps),
            tuple(b[3] for b in lay.bumps),
            RectWindow(x0, x1, y0, y1, 10.0),
        )
    )

    px0, px1, py0, py1 = lay.park_rect
    park_window = RectWindow(px0 - 3, px1 + 3, py0 - 3, py1 + 3, 6.0)
    hf.features.append(Flatten(park_window, hf.mean_over(park_window, lay.cells["park"])))

    lake_window = EllipseWindow(lay.lake, 1.2, 1.6)
    hf.features.append(Flatten(lake_window, hf.mean_over(lake_window, lay.cells["lake"]), 0.85))
    hf.features.append(Basin(lay.lake, lay.lake_depth, 0.4, 1.15))

    circle = Ellipse(lay.cave.cx, lay.cave.cy, 1.0, 1.0, 0.0)
    cave_window = EllipseWindow(circle, lay.plateau_radius, lay.plateau_radius + 3.0)
    cave_level_raw = hf.mean_over(cave_window, lay.cells["cave"])
    hf.features.append(Flatten(cave_window, cave_level_raw))
    hf.features.append(Pit(lay.cave, lay.cave_depth, 0.6, lay.ramp_length, 1.5, 1.5))

    # the hills give way when the world would exceed its relief (the pit and basin keep their depth)
    for _ in range(20):
        if hf.relief(EXTENT) <= MAX_RELIEF - 0.5:
            break
        hf.features[0] = replace(hf.features[0], gain=hf.features[0].gain * 0.93)
    hf.normalise(EXTENT, MAX_RELIEF)
    plan.heightfield = hf
    plan.cave_level = hf.scale * (cave_level_raw - hf.offset)
    plan.grid_fit = fit_grid(
        hf, EXTENT, plan.detail.terrain_tolerance, stage_rng(plan.seed, "world.terrain.error")
    )
    # water fills the basin up to just below the lowest point of its rim
    angles = np.linspace(0, 2 * np.pi, 180, endpoint=False)
    rim = [
        plan.ground(*lay.lake.to_world(r * lay.lake.a * np.cos(angles), r * lay.lake.b * np.sin(angles)))
        for r in (1.15, 1.25, 1.35)
    ]
    plan.water_z = float(np.min(rim)) - 0.15
    mesh = plan.grid.mesh()
    plan.add_prototype("terrain", mesh)
    plan.add_element("terrain", WORLD_ZONE, "terrain", "terrain", {}, radius=HALF)


# -- poses ------------------------------------------------------------------------------


def footprint_ok(
    plan: WorldPlan, x: float, y: float, yaw_deg: float, tilt_margin: float = 5.0, allow_pit: bool = False
) -> bool:
    """Numpy pre-check of a pose against the plan: the four laser tips on dry terrain,
    gentle and even enough (with margin) for `placement.place` to accept it."""
    tips = laser_xy(Pose(x, y, yaw_deg))
    if np.any(np.abs(tips) > HALF - 0.5):
        return False
    z = plan.ground(tips[:, 0], tips[:, 1])
    if np.any(plan.in_water(tips[:, 0], tips[:, 1], 0.2)):
        return False
    if not allow_pit:
        u, v = plan.layout.cave.local(tips[:, 0], tips[:, 1])
        lay = plan.layout
        roof = (u > lay.roof_u[0]) & (u < lay.roof_u[1]) & (v > lay.roof_v[0]) & (v < lay.roof_v[1])
        if np.any(lay.cave.radius(tips[:, 0], tips[:, 1]) < 1.1) or np.any(roof):
            return False
    unevenness = abs((z[0] + z[1]) - (z[2] + z[3])) / 2
    sx, sy = (z[0] - z[1]) / (2 * ARM_X), (z[2] - z[3]) / (2 * ARM_Y)
    tilt = math.degrees(math.atan(math.hypot(sx, sy)))
    return unevenness <= MAX_UNEVENNESS / 2 and tilt <= MAX_TILT_DEG - tilt_margin


def _yaw_towards(x, y, tx, ty) -> float:
    return round(math.degrees(math.atan2(ty - y, tx - x)) % 360.0, 1)


def stage_poses(plan: WorldPlan, rng: np.random.Generator) -> None:
    """Reserve a few scan sites per zone, each where that zone's classes are in view."""
    lay = plan.layout
    sites: list[Site] = []

    def add(zone, x, y, yaw, kind, z_start=None, allow_pit=False, min_gap=6.0):
        # rounded first, so the pose a user copies from the sidecar is the pose checked
        x, y, yaw = round(float(x), 3), round(float(y), 3), round(float(yaw) % 360.0, 1)
        if not footprint_ok(plan, x, y, yaw, allow_pit=allow_pit):
            return False
        if any(s.zone == zone and math.hypot(s.x - x, s.y - y) < min_gap for s in sites):
            return False
        sites.append(Site(zone, float(x), float(y), float(yaw), kind, z_start))
        return True

    def tries(zone, count, gen, attempts=200):
        n = 0
        for _ in range(attempts):
            if n >= count:
                return
            n += bool(gen())

    # forest: anywhere inside, clear of the border
    fx0, fx1, fy0, fy1 = inset(lay.cells["forest"], 8.0)
    tries(
        "forest",
        6,
        lambda: add(
            "forest",
            rng.uniform(fx0, fx1),
            rng.uniform(fy0, fy1),
            rng.uniform(0, 360),
            "forest",
            min_gap=10.0,
        ),
    )

    # park: 4-8 m inside the fence, where tables, benches and the fence are all in range
    px0, px1, py0, py1 = lay.park_rect

    def park_site():
        side = rng.integers(4)
        d = rng.uniform(4.5, 8.0)
        if side < 2:
            x = px0 + d if side == 0 else px1 - d
            y = rng.uniform(py0 + 6, py1 - 6)
        else:
            y = py0 + d if side == 2 else py1 - d
            x = rng.uniform(px0 + 6, px1 - 6)
        return add(
            "park", x, y, _yaw_towards(x, y, (px0 + px1) / 2, (py0 + py1) / 2), "near fence", min_gap=10.0
        )

    tries("park", 6, park_site)

    # hills: a few metres beside the power line, near a pole
    def hills_site():
        k = int(rng.integers(len(lay.poles) - 1))
        a, b = lay.poles[k], lay.poles[k + 1]
        d = b - a
        t = rng.uniform(0.2, 0.8)
        normal = np.array([-d[1], d[0]]) / np.linalg.norm(d)
        pt = a + t * d + normal * rng.choice([-1, 1]) * rng.uniform(2.5, 5.5)
        return add(
            "hills", pt[0], pt[1], math.degrees(math.atan2(d[1], d[0])) % 360, "near power line", min_gap=8.0
        )

    tries("hills", 6, hills_site)

    # lake: on the shore, a couple of metres from the water, facing it
    e = lay.lake
    for ang in np.linspace(0, 2 * np.pi, 10, endpoint=False) + rng.uniform(0, 0.6):
        for r in np.arange(0.0, 2.2, 0.02):  # from the middle outwards to the waterline
            x, y = e.to_world(r * e.a * math.cos(ang), r * e.b * math.sin(ang))
            if plan.ground(x, y) > plan.water_z + 0.25:
                x, y = e.to_world((r * e.a + 1.5) * math.cos(ang), (r * e.b + 1.5) * math.sin(ang))
                add("lake", float(x), float(y), _yaw_towards(x, y, e.cx, e.cy), "shore", min_gap=8.0)
                break

    # cave: inside under the roof (needs --z-start), in the open pit, on the plateau
    c = lay.cave
    floor = plan.cave_level - plan.cave_depth_scaled
    u_in = lay.roof_u[1] - 1.3
    head = math.degrees(c.angle) % 360
    for v in (0.0, 1.0, -1.0):
        x, y = c.to_world(u_in, v)
        add(
            "cave",
            float(x),
            float(y),
            (head + 180) % 360,
            "inside cave",
            z_start=round(floor + 1.5, 3),
            allow_pit=True,
            min_gap=0.9,
        )
    for v in (0.0, 1.2):
        x, y = c.to_world(lay.roof_u[1] + 1.5, v)
        add("cave", float(x), float(y), (head + 180) % 360, "cave entrance", allow_pit=True, min_gap=0.9)
    for ang in np.linspace(0.6, 2 * np.pi - 0.6, 5):
        x, y = c.to_world((c.a + 3.0) * math.cos(ang), (c.b + 3.0) * math.sin(ang))
        add("cave", float(x), float(y), _yaw_towards(x, y, c.cx, c.cy), "cave rim", min_gap=4.0)

    # trail: on the flooring, heading along it
    path = lay.trail
    for s in np.linspace(0.1, 0.9, 6):
        i = int(s * (len(path) - 2))
        d = path[i + 1] - path[i]
        add(
            "trail",
            path[i, 0],
            path[i, 1],
            math.degrees(math.atan2(d[1], d[0])) % 360,
            "on trail",
            min_gap=8.0,
        )

    plan.sites = sites


# -- flat features: trail, lake, cave roof ----------------------------------------------


def stage_trail(plan: WorldPlan, rng: np.random.Generator) -> None:
    """Flooring that follows the terrain: a strip a few cm above the terrain mesh, with
    short skirts down into the ground so no grazing beam sees under its edges."""
    lay, d = plan.layout, plan.detail
    path = resample(lay.trail, d.trail_step)
    tangent = np.gradient(path, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    across = np.linspace(-lay.trail_width / 2, lay.trail_width / 2, d.trail_across)
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
    plan.add_element("trail", "trail", "terrain", "trail", {}, radius=lay.trail_width / 2)


def stage_lake(plan: WorldPlan, rng: np.random.Generator) -> None:
    """The water surface: 2 m cells at the water level wherever the terrain dips below it
    (the part of a cell beyond the shore is under the terrain, a metre or two at most)."""
    e = plan.layout.lake
    reach = 1.2 * max(e.a, e.b)
    cell = 2.0
    xs = np.arange(e.cx - reach, e.cx + reach, cell)
    ys = np.arange(e.cy - reach, e.cy + reach, cell)
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
    plan.add_element("lake", "lake", WATER.name, "water", {}, radius=max(e.a, e.b))


def stage_cave(plan: WorldPlan, rng: np.random.Generator) -> None:
    """The cave roof: a slab of flooring over the back of the pit, resting on the plateau."""
    lay = plan.layout
    (u0, u1), (v0, v1) = lay.roof_u, lay.roof_v
    m = shapes.box(((u0 + u1) / 2, (v0 + v1) / 2, 0.05), (u1 - u0, v1 - v0, 0.4))
    c = lay.cave
    plan.add_prototype("cave_roof", m)
    plan.add_element(
        "cave",
        "cave",
        "terrain",
        "cave_roof",
        {},
        location=(c.cx, c.cy, plan.cave_level),
        yaw=c.angle,
        radius=max(u1 - u0, v1 - v0) / 2,
    )


# -- vegetation, rocks ------------------------------------------------------------------


TREE_MIX = {
    "forest": (("conifer", 0.4), ("broadleaf", 0.35), ("birch", 0.25)),
    "park": (("broadleaf", 0.7), ("birch", 0.3)),
    "lake": (("birch", 0.5), ("broadleaf", 0.5)),
    "trail": (("conifer", 0.5), ("broadleaf", 0.3), ("birch", 0.2)),
    "hills": (("conifer", 0.6), ("broadleaf", 0.4)),
    "cave": (("conifer", 0.5), ("birch", 0.5)),
}


def _zone_points(plan, rng, zone, density, min_dist, radius, extra_ok=None, allow_park_interior=False):
    rect = plan.layout.cells[zone]
    count = int(round(density * cell_area(rect) / 1000.0))
    if count <= 0:
        return np.zeros((0, 2))

    def ok(x, y):
        good = ~plan.blocked(x, y, radius, allow_park_interior=allow_park_interior)
        good &= (
            (x > rect[0] + radius) & (x < rect[1] - radius) & (y > rect[2] + radius) & (y < rect[3] - radius)
        )
        if extra_ok is not None:
            good &= extra_ok(x, y)
        return good

    return darts(rng, rect, count, min_dist, ok)


def _line_clear(plan, x, y, d):
    poles = plan.layout.poles
    return polyline_distance(poles, np.column_stack([x, y])) > d


def _park_border_band(plan):
    """Park trees grow only along the fence, leaving the lawn to the picnic tables."""
    x0, x1, y0, y1 = plan.layout.park_rect

    def ok(x, y):
        return ~((x > x0 + 3.5) & (x < x1 - 3.5) & (y > y0 + 3.5) & (y < y1 - 3.5))

    return ok


def stage_trees(plan: WorldPlan, rng: np.random.Generator) -> None:
    p, d = plan.params.trees, plan.detail
    kinds = {}
    for kind, make in shapes.TREE_KINDS.items():
        for v in range(p.variants):
            t = make(rng, d)
            key = f"{kind}{v}"
            plan.add_prototype(f"tree_{key}_trunk", t.trunk)
            plan.add_prototype(f"tree_{key}_crown", t.crown)
            kinds.setdefault(kind, []).append((key, t))
    counter: dict = {}
    for zone in ZONES:
        extra = None
        if zone == "hills":
            extra = lambda x, y: _line_clear(plan, x, y, 7.0)  # noqa: E731  a cleared corridor under the wires
        if zone == "park":
            extra = _park_border_band(plan)
        pts = _zone_points(plan, rng, zone, density_of(p.density, zone), p.min_spacing, 0.4, extra)
        names, weights = zip(*TREE_MIX[zone])
        for x, y in pts:
            kind = names[rng.choice(len(names), p=np.array(weights) / sum(weights))]
            key, t = kinds[kind][int(rng.integers(len(kinds[kind])))]
            s = rng.uniform(0.8, 1.2)
            yaw = rng.uniform(0, 2 * math.pi)
            z = float(plan.ground_under(x, y, t.trunk_radius * s))
            loc = (float(x), float(y), z)
            plan.add_element(
                "trees",
                zone,
                "trunk",
                f"tree_{key}_trunk",
                counter,
                location=loc,
                yaw=yaw,
                scale=(s, s, s),
                radius=t.trunk_radius * s,
            )
            plan.add_element(
                "trees",
                zone,
                "treetop",
                f"tree_{key}_crown",
                counter,
                location=loc,
                yaw=yaw,
                scale=(s, s, s),
                radius=t.crown_radius * s,
            )


def stage_bushes(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.bushes
    protos = []
    for v in range(p.variants):
        mesh, radius = shapes.bush(rng, plan.detail)
        protos.append((plan.add_prototype(f"bush{v}", mesh), radius))
    counter: dict = {}
    for zone in ZONES:
        pts = _zone_points(plan, rng, zone, density_of(p.density, zone), p.min_spacing, 0.7)
        for x, y in pts:
            key, radius = protos[int(rng.integers(len(protos)))]
            s = rng.uniform(0.7, 1.4)
            z = float(plan.ground(x, y)) - 0.05
            plan.add_element(
                "bushes",
                zone,
                "bush",
                key,
                counter,
                location=(float(x), float(y), z),
                yaw=rng.uniform(0, 2 * math.pi),
                scale=(s, s, s * rng.uniform(0.8, 1.1)),
                radius=radius * s,
            )


def stage_rocks(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.rocks
    protos = []
    for v in range(p.variants):
        mesh, radius = shapes.rock(rng, plan.detail)
        protos.append((plan.add_prototype(f"rock{v}", mesh), radius))
    counter: dict = {}
    lo, hi = np.log(p.size[0]), np.log(p.size[1])
    for zone in ZONES:
        pts = _zone_points(plan, rng, zone, density_of(p.density, zone), p.min_spacing, 1.0)
        for x, y in pts:
            key, radius = protos[int(rng.integers(len(protos)))]
            size = float(np.exp(rng.uniform(lo, hi)))
            sc = (size * rng.uniform(0.8, 1.2), size * rng.uniform(0.8, 1.2), size * rng.uniform(0.7, 1.1))
            z = float(plan.ground_under(x, y, 0.3 * size))
            plan.add_element(
                "rocks",
                zone,
                "rock",
                key,
                counter,
                location=(float(x), float(y), z),
                yaw=rng.uniform(0, 2 * math.pi),
                scale=sc,
                radius=radius * max(sc[:2]),
            )


def stage_grass(plan: WorldPlan, rng: np.random.Generator) -> None:
    p, d = plan.params.grass, plan.detail
    low = [
        plan.add_prototype(f"low_grass{v}", shapes.tuft(rng, 0.28, 0.32, d.tuft_planes, d.tuft_blades))
        for v in range(p.variants)
    ]
    high = [
        plan.add_prototype(f"high_grass{v}", shapes.tuft(rng, 0.95, 0.45, d.tuft_planes, d.tuft_blades))
        for v in range(p.variants)
    ]
    counter: dict = {}
    for zone in ZONES:
        for cls, protos, density, radius in (
            ("low grass", low, p.low_density, 0.2),
            ("high grass", high, p.high_density, 0.3),
        ):
            extra = None
            if zone == "lake" and cls == "high grass":  # reeds: along the shore
                extra = lambda x, y: plan.ground(x, y) < plan.water_z + 1.2  # noqa: E731
            pts = _zone_points(
                plan,
                rng,
                zone,
                density_of(density, zone),
                p.min_spacing,
                radius,
                extra,
                allow_park_interior=True,
            )
            for x, y in pts:
                s = rng.uniform(0.7, 1.4)
                plan.add_element(
                    "grass",
                    zone,
                    cls,
                    protos[int(rng.integers(len(protos)))],
                    counter,
                    location=(float(x), float(y), float(plan.ground(x, y))),
                    yaw=rng.uniform(0, 2 * math.pi),
                    scale=(s, s, s),
                    radius=radius * s,
                )


# -- park and power line ----------------------------------------------------------------


def stage_park(plan: WorldPlan, rng: np.random.Generator) -> None:
    """A fence round the park with a couple of gates; picnic tables with benches near each
    park scan site and elsewhere; a few lone benches."""
    p, lay = plan.params.park, plan.layout
    plan.add_prototype("fence_section", shapes.fence_section(p.fence_section))
    plan.add_prototype("fence_post", shapes.fence_post())
    plan.add_prototype("table", shapes.table())
    plan.add_prototype("bench", shapes.bench())
    counter: dict = {}
    x0, x1, y0, y1 = lay.park_rect
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    gate_sides = set(rng.choice(4, size=min(p.gates, 4), replace=False).tolist())
    for side in range(4):
        a, b = np.array(corners[side]), np.array(corners[(side + 1) % 4])
        length = float(np.linalg.norm(b - a))
        n = int(length // p.fence_section)
        start = a + (b - a) / length * (length - n * p.fence_section) / 2
        yaw = math.atan2(b[1] - a[1], b[0] - a[0])
        gate = set(range(n // 2 - 1, n // 2 + 1)) if side in gate_sides else set()
        for k in range(n):
            pt = start + (b - a) / length * p.fence_section * k
            if k in gate:
                continue
            plan.add_element(
                "park",
                "park",
                "fence",
                "fence_section",
                counter,
                location=(float(pt[0]), float(pt[1]), float(plan.ground(*pt))),
                yaw=yaw,
                radius=p.fence_section / 2,
            )
            if k + 1 in gate or k == n - 1:  # close the run with a post
                end = pt + (b - a) / length * p.fence_section
                plan.add_element(
                    "park",
                    "park",
                    "fence",
                    "fence_post",
                    counter,
                    location=(float(end[0]), float(end[1]), float(plan.ground(*end))),
                    yaw=yaw,
                    radius=0.1,
                )

    inner = (x0 + 5.0, x1 - 5.0, y0 + 5.0, y1 - 5.0)
    groups: list[np.ndarray] = []

    def free(pt, r):
        if not (inner[0] < pt[0] < inner[1] and inner[2] < pt[1] < inner[3]):
            return False
        if any(np.hypot(*(pt - g)) < 6.0 for g in groups):
            return False
        return not any(math.hypot(s.x - pt[0], s.y - pt[1]) < r + SITE_CLEARANCE for s in plan.sites)

    park_sites = [s for s in plan.sites if s.zone == "park"]
    targets = [np.array([s.x, s.y]) for s in park_sites] + [None] * 3
    for target in targets:
        for _ in range(60):
            if target is None:
                pt = np.array([rng.uniform(inner[0], inner[1]), rng.uniform(inner[2], inner[3])])
            else:
                ang = rng.uniform(0, 2 * math.pi)
                pt = target + rng.uniform(4.0, 6.5) * np.array([math.cos(ang), math.sin(ang)])
            if free(pt, 2.2):
                groups.append(pt)
                break
    for g in groups:
        yaw = rng.uniform(0, math.pi)
        c, s = math.cos(yaw), math.sin(yaw)
        plan.add_element(
            "park",
            "park",
            "table",
            "table",
            counter,
            location=(float(g[0]), float(g[1]), float(plan.ground(*g))),
            yaw=yaw,
            radius=1.0,
        )
        for side, turn in ((1, math.pi), (-1, 0.0)):
            b = g + side * 0.95 * np.array([-s, c])
            plan.add_element(
                "park",
                "park",
                "bench",
                "bench",
                counter,
                location=(float(b[0]), float(b[1]), float(plan.ground(*b))),
                yaw=yaw + turn,
                radius=0.8,
            )
    for _ in range(p.lone_benches):
        for _ in range(60):
            side = int(rng.integers(4))
            t = rng.uniform(0.15, 0.85)
            a, b = np.array(corners[side]), np.array(corners[(side + 1) % 4])
            inward = np.array([-(b - a)[1], (b - a)[0]]) / np.linalg.norm(b - a)
            pt = a + t * (b - a) + inward * 5.5
            if free(pt, 1.0):
                groups.append(pt)
                yaw = math.atan2(b[1] - a[1], b[0] - a[0])
                plan.add_element(
                    "park",
                    "park",
                    "bench",
                    "bench",
                    counter,
                    location=(float(pt[0]), float(pt[1]), float(plan.ground(*pt))),
                    yaw=yaw,
                    radius=0.8,
                )
                break


def stage_powerline(plan: WorldPlan, rng: np.random.Generator) -> None:
    """Poles along the route over the hills, three catenary wires per span."""
    p, d = plan.params.powerline, plan.detail
    poles = plan.layout.poles
    plan.add_prototype("pole", shapes.pole(d))
    counter: dict = {}
    heading = np.gradient(poles, axis=0)
    tops = []
    for (x, y), h in zip(poles, heading):
        yaw = math.atan2(h[1], h[0])
        loc = (float(x), float(y), float(plan.ground_under(x, y, 0.15)))
        plan.add_element("powerline", "hills", "pole", "pole", counter, location=loc, yaw=yaw, radius=0.15)
        tops.append(shapes.transform((shapes.POLE_ATTACHMENTS, None), loc, yaw))
    for k in range(len(poles) - 1):
        span = float(np.hypot(*(poles[k + 1] - poles[k])))
        sag = span * rng.uniform(*p.sag_ratio)
        samples = max(4, int(math.ceil(span / d.wire_step))) + 1
        for j in range(len(shapes.POLE_ATTACHMENTS)):
            path = shapes.catenary(tops[k][j], tops[k + 1][j], sag, samples)
            key = plan.add_prototype(f"wire{k}_{j}", shapes.wire(path, p.wire_radius, d.wire_sides))
            plan.add_element("powerline", "hills", "wire", key, counter, radius=p.wire_radius)


STAGE_FUNCS = {
    "layout": stage_layout,
    "terrain": stage_terrain,
    "poses": stage_poses,
    "trail": stage_trail,
    "lake": stage_lake,
    "cave": stage_cave,
    "trees": stage_trees,
    "bushes": stage_bushes,
    "rocks": stage_rocks,
    "grass": stage_grass,
    "park": stage_park,
    "powerline": stage_powerline,
}


def plan_world(
    seed,
    detail: str = "default",
    params: WorldParams | None = None,
    progress: Callable[[str, float], None] | None = None,
) -> WorldPlan:
    """Plan the whole world for a seed. `progress(stage, seconds)` is called after each stage."""
    plan = WorldPlan(check_seed(seed), detail_level(detail), params or WorldParams())
    for stage in STAGES:
        t0 = time.perf_counter()
        STAGE_FUNCS[stage](plan, stage_rng(plan.seed, f"world.{stage}"))
        plan.timings[stage] = time.perf_counter() - t0
        if progress is not None:
            progress(stage, plan.timings[stage])
    return plan


# ---------------------------------------------------------------------------------------
# hashes and poses


def plan_hash(plan: WorldPlan, stage: str | None = None) -> str:
    """SHA-256 over every element's world vertices, faces and tags (optionally one stage's)."""
    h = hashlib.sha256()
    for el in sorted(plan.elements, key=lambda e: e.name):
        if stage is not None and el.stage != stage:
            continue
        h.update(f"{el.name}|{el.wildscan_class}|{el.instance}|{el.zone}|{el.stage}".encode())
        h.update(np.round(plan.element_vertices(el), 5).astype(np.float64).tobytes())
        h.update(plan.prototypes[el.proto].faces.astype(np.int32).tobytes())
    return h.hexdigest()


def candidate_sites(plan: WorldPlan, zone: str, count: int) -> list[Site]:
    """The reserved sites of a zone, then (if more are asked) random footprint-checked
    candidates from the stage 'world.poses.extra' (same seed, same list)."""
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
