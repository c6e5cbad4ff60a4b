"""One tile of the endless landscape as plain data: `build_tile(...) -> Tile` (numpy only).

A tile's content is a pure function of (seed, biome, detail, vegetation, i, j, level): the
terrain sampled on the global lattice (tiles.py) with a skirt round its edge, split by
ground material; its cover grid (0.5 m cells); water over its lakes; and its elements,
scattered by generators seeded from (seed, family, i, j) (`stage_rng`), or taken from the
features of the anchor cells (anchors.py) that lie in it: clearings, power lines, cave roofs.
"""

from __future__ import annotations

import numpy as np

from ..biomes import biome_of
from ..heightfield import TerrainGrid
from ..shapes.primitives import box, faces_subset, grid_heightfield
from . import anchors as A
from . import fields as F
from .clearing import add_clearings
from .ground import cover_cells, materials_of
from .library import library
from .powerline import add_powerline
from .raster import tile_raster
from .scatter import scatter_elements
from .tile import Tile, lattice
from .tiles import LEVEL_FACTORS, TERRAIN_SPACING, TILE_M, check_tile, tile_rect

SKIRT_DEPTH = 0.6  # m a tile's skirt hangs below its edge: more than any level's lattice error
WATER_CELL = 2.0  # m, the water surface's quads
COVER_CELL = 0.5  # m (cover.CELL)


def build_tile(seed: int, biome: str, detail: str, vegetation: str, i: int, j: int, level: int = 0) -> Tile:
    """Tile (i, j) at `level` (module docstring). The terrain is sampled on the full-detail
    lattice; a coarser level's mesh takes every LEVEL_FACTORS[level]-th node of it (the same
    numbers a coarser lattice would compute: its nodes are the same points)."""
    check_tile(i, j)
    land = F.landscape(seed, biome)
    xs, ys = lattice(i, j, TERRAIN_SPACING[detail])
    fine = TerrainGrid(xs, ys, land.height(*np.meshgrid(xs, ys)))
    step = LEVEL_FACTORS[level]
    grid = TerrainGrid(xs[::step], ys[::step], fine.z[::step, ::step])
    x0, _, y0, _ = tile_rect(i, j)
    raster = tile_raster(land, x0, y0, TILE_M, fine)
    cls, height = cover_cells(land, raster, fine) if biome_of(biome).cover else _bare_cover()
    tile = Tile(i, j, level, grid, cls, height, fine=fine, raster=raster)
    _terrain(tile)
    _water(tile, land)
    lib = library(seed, detail, vegetation)
    scatter_elements(tile, land, lib, level, vegetation)
    add_clearings(tile, land, lib)
    add_powerline(tile, land, lib, detail)
    _cave_roofs(tile, land)
    return tile


def _bare_cover():
    n = int(round(TILE_M / COVER_CELL))
    return np.zeros((n, n), dtype=np.uint8), np.zeros((n, n), dtype=np.float32)


def _terrain(tile: Tile) -> None:
    """The lattice's triangles and a skirt round the tile, one element per ground material."""
    g = tile.grid
    v, f = grid_heightfield(g.xs, g.ys, g.z)
    sv, sf = _skirt(g)
    v, f = np.concatenate([v, sv]), np.concatenate([f, sf + len(v)])
    material = materials_of(tile.raster, v, f)
    for name in sorted(set(material.tolist())):
        mesh = faces_subset((v, f), material == name)
        key = tile.own(f"ground.{name.replace(' ', '_')}", mesh)
        tile.add("ground", name, key, radius=0.0)


def _skirt(g: TerrainGrid) -> tuple[np.ndarray, np.ndarray]:
    """A vertical strip SKIRT_DEPTH deep under each edge of the tile (facing out), so where a
    neighbour at another level meets this one with a slightly different edge, no beam passes
    between them. Its vertices are the edge's own, and copies lowered."""
    ny, nx = g.z.shape
    rings = [
        [(k, 0) for k in range(nx)],  # south edge, west to east
        [(nx - 1, k) for k in range(ny)],  # east edge, south to north
        [(k, ny - 1) for k in range(nx - 1, -1, -1)],  # north edge, east to west
        [(0, k) for k in range(ny - 1, -1, -1)],  # west edge, north to south
    ]
    verts, faces = [], []
    n = 0
    for ring in rings:
        top = np.array([[g.xs[a], g.ys[b], g.z[b, a]] for a, b in ring])
        bottom = top - [0.0, 0.0, SKIRT_DEPTH]
        m = len(top)
        k = np.arange(m - 1)
        # counter-clockwise round the tile: outward faces wind (top k, bottom k, bottom k+1)
        faces.append(np.stack([n + k, n + m + k, n + m + k + 1], -1))
        faces.append(np.stack([n + k, n + m + k + 1, n + k + 1], -1))
        verts += [top, bottom]
        n += 2 * m
    return np.concatenate(verts), np.concatenate(faces).astype(np.int32)


def _water(tile: Tile, land: F.Landscape) -> None:
    """Quads at each lake's level over the cells whose centre lies within its shore."""
    x0, x1, y0, y1 = tile.rect
    for c in land.anchors.cells_over(x0, x1, y0, y1, 0.5 * A.ANCHOR_M):
        if c.lake is None:
            continue
        e = c.lake.basin
        reach = A.LAKE_SHORE * max(e.a, e.b)
        if e.cx + reach < x0 or e.cx - reach > x1 or e.cy + reach < y0 or e.cy - reach > y1:
            continue
        n = int(round(TILE_M / WATER_CELL))
        centres = x0 + (np.arange(n) + 0.5) * WATER_CELL, y0 + (np.arange(n) + 0.5) * WATER_CELL
        gx, gy = np.meshgrid(*centres)
        inside = e.radius(gx, gy) < A.LAKE_SHORE
        if not inside.any():
            continue
        level = land.anchors.level(c, "lake")
        xs = x0 + np.arange(n + 1) * WATER_CELL
        ys = y0 + np.arange(n + 1) * WATER_CELL
        v, f = grid_heightfield(xs, ys, np.full((n + 1, n + 1), level))
        keep = np.concatenate([inside.reshape(-1), inside.reshape(-1)])
        key = tile.own(f"water{c.ci}_{c.cj}", faces_subset((v, f), keep))
        tile.add("wetland", "water", key, radius=0.0)


def _cave_roofs(tile: Tile, land: F.Landscape) -> None:
    """Each cave's roof slab (rock), cut to the tile: every tile under it builds its part."""
    x0, x1, y0, y1 = tile.rect
    for c in land.anchors.cells_over(x0, x1, y0, y1, 0.5 * A.ANCHOR_M):
        if c.cave is None:
            continue
        bx0, bx1, by0, by1, z0, z1 = c.cave.roof_box(land.anchors.level(c, "cave"))
        cx0, cx1, cy0, cy1 = max(bx0, x0), min(bx1, x1), max(by0, y0), min(by1, y1)
        if cx0 >= cx1 or cy0 >= cy1:
            continue
        centre = ((cx0 + cx1) / 2, (cy0 + cy1) / 2, (z0 + z1) / 2)
        key = tile.own(f"cave_roof{c.ci}_{c.cj}", box(centre, (cx1 - cx0, cy1 - cy0, z1 - z0)))
        tile.add("rock", "rock", key, radius=0.0)
