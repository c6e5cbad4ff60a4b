"""The elements a tile scatters over its land covers (numpy only): trees, bushes, rocks,
deadwood, grass tufts and reeds, and each clearing's park furniture.

Each family draws from its own generator `stage_rng(seed, "endless.<family>.<i>.<j>")`:
candidates uniform over the tile at the family's highest density, each kept with the
probability its land cover's density gives (thinning a Poisson process), and where nothing
keeps it out (water, a trail's tread, a clearing's lawn, a cave, a power-line pole).
Densities are per 1000 m^2, the stages' own (stages/trees.py ... deadwood.py) by land cover.
"""

from __future__ import annotations

import math

import numpy as np

from ... import detmath as dm
from ...rng import stage_rng
from ..biomes import biome_of
from . import fields as F
from .tile import ground_under
from .tiles import ROCK_DROP_LEVEL, SMALL_DROP_LEVEL, TILE_M

# per 1000 m^2, by LAND_COVERS (forest, meadow, scrub, wetland, rock, trail, clearing); trees
# as stages/trees.py's porous (closed-canopy forest ~500 stems/ha) and solid stands
TREES_POROUS = (50.0, 0.8, 4.0, 1.0, 1.5, 0.0, 0.0)
TREES_SOLID = (18.0, 0.8, 3.0, 1.0, 1.2, 0.0, 0.0)
BUSHES = (6.0, 2.0, 25.0, 4.0, 4.0, 0.0, 0.0)
ROCKS = (2.0, 0.5, 3.0, 1.0, 30.0, 0.0, 0.0)
LOGS = (8.0, 0.3, 1.0, 1.0, 0.5, 0.0, 0.0)  # stages/deadwood.py (Forest Europe 2020)
STUMPS = (6.0, 0.2, 1.0, 0.5, 0.0, 0.0, 0.0)
LOW_TUFTS = (6.0, 25.0, 10.0, 5.0, 6.0, 0.0, 10.0)
HIGH_TUFTS = (2.0, 6.0, 4.0, 0.0, 2.0, 0.0, 0.0)
REEDS = (0.0, 0.0, 0.0, 30.0, 0.0, 0.0, 0.0)
TREE_MIX = {  # kinds per land cover (stages/trees.py TREE_MIX's shares)
    F.FOREST: (("conifer", 0.4), ("broadleaf", 0.35), ("birch", 0.25)),
    None: (("broadleaf", 0.5), ("birch", 0.3), ("conifer", 0.2)),
}
SMALL_ROCK = 0.5  # m: a stone smaller than this is left out of coarse tiles


def _candidates(land: F.Landscape, tile, family: str, densities):
    """(rng, x, y, cover) of the family's kept candidates (the tile's raster answers where)."""
    rng = stage_rng(land.seed, f"endless.{family}.{tile.i}.{tile.j}")
    top = max(densities)
    if top <= 0:
        return rng, np.zeros(0), np.zeros(0), np.zeros(0, dtype=np.uint8)
    count = int(rng.poisson(top * TILE_M * TILE_M / 1000.0))
    x0, x1, y0, y1 = tile.rect
    x, y, u = rng.uniform(x0, x1, count), rng.uniform(y0, y1, count), rng.random(count)
    flat = tile.raster.cells(x, y)
    cover = tile.raster.at("cover", flat)
    keep = u < np.asarray(densities)[cover] / top
    keep &= ~_kept_out(tile.raster, flat, family)
    return rng, x[keep], y[keep], cover[keep]


def _kept_out(r, flat, family: str) -> np.ndarray:
    """Where the family may not stand: water (reeds: only under it), a trail's tread and
    margin, a clearing's lawn (but for grass), a cave, a power line's poles (and, for trees,
    its corridor)."""
    bad = r.at("water" if family == "reeds" else "damp", flat)
    margin = 0.3 if family in ("low", "high") else 1.0
    bad |= r.at("trail", flat) < r.half_width.reshape(-1).take(flat) + margin
    if family != "low":
        bad |= r.at("clearing", flat)
    bad |= r.at("cave_keep", flat) | r.at("line", flat)
    if family == "trees":
        bad |= r.at("corridor", flat)
    return bad


def _yaw(rng) -> float:
    return rng.uniform(0, 2 * math.pi)


def _add_all(tile, cls: str, xs, ys, zs, covers, picks) -> None:
    """One element of class `cls` a candidate: picks[k] = (prototype, scale, radius, yaw)."""
    for x, y, z, cover, (key, scale, radius, yaw) in zip(xs, ys, zs, covers, picks):
        location = (float(x), float(y), float(z))
        tile.add(F.LAND_COVERS[cover], cls, key, location=location, yaw=yaw, scale=scale, radius=radius)


