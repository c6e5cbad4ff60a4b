"""Stage "deadwood": fallen logs and stumps (class log), most of them in the forest and on the
hills; none in the paper biome. Each lies where an element may stand (the zones' keep-outs)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..biomes import biome_of
from ..plan import ZONES, Clearance, Density, WorldPlan, density_of
from ..shapes.primitives import cylinder, tube

STAGE = "deadwood"


@dataclass(frozen=True)
class DeadwoodParams:
    # Per 1000 m^2. Temperate managed forests hold tens of m^3 of deadwood a hectare, a few
    # hundred pieces; a fallen log over ~2 m is a few a hundred m^2 (Forest Europe, State of
    # Europe's Forests 2020, indicator 4.5: 11.5 m^3/ha on average).
    log_density: Density = (("forest", 8.0), ("hills", 2.0), ("trail", 2.0), ("lake", 1.0), ("cave", 1.0))
    stump_density: Density = (("forest", 6.0), ("hills", 2.0), ("trail", 1.5), ("lake", 1.0))
    log_length: tuple[float, float] = (1.5, 3.5)  # m
    log_radius: tuple[float, float] = (0.08, 0.25)  # m
    stump_radius: tuple[float, float] = (0.15, 0.35)  # m
    stump_height: tuple[float, float] = (0.2, 0.6)  # m
    min_spacing: float = 2.5
    variants: int = 3


def log_mesh(length: float, radius: float, sides: int = 8):
    """A log lying along X, centred on the origin, resting on z = 0."""
    half = length / 2.0
    return tube([[-half, 0.0, radius], [half, 0.0, radius]], radius, sides)


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    factor = biome_of(plan.biome).deadwood if biome_of(plan.biome).cover else 0.0
    if factor <= 0.0:
        return
    p = getattr(
        plan.params, STAGE, DeadwoodParams()
    )  # not a WorldParams field: paper's world.json keeps its bytes
    logs, stumps = [], []
    for v in range(p.variants):
        length, radius = rng.uniform(*p.log_length), rng.uniform(*p.log_radius)
        logs.append((plan.add_prototype(f"log{v}", log_mesh(length, radius)), length))
        r, h = rng.uniform(*p.stump_radius), rng.uniform(*p.stump_height)
        stumps.append((plan.add_prototype(f"stump{v}", cylinder(r, h, 10, base=(0.0, 0.0, -0.1))), r))
    counter: dict = {}
    for zone in ZONES:
        for protos, density, reach in ((logs, p.log_density, 1.8), (stumps, p.stump_density, 0.4)):
            pts = plan.scatter(rng, zone, factor * density_of(density, zone), p.min_spacing, Clearance(reach))
            for x, y in pts:
                key, size = protos[int(rng.integers(len(protos)))]
                s = rng.uniform(0.8, 1.2)
                half = size * s / 2.0 if protos is logs else size * s
                plan.add_element(
                    STAGE,
                    zone,
                    "log",
                    key,
                    counter,
                    location=(float(x), float(y), float(plan.ground_under(x, y, half)) - 0.02),
                    yaw=rng.uniform(0, 2 * math.pi),
                    scale=(s, s, s),
                    radius=half,
                )
