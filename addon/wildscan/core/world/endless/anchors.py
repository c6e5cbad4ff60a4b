"""Features that span tiles, each decided from its anchor cell (numpy only).

The plane is cut into ANCHOR_M squares (anchor cells). Cell (ci, cj) draws everything about
itself from its own generator `stage_rng(seed, "endless.anchor.<ci>.<cj>")`: a jittered node
(where trails meet), whether a clearing lies round the node, a lake in one quadrant, a rock
outcrop with a cave in another, and whether a trail leaves the node east and north to the
neighbouring cells' nodes. A power line runs along a row of cells when that row's own
generator says so. Nothing depends on which tile asks, so every tile a lake, a trail, a
power line or a cave crosses agrees on it.
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

    def __init__(self, seed: int, base_height):
        self.seed = int(seed)
        self.base_height = base_height  # the terrain before lakes and caves (their levels)
        self._levels: dict = {}
        self.cell = functools.lru_cache(maxsize=4096)(self._draw)
        self.row_line = functools.lru_cache(maxsize=1024)(self._draw_row)
        self.trails_of = functools.lru_cache(maxsize=4096)(self._trails_of)

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

    def _trails_of(self, ci: int, cj: int) -> tuple[Trail, ...]:
        """The trails leaving cell (ci, cj)'s node east and north."""
        c = self.cell(ci, cj)
        out = []
        ways = ((c.east, (1, 0), c.east_kind, c.bend[0]), (c.north, (0, 1), c.north_kind, c.bend[1]))
        for go, (di, dj), kind, bend in ways:
            if go:
                out.append(Trail(_bent(c.node, self.cell(ci + di, cj + dj).node, bend), kind))
        return tuple(out)

    # -- which cells matter where ---------------------------------------------------------

    def cells_over(self, xmin: float, xmax: float, ymin: float, ymax: float, margin: float = ANCHOR_M):
        """Every cell whose features may reach the rectangle grown by `margin`."""
        i0, i1 = math.floor((xmin - margin) / ANCHOR_M), math.floor((xmax + margin) / ANCHOR_M)
        j0, j1 = math.floor((ymin - margin) / ANCHOR_M), math.floor((ymax + margin) / ANCHOR_M)
        return [self.cell(i, j) for j in range(j0, j1 + 1) for i in range(i0, i1 + 1)]

    def _near(self, x, y, margin: float = 0.5 * ANCHOR_M):
        return self.cells_over(float(np.min(x)), float(np.max(x)), float(np.min(y)), float(np.max(y)), margin)

    def trails_over(self, xmin, xmax, ymin, ymax) -> list[Trail]:
        return [t for c in self.cells_over(xmin, xmax, ymin, ymax) for t in self.trails_of(c.ci, c.cj)]

    def lines_over(self, ymin: float, ymax: float) -> list[float]:
        """The y of every power line within a band of y."""
        j0, j1 = math.floor(ymin / ANCHOR_M), math.floor(ymax / ANCHOR_M)
        return [y for j in range(j0, j1 + 1) if (y := self.row_line(j)) is not None]

    # -- the terrain's features -----------------------------------------------------------

    def level(self, c: Cell, which: str) -> float:
        """The water level of a cell's lake, or the plateau of its cave: the base terrain at
        its centre (kept once asked)."""
        key = (c.ci, c.cj, which)
        if key not in self._levels:
            e = c.lake.basin if which == "lake" else c.cave.pit
            self._levels[key] = float(self.base_height(np.array([e.cx]), np.array([e.cy]))[0])
        return self._levels[key]

    def terrain_features(self, x, y) -> list:
        """The heightfield features (Flatten, Basin, Pit) of the cells near the points."""
        if np.size(x) == 0:
            return []
        out = []
        for c in self._near(x, y):
            if c.clearing:
                ring = Ellipse(c.node[0], c.node[1], c.clearing, c.clearing, 0.0)
                level = float(self.base_height(np.array([c.node[0]]), np.array([c.node[1]]))[0])
                out.append(Flatten(EllipseWindow(ring, 0.8, 1.5), level, 0.6))
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


def _bent(a, b, bend: float, samples: int = 9) -> np.ndarray:
    """A gently bent path from a to b: the chord pushed sideways by `bend` of its length at
    the middle (a sine arch)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    t = np.linspace(0.0, 1.0, samples)
    d = b - a
    normal = np.array([-d[1], d[0]])
    arch = bend * dm.sin(math.pi * t)
    return a[None] + t[:, None] * d[None] + arch[:, None] * normal[None]


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
