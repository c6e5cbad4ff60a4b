"""A tile's land, once, on its 0.5 m cells (numpy only): what every later step of a tile's build
asks of the landscape (land cover, trails, water, caves, clearings, power lines), evaluated at
the cells' centres over the tile's full-detail terrain, then looked up by cell.

So the fields and anchors are read once per cell, not once per question; and, being made from
the full-detail lattice whatever the tile's level, a tile's cover and materials are the same at
every level of detail.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..heightfield import TerrainGrid
from . import anchors as A
from . import fields as F

CELL = 0.5  # m (cover.CELL)
CAVE_KEEP = 2.0  # m round a cave's pit, ramp and roof where no element stands


@dataclass
class Raster:
    x0: float
    y0: float
    n: int
    x: np.ndarray  # (n, n) cell centres
    y: np.ndarray
    ground: np.ndarray  # the full-detail terrain at the centres
    cover: np.ndarray  # uint8 LAND_COVERS codes
    trail: np.ndarray  # m to the nearest trail's centre line
    kind: np.ndarray  # that trail's kind (anchors.TRAIL_KINDS)
    water: np.ndarray  # the ground lies under a lake's water
    damp: np.ndarray  # ... or less than 0.15 m above it
    cave: np.ndarray  # the cave itself: pit, ramp (bare rock)
    cave_keep: np.ndarray  # the cave and CAVE_KEEP round it and its roof
    clearing: np.ndarray
    corridor: np.ndarray  # under a power line (trees cleared)
    line: np.ndarray  # within 1.5 m of a power line's axis (its poles)

    @property
    def half_width(self) -> np.ndarray:
        return np.array([k[1] for k in A.TRAIL_KINDS])[self.kind]

    def cells(self, x, y) -> np.ndarray:
        """The flat index of the cell holding each point (points on the tile's far edges: the
        last cell)."""
        i = np.clip(np.floor((np.asarray(x) - self.x0) / CELL).astype(np.int64), 0, self.n - 1)
        j = np.clip(np.floor((np.asarray(y) - self.y0) / CELL).astype(np.int64), 0, self.n - 1)
        return j * self.n + i

    def at(self, name: str, flat: np.ndarray) -> np.ndarray:
        return getattr(self, name).reshape(-1).take(flat)


def tile_raster(land: F.Landscape, x0: float, y0: float, size: float, fine: TerrainGrid) -> Raster:
    n = int(round(size / CELL))
    k = (np.arange(n, dtype=np.float64) + 0.5) * CELL
    x, y = np.meshgrid(x0 + k, y0 + k)
    ground = fine.height_at(x, y)
    a = land.anchors
    trail, kind = a.trail_nearest(x, y)
    cave, keep = _caves(land, x, y)
    lines = a.lines_over(y0 - 2.0, y0 + size + 2.0)
    line = np.zeros(x.shape, dtype=bool)
    for y_line in lines:
        line |= np.abs(y - y_line) < 1.5
    return Raster(
        x0=x0,
        y0=y0,
        n=n,
        x=x,
        y=y,
        ground=ground,
        cover=land.land_cover(x, y, ground, trail=(trail, kind)),
        trail=trail,
        kind=kind,
        water=a.under_water(x, y, ground),
        damp=a.under_water(x, y, ground - 0.15),
        cave=cave,
        cave_keep=keep,
        clearing=a.in_clearing(x, y),
        corridor=a.corridor(x, y),
        line=line,
    )


def _caves(land: F.Landscape, x, y) -> tuple[np.ndarray, np.ndarray]:
    bare = np.zeros(x.shape, dtype=bool)
    keep = np.zeros(x.shape, dtype=bool)
    box = (float(x.min()), float(x.max()), float(y.min()), float(y.max()))
    for c in land.anchors.cells_over(*box, 0.5 * A.ANCHOR_M):
        if c.cave is None:
            continue
        p = c.cave.pit
        u, v = p.local(x, y)
        radius = p.radius(x, y)
        bare |= (radius < 1.15) | ((u > 0) & (u < p.a + c.cave.ramp) & (np.abs(v) < 3.0))
        keep |= (radius < 1.4) | (
            (u > -p.a - 1.0 - CAVE_KEEP) & (u < p.a + c.cave.ramp + 1.0) & (np.abs(v) < p.b + 1.0 + CAVE_KEEP)
        )
    return bare, keep
