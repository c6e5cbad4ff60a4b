"""A small tagged test world, as numpy meshes (no bpy here).

The test world is a fixed 60 m x 60 m layout with a little seed jitter: every
class of Table I plus water within ~14 m of the origin, so one r_h = 1 deg scan
from (0, 0) sees them all. It exists for tests and demos; the real worlds come
from the full world planner. It is built from the same primitives as they are
(shapes/primitives.py).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import detmath as dm
from ..rng import stage_rng
from .elements import Element, ElementSet, Prototype
from .shapes.powerline import catenary_points
from .shapes.primitives import Mesh, beam, box, cone, disc, merge, rotate_z, tube, uv_sphere
from .terrain_grid import TerrainGrid

# ---------------------------------------------------------------------------
# the plan

TEST_ZONE = "testworld"  # its elements belong to none of the procedural world's zones


@dataclass
class TestWorldPlan(ElementSet):
    """The test world: each element is its own prototype, already in world metres (its
    placement is the identity), so `element_vertices(el)` are the mesh's vertices."""

    __test__ = False  # not a pytest test class despite the name

    seed: int
    xs: np.ndarray  # terrain grid x coordinates (nx,)
    ys: np.ndarray  # terrain grid y coordinates (ny,)
    heights: np.ndarray  # (ny, nx) terrain z at the grid vertices
    pond_center: tuple[float, float]
    pond_radius: float  # radius of the depression
    water_radius: float  # radius of the flat water disc
    pond_water_z: float
    rock_positions: np.ndarray  # (K, 3) rock centres (x, y, ground z there), largest first
    rock_radii: np.ndarray  # (K,) horizontal radius of each rock
    poses: dict[str, tuple[float, float, float]]
    prototypes: dict[str, Prototype] = field(default_factory=dict)
    elements: list[Element] = field(default_factory=list)

    @property
    def spacing(self) -> float:
        return float(self.xs[1] - self.xs[0])

    @property
    def grid(self) -> TerrainGrid:
        return TerrainGrid(self.xs, self.ys, self.heights)

    @property
    def classes(self) -> set[str]:
        return {e.wildscan_class for e in self.elements}

    def height_at(self, x, y):
        """Terrain z at (x, y), exactly as the triangulated mesh; NaN off the terrain."""
        return height_on_terrain(self.grid, x, y)


def height_on_terrain(grid: TerrainGrid, x, y):
    """The terrain mesh's height (`TerrainGrid.height_at`) where the grid covers (x, y), NaN
    beyond it; a float for scalar x and y."""
    scalar = np.ndim(x) == 0 and np.ndim(y) == 0
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    inside = (x >= grid.xs[0]) & (x <= grid.xs[-1]) & (y >= grid.ys[0]) & (y <= grid.ys[-1])
    z = np.where(inside, grid.height_at(x, y), np.nan)
    return float(z) if scalar else z


HALF_SIZE = 30.0
SPACING = 0.5
CLEAR_RADIUS = 3.0
MAX_SLOPE_DEG = 14.0
POND_CENTER = (12.0, -10.0)
POND_RADIUS = 7.0

# Anchors of the layout (x, y) before seed jitter; chosen so nothing enters the
# clear zone, the pond, or another element (see the tests).
_POLES = ((-7.0, 5.0), (0.0, 9.0))
_TREES = (((7.5, 6.5), "conifer"), ((-9.5, -3.0), "broadleaf"), ((-3.0, -10.5), "broadleaf"))
_ROCKS = (((5.0, -3.5), 1.2), ((-6.0, -7.0), 0.8), ((10.5, 0.5), 0.7), ((1.5, -8.0), 0.5))
_TABLE = (4.5, 2.5)
_FENCE = ((-12.5, -6.0), (-12.5, 4.0))
_BUSHES = ((-3.5, 4.0), (9.0, 3.0), (-8.5, -9.0), (2.0, -12.0))
_LOW_GRASS = ((-1.5, -5.0), (0.5, 5.0), (-6.5, 0.5))
_HIGH_GRASS = ((-10.0, 9.0), (3.0, 12.5))
JITTER = 0.5


