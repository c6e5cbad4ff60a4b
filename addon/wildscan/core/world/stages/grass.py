"""Stage "grass": low and high grass tufts, the lawn included; high grass by the lake is reeds.
With porous vegetation high grass is separate blades (grown with the generator
"world.grass.foliage"); low grass is the same crossed zig-zag tufts either way."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...rng import stage_rng
from ..plan import ZONES, Clearance, Density, WorldPlan, density_of
from ..shapes.plants import blade_tuft, tuft

STAGE = "grass"


@dataclass(frozen=True)
class GrassParams:
    low_density: Density = (
        ("forest", 45.0),
        ("park", 45.0),
        ("hills", 45.0),
        ("lake", 40.0),
        ("trail", 45.0),
        ("cave", 35.0),
    )
    high_density: Density = (
        ("hills", 16.0),
        ("lake", 30.0),
        ("trail", 20.0),
        ("forest", 10.0),
        ("cave", 8.0),
    )
    min_spacing: float = 0.8
    variants: int = 3


def _where_grass_grows(plan: WorldPlan, zone: str, wildscan_class: str):
    if zone == "lake" and wildscan_class == "high grass":  # reeds: along the shore
        return lambda x, y: plan.ground(x, y) < plan.water_z + 1.2
    return None


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    p, d = plan.params.grass, plan.detail
    low = [
        plan.add_prototype(f"low_grass{v}", tuft(rng, 0.28, 0.32, d.tuft_planes, d.tuft_blades))
        for v in range(p.variants)
    ]
    high = [tuft(rng, 0.95, 0.45, d.tuft_planes, d.tuft_blades) for _ in range(p.variants)]
    if plan.porous:  # the solid tufts are drawn either way: the placements stay the same
        foliage = stage_rng(plan.seed, f"world.{STAGE}.foliage")
        high = [blade_tuft(foliage, 0.95, 0.45) for _ in range(p.variants)]
    high = [plan.add_prototype(f"high_grass{v}", mesh) for v, mesh in enumerate(high)]
    counter: dict = {}
    for zone in ZONES:
        for cls, protos, density, radius in (
            ("low grass", low, p.low_density, 0.2),
            ("high grass", high, p.high_density, 0.3),
        ):
            need = Clearance(radius, park_interior=True)
            extra = _where_grass_grows(plan, zone, cls)
            pts = plan.scatter(rng, zone, density_of(density, zone), p.min_spacing, need, extra)
            for x, y in pts:
                s = rng.uniform(0.7, 1.4)
                plan.add_element(
                    STAGE,
                    zone,
                    cls,
                    protos[int(rng.integers(len(protos)))],
                    counter,
                    location=(float(x), float(y), float(plan.ground(x, y))),
                    yaw=rng.uniform(0, 2 * math.pi),
                    scale=(s, s, s),
                    radius=radius * s,
                )
