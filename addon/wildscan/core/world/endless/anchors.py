"""Features that span tiles, each decided from its anchor cell (numpy only).

The plane is cut into ANCHOR_M squares (anchor cells). Cell (ci, cj) draws everything about
itself from its own generator `stage_rng(seed, "endless.anchor.<ci>.<cj>")`: a jittered node
(where trails meet), whether a clearing lies round the node, a lake in one quadrant, a rock
outcrop with a cave in another, and whether a trail leaves the node east and north to the
neighbouring cells' nodes. A power line runs along a row of cells when that row's own
generator says so. Nothing depends on which tile asks, so every tile a lake, a trail, a
power line or a cave crosses agrees on it.

A trail keeps to land a robot can drive: its drawn bend is kept when the land along it is
nowhere steeper than MAX_TRAIL_SLOPE_DEG (the terrain's slope over SLOPE_SPAN_M, every
SLOPE_STEP_M along it: `steepest_grades`); else it takes the first of a fixed list of other
bends and S-shapes (TRAIL_SHAPES) that is, and where none is the trail is not laid. The
terrain it is measured on (lakes, caves and clearings included, never the trails) is a pure
function of the seed, so this too is decided from the anchor cell alone.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from ... import detmath as dm
from ...rng import stage_rng
from ..heightfield import Basin, Ellipse, EllipseWindow, Flatten, Pit

ANCHOR_M = 300.0  # m, side of an anchor cell
NODE_JITTER = 0.12  # of ANCHOR_M: how far a node lies from its cell's centre
TRAIL_CHANCE = 0.7  # a trail leaves a node east (and, drawn apart, north)
CLEARING_CHANCE = 0.45
LAKE_CHANCE = 0.35
CAVE_CHANCE = 0.3
POWERLINE_CHANCE = 0.3  # a row of cells carries a power line
POLE_SPACING = 40.0  # m between a power line's poles: wooden 11-20 kV lines span 40-80 m
CORRIDOR_HALF = 8.0  # m: trees are cleared this far either side of a power line
# Trail kinds: (name, half width m, ground material). A forest track takes a vehicle (3-4 m
# of gravel), a footpath 1-2 m of soil, a paved path about 2 m of asphalt.
TRAIL_KINDS = (("track", 1.75, "gravel"), ("footpath", 0.75, "soil"), ("paved path", 1.0, "paved"))
TRAIL_WEIGHTS = (0.35, 0.45, 0.2)
LAKE_SHORE = 1.2  # normalised radius within which the lake's water may stand
WET_SHORE = 1.6  # ... and its wet shore reaches
SHORE_RISE = 0.5  # m the flattened shore lies above the water
WET_ABOVE = 0.9  # m above the water the shore is wet (stages/cover.py WET_ABOVE_LAKE)
# The steepest land a trail crosses. The robot's placement refuses a tilt over 25 deg
# (core/placement.py MAX_TILT_DEG), and the terrain's own bumps and the cross slope add a
# few degrees to the field's smooth slope (seed 1 at (170.0, -528.1): a 25.3 deg tilt refused
# where the field's slope was 25.2 deg), so trails keep under 18 deg; forest roads are built
# to grades of 8-12 % with short pitches to 20 % (~11 deg; USDA Forest Service, Low-Volume
# Roads Engineering Best Management Practices, Keller & Sherar 2003, ch. 7), footpaths steeper.
MAX_TRAIL_SLOPE_DEG = 18.0
MAX_TRAIL_GRADE = math.tan(math.radians(MAX_TRAIL_SLOPE_DEG))
SLOPE_STEP_M = 2.0  # m between the slope's samples along a trail
SLOPE_SPAN_M = 0.6  # m: the placement lasers' span (core/placement.py: ARM_X 0.335, ARM_Y 0.27 m each way)
# The other shapes a trail may take, in the order tried: (added to its drawn bend, an S-wiggle),
# both of its length at the arch's top (_bent); sideways at most 0.58 of the length
TRAIL_SHAPES = tuple(
    (bend, wiggle)
    for bend in (0.0, -0.1, 0.1, -0.2, 0.2, -0.3, 0.3)
    for wiggle in (0.0, 0.08, -0.08, 0.16, -0.16)
)[1:]


@dataclass(frozen=True)
class Lake:
    basin: Ellipse
    depth: float


@dataclass(frozen=True)
class Cave:
    pit: Ellipse  # axis along X or Y (angle a multiple of 90 deg), so its roof is a box
    depth: float
    outcrop: float  # m, radius of the rock outcrop round it
    ramp: float = 6.0  # m beyond the pit's end where its ramp reaches the plateau

    @property
    def plateau(self) -> float:
        return self.pit.a + self.ramp + 1.0

    def roof_box(self, level: float) -> tuple[float, float, float, float, float, float]:
        """(xmin, xmax, ymin, ymax, zmin, zmax) of the roof slab over the back of the pit."""
        u0, u1 = -self.pit.a - 1.0, -0.1 * self.pit.a
        v0, v1 = -self.pit.b - 1.0, self.pit.b + 1.0
        corners = [self.pit.to_world(u, v) for u in (u0, u1) for v in (v0, v1)]
        xs, ys = [float(c[0]) for c in corners], [float(c[1]) for c in corners]
        return min(xs), max(xs), min(ys), max(ys), level - 0.1, level + 0.6


@dataclass(frozen=True)
class Trail:
    path: np.ndarray  # (K, 2)
    kind: int  # index into TRAIL_KINDS


@dataclass(frozen=True)
class Cell:
    ci: int
    cj: int
    node: tuple[float, float]
    clearing: float  # m, radius of the clearing round the node (0: none)
    lake: Lake | None
    cave: Cave | None
    east: bool
    north: bool
    east_kind: int
    north_kind: int
    bend: tuple[float, float]  # the east and north trails' sideways bends, of their length


class Anchors:
    """The anchor cells of a seed, drawn on demand and kept (a pure function of the cell)."""

    def __init__(self, seed: int, base_height, height=None):
        self.seed = int(seed)
        self.base_height = base_height  # the terrain before lakes and caves (their levels)
        self.height = height or base_height  # the terrain with them: what a trail's slope is read on
        self._levels: dict = {}
        self.cell = functools.lru_cache(maxsize=4096)(self._draw)
        self.row_line = functools.lru_cache(maxsize=1024)(self._draw_row)
        self.trail_way = functools.lru_cache(maxsize=8192)(self._trail_way)

    # -- drawing --------------------------------------------------------------------------

    def _draw(self, ci: int, cj: int) -> Cell:
        rng = stage_rng(self.seed, f"endless.anchor.{ci}.{cj}")
        cx, cy = (ci + 0.5) * ANCHOR_M, (cj + 0.5) * ANCHOR_M
        j = NODE_JITTER * ANCHOR_M
        node = (cx + rng.uniform(-j, j), cy + rng.uniform(-j, j))
        clearing = rng.uniform(14.0, 24.0) if rng.random() < CLEARING_CHANCE else 0.0
        quadrants = rng.permutation(4)  # the lake and the cave each in their own quadrant
        lake = _lake(rng, cx, cy, int(quadrants[0])) if rng.random() < LAKE_CHANCE else None
        cave = _cave(rng, cx, cy, int(quadrants[1])) if rng.random() < CAVE_CHANCE else None
        east, north = rng.random() < TRAIL_CHANCE, rng.random() < TRAIL_CHANCE
        kinds = rng.choice(len(TRAIL_KINDS), size=2, p=np.array(TRAIL_WEIGHTS))
        bend = (rng.uniform(-0.12, 0.12), rng.uniform(-0.12, 0.12))
        return Cell(ci, cj, node, clearing, lake, cave, east, north, int(kinds[0]), int(kinds[1]), bend)

    def _draw_row(self, cj: int) -> float | None:
        """The y of the power line along row cj of cells, or None."""
        rng = stage_rng(self.seed, f"endless.powerline.{cj}")
        if rng.random() >= POWERLINE_CHANCE:
            return None
        return (cj + rng.uniform(0.25, 0.75)) * ANCHOR_M

    def trails_of(self, ci: int, cj: int) -> tuple[Trail, ...]:
        """The trails leaving cell (ci, cj)'s node east and north (each as gentle as the
        module docstring says, or none)."""
        c = self.cell(ci, cj)
        ways = [self.trail_way(ci, cj, way) for way, go in enumerate((c.east, c.north)) if go]
        return tuple(t for t in ways if t is not None)

    def _trail_way(self, ci: int, cj: int, way: int) -> Trail | None:
        """The trail from cell (ci, cj)'s node east (way 0) or north (1), if it leaves."""
        c = self.cell(ci, cj)
        if not (c.east, c.north)[way]:
            return None
        di, dj = WAYS[way]
        path = self._gentle(c.node, self.cell(ci + di, cj + dj).node, c.bend[way])
        return None if path is None else Trail(path, (c.east_kind, c.north_kind)[way])

    def _gentle(self, a, b, bend: float) -> np.ndarray | None:
        """The drawn bend from a to b if the land along it is gentle enough, else the first
        of TRAIL_SHAPES that is (tried a few at a time), else None."""
        drawn = _bent(a, b, bend)
        if steepest_grades([drawn], self.height)[0] <= MAX_TRAIL_GRADE:
            return drawn
        for k in range(0, len(TRAIL_SHAPES), SHAPES_A_CALL):
            shapes = TRAIL_SHAPES[k : k + SHAPES_A_CALL]
            others = [_bent(a, b, bend + more, wiggle, TURNING_SAMPLES) for more, wiggle in shapes]
            ok = np.flatnonzero(steepest_grades(others, self.height) <= MAX_TRAIL_GRADE)
            if len(ok):
                return others[int(ok[0])]
        return None

    def _may_reach(self, c: Cell, way: int, xmin, xmax, ymin, ymax) -> bool:
        """Whether the trail from cell c east or north, in any shape it may take, can come
        within TRAIL_REACH of the rectangle (so the rest need not be laid to be known)."""
        di, dj = WAYS[way]
        a, b = c.node, self.cell(c.ci + di, c.cj + dj).node
        side = (abs(c.bend[way]) + MAX_SIDEWAYS) * math.hypot(b[0] - a[0], b[1] - a[1]) + TRAIL_REACH
        return (
            min(a[0], b[0]) - side <= xmax
            and max(a[0], b[0]) + side >= xmin
            and min(a[1], b[1]) - side <= ymax
            and max(a[1], b[1]) + side >= ymin
        )

    # -- which cells matter where ---------------------------------------------------------

    def cells_over(self, xmin: float, xmax: float, ymin: float, ymax: float, margin: float = ANCHOR_M):
        """Every cell whose features may reach the rectangle grown by `margin`."""
        i0, i1 = math.floor((xmin - margin) / ANCHOR_M), math.floor((xmax + margin) / ANCHOR_M)
        j0, j1 = math.floor((ymin - margin) / ANCHOR_M), math.floor((ymax + margin) / ANCHOR_M)
        return [self.cell(i, j) for j in range(j0, j1 + 1) for i in range(i0, i1 + 1)]

    def _near(self, x, y, margin: float = 0.5 * ANCHOR_M):
        return self.cells_over(float(np.min(x)), float(np.max(x)), float(np.min(y)), float(np.max(y)), margin)

    def trails_over(self, xmin, xmax, ymin, ymax) -> list[Trail]:
        """Every trail that may come within TRAIL_REACH of the rectangle (and perhaps a few
        more), in the order of their cells, east before north."""
        out = []
        for c in self.cells_over(xmin, xmax, ymin, ymax):
            for way, go in enumerate((c.east, c.north)):
                if go and self._may_reach(c, way, xmin, xmax, ymin, ymax):
                    t = self.trail_way(c.ci, c.cj, way)
                    if t is not None:
                        out.append(t)
        return out

    def lines_over(self, ymin: float, ymax: float) -> list[float]:
        """The y of every power line within a band of y."""
        j0, j1 = math.floor(ymin / ANCHOR_M), math.floor(ymax / ANCHOR_M)
        return [y for j in range(j0, j1 + 1) if (y := self.row_line(j)) is not None]

    # -- the terrain's features -----------------------------------------------------------

    def level(self, c: Cell, which: str) -> float:
        """The water level of a cell's lake, the plateau of its cave, or its clearing's lawn:
        the base terrain at its centre (kept once asked)."""
        key = (c.ci, c.cj, which)
        if key not in self._levels:
            if which == "clearing":
                x, y = c.node
            else:
                e = c.lake.basin if which == "lake" else c.cave.pit
                x, y = e.cx, e.cy
            self._levels[key] = float(self.base_height(np.array([x]), np.array([y]))[0])
        return self._levels[key]

    def terrain_features(self, x, y) -> list:
        """The heightfield features (Flatten, Basin, Pit) of the cells near the points."""
        if np.size(x) == 0:
            return []
        out = []
        for c in self._near(x, y):
            if c.clearing:
                ring = Ellipse(c.node[0], c.node[1], c.clearing, c.clearing, 0.0)
                out.append(Flatten(EllipseWindow(ring, 0.8, 1.5), self.level(c, "clearing"), 0.6))
            if c.lake is not None:
                level = self.level(c, "lake")
                out.append(Flatten(EllipseWindow(c.lake.basin, 1.25, 2.0), level + SHORE_RISE))
                out.append(Basin(c.lake.basin, c.lake.depth, 0.45, 1.15))
            if c.cave is not None:
                level = self.level(c, "cave")
                p = c.cave.pit
                plateau = Ellipse(p.cx, p.cy, c.cave.plateau, c.cave.plateau, 0.0)
                out.append(Flatten(EllipseWindow(plateau, 1.0, 1.6), level))
                out.append(Pit(p, c.cave.depth, 0.55, c.cave.ramp, 1.5, 1.5))
        return out

    # -- land-cover masks -----------------------------------------------------------------

    def under_water(self, x, y, h) -> np.ndarray:
        """Where the ground lies below a lake's water level."""
        out = np.zeros(np.shape(x), dtype=bool)
        for c in self._near(x, y):
            if c.lake is not None:
                out |= (c.lake.basin.radius(x, y) < LAKE_SHORE) & (h < self.level(c, "lake"))
        return out

    def shore(self, x, y, h) -> np.ndarray:
        out = np.zeros(np.shape(x), dtype=bool)
        for c in self._near(x, y):
            if c.lake is not None:
                level = self.level(c, "lake")
                out |= (c.lake.basin.radius(x, y) < WET_SHORE) & (h < level + WET_ABOVE)
        return out

    def in_outcrop(self, x, y) -> np.ndarray:
        out = np.zeros(np.shape(x), dtype=bool)
        for c in self._near(x, y):
            if c.cave is not None:
                p = c.cave.pit
                out |= dm.hypot(x - p.cx, y - p.cy) < c.cave.outcrop
        return out

    def in_clearing(self, x, y) -> np.ndarray:
        out = np.zeros(np.shape(x), dtype=bool)
        for c in self._near(x, y):
            if c.clearing:
                out |= dm.hypot(x - c.node[0], y - c.node[1]) < c.clearing
        return out

    def corridor(self, x, y) -> np.ndarray:
        out = np.zeros(np.shape(x), dtype=bool)
        if np.size(y) == 0:
            return out
        for line in self.lines_over(float(np.min(y)) - CORRIDOR_HALF, float(np.max(y)) + CORRIDOR_HALF):
            out |= np.abs(y - line) < CORRIDOR_HALF
        return out

    def trail_nearest(self, x, y) -> tuple[np.ndarray, np.ndarray]:
        """(distance to the nearest trail, that trail's kind) at points (inf, 0 with none)."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        best = np.full(x.shape, np.inf)
        kind = np.zeros(x.shape, dtype=np.int8)
        if x.size == 0:
            return best, kind
        reach = 5.0  # m: only a trail this near decides anything
        x0, x1, y0, y1 = float(x.min()), float(x.max()), float(y.min()), float(y.max())
        for t in self.trails_over(x0, x1, y0, y1):
            lo, hi = t.path.min(axis=0) - reach, t.path.max(axis=0) + reach
            if lo[0] > x1 or hi[0] < x0 or lo[1] > y1 or hi[1] < y0:
                continue
            d = _polyline_distance(t.path, x, y)
            closer = d < best
            best = np.where(closer, d, best)
            kind = np.where(closer, t.kind, kind).astype(np.int8)
        return best, kind

    def trail_distance(self, x, y) -> np.ndarray:
        return self.trail_nearest(x, y)[0]

    def trail_half_width(self, x, y) -> np.ndarray:
        widths = np.array([k[1] for k in TRAIL_KINDS])
        return widths[self.trail_nearest(x, y)[1]]


def _lake(rng, cx: float, cy: float, quadrant: int) -> Lake:
    sx, sy = (1 if quadrant & 1 else -1), (1 if quadrant & 2 else -1)
    a = rng.uniform(14.0, 32.0)
    b = a * rng.uniform(0.55, 0.9)
    centre = (
        cx + sx * 0.28 * ANCHOR_M + rng.uniform(-10, 10),
        cy + sy * 0.28 * ANCHOR_M + rng.uniform(-10, 10),
    )
    return Lake(Ellipse(centre[0], centre[1], a, b, rng.uniform(0.0, math.pi)), rng.uniform(2.0, 3.5))


def _cave(rng, cx: float, cy: float, quadrant: int) -> Cave:
    sx, sy = (1 if quadrant & 1 else -1), (1 if quadrant & 2 else -1)
    centre = (
        cx + sx * 0.3 * ANCHOR_M + rng.uniform(-10, 10),
        cy + sy * 0.3 * ANCHOR_M + rng.uniform(-10, 10),
    )
    a, b = rng.uniform(6.0, 8.0), rng.uniform(3.5, 4.5)
    angle = 0.5 * math.pi * int(rng.integers(4))
    return Cave(Ellipse(centre[0], centre[1], a, b, angle), rng.uniform(2.5, 3.5), rng.uniform(22.0, 32.0))


WAYS = ((1, 0), (0, 1))  # a trail leaves its node east, or north
TRAIL_REACH = 10.0  # m: trails_over lists every trail within this of its rectangle (trail_nearest asks 5 m)
MAX_SIDEWAYS = max(abs(more) + abs(wiggle) for more, wiggle in TRAIL_SHAPES)  # of the length, past the bend
SHAPES_A_CALL = 6  # shapes tried together (one call of the height: most steep trails pass by the first few)
TURNING_SAMPLES = 13  # points of a trail's polyline that bends round steep land (an S takes more)


def _bent(a, b, bend: float, wiggle: float = 0.0, samples: int = 9) -> np.ndarray:
    """A gently bent path from a to b: the chord pushed sideways by `bend` of its length at
    the middle (a sine arch), and by `wiggle` of it in an S (a full sine)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    t = np.linspace(0.0, 1.0, samples)
    d = b - a
    normal = np.array([-d[1], d[0]])
    arch = bend * dm.sin(math.pi * t)
    if wiggle:
        arch = arch + wiggle * dm.sin(2.0 * math.pi * t)
    return a[None] + t[:, None] * d[None] + arch[:, None] * normal[None]