def _smoothstep(e0: float, e1: float, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _terrain_heights(seed: int, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """Gentle relief: two long sine waves (damped near the origin), a few broad gaussian
    bumps away from the origin and the pond depression; rescaled so no triangle is
    steeper than MAX_SLOPE_DEG; z = 0 at the origin."""
    rng = stage_rng(seed, "testworld.terrain")
    gx, gy = np.meshgrid(xs, ys)
    r = dm.hypot(gx, gy)
    waves = np.zeros_like(gx)
    for _ in range(2):
        ang, phase = rng.uniform(0, 2 * np.pi, 2)
        wavelength, amp = rng.uniform(24.0, 36.0), rng.uniform(0.1, 0.2)
        sin, cos = dm.sincos(ang)
        waves += amp * dm.sin(2 * np.pi * (gx * cos + gy * sin) / wavelength + phase)
    relief = waves * (0.25 + 0.75 * _smoothstep(2.0, 12.0, r))
    for cx, cy, amp, sigma in _bumps(rng):
        dx, dy = gx - cx, gy - cy
        relief += amp * dm.exp(-(dx * dx + dy * dy) / (2 * (sigma * sigma)))
    rp = dm.hypot(gx - POND_CENTER[0], gy - POND_CENTER[1]) / POND_RADIUS
    depth = rng.uniform(1.0, 1.2)
    bowl = np.clip(1.0 - rp * rp, 0.0, None)
    z = relief - depth * (bowl * bowl)
    slope = _max_slope(xs, ys, z)
    limit = dm.tan(dm.radians(MAX_SLOPE_DEG))
    if slope > limit:
        z *= limit / slope
    origin = np.argmin(np.abs(ys)), np.argmin(np.abs(xs))
    return z - z[origin]


def _bumps(rng, count: int = 4):
    """Broad gaussian hills and dips away from the origin and away from the pond, so the
    pond's rim stays level enough to hold water."""
    bumps = []
    while len(bumps) < count:
        dist, ang = rng.uniform(14.0, 26.0), rng.uniform(0, 2 * np.pi)
        amp, sigma = rng.uniform(-0.6, 1.0), rng.uniform(6.0, 9.0)
        cx, cy = dist * dm.cos(ang), dist * dm.sin(ang)
        if dm.hypot(cx - POND_CENTER[0], cy - POND_CENTER[1]) >= 14.0:
            bumps.append((cx, cy, amp, sigma))
    return bumps


def _max_slope(xs, ys, z) -> float:
    """Largest gradient magnitude over the mesh triangles."""
    dx, dy = xs[1] - xs[0], ys[1] - ys[0]
    z00, z10, z01, z11 = z[:-1, :-1], z[:-1, 1:], z[1:, :-1], z[1:, 1:]
    lower = dm.hypot((z10 - z00) / dx, (z11 - z10) / dy)
    upper = dm.hypot((z11 - z01) / dx, (z01 - z00) / dy)
    return float(max(lower.max(), upper.max()))


class _Builder(ElementSet):
    """Collects elements with consecutive instance ids; places parts on the terrain."""

    def __init__(self, seed: int, grid: TerrainGrid):
        self.seed = seed
        self.grid = grid
        self.prototypes: dict[str, Prototype] = {}
        self.elements: list[Element] = []

    def ground(self, x, y):
        return height_on_terrain(self.grid, x, y)

    def rng(self, stage: str) -> np.random.Generator:
        return stage_rng(self.seed, f"testworld.{stage}")

    def add(self, stage: str, name: str, wildscan_class: str, mesh: Mesh) -> Element:
        """An element whose prototype is `mesh`, in world metres."""
        el = Element(
            name, wildscan_class, len(self.elements) + 1, TEST_ZONE, stage, self.add_prototype(name, mesh)
        )
        self.elements.append(el)
        return el

    def jittered(self, rng, anchor) -> np.ndarray:
        return np.asarray(anchor, dtype=np.float64) + rng.uniform(-JITTER, JITTER, 2)

    def post(self, x: float, y: float, width: float, height: float, sink: float = 0.1) -> Mesh:
        """A square post from below the lowest ground under it up to `height` above its centre."""
        h = width / 2
        z0 = float(np.min(self.ground(x + np.array([-h, h, -h, h]), y + np.array([-h, -h, h, h])))) - sink
        z1 = self.ground(x, y) + height
        return box((x, y, (z0 + z1) / 2), (width, width, z1 - z0))


def _add_trees(b: _Builder) -> None:
    rng = b.rng("trees")
    for k, (anchor, kind) in enumerate(_TREES, start=1):
        x, y = b.jittered(rng, anchor)
        g = b.ground(x, y)
        r_trunk = rng.uniform(0.15, 0.25)
        if kind == "conifer":
            height = rng.uniform(6.0, 7.5)
            trunk_top = height * 0.7
            crown = cone(rng.uniform(1.4, 1.8), height - 1.5, 14, (x, y, g + 1.5))
        else:
            trunk_top = rng.uniform(2.8, 3.6)
            rc = rng.uniform(1.5, 2.0)
            crown = uv_sphere(rc, 7, 12, (x, y, g + trunk_top + 0.6 * rc))
        trunk = tube([(x, y, g - 0.3), (x, y, g + trunk_top)], r_trunk, 10)
        b.add("trees", f"tree_{k}_trunk", "trunk", trunk)
        b.add("trees", f"tree_{k}_crown", "treetop", crown)


def _lumpy(rng, radii, rings: int, segments: int, roughness: float) -> Mesh:
    """Ellipsoid with smooth-ish radial noise, centred on the origin."""
    v, f = uv_sphere(1.0, rings, segments)
    noise = 1.0 + roughness * rng.uniform(-1.0, 1.0, len(v))
    return v * noise[:, None] * np.asarray(radii), f


def _add_rocks(b: _Builder) -> tuple[np.ndarray, np.ndarray]:
    rng = b.rng("rocks")
    centres, radii = [], []
    for k, (anchor, size) in enumerate(_ROCKS, start=1):
        x, y = b.jittered(rng, anchor)
        sx, sy = size * rng.uniform(0.85, 1.15, 2)
        sz = size * rng.uniform(0.55, 0.75)
        v, f = _lumpy(rng, (sx, sy, sz), 7, 12, 0.1)
        v = rotate_z(v, rng.uniform(0, 2 * np.pi))
        g = b.ground(x, y)
        # sunk by a third of its height so it sits in the ground, not on a point
        b.add("rocks", f"rock_{k}", "rock", (v + [x, y, g + 0.3 * sz], f))
        centres.append((x, y, g))
        radii.append(max(sx, sy))
    return np.asarray(centres), np.asarray(radii)


def _add_furniture(b: _Builder) -> None:
    rng = b.rng("furniture")
    cx, cy = b.jittered(rng, _TABLE)
    yaw = rng.uniform(0, 2 * np.pi)

    def local(dx, dy):
        c, s = dm.cos(yaw), dm.sin(yaw)
        return cx + c * dx - s * dy, cy + s * dx + c * dy

    def furniture(parts_local):
        """Boxes given in the piece's frame (dx, dy, size, z above ground); legs reach the ground."""
        g = b.ground(cx, cy)
        parts = []
        for (dx, dy), size, z in parts_local:
            v, f = box((dx, dy, g + z), size)
            parts.append((rotate_z(v, yaw) + [cx, cy, 0.0], f))
        return parts

    top = furniture([((0.0, 0.0), (1.6, 0.8, 0.05), 0.75)])
    legs = [b.post(*local(sx * 0.72, sy * 0.32), 0.06, 0.75) for sx in (-1, 1) for sy in (-1, 1)]
    b.add("furniture", "table", "table", merge(top + legs))

    seat = furniture([((0.0, -0.85), (1.5, 0.4, 0.05), 0.45), ((0.0, -1.03), (1.5, 0.05, 0.35), 0.72)])
    bench_legs = [
        b.post(*local(sx * 0.65, -0.85 + sy * 0.15), 0.05, 0.45) for sx in (-1, 1) for sy in (-1, 1)
    ]
    back_posts = [b.post(*local(sx * 0.65, -1.03), 0.05, 0.9) for sx in (-1, 1)]
    b.add("furniture", "bench", "bench", merge(seat + bench_legs + back_posts))


def _add_fence(b: _Builder) -> None:
    rng = b.rng("fence")
    p0, p1 = b.jittered(rng, _FENCE[0]), b.jittered(rng, _FENCE[1])
    n_posts = 6
    t = np.linspace(0.0, 1.0, n_posts)
    xy = p0[None, :] + t[:, None] * (p1 - p0)[None, :]
    g = b.ground(xy[:, 0], xy[:, 1])
    parts = [b.post(x, y, 0.1, 1.2) for x, y in xy]
    for h in (0.45, 0.95):
        for k in range(n_posts - 1):
            a = (xy[k, 0], xy[k, 1], g[k] + h)
            c = (xy[k + 1, 0], xy[k + 1, 1], g[k + 1] + h)
            parts.append(beam(a, c, 0.07))
    b.add("fence", "fence", "fence", merge(parts))


def _add_bushes(b: _Builder) -> None:
    rng = b.rng("bushes")
    for k, anchor in enumerate(_BUSHES, start=1):
        x, y = b.jittered(rng, anchor)
        r = rng.uniform(0.5, 0.9)
        v, f = _lumpy(rng, (r, r, 0.7 * r), 6, 10, 0.15)
        b.add("bushes", f"bush_{k}", "bush", (v + [x, y, b.ground(x, y) + 0.45 * r], f))


def _tuft(rng, b: _Builder, x: float, y: float, height: float, width: float, blades: int) -> Mesh:
    """Blades as single triangles fanned around (x, y), rooted just below the ground."""
    ang = rng.uniform(0, 2 * np.pi, blades)
    h = height * rng.uniform(0.7, 1.1, blades)
    lean = h * rng.uniform(0.1, 0.35, blades)
    bx, by = x + 0.03 * dm.cos(ang), y + 0.03 * dm.sin(ang)
    gz = b.ground(bx, by) - 0.02
    px, py = -dm.sin(ang) * width / 2, dm.cos(ang) * width / 2  # across the blade
    v = np.stack(
        [
            np.stack([bx - px, by - py, gz], -1),
            np.stack([bx + px, by + py, gz], -1),
            np.stack([bx + lean * dm.cos(ang), by + lean * dm.sin(ang), gz + h], -1),
        ],
        1,
    ).reshape(-1, 3)
    return v, np.arange(3 * blades, dtype=np.int32).reshape(-1, 3)


def _add_grass(b: _Builder) -> None:
    rng = b.rng("grass")
    kinds = (
        ("low_grass", "low grass", _LOW_GRASS, 0.25, 0.03, 1.2),
        ("high_grass", "high grass", _HIGH_GRASS, 0.9, 0.04, 1.5),
    )
    for prefix, cls, anchors, height, width, radius in kinds:
        for k, anchor in enumerate(anchors, start=1):
            cx, cy = b.jittered(rng, anchor)
            n_tufts = 14
            rr = radius * np.sqrt(rng.uniform(0, 1, n_tufts))
            aa = rng.uniform(0, 2 * np.pi, n_tufts)
            tufts = [
                _tuft(rng, b, cx + r * dm.cos(a), cy + r * dm.sin(a), height, width, 7)
                for r, a in zip(rr, aa)
            ]
            b.add("grass", f"{prefix}_{k}", cls, merge(tufts))


def _wire_path(p0, p1, sag: float) -> np.ndarray:
    """The wire's catenary, its parameter from the parabola approximation a = L^2 / (8 sag)
    (so its lowest point hangs about, not exactly, `sag` below the chord's midpoint)."""
    span = float(dm.hypot(*np.subtract(p1, p0)[:2]))
    return catenary_points(p0, p1, span * span / (8.0 * sag), 48)


def _add_poles_and_wire(b: _Builder) -> None:
    rng = b.rng("wire")
    tops = []
    for k, anchor in enumerate(_POLES, start=1):
        x, y = b.jittered(rng, anchor)
        g = b.ground(x, y)
        height = rng.uniform(5.8, 6.3)
        b.add("wire", f"pole_{k}", "pole", tube([(x, y, g - 0.4), (x, y, g + height)], 0.1, 12))
        tops.append((x, y, g + height - 0.2))
    path = _wire_path(tops[0], tops[1], sag=rng.uniform(0.9, 1.3))
    b.add("wire", "wire", "wire", tube(path, 0.015, 6))


def _add_water(b: _Builder) -> tuple[float, float]:
    """A flat disc inside the depression, just below the lowest ground on its rim so its
    edge is hidden under the terrain."""
    water_radius = 0.95 * POND_RADIUS
    theta = np.linspace(0, 2 * np.pi, 96, endpoint=False)
    rim = b.ground(
        POND_CENTER[0] + water_radius * dm.cos(theta), POND_CENTER[1] + water_radius * dm.sin(theta)
    )
    water_z = float(rim.min()) - 0.05
    b.add("water", "water", "water", disc(water_radius, water_z, POND_CENTER))
    return water_radius, water_z


def plan_test_world(seed: int) -> TestWorldPlan:
    """The test world for `seed`: same seed, identical arrays."""
    seed = int(seed)
    n = int(round(2 * HALF_SIZE / SPACING)) + 1
    xs = np.linspace(-HALF_SIZE, HALF_SIZE, n)
    ys = xs.copy()
    heights = _terrain_heights(seed, xs, ys)
    b = _Builder(seed, TerrainGrid(xs, ys, heights))
    b.add("terrain", "terrain", "terrain", b.grid.mesh())
    water_radius, water_z = _add_water(b)
    _add_trees(b)
    rock_centres, rock_radii = _add_rocks(b)
    _add_furniture(b)
    _add_fence(b)
    _add_bushes(b)
    _add_grass(b)
    _add_poles_and_wire(b)
    poses = {
        "origin": (0.0, 0.0, 0.0),
        "on_water": (POND_CENTER[0], POND_CENTER[1], 0.0),
        "on_rock": (float(rock_centres[0, 0]), float(rock_centres[0, 1]), 0.0),
        "off_world": (100.0, 100.0, 0.0),
    }
    return TestWorldPlan(
        seed=seed,
        xs=xs,
        ys=ys,
        heights=heights,
        pond_center=POND_CENTER,
        pond_radius=POND_RADIUS,
        water_radius=water_radius,
        pond_water_z=water_z,
        rock_positions=rock_centres,
        rock_radii=rock_radii,
        poses=poses,
        prototypes=b.prototypes,
        elements=b.elements,
    )
