"""Stage "terrain": the analytic height field, the grid that approximates it, and the hills.

Fractal noise, the hills' bumps, then each zone's shape on the terrain (the
park's plateau, the lake's basin, the cave's plateau and pit), scaled to at most
MAX_RELIEF; the terrain mesh is the adaptive grid that stays within the detail
level's tolerance of it (terrain_grid.fit_grid, its own stream "world.terrain.error"). Where
the biome covers the ground, the grid's triangles that are the cave's rock faces (its steep
walls: cave.Cave.rock_faces) are an element of their own, class rock; the rest is terrain.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...rng import stage_rng
from ..biomes import biome_of
from ..geometry2d import Rect, inset
from ..heightfield import Bumps, FractalNoise, Heightfield, RectWindow
from ..plan import EXTENT, HALF, MAX_RELIEF, WORLD_ZONE, WorldPlan
from ..shapes.primitives import faces_subset
from ..terrain_grid import fit_grid
from . import cave, lake, park

STAGE = "terrain"

Bump = tuple[float, float, float, float]  # cx, cy, height, sigma


@dataclass(frozen=True)
class TerrainParams:
    wavelength: float = 55.0  # m, largest noise feature
    octaves: int = 4  # the finest octave is wavelength / 8 (~7 m)
    amplitude: float = 2.5  # m
    hill_height: tuple[float, float] = (5.0, 11.0)


def draw_hills(rng: np.random.Generator, cell: Rect, hill_height: tuple[float, float]) -> list[Bump]:
    """Three to five gaussian hills in the hills' cell (drawn during the layout stage)."""
    bumps = []
    for _ in range(int(rng.integers(3, 6))):
        sigma = rng.uniform(6.0, 10.0)
        hx0, hx1, hy0, hy1 = inset(cell, 1.6 * sigma)  # whole hills, not cut by the zone's edge
        bumps.append((rng.uniform(hx0, hx1), rng.uniform(hy0, hy1), rng.uniform(*hill_height), sigma))
    return bumps


def hills(bumps: list[Bump], cell: Rect) -> Bumps:
    x0, x1, y0, y1 = cell
    return Bumps(
        tuple((b[0], b[1]) for b in bumps),
        tuple(b[2] for b in bumps),
        tuple(b[3] for b in bumps),
        RectWindow(x0, x1, y0, y1, 10.0),
    )


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    p, lay = plan.params.terrain, plan.layout
    hf = Heightfield(FractalNoise(rng, p.wavelength, p.octaves), p.amplitude)
    hf.features.append(hills(lay.bumps, lay.cells["hills"]))
    # in this order: each plateau is flattened to the mean height of what is there before it
    park.shape_terrain(hf, lay.park, lay.cells["park"])
    lake.shape_terrain(hf, lay.lake, lay.cells["lake"])
    cave_level_raw = cave.shape_terrain(hf, lay.cave, lay.cells["cave"])
    _lower_hills_to_relief(hf)
    hf.normalise(EXTENT, MAX_RELIEF)
    plan.heightfield = hf
    plan.cave_level = hf.scale * (cave_level_raw - hf.offset)
    plan.grid_fit = fit_grid(
        hf, EXTENT, plan.detail.terrain_tolerance, stage_rng(plan.seed, "world.terrain.error")
    )
    plan.water_z = lake.water_level(plan, lay.lake)
    mesh, counter = plan.grid.mesh(), {}
    rock = lay.cave.rock_faces(*mesh) if biome_of(plan.biome).cover else None
    plan.add_prototype("terrain", mesh if rock is None else faces_subset(mesh, ~rock))
    plan.add_element(STAGE, WORLD_ZONE, "terrain", "terrain", counter, radius=HALF)
    if rock is not None:  # the cave's rock faces: one element of the same mesh's triangles
        plan.add_prototype("cave_rock_faces", faces_subset(mesh, rock))
        plan.add_element(STAGE, "cave", "rock", "cave_rock_faces", counter, name="faces", radius=0.0)


def _lower_hills_to_relief(hf: Heightfield) -> None:
    """The hills give way when the world would exceed its relief (the pit and basin keep
    their depth)."""
    for _ in range(20):
        if hf.relief(EXTENT) <= MAX_RELIEF - 0.5:
            break
        hf.features[0] = replace(hf.features[0], gain=hf.features[0].gain * 0.93)
