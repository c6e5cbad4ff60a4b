"""A region of the endless landscape as a WorldPlan (numpy only):
`plan_region(seed, biome, detail, vegetation, tiles, levels) -> WorldPlan`.

The tiles are built (build.build_tile, or taken from `tile_source`: the front's cache) and
joined in one fixed order (sorted by tile), so a region's plan is the same whichever order its
tiles were built in. The plan has the shape every later step reads (plan.py): a terrain grid
(the region's bounding rectangle on the full-detail lattice: what elements stand on and the
robot's placement and `hag` measure from), a cover grid stitched from the tiles' cells, the
elements and their meshes, and a layout (EndlessLayout) answering the plan's questions
(water, keep-outs, trails) from the landscape's fields.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ... import detmath as dm
from ..biomes import biome_of
from ..cover import CELL, CoverGrid
from ..detail import detail_level
from ..heightfield import GridError, GridFit, TerrainGrid
from ..plan import Clearance, WorldPlan, ZoneShape, check_seed, check_vegetation, plan_hash
from . import anchors as A
from . import fields as F
from .build import build_tile
from .library import library
from .tile import Tile, lattice
from .tiles import TERRAIN_SPACING, TILE_M, tile_rect

LAYOUT = "endless"


@dataclass(frozen=True)
class EndlessParams:
    """What a region's world.json records of how it was made."""

    layout: str = LAYOUT
    tile_m: float = TILE_M
    anchor_m: float = A.ANCHOR_M
    tiles: list = field(default_factory=list)  # [[i, j, level], ...]


class _Water(ZoneShape):
    def __init__(self, land: F.Landscape):
        self.land = land

    def water_at(self, plan, x, y, margin: float = 0.0):
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        return self.land.anchors.under_water(x, y, plan.ground(x, y) - margin)

    def keep_out(self, plan, x, y, need: Clearance) -> np.ndarray:
        return self.water_at(plan, x, y, need.water_margin)

    def pose_keep_out(self, plan, x, y, allow_pit: bool) -> np.ndarray:
        return self.water_at(plan, x, y, 0.2)

    def features(self, plan) -> dict:
        return {}


class _Trails(ZoneShape):
    def __init__(self, land: F.Landscape, extent):
        self.land, self.extent = land, extent
        x0, x1, y0, y1 = extent
        inside = [t for t in land.anchors.trails_over(x0, x1, y0, y1)]
        self.trails = inside
        longest = max(inside, key=lambda t: len(t.path), default=None)
        self.path = longest.path if longest is not None else np.zeros((2, 2))

    def distance(self, x, y):
        return self.land.anchors.trail_distance(
            np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        )

    def keep_out(self, plan, x, y, need: Clearance) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        a = self.land.anchors
        return a.trail_distance(x, y) < a.trail_half_width(x, y) + need.radius

    def features(self, plan) -> dict:
        return {"trails": len(self.trails)}


class _Caves(ZoneShape):
    def __init__(self, land: F.Landscape):
        self.land = land

    def _inside(self, x, y, grow: float) -> np.ndarray:
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        out = np.zeros(x.shape, dtype=bool)
        if x.size == 0:
            return out
        for c in self.land.anchors.cells_over(
            float(x.min()), float(x.max()), float(y.min()), float(y.max()), 0.5 * A.ANCHOR_M
        ):
            if c.cave is not None:
                p = c.cave.pit
                u, v = p.local(x, y)
                out |= (
                    (u > -p.a - 1.0 - grow) & (u < p.a + c.cave.ramp + grow) & (np.abs(v) < p.b + 1.0 + grow)
                )
        return out

    def keep_out(self, plan, x, y, need: Clearance) -> np.ndarray:
        return self._inside(x, y, need.radius + 0.8)

    def pose_keep_out(self, plan, x, y, allow_pit: bool) -> np.ndarray:
        return np.zeros(np.broadcast(x, y).shape, dtype=bool) if allow_pit else self._inside(x, y, 0.0)

    def features(self, plan) -> dict:
        return {}


