"""The endless landscape (layout "endless"): a world that is a pure function of (seed, biome,
position), built in square tiles on demand (numpy only).

    fields.py     the continuous fields: terrain height, land cover (LAND_COVERS), their shares
    anchors.py    features that span tiles, decided from their anchor cell: lakes, clearings,
                  outcrops with caves, the trail network, power lines
    ground.py     the sward layer's class and height per cell, the ground's material per triangle
    library.py    the meshes every tile shares (trees, bushes, rocks, tufts, furniture, pole)
    scatter.py    the elements a tile scatters over its land covers
    clearing.py   park furniture in the clearings
    powerline.py  poles and wires, cut at the tiles' edges
    build.py      one tile: build_tile(seed, biome, detail, vegetation, i, j, level) -> Tile
    tiles.py      the tile grid, the level of detail, tile_levels(device, x, y, lod)
    region.py     plan_region(seed, biome, detail, vegetation, tiles, levels) -> WorldPlan

docs/landscape.md describes the model, its sources, the tile size and the LOD rules.
"""

from .anchors import ANCHOR_M, TRAIL_KINDS
from .build import build_tile
from .fields import BIOME_SHARES, LAND_COVERS, height_at, land_cover_at, landscape, trail_network
from .region import LAYOUT, EndlessLayout, merge_covers, merge_grids, plan_region, region_extent
from .tile import Tile, instance_base
from .tiles import (
    LEVEL_FACTORS,
    LOD_CHOICES,
    TERRAIN_SPACING,
    TILE_M,
    beam_spacing_rad,
    level_at,
    tile_distance,
    tile_levels,
    tile_of,
    tile_rect,
    tiles_in_disc,
    tiles_in_region,
)

__all__ = [
    "ANCHOR_M",
    "BIOME_SHARES",
    "LAND_COVERS",
    "LAYOUT",
    "LEVEL_FACTORS",
    "LOD_CHOICES",
    "TERRAIN_SPACING",
    "TILE_M",
    "TRAIL_KINDS",
    "EndlessLayout",
    "Tile",
    "beam_spacing_rad",
    "build_tile",
    "height_at",
    "instance_base",
    "land_cover_at",
    "landscape",
    "level_at",
    "merge_covers",
    "merge_grids",
    "plan_region",
    "region_extent",
    "tile_distance",
    "tile_levels",
    "tile_of",
    "tile_rect",
    "tiles_in_disc",
    "tiles_in_region",
    "trail_network",
]
