"""What covers the endless landscape's ground (numpy only): the sward layer's class and height
per 0.5 m cell (cover.CoverGrid's arrays), and the ground's own material per terrain triangle.

The sward follows land use. Heights (m) and their sources:

  mown lawn     0.03-0.08  clearings and the verges of tracks and paths: amenity grass is mown
                           to 25-50 mm and left to grow a few cm between cuts (RHS, "Lawns:
                           mowing", rhs.org.uk)
  grazed        0.05-0.10  pasture: sward height targets of 4-10 cm for sheep and cattle
                           (AHDB, "Planning grazing strategies for better returns", 2020)
  meadow        0.25-0.5   unmown hay meadow in summer (stages/cover.py: 0.1-0.3 grazed or mown,
                           higher uncut)
  tall sward    0.6-1.0    rank grassland, tall herbs (cover.TYPICAL_HEIGHT high grass 0.8)
  reeds         1.2-1.8    common reed (Phragmites australis) stands 1-3 m tall (USDA Plant
                           Guide, "Common reed")
  undergrowth   0.4-1.0    bramble and bracken under trees (cover.TYPICAL_HEIGHT bush 0.7)
  scrub         0.8-1.5    low shrubs (heath, broom, young thicket)

Ground materials (classes appended after 15, core/classes.py): gravel on tracks, soil on
footpaths, meadows, scrub and clearings, asphalt (`paved`) on paved paths, mud in wet ground
and under water, leaf litter on the forest floor and rock slab on outcrops and in caves.
"""

from __future__ import annotations

import numpy as np

from .. import cover as C
from ..biomes import biome_of
from ..heightfield import TerrainGrid
from . import anchors as A
from . import fields as F
from .raster import Raster

CELL = C.CELL
BARE_SLOPE_TAN = 0.7812856265  # tan 38 deg: steeper ground holds no sward (stages/cover.py)
LAWN, GRAZED, MEADOW, TALL, REEDS, UNDERGROWTH, SCRUB = 0.05, 0.08, 0.35, 0.8, 1.5, 0.7, 1.1
WHEEL_GAUGE = 1.5  # m between a track's wheel tracks (stages/cover.py WHEEL_GAUGE, cited there)
VERGE = 1.5  # m of mown verge beside a track or path

# material by land cover (LAND_COVERS order); the trail's by its kind (anchors.TRAIL_KINDS)
MATERIAL_BY_COVER = ("leaf litter", "soil", "soil", "mud", "rock slab", "soil", "soil")


def cover_cells(land: F.Landscape, r: Raster, fine: TerrainGrid) -> tuple[np.ndarray, np.ndarray]:
    """(class, height) of the tile's sward cells (r: the tile's raster)."""
    x, y, cover = r.x, r.y, r.cover
    biome = biome_of(land.biome)
    patch, tall = land.uniform_patch(x, y, 0), land.uniform_patch(x, y, 1)
    cls = np.zeros(x.shape, dtype=np.uint8)
    height = np.zeros(x.shape, dtype=np.float64)

    def put(mask, c, h):
        cls[mask] = c
        height[mask] = h

    forest, meadow, scrub = cover == F.FOREST, cover == F.MEADOW, cover == F.SCRUB
    put(forest & (tall < 0.3), C.LOW_GRASS, MEADOW * 0.6)  # shade grass
    put(forest & (patch < 0.6 * biome.undergrowth), C.BUSH, UNDERGROWTH)
    put(meadow, C.LOW_GRASS, np.where(patch < 0.35, GRAZED, MEADOW)[meadow])
    put(meadow & (tall > 1.0 - biome.tall_grass), C.HIGH_GRASS, TALL)
    put(meadow & (patch > 1.0 - biome.open_shrub), C.BUSH, SCRUB)
    put(scrub, C.LOW_GRASS, MEADOW * 0.6)
    put(scrub & (patch < 0.65), C.BUSH, SCRUB)
    put(cover == F.WETLAND, C.HIGH_GRASS, REEDS)
    put((cover == F.WETLAND) & (tall < 0.2), C.LOW_GRASS, MEADOW)
    put((cover == F.ROCK) & (patch < 0.25), C.LOW_GRASS, GRAZED)
    put(cover == F.CLEARING, C.LOW_GRASS, LAWN)
    _trails(r, put)
    put(r.water | r.cave | _steep(fine, x, y), 0, 0.0)
    height = height * biome.grass_height * (0.75 + 0.5 * land.uniform_patch(x, y, 2))
    return cls, height.astype(np.float32)


def _trails(r: Raster, put) -> None:
    """A track's median grows short grass between bare wheel tracks; a footpath or a paved path
    is bare; every trail has a mown verge."""
    dist, half = r.trail, r.half_width
    put((dist >= half) & (dist < half + VERGE), C.LOW_GRASS, LAWN)
    tread = dist < half
    put(tread, 0, 0.0)
    wheels = np.abs(dist - WHEEL_GAUGE / 2) < 0.3  # two 0.6 m wheel tracks
    put(tread & (r.kind == 0) & ~wheels, C.LOW_GRASS, GRAZED)  # median and edges


def _steep(grid: TerrainGrid, x, y) -> np.ndarray:
    d = 0.25
    gx = (grid.height_at(x + d, y) - grid.height_at(x - d, y)) / (2 * d)
    gy = (grid.height_at(x, y + d) - grid.height_at(x, y - d)) / (2 * d)
    return gx * gx + gy * gy > BARE_SLOPE_TAN * BARE_SLOPE_TAN


def materials_of(r: Raster, vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The ground material (a class name) of each terrain triangle: its centre's cell's land
    cover's; a trail's tread by its kind; mud under water, rock slab in a cave."""
    t = vertices[faces]
    flat = r.cells(t[:, :, 0].mean(axis=1), t[:, :, 1].mean(axis=1))
    cover = r.at("cover", flat)
    names = np.array(MATERIAL_BY_COVER, dtype=object)[cover]
    kind = r.at("kind", flat)
    on_trail = (cover == F.TRAIL) & (r.at("trail", flat) < r.half_width.reshape(-1).take(flat))
    names[on_trail] = np.array([k[2] for k in A.TRAIL_KINDS], dtype=object)[kind[on_trail]]
    names[r.at("water", flat)] = "mud"
    names[r.at("cave", flat)] = "rock slab"
    return names
