"""Stage "bushes": bushes scattered over every zone: stems carrying leaf clusters (porous
vegetation, each grown with its own generator "world.bushes.foliage.<v>") or lumpy domes
(solid)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...rng import stage_rng
from ..plan import ZONES, Clearance, Density, WorldPlan, density_of
from ..shapes.plants import bush, porous_bush

STAGE = "bushes"


@dataclass(frozen=True)
class BushParams:
    density: Density = (
        ("forest", 10.0),
        ("trail", 8.0),
        ("lake", 6.0),
        ("hills", 4.0),
        ("cave", 6.0),
        ("park", 3.0),
    )
    min_spacing: float = 1.6
    variants: int = 3


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.bushes
    protos = []
    for v in range(p.variants):
        mesh, radius = bush(rng, plan.detail)  # drawn either way: the placements stay the same
        if plan.porous:
            mesh = porous_bush(radius, stage_rng(plan.seed, f"world.{STAGE}.foliage.{v}"), plan.detail)
        protos.append((plan.add_prototype(f"bush{v}", mesh), radius))
    counter: dict = {}
    for zone in ZONES:
        pts = plan.scatter(rng, zone, density_of(p.density, zone), p.min_spacing, Clearance(0.7))
        for x, y in pts:
            key, radius = protos[int(rng.integers(len(protos)))]
            s = rng.uniform(0.7, 1.4)
            z = float(plan.ground(x, y)) - 0.05
            plan.add_element(
                STAGE,
                zone,
                "bush",
                key,
                counter,
                location=(float(x), float(y), z),
                yaw=rng.uniform(0, 2 * math.pi),
                scale=(s, s, s * rng.uniform(0.8, 1.1)),
                radius=radius * s,
            )