# The tallest sward a pose may stand in (m): well below the optical centre (placement.py
# COLUMN_HEIGHT, 0.723 m), so the beams leave the layer near the robot. A robot does not drive
# into a reed bed, a thicket or undergrowth; standing in one, its beams would stop within a
# spinning lidar's minimum range (0.8 m for the OS1-64) and return nothing.
STAND_COVER_MAX = 0.5
# ... nor any within this reach (m) of a laser tip: a beam stopped that near the sensor falls
# inside the minimum range too (the robot itself flattens only cover_cells.TRAMPLED, 0.45 m)
STAND_COVER_REACH = 1.0
# eight directions at half and at the whole reach
_AROUND = [(f * c, f * s) for f in (0.5, 1.0) for s, c in zip(*dm.sincos(np.arange(8) * np.pi / 4))]


class _Thickets(ZoneShape):
    """Where the sward is too tall to stand in (STAND_COVER_MAX, within STAND_COVER_REACH):
    no pose there."""

    def keep_out(self, plan, x, y, need: Clearance) -> np.ndarray:
        return np.zeros(np.broadcast(x, y).shape, dtype=bool)

    def pose_keep_out(self, plan, x, y, allow_pit: bool) -> np.ndarray:
        if plan.cover is None:
            return np.zeros(np.broadcast(x, y).shape, dtype=bool)
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        tall = plan.cover.at(x, y)[1] > STAND_COVER_MAX
        for dx, dy in _AROUND:
            tall |= plan.cover.at(x + STAND_COVER_REACH * dx, y + STAND_COVER_REACH * dy)[1] > STAND_COVER_MAX
        return tall

    def features(self, plan) -> dict:
        return {}


class EndlessLayout:
    """The layout of a region of the endless landscape: the fields and anchors, answering what
    stages/layout.py's Layout answers for the paper's island."""

    endless = True

    def __init__(self, land: F.Landscape, extent, tiles: dict[tuple[int, int], int]):
        self.land, self.extent, self.tiles = land, tuple(float(v) for v in extent), dict(tiles)
        self.cells: dict = {}  # no rectangular zones: land covers (land_cover) instead
        self.lake = _Water(land)
        self.trail = _Trails(land, self.extent)
        self.cave = _Caves(land)
        self.thickets = _Thickets()

    def zone_shapes(self) -> dict[str, ZoneShape]:
        return {"lake": self.lake, "trail": self.trail, "cave": self.cave, "thickets": self.thickets}

    def land_cover(self, x, y) -> np.ndarray:
        return self.land.land_cover(x, y)

    def describe(self, plan: WorldPlan, poses=None) -> dict:
        x0, x1, y0, y1 = self.extent
        t = (np.arange(int((x1 - x0) / 10)) + 0.5) * 10 + x0, (np.arange(int((y1 - y0) / 10)) + 0.5) * 10 + y0
        cover = self.land.land_cover(*np.meshgrid(*t))
        shares = {name: round(float((cover == k).mean()), 4) for k, name in enumerate(F.LAND_COVERS)}
        out = {
            "seed": plan.seed,
            "layout": LAYOUT,
            "detail": plan.detail.name,
            "vegetation": plan.vegetation,
            "biome": plan.biome,
            "extent": {"xmin": x0, "xmax": x1, "ymin": y0, "ymax": y1},
            "tiles": [[i, j, lv] for (i, j), lv in sorted(self.tiles.items())],
            "land_cover": shares,
            "cover": plan.cover_facts(),
            "counts": plan.counts(),
            "hash": plan_hash(plan),
        }
        if poses is not None:
            out["poses"] = poses
        return out


def region_extent(tiles) -> tuple[float, float, float, float]:
    rects = [tile_rect(i, j) for i, j in tiles]
    return (
        min(r[0] for r in rects),
        max(r[1] for r in rects),
        min(r[2] for r in rects),
        max(r[3] for r in rects),
    )


