"""The endless landscape's continuous fields: terrain height and land cover, pure functions of
(seed, biome, x, y) (numpy only).

Every field here is seeded noise (heightfield.FractalNoise, built from `stage_rng(seed, name)`)
plus the features of the anchor cells near the point (anchors.py: lakes, clearings, outcrops
with caves, trails, power lines), so the same (seed, x, y) gives the same numbers whichever
tile or region asks, in any order: that is what makes tiles agree at their seams.

Land cover (LAND_COVERS, the names `poses --zone` and a dataset's `[poses] cover` take) is
decided per point, the first that holds winning: a trail's tread, a clearing, water and wet
ground (a lake's shore, or the wettest share of the moisture field), a rock outcrop (the
rockiest share of its field, and every cave's outcrop), then forest, scrub or meadow by the
vegetation field's quantiles. The shares come from the biome (biome_shares below; their
sources are cited there): they are a choice, made to resemble European semi-natural land.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from ...rng import stage_rng
from ..biomes import biome_of
from ..heightfield import FractalNoise, smootherstep
from . import anchors as A

LAND_COVERS = ("forest", "meadow", "scrub", "wetland", "rock", "trail", "clearing")  # add, never rename
FOREST, MEADOW, SCRUB, WETLAND, ROCK, TRAIL, CLEARING = range(len(LAND_COVERS))


@dataclass(frozen=True)
class Shares:
    """Target shares of the land (before trails and clearings, which the anchors decide):
    wetland and rock are the wettest and rockiest shares of their fields, forest and scrub
    shares of the vegetation field's quantiles over the rest; meadow takes what is left."""

    forest: float
    scrub: float
    wetland: float
    rock: float


# Shares of the cover types. A choice, informed by the CORINE Land Cover 2018 inventory of the
# EEA-39 countries (European Environment Agency, "CORINE Land Cover 2018", land cover
# accounts; "Land cover and change statistics 2000-2018", EEA dashboard): forests cover about
# a third of the land, grassland and pasture about a fifth, transitional woodland-shrub,
# moors and heath and sclerophyllous scrub together about 7-8 %, inland wetlands and water
# bodies about 3-4 %, bare rock and sparsely vegetated land about 3 %; arable land and
# artificial surfaces (the rest) have no place in a natural world, so the semi-natural classes
# are renormalised to the whole (forest ~45 %, grassland ~30 %, scrub ~12 %, wet ~5 %, rock
# ~4 %: the `mixed` biome below, rounded). State of Europe's Forests 2020 (Forest Europe)
# gives forest 35 % of Europe's land, which `forest` biome's 65 % deliberately exceeds (a
# forest landscape, as the `meadow` one is a grassland one).
BIOME_SHARES = {
    "mixed": Shares(forest=0.45, scrub=0.12, wetland=0.05, rock=0.04),
    "meadow": Shares(forest=0.15, scrub=0.10, wetland=0.06, rock=0.03),
    "forest": Shares(forest=0.65, scrub=0.08, wetland=0.04, rock=0.03),
    "scrub": Shares(forest=0.12, scrub=0.45, wetland=0.02, rock=0.08),
    "paper": Shares(forest=0.45, scrub=0.12, wetland=0.05, rock=0.04),
}

# The terrain: rolling hills (RELIEF_WAVELENGTH, a few octaves) and the detail of today's worlds
# (stages/terrain.py TerrainParams: 55 m, 4 octaves, 2.5 m); an outcrop rises by up to
# OUTCROP_RISE where the rock field peaks. Relief of a few tens of metres over kilometres: a
# lowland or hill landscape, where ground robots work.
RELIEF_WAVELENGTH = 600.0  # m
RELIEF_AMPLITUDE = 14.0  # m
DETAIL_WAVELENGTH = 55.0  # m
DETAIL_AMPLITUDE = 2.5  # m
OUTCROP_RISE = 3.0  # m
OUTCROP_RAMP = 0.25  # of the rockiness field: the rise spreads over the outcrop's rim, no cliff
FIELD_WAVELENGTH = 260.0  # m: the patches of the land-cover fields (forest stands, meadows)
QUANTILE_SAMPLES = 160  # per side of the lattice a field's quantiles are measured on (3.2 km)


