"""Stage "trees": conifers, broadleaves and birches scattered over every zone, densest in
the forest; each tree is two elements, its trunk (with branches) and its crown.

Porous vegetation (the default) grows each prototype's skeleton and leaves from the
solid shape's size and envelope with a generator of its own ("world.trees.foliage.<kind><v>"), so
the stage's own generator draws exactly what it drew for solid crowns and every tree
stands where it stood."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...rng import stage_rng
from ..plan import ZONES, Clearance, Density, WorldPlan, density_of
from ..shapes.porous_trees import POROUS_KINDS
from ..shapes.trees import TREE_KINDS, TreeShape

STAGE = "trees"

# The kinds of tree growing in each zone, with their shares.
TREE_MIX = {
    "forest": (("conifer", 0.4), ("broadleaf", 0.35), ("birch", 0.25)),
    "park": (("broadleaf", 0.7), ("birch", 0.3)),
    "lake": (("birch", 0.5), ("broadleaf", 0.5)),
    "trail": (("conifer", 0.5), ("broadleaf", 0.3), ("birch", 0.2)),
    "hills": (("conifer", 0.6), ("broadleaf", 0.4)),
    "cave": (("conifer", 0.5), ("birch", 0.5)),
}


@dataclass(frozen=True)
class TreeParams:
    density: Density = (
        ("forest", 18.0),
        ("trail", 3.0),
        ("lake", 2.0),
        ("hills", 1.2),
        ("cave", 1.0),
        ("park", 1.5),
    )
    min_spacing: float = 4.0
    variants: int = 2
    # Porous vegetation grows the forest as real forests stand, its canopy closed (about 500
    # stems a hectare, crowns touching), so the sky seen from under it is what canopy
    # gap-fraction studies report (docs/validation.md "Vegetation"); the solid world keeps the paper
    # world's open stand above.
    porous_density: Density = (
        ("forest", 50.0),
        ("trail", 4.0),
        ("lake", 2.0),
        ("hills", 1.2),
        ("cave", 1.0),
        ("park", 1.5),
    )
    porous_min_spacing: float = 3.0


def _where_trees_grow(plan: WorldPlan, zone: str):
    """Besides every zone's keep-outs: not under the power line (a cleared corridor) and, in
    the park, only along the fence (the lawn is the picnic tables')."""
    if zone == "hills":
        return lambda x, y: plan.layout.powerline.corridor_clear(x, y, 7.0)
    if zone == "park":
        return lambda x, y: ~plan.layout.park.on_lawn(x, y)
    return None


def _prototypes(plan: WorldPlan, rng: np.random.Generator) -> dict[str, list[tuple[str, TreeShape]]]:
    """`variants` shapes of each kind, each a trunk and a crown prototype."""
    kinds: dict[str, list[tuple[str, TreeShape]]] = {}
    for kind, make in TREE_KINDS.items():
        for v in range(plan.params.trees.variants):
            t = make(rng, plan.detail)
            key = f"{kind}{v}"
            if plan.porous:  # each prototype's own generator: tuning one kind moves no other
                foliage = stage_rng(plan.seed, f"world.{STAGE}.foliage.{key}")
                trunk, crown = POROUS_KINDS[kind](t, foliage, plan.detail)
            else:
                trunk, crown = t.trunk, t.crown
            plan.add_prototype(f"tree_{key}_trunk", trunk)
            plan.add_prototype(f"tree_{key}_crown", crown)
            kinds.setdefault(kind, []).append((key, t))
    return kinds


def run(plan: WorldPlan, rng: np.random.Generator) -> None:
    p = plan.params.trees
    kinds = _prototypes(plan, rng)
    density, spacing = (p.porous_density, p.porous_min_spacing) if plan.porous else (p.density, p.min_spacing)
    counter: dict = {}
    for zone in ZONES:
        pts = plan.scatter(
            rng,
            zone,
            density_of(density, zone),
            spacing,
            Clearance(0.4),
            _where_trees_grow(plan, zone),
        )
        names, weights = zip(*TREE_MIX[zone])
        for x, y in pts:
            kind = names[rng.choice(len(names), p=np.array(weights) / sum(weights))]
            key, t = kinds[kind][int(rng.integers(len(kinds[kind])))]
            s = rng.uniform(0.8, 1.2)
            yaw = rng.uniform(0, 2 * math.pi)
            z = float(plan.ground_under(x, y, t.trunk_radius * s))
            placed = dict(location=(float(x), float(y), z), yaw=yaw, scale=(s, s, s))
            plan.add_element(
                STAGE, zone, "trunk", f"tree_{key}_trunk", counter, radius=t.trunk_radius * s, **placed
            )
            plan.add_element(
                STAGE, zone, "treetop", f"tree_{key}_crown", counter, radius=t.crown_radius * s, **placed
            )