def scatter_elements(tile, land: F.Landscape, lib, level: int, vegetation: str) -> None:
    biome = biome_of(land.biome)
    _trees(tile, land, lib, TREES_POROUS if vegetation == "porous" else TREES_SOLID)
    bushes = lib.family("bush")
    rng, xs, ys, covers = _candidates(land, tile, "bushes", BUSHES)
    picks = []
    for _ in covers:
        key = bushes[int(rng.integers(len(bushes)))]
        s = rng.uniform(0.7, 1.4)
        picks.append((key, (s, s, s * rng.uniform(0.8, 1.1)), lib.radius[key] * s, _yaw(rng)))
    _add_all(tile, "bush", xs, ys, tile.grid.height_at(xs, ys) - 0.05, covers, picks)
    rocks = lib.family("rock")
    rng, xs, ys, covers = _candidates(land, tile, "rocks", ROCKS)
    lo, hi = dm.log(0.25), dm.log(2.0)
    picks, sizes = [], []
    for _ in covers:
        key = rocks[int(rng.integers(len(rocks)))]
        size = dm.exp(rng.uniform(lo, hi))
        sc = (size * rng.uniform(0.8, 1.2), size * rng.uniform(0.8, 1.2), size * rng.uniform(0.7, 1.1))
        picks.append((key, sc, lib.radius[key] * max(sc[:2]), _yaw(rng)))
        sizes.append(size)
    sizes = np.array(sizes)
    keep = sizes >= (SMALL_ROCK if level >= ROCK_DROP_LEVEL else 0.0)  # coarse tiles: no small stones
    zs = ground_under(tile.grid, xs, ys, 0.3 * sizes)
    _add_all(tile, "rock", xs[keep], ys[keep], zs[keep], covers[keep], [p for p, k in zip(picks, keep) if k])
    if biome.cover:
        _deadwood(tile, land, lib, biome.deadwood, level >= SMALL_DROP_LEVEL)
    if level < SMALL_DROP_LEVEL:
        _tufts(tile, land, lib)


def _trees(tile, land: F.Landscape, lib, densities) -> None:
    """A trunk and a crown a tree, of the kinds its land cover grows."""
    rng, xs, ys, covers = _candidates(land, tile, "trees", densities)
    picks = []
    for cover in covers:
        kinds, weights = zip(*TREE_MIX.get(int(cover), TREE_MIX[None]))
        kind = kinds[rng.choice(len(kinds), p=np.array(weights) / sum(weights))]
        picks.append(
            (*lib.trees[kind][int(rng.integers(len(lib.trees[kind])))], rng.uniform(0.8, 1.2), _yaw(rng))
        )
    zs = ground_under(tile.grid, xs, ys, np.array([p[1] * p[3] for p in picks]))
    for part, k in (("trunk", 1), ("crown", 2)):
        parts = [
            (f"{key}_{part}", (s, s, s), p[k] * s, yaw) for p in picks for key, s, yaw in [(p[0], p[3], p[4])]
        ]
        _add_all(tile, "trunk" if part == "trunk" else "treetop", xs, ys, zs, covers, parts)


def _deadwood(tile, land: F.Landscape, lib, factor: float, drop_small: bool) -> None:
    for family, densities, prefix in (("logs", LOGS, "log"), ("stumps", STUMPS, "stump")):
        protos = lib.family(prefix)
        rng, xs, ys, covers = _candidates(land, tile, family, tuple(factor * d for d in densities))
        if drop_small and family == "stumps":
            continue
        picks = []
        for _ in covers:
            key = protos[int(rng.integers(len(protos)))]
            s = rng.uniform(0.8, 1.2)
            picks.append((key, (s, s, s), lib.radius[key] * s, _yaw(rng)))
        zs = ground_under(tile.grid, xs, ys, np.array([p[2] for p in picks])) - 0.02
        _add_all(tile, "log", xs, ys, zs, covers, picks)


def _tufts(tile, land: F.Landscape, lib) -> None:
    for family, densities, prefix, cls in (
        ("low", LOW_TUFTS, "low_grass", "low grass"),
        ("high", HIGH_TUFTS, "high_grass", "high grass"),
        ("reeds", REEDS, "reed", "high grass"),
    ):
        protos = lib.family(prefix)
        rng, xs, ys, covers = _candidates(land, tile, family, densities)
        picks = []
        for _ in covers:
            key = protos[int(rng.integers(len(protos)))]
            s = rng.uniform(0.7, 1.4)
            picks.append((key, (s, s, s), lib.radius[key] * s, _yaw(rng)))
        _add_all(tile, cls, xs, ys, tile.grid.height_at(xs, ys), covers, picks)
