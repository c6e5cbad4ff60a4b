"""One tile's content as plain data (numpy only): `Tile`, its instance ids and its lattice.

build.py fills a Tile in; scatter.py, clearing.py and powerline.py add their elements to it.
Instance ids come from the tile's own block (instance_base), so no tile's ids depend on
another's, or on the order of builds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import detmath as dm
from ..elements import Element, Prototype
from ..heightfield import TerrainGrid
from .tiles import MAX_TILE_INDEX, TILE_M, tile_rect

TILE_BLOCK = 8_192  # instance ids a tile may hand out
INSTANCE_BASE = 1_000_000  # above the cover layer's (cover.COVER_INSTANCE_BASE: 900,000)


@dataclass
class Tile:
    i: int
    j: int
    level: int
    grid: TerrainGrid  # the terrain lattice at this tile's level
    cover_class: np.ndarray  # (n, n) uint8 at COVER_CELL
    cover_height: np.ndarray  # (n, n) float32
    prototypes: dict[str, Prototype] = field(default_factory=dict)  # this tile's own meshes
    elements: list[Element] = field(default_factory=list)
    counter: int = 0
    fine: TerrainGrid | None = None  # the terrain on the full-detail lattice (whatever the level)
    raster: object = None  # raster.Raster: the land on the tile's 0.5 m cells, while it is built

    @property
    def rect(self):
        return tile_rect(self.i, self.j)

    def add(self, cover: str, wildscan_class: str, proto: str, **kw) -> Element:
        if self.counter >= TILE_BLOCK - 1:
            raise RuntimeError(f"tile ({self.i}, {self.j}) holds more than {TILE_BLOCK - 1} elements")
        self.counter += 1
        k = self.counter
        name = f"{cover}.{wildscan_class.replace(' ', '_')}.t{self.i}_{self.j}.{k:05d}"
        el = Element(name, wildscan_class, instance_base(self.i, self.j) + k, cover, "endless", proto, **kw)
        self.elements.append(el)
        return el

    def own(self, key: str, mesh) -> str:
        key = f"t{self.i}_{self.j}.{key}"
        self.prototypes[key] = Prototype(
            key, np.asarray(mesh[0], dtype=np.float64), np.asarray(mesh[1], dtype=np.int32)
        )
        return key


def instance_base(i: int, j: int) -> int:
    """The first instance id of tile (i, j)'s block (ids base+1 .. base+TILE_BLOCK-1)."""
    span = 2 * MAX_TILE_INDEX + 1
    return INSTANCE_BASE + ((i + MAX_TILE_INDEX) * span + (j + MAX_TILE_INDEX)) * TILE_BLOCK


def lattice(i: int, j: int, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """The tile's lattice lines: i TILE_M + k spacing, exact (whole multiples of binary
    fractions), so two tiles compute the very same numbers on their shared edge."""
    n = int(round(TILE_M / spacing))
    k = np.arange(n + 1, dtype=np.float64)
    return i * TILE_M + k * spacing, j * TILE_M + k * spacing


_RIM = dm.sincos(np.linspace(0, 2 * np.pi, 6, endpoint=False))  # (sin, cos) of six directions


def ground_under(grid: TerrainGrid, x, y, radius) -> np.ndarray:
    """The lowest height of the tile's mesh under discs (plan.WorldPlan.ground_under), at
    arrays of centres and radii."""
    x, y, radius = (np.asarray(v, dtype=np.float64) for v in (x, y, radius))
    zs = [grid.height_at(x, y)] + [grid.height_at(x + radius * c, y + radius * s) for s, c in zip(*_RIM)]
    return np.min(zs, axis=0)
