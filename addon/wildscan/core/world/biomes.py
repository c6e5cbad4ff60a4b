"""Biomes (numpy only): what grows where, as a change of the mix, never of the zones.

    wildscan world --biome mixed|meadow|forest|scrub|paper      (SPEC.toml `biome`)

A biome scales the element stages' densities (trees, bushes, high grass) and says how the
ground between them is covered (stages/cover.py: the sward layer a beam enters) and how much
deadwood lies about (stages/deadwood.py). The zones, the terrain, the trail, the lake, the cave,
the park and the power line are the same in every biome.

`paper` is the world WildScan built before biomes existed, byte for byte: bare ground between
the paper's elements, no ground cover, no deadwood (tests/golden pins it). `mixed` is the
default: a temperate mosaic of meadow, forest with undergrowth and some scrub, tuned so a
dataset's class mix comes near RELLIS-3D's (docs/ground.md; `wildscan bench --suite biomes`
measures it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..checks import one_of

BIOMES = ("mixed", "meadow", "forest", "scrub", "paper")
DEFAULT_BIOME = "mixed"
PAPER = "paper"


@dataclass(frozen=True)
class Biome:
    """How a biome changes the world. Densities are factors on the stages' own (1: as the paper
    world); the cover shares are of the cells where cover may grow (stages/cover.py)."""

    name: str
    cover: bool = True  # a sward layer over the ground (False: the paper's bare ground)
    trees: float = 1.0  # factor on the trees stage's densities outside the forest zone
    forest_trees: float = 1.0  # ... in the forest zone
    bushes: float = 1.0  # factor on the bushes stage's densities
    open_shrub: float = 0.2  # share of open ground under shrubs (bush layer)
    tall_grass: float = 0.15  # share of open, dry ground under tall grass (wet ground is all tall)
    undergrowth: float = 0.7  # share of shaded ground under undergrowth (ferns, bramble: bush layer)
    grass_height: float = 1.0  # factor on the sward's heights
    deadwood: float = 1.0  # factor on the deadwood stage's densities
    summary: str = ""


BIOME_TABLE: dict[str, Biome] = {
    b.name: b
    for b in (
        Biome(
            "mixed",
            summary="temperate mosaic: meadows, a forest with undergrowth and deadwood, some scrub",
        ),
        Biome(
            "meadow",
            trees=0.4,
            forest_trees=0.6,
            bushes=0.6,
            open_shrub=0.05,
            tall_grass=0.3,
            undergrowth=0.35,
            grass_height=1.15,
            deadwood=0.4,
            summary="open grassland: tall swards, few trees and shrubs",
        ),
        Biome(
            "forest",
            trees=2.5,
            forest_trees=1.2,
            bushes=1.3,
            open_shrub=0.2,
            tall_grass=0.1,
            undergrowth=0.75,
            deadwood=2.0,
            summary="closed woodland: more trees in every zone, dense undergrowth, much deadwood",
        ),
        Biome(
            "scrub",
            trees=0.5,
            forest_trees=0.5,
            bushes=3.0,
            open_shrub=0.45,
            tall_grass=0.05,
            undergrowth=0.6,
            grass_height=0.7,
            deadwood=0.5,
            summary="Mediterranean hillside (the paper's robot worked in one): shrubs, short dry grass",
        ),
        Biome("paper", cover=False, summary="the paper's world: bare ground, no cover, no deadwood"),
    )
}


def check_biome(biome: str) -> str:
    return one_of(biome, "biome", BIOMES)


def biome_of(name: str) -> Biome:
    return BIOME_TABLE[check_biome(name)]


def _scaled(density, factor: float, forest_factor: float | None = None):
    forest = factor if forest_factor is None else forest_factor
    return tuple((zone, value * (forest if zone == "forest" else factor)) for zone, value in density)


def biome_params(biome: Biome, params):
    """The stage parameters (pipeline.WorldParams) of `biome`: `params` itself for paper (so its
    world keeps every byte), otherwise with the trees' and bushes' densities scaled."""
    if not biome.cover:
        return params
    trees = params.trees
    trees = replace(
        trees,
        density=_scaled(trees.density, biome.trees, biome.forest_trees),
        porous_density=_scaled(trees.porous_density, biome.trees, biome.forest_trees),
    )
    bushes = replace(params.bushes, density=_scaled(params.bushes.density, biome.bushes))
    return replace(params, trees=trees, bushes=bushes)