class Landscape:
    """The fields of one (seed, biome): built once (landscape(seed, biome) caches them) and
    read anywhere; every method is a pure function of its arguments."""

    def __init__(self, seed: int, biome: str):
        self.seed, self.biome = int(seed), biome_of(biome).name
        self.shares = BIOME_SHARES[self.biome]
        self.relief = FractalNoise(stage_rng(self.seed, "endless.relief"), RELIEF_WAVELENGTH, 3)
        self.detail = FractalNoise(stage_rng(self.seed, "endless.detail"), DETAIL_WAVELENGTH, 4)
        self.vegetation = FractalNoise(stage_rng(self.seed, "endless.vegetation"), FIELD_WAVELENGTH, 3)
        self.moisture = FractalNoise(stage_rng(self.seed, "endless.moisture"), FIELD_WAVELENGTH, 3)
        self.rockiness = FractalNoise(stage_rng(self.seed, "endless.rockiness"), 0.6 * FIELD_WAVELENGTH, 3)
        self.patch = FractalNoise(stage_rng(self.seed, "endless.patch"), 12.0, 2)  # cover's clumps
        self._thresholds()
        self.anchors = A.Anchors(self.seed, self.base_height, self.height)

    def _thresholds(self) -> None:
        """The field values that cut the shares: quantiles over a 3.2 km lattice (a pure
        function of the seed: the same lattice every time)."""
        t = (np.arange(QUANTILE_SAMPLES) - QUANTILE_SAMPLES / 2) * 20.0 + 7.0
        gx, gy = np.meshgrid(t, t)
        s = self.shares
        self.wet_cut = float(np.quantile(self.moisture(gx, gy), 1.0 - s.wetland))
        self.rock_cut = float(np.quantile(self.rockiness(gx, gy), 1.0 - s.rock))
        rest = 1.0 - s.wetland - s.rock
        veg = self.vegetation(gx, gy)
        fine = np.arange(QUANTILE_SAMPLES) * 0.77  # the patch field's own scale
        self.patch_levels = np.quantile(self.patch(*np.meshgrid(fine, fine)), np.linspace(0.0, 1.0, 101))
        self.forest_cut = float(np.quantile(veg, 1.0 - s.forest / rest))
        self.scrub_cut = float(np.quantile(veg, 1.0 - (s.forest + s.scrub) / rest))

    def uniform_patch(self, x, y, k: int) -> np.ndarray:
        """The k-th patch field (the cover's clumps, ~12 m) at points, ranked to [0, 1]: a share
        s of the land lies below s."""
        shift = 1000.0 * k
        values = self.patch(np.asarray(x) + shift, np.asarray(y) - 0.7 * shift)
        return np.interp(values, self.patch_levels, np.linspace(0.0, 1.0, 101))

    # -- terrain ------------------------------------------------------------------------

    def base_height(self, x, y) -> np.ndarray:
        """The terrain before lakes and caves: hills, detail and outcrops."""
        x, y = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
        h = RELIEF_AMPLITUDE * self.relief(x, y) + DETAIL_AMPLITUDE * self.detail(x, y)
        rise = smootherstep((self.rockiness(x, y) - self.rock_cut) / OUTCROP_RAMP + 0.5)
        return h + OUTCROP_RISE * rise

    def height(self, x, y) -> np.ndarray:
        """The terrain's height (m) at points: base_height shaped by the lakes and caves of
        the anchor cells near them."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        h = self.base_height(x, y)
        for feature in self.anchors.terrain_features(x, y):
            h = feature.apply(x, y, h)
        return h

    # -- land cover ---------------------------------------------------------------------

    def land_cover(self, x, y, height=None, trail=None) -> np.ndarray:
        """uint8 codes into LAND_COVERS at points (module docstring for the order). `height`:
        the terrain there if the caller has it (the water's test needs it); `trail`: the
        points' anchors.trail_nearest if the caller has it."""
        x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
        veg = self.vegetation(x, y)
        out = np.where(veg > self.forest_cut, FOREST, np.where(veg > self.scrub_cut, SCRUB, MEADOW))
        out = out.astype(np.uint8)
        out[self.rockiness(x, y) > self.rock_cut] = ROCK
        out[self.anchors.in_outcrop(x, y)] = ROCK
        out[self.anchors.corridor(x, y) & (out == FOREST)] = SCRUB  # a power line's cleared corridor
        out[self.moisture(x, y) > self.wet_cut] = WETLAND
        h = self.height(x, y) if height is None else height
        out[self.anchors.shore(x, y, h)] = WETLAND
        out[self.anchors.in_clearing(x, y)] = CLEARING
        dist, kind = self.anchors.trail_nearest(x, y) if trail is None else trail
        out[dist < np.array([k[1] for k in A.TRAIL_KINDS])[kind]] = TRAIL
        out[self.anchors.under_water(x, y, h)] = WETLAND
        return out


@functools.lru_cache(maxsize=8)
def landscape(seed: int, biome: str) -> Landscape:
    """The fields of (seed, biome), built once per process."""
    return Landscape(int(seed), biome_of(biome).name)


def land_cover_at(seed: int, biome: str, x, y) -> np.ndarray:
    """uint8 codes into LAND_COVERS of the endless landscape of (seed, biome) at points."""
    return landscape(seed, biome).land_cover(x, y)


def height_at(seed: int, biome: str, x, y) -> np.ndarray:
    """The analytic terrain height of the endless landscape of (seed, biome) at points (the
    mesh is this sampled on the tile lattice)."""
    return landscape(seed, biome).height(x, y)


def trail_network(seed: int, biome: str, xmin: float, ymin: float, xmax: float, ymax: float) -> list:
    """The trails that come within a rectangle: [(path (K, 2) m, kind name)], each from its
    anchor cell's node to a neighbour's node (anchors.py), in the order of their cells; two
    trails meet where they share an end (a node)."""
    trails = landscape(seed, biome).anchors.trails_over(xmin, xmax, ymin, ymax)
    inside = [
        t
        for t in trails
        if t.path[:, 0].max() >= xmin
        and t.path[:, 0].min() <= xmax
        and t.path[:, 1].max() >= ymin
        and t.path[:, 1].min() <= ymax
    ]
    return [(t.path.copy(), A.TRAIL_KINDS[t.kind][0]) for t in inside]
