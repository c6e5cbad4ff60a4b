"""Stage "rocks": faceted stones of log-uniform size, most of them on the hills and in the cave."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ... import detmath as dm
from ..plan import ZONES, Clearance, Density, WorldPlan, density_of
from ..shapes.rocks import rock

STAGE = "rocks"


@dataclass(frozen=True)
class RockParams:
    density: Density = (
        ("hills", 8.0),
        ("cave", 9.0),
        ("lake", 5.0),
        ("trail", 4.0),
        ("forest", 3.0),
        ("park", 0.4),
    )
    min_spacing: float = 1.8
    size: tuple[float, float] = (0.25, 2.0)  # m, log-uniform
    variants: int = 4


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.rocks
    protos = []
    for v in range(p.variants):
        mesh, radius = rock(rng, plan.detail)
        protos.append((plan.add_prototype(f"rock{v}", mesh), radius))
    counter: dict = {}
    lo, hi = dm.log(p.size[0]), dm.log(p.size[1])
    for zone in ZONES:
        pts = plan.scatter(rng, zone, density_of(p.density, zone), p.min_spacing, Clearance(1.0))
        for x, y in pts:
            key, radius = protos[int(rng.integers(len(protos)))]
            size = dm.exp(rng.uniform(lo, hi))
            sc = (size * rng.uniform(0.8, 1.2), size * rng.uniform(0.8, 1.2), size * rng.uniform(0.7, 1.1))
            z = float(plan.ground_under(x, y, 0.3 * size))
            plan.add_element(
                STAGE,
                zone,
                "rock",
                key,
                counter,
                location=(float(x), float(y), z),
                yaw=rng.uniform(0, 2 * math.pi),
                scale=sc,
                radius=radius * max(sc[:2]),
            )
