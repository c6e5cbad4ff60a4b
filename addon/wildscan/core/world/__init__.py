"""The whole natural world as plain data: `plan_world(seed, detail) -> WorldPlan` (numpy only).

A 150 m x 150 m world centred on the origin with six zones (hills, forest,
park, lake, cave, trail) laid out on a seeded 3x2 or 2x3 grid of cells, a
terrain of at most 20 m relief, and every element of the paper's Table I
placed on it. Blender only realises the plan (blender/builder.py); the aerial
map, pose lists and fast ray casting read it directly.

    pipeline.py     plan_world: the stages in order, WorldParams
    plan.py         WorldPlan (what the stages fill in and the queries they share), Site, plan_hash
    stages/         one module per stage: layout, terrain, poses, lake, cave, trail, park,
                    powerline, trees, bushes, rocks, grass, deadwood, cover
    biomes.py       the biomes: how each changes the mix (paper: the world from before biomes)
    cover.py        the ground cover's grid (the sward layer a beam enters)
    shapes/         the meshes, one module per family (primitives, trees, plants, rocks,
                    furniture, powerline)
    elements.py     Element and Prototype, shared by both worlds
    heightfield.py  the analytic terrain h(x, y)
    terrain_grid.py the adaptive grid approximating it (the terrain mesh)
    detail.py       detail levels
    geometry2d.py   polylines, rectangles, scattering
    testworld.py    the small fixed test world
"""

from .biomes import BIOMES, DEFAULT_BIOME, check_biome
from .detail import DETAILS, DetailLevel, detail_level, model_errors
from .elements import Element, Prototype
from .pipeline import STAGES, WorldParams, plan_world
from .plan import (
    DEFAULT_VEGETATION,
    ELEMENT_STAGES,
    EXTENT,
    HALF,
    MAX_RELIEF,
    MAX_SEED,
    SITE_CLEARANCE,
    STAGE_INSTANCE_BASE,
    STAGE_INSTANCE_BLOCK,
    VEGETATION,
    WORLD_ZONE,
    ZONES,
    Clearance,
    Site,
    WorldPlan,
    check_seed,
    check_vegetation,
    check_zone,
    plan_hash,
)
from .stages.bushes import BushParams
from .stages.grass import GrassParams
from .stages.layout import Layout, LayoutParams
from .stages.park import ParkParams
from .stages.poses import candidate_sites, footprint_ok
from .stages.powerline import PowerlineParams
from .stages.rocks import RockParams
from .stages.terrain import TerrainParams
from .stages.trail import TrailParams
from .stages.trees import TreeParams

__all__ = [
    "BIOMES",
    "DEFAULT_BIOME",
    "check_biome",
    "DEFAULT_VEGETATION",
    "DETAILS",
    "ELEMENT_STAGES",
    "EXTENT",
    "HALF",
    "MAX_RELIEF",
    "MAX_SEED",
    "SITE_CLEARANCE",
    "STAGES",
    "STAGE_INSTANCE_BASE",
    "STAGE_INSTANCE_BLOCK",
    "VEGETATION",
    "WORLD_ZONE",
    "ZONES",
    "BushParams",
    "Clearance",
    "DetailLevel",
    "Element",
    "GrassParams",
    "Layout",
    "LayoutParams",
    "ParkParams",
    "PowerlineParams",
    "Prototype",
    "RockParams",
    "Site",
    "TerrainParams",
    "TrailParams",
    "TreeParams",
    "WorldParams",
    "WorldPlan",
    "candidate_sites",
    "check_seed",
    "check_vegetation",
    "check_zone",
    "detail_level",
    "footprint_ok",
    "model_errors",
    "plan_hash",
    "plan_world",
]