def plan_region(
    seed,
    biome: str,
    detail: str,
    vegetation: str,
    tiles,
    levels: dict[tuple[int, int], int] | None = None,
    tile_source: Callable[[int, int, int], Tile] | None = None,
) -> WorldPlan:
    """The WorldPlan of a set of tiles (a list of (i, j), or {(i, j): level}; `levels`
    overrides; missing levels are 0). `tile_source(i, j, level)` gives a tile (a cache) in
    place of building it here."""
    seed, vegetation = check_seed(seed), check_vegetation(vegetation)
    b = biome_of(biome)
    wanted = (
        {tuple(t): 0 for t in tiles}
        if not isinstance(tiles, dict)
        else {tuple(k): v for k, v in tiles.items()}
    )
    if levels:
        wanted.update({tuple(k): int(v) for k, v in levels.items()})
    if not wanted:
        raise ValueError("plan_region needs at least one tile")
    make = tile_source or (lambda i, j, lv: build_tile(seed, b.name, detail, vegetation, i, j, lv))
    built = [make(i, j, lv) for (i, j), lv in sorted(wanted.items())]
    extent = region_extent(wanted)
    land = F.landscape(seed, b.name)
    params = EndlessParams(tiles=[[i, j, lv] for (i, j), lv in sorted(wanted.items())])
    plan = WorldPlan(seed, detail_level(detail), params, vegetation, b.name)
    plan.extent = extent
    plan.layout = EndlessLayout(land, extent, wanted)
    fine = [fine_grid(land, detail, t) for t in built]
    grid = merge_grids(fine)
    s = TERRAIN_SPACING[detail]
    plan.grid_fit = GridFit(grid, GridError(0.0, 0.0, 0.0, 0), 0.0, 0, s, s)
    lib = library(seed, detail, vegetation)
    used = {el.proto for t in built for el in t.elements}
    plan.prototypes = {k: p for k, p in lib.prototypes.items() if k in used}
    for t in built:
        plan.prototypes.update(t.prototypes)
        plan.elements.extend(t.elements)
    if b.cover:
        plan.cover = merge_covers([tile_cover(t, g) for t, g in zip(built, fine)])
    return plan


def fine_grid(land: F.Landscape, detail: str, tile: Tile) -> TerrainGrid:
    """A tile's terrain on the full-detail lattice (its own, else sampled: a tile from a cache)."""
    if tile.fine is not None:
        return tile.fine
    xs, ys = lattice(tile.i, tile.j, TERRAIN_SPACING[detail])
    return TerrainGrid(xs, ys, land.height(*np.meshgrid(xs, ys)))


def merge_grids(grids: list[TerrainGrid]) -> TerrainGrid:
    """One rectilinear grid over several tiles' grids (each on the same global lattice): their
    nodes where they have them (shared edges hold the same numbers), elsewhere (a corner no
    tile covers) the lowest height of the others, so no NaN reaches a lookup."""
    xs = np.unique(np.concatenate([g.xs for g in grids]))
    ys = np.unique(np.concatenate([g.ys for g in grids]))
    z = np.full((len(ys), len(xs)), np.nan)
    for g in grids:
        a, b = np.searchsorted(xs, g.xs[0]), np.searchsorted(ys, g.ys[0])
        z[b : b + len(g.ys), a : a + len(g.xs)] = g.z
    if np.isnan(z).any():
        z[np.isnan(z)] = np.nanmin(z)
    return TerrainGrid(xs, ys, z)


def merge_covers(covers: list[CoverGrid | None]) -> CoverGrid | None:
    """The cover grid of several tiles (each tile's own, from a plan of that tile alone): their
    cells pasted into one grid over the tiles' bounding rectangle (bare where no tile is), over
    their terrain grids merged (merge_grids). None when the tiles have no cover (biome paper).
    plan_region's cover is this of its tiles', so a region is the same whether planned whole
    or joined from tiles planned one by one."""
    covers = [c for c in covers if c is not None]
    if not covers:
        return None
    cell = covers[0].cell
    x0, y0 = min(c.x0 for c in covers), min(c.y0 for c in covers)
    x1 = max(c.x0 + c.shape[1] * cell for c in covers)
    y1 = max(c.y0 + c.shape[0] * cell for c in covers)
    nx, ny = int(round((x1 - x0) / cell)), int(round((y1 - y0) / cell))
    cls = np.zeros((ny, nx), dtype=np.uint8)
    height = np.zeros((ny, nx), dtype=np.float32)
    for c in covers:
        a, b = int(round((c.x0 - x0) / cell)), int(round((c.y0 - y0) / cell))
        cls[b : b + c.shape[0], a : a + c.shape[1]] = c.class_id
        height[b : b + c.shape[0], a : a + c.shape[1]] = c.height
    grid = merge_grids([TerrainGrid(c.terrain_xs, c.terrain_ys, c.terrain_z) for c in covers])
    return CoverGrid(x0, y0, cell, cls, height, grid.xs, grid.ys, grid.z)


def tile_cover(tile: Tile, fine: TerrainGrid) -> CoverGrid:
    """A tile's own cover grid, over its full-detail terrain."""
    x0, _, y0, _ = tile.rect
    return CoverGrid(x0, y0, CELL, tile.cover_class, tile.cover_height, fine.xs, fine.ys, fine.z)
