"""Stage "layout": where the six zones lie, and the shape each zone's stage draws for it.

The 150 m square is cut into a 3x2 or 2x3 grid of cells with jittered
boundaries and the zones are shuffled over the cells; then, in this order (the
order of this stage's draws), the hills' bumps (terrain), the power-line route
(powerline), the park's fenced area (park), the lake (lake), the cave (cave)
and the trail (trail). Each zone's module draws its own shape.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry2d import Rect
from ..plan import HALF, ZONES, WorldPlan, ZoneShape
from . import cave, lake, park, powerline, terrain, trail
from .cave import Cave
from .lake import Lake
from .park import Park
from .powerline import PowerLine
from .terrain import Bump
from .trail import Trail

STAGE = "layout"


@dataclass(frozen=True)
class LayoutParams:
    boundary_jitter: float = 5.0
    pole_spacing: float = 17.0


@dataclass
class Layout:
    cells: dict[str, Rect]
    grid_shape: tuple[int, int]
    bumps: list[Bump]  # the hills (raised by the terrain stage)
    powerline: PowerLine  # over the hills
    park: Park
    lake: Lake
    cave: Cave
    trail: Trail

    def zone_shapes(self) -> dict[str, ZoneShape]:
        """Each zone's shape by zone (the forest has none: it holds only elements)."""
        return {
            "hills": self.powerline,
            "park": self.park,
            "lake": self.lake,
            "cave": self.cave,
            "trail": self.trail,
        }


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.layout
    cols, rows = (3, 2) if rng.random() < 0.5 else (2, 3)
    cells = _zone_cells(rng, cols, rows, p.boundary_jitter)
    # one statement per draw, so the order of the draws is plain to see
    hills = terrain.draw_hills(rng, cells["hills"], plan.params.terrain.hill_height)
    line = powerline.draw(rng, cells["hills"], p.pole_spacing)
    fenced = park.draw(rng, cells["park"])
    water = lake.draw(rng, cells["lake"])
    pit = cave.draw(rng, cells["cave"])
    path = trail.draw(rng, cells["trail"])
    plan.layout = Layout(cells, (cols, rows), hills, line, fenced, water, pit, path)


def _zone_cells(rng: np.random.Generator, cols: int, rows: int, jitter: float) -> dict[str, Rect]:
    def bounds(n):
        b = np.linspace(-HALF, HALF, n + 1)
        b[1:-1] += rng.uniform(-jitter, jitter, n - 1)
        return b

    xb, yb = bounds(cols), bounds(rows)
    cells = [(xb[i], xb[i + 1], yb[j], yb[j + 1]) for j in range(rows) for i in range(cols)]
    order = rng.permutation(len(ZONES))
    return {ZONES[k]: tuple(float(v) for v in cells[order[k]]) for k in range(len(ZONES))}
