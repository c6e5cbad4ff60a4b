"""The stage pipeline: `plan_world(seed, detail) -> WorldPlan`, and WorldParams (numpy only).

Stages and determinism
----------------------
Each stage draws from its own generator `stage_rng(seed, "world.<stage>")`:

    layout -> terrain -> poses -> trail, lake, cave, trees, bushes, rocks, grass, park, powerline,
              deadwood -> cover

The element stages read only what comes before them in that chain (the
layout, the terrain and the reserved pose sites), never each other, so changing
one element stage's parameters leaves every other stage's geometry and tags
exactly as they were. Instance ids are allocated in blocks per stage
(plan.STAGE_INSTANCE_BASE) for the same reason.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Callable

from ..rng import stage_rng
from .biomes import DEFAULT_BIOME, biome_of, biome_params
from .detail import detail_level
from .plan import DEFAULT_VEGETATION, WorldPlan, check_seed, check_vegetation
from .stages import (
    bushes,
    cave,
    cover,
    deadwood,
    grass,
    lake,
    layout,
    park,
    poses,
    powerline,
    rocks,
    terrain,
    trail,
    trees,
)
from .stages.bushes import BushParams
from .stages.grass import GrassParams
from .stages.layout import LayoutParams
from .stages.park import ParkParams
from .stages.powerline import PowerlineParams
from .stages.rocks import RockParams
from .stages.terrain import TerrainParams
from .stages.trail import TrailParams
from .stages.trees import TreeParams


@dataclass(frozen=True)
class WorldParams:
    """Every stage's parameters (a stage without any has no field); change one stage's, the
    others' elements stay as they were."""

    layout: LayoutParams = LayoutParams()
    terrain: TerrainParams = TerrainParams()
    trail: TrailParams = TrailParams()
    trees: TreeParams = TreeParams()
    bushes: BushParams = BushParams()
    rocks: RockParams = RockParams()
    grass: GrassParams = GrassParams()
    park: ParkParams = ParkParams()
    powerline: PowerlineParams = PowerlineParams()

    def with_stage(self, stage: str, **changes) -> WorldParams:
        """A copy with one stage's parameters changed."""
        return replace(self, **{stage: replace(getattr(self, stage), **changes)})


# The stages in the order they run; each reads only what the ones before it made.
# deadwood and cover add nothing to a paper world; cover reads the elements before it (crowns
# shade, rocks and logs leave bare ground).
STAGE_MODULES = (
    layout, terrain, poses, trail, lake, cave, trees, bushes, rocks, grass, park, powerline, deadwood, cover
)  # fmt: skip
STAGES = tuple(stage.STAGE for stage in STAGE_MODULES)


def plan_world(
    seed,
    detail: str = "default",
    params: WorldParams | None = None,
    progress: Callable[[str, float], None] | None = None,
    vegetation: str = DEFAULT_VEGETATION,
    biome: str = DEFAULT_BIOME,
) -> WorldPlan:
    """Plan the whole world for a seed. `progress(stage, seconds)` is called after each stage;
    `vegetation` is porous (the default) or solid (plan.VEGETATION); `biome` one of
    biomes.BIOMES (paper: the world from before biomes, byte for byte)."""
    b = biome_of(biome)
    plan = WorldPlan(
        check_seed(seed),
        detail_level(detail),
        biome_params(b, params or WorldParams()),
        check_vegetation(vegetation),
        b.name,
    )
    for stage in STAGE_MODULES:
        t0 = time.perf_counter()
        stage.run(plan, stage_rng(plan.seed, f"world.{stage.STAGE}"))
        plan.timings[stage.STAGE] = time.perf_counter() - t0
        if progress is not None:
            progress(stage.STAGE, plan.timings[stage.STAGE])
    return plan