def along(path: np.ndarray, step: float) -> np.ndarray:
    """Points of the polyline at most `step` apart, its vertices included."""
    out = [path[:1]]
    for a, b in zip(path[:-1], path[1:]):
        count = max(1, int(np.ceil(float(np.hypot(*(b - a))) / step)))
        out.append(a + np.outer(np.arange(1, count + 1) / count, b - a))
    return np.concatenate(out)


def steepest_grades(paths, height) -> np.ndarray:
    """(len(paths),) the steepest grade (rise over run) of the land `height(x, y)` along each
    polyline: the slope over SLOPE_SPAN_M (central differences along x and y), every
    SLOPE_STEP_M of it (`along`). All paths' samples in one call of `height`."""
    points = [along(np.asarray(p, dtype=np.float64), SLOPE_STEP_M) for p in paths]
    xy = np.concatenate(points)
    n, h = len(xy), SLOPE_SPAN_M / 2
    x, y = xy[:, 0], xy[:, 1]
    z = height(np.concatenate([x + h, x - h, x, x]), np.concatenate([y, y, y + h, y - h]))
    gx, gy = (z[:n] - z[n : 2 * n]) / SLOPE_SPAN_M, (z[2 * n : 3 * n] - z[3 * n :]) / SLOPE_SPAN_M
    grade = np.sqrt(gx * gx + gy * gy)
    ends = np.cumsum([len(p) for p in points])
    return np.array([grade[e - len(p) : e].max() for p, e in zip(points, ends)])


def _polyline_distance(path: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Distance from points to a polyline, segment by segment (few segments, many points)."""
    best = np.full(x.shape, np.inf)
    for (ax, ay), (bx, by) in zip(path[:-1], path[1:]):
        dx, dy = bx - ax, by - ay
        length2 = max(dx * dx + dy * dy, 1e-12)
        t = np.clip(((x - ax) * dx + (y - ay) * dy) / length2, 0.0, 1.0)
        gx, gy = x - (ax + t * dx), y - (ay + t * dy)
        best = np.minimum(best, gx * gx + gy * gy)
    return np.sqrt(best)
