"""The meshes every tile of an endless landscape shares (numpy only): trees, bushes, rocks,
grass tufts, deadwood, park furniture and the power-line pole, each drawn once per (seed,
detail, vegetation) from its own generator `stage_rng(seed, "endless.library.<family>")`.

A tile names these by key; it never draws a mesh of its own but its terrain, water, wires
and cave roof (which are where they are), so building a tile costs placements, not shapes.

Drawing the library takes about a second (porous crowns); a front that keeps a cache can store
it (`library_arrays`) and give it back to a later process (`provide_library`), which then
builds tiles without drawing it again: the same arrays, so the same tiles.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from ...rng import stage_rng
from ..detail import detail_level
from ..elements import Prototype
from ..shapes.furniture import bench, fence_post, fence_section, table
from ..shapes.plants import blade_tuft, bush, porous_bush, tuft
from ..shapes.porous_trees import POROUS_KINDS
from ..shapes.powerline import pole
from ..shapes.primitives import cylinder
from ..shapes.rocks import rock
from ..shapes.trees import TREE_KINDS
from ..stages.deadwood import log_mesh

VARIANTS = 3  # of each family
FENCE_SECTION = 2.5  # m (stages/park.py ParkParams)


@dataclass
class Library:
    prototypes: dict[str, Prototype] = field(default_factory=dict)
    radius: dict[str, float] = field(default_factory=dict)  # key -> footprint radius, m
    trees: dict[str, list[tuple[str, float, float]]] = field(
        default_factory=dict
    )  # kind -> (key, trunk r, crown r)

    def add(self, key: str, mesh, radius: float = 0.0) -> str:
        self.prototypes[key] = Prototype(
            key, np.asarray(mesh[0], dtype=np.float64), np.asarray(mesh[1], dtype=np.int32)
        )
        self.radius[key] = float(radius)
        return key

    def family(self, prefix: str) -> list[str]:
        return sorted(k for k in self.prototypes if k.startswith(prefix))


_LIBRARIES: dict[tuple, Library] = {}  # per process, by (seed, detail, vegetation)
_KEEP = 8


def library(seed: int, detail: str, vegetation: str) -> Library:
    """The shared meshes of a landscape (drawn once per process, or given: provide_library)."""
    key = (int(seed), detail, vegetation)
    if key not in _LIBRARIES:
        if len(_LIBRARIES) >= _KEEP:
            _LIBRARIES.pop(next(iter(_LIBRARIES)))
        _LIBRARIES[key] = draw_library(*key)
    return _LIBRARIES[key]


def forget_libraries() -> None:
    _LIBRARIES.clear()


def provide_library(seed: int, detail: str, vegetation: str, arrays: dict) -> None:
    """Use `arrays` (library_arrays of the same seed, detail and vegetation, from a cache) as
    this process's library."""
    _LIBRARIES[(int(seed), detail, vegetation)] = library_from_arrays(arrays)


def library_arrays(lib: Library) -> dict[str, np.ndarray]:
    """The library as named arrays (np.savez), every mesh and number as it is."""
    out = {"meta": np.array(json.dumps({"radius": lib.radius, "trees": lib.trees}, sort_keys=True))}
    for key, p in lib.prototypes.items():
        out[f"v:{key}"], out[f"f:{key}"] = p.vertices, p.faces
    return out


def library_from_arrays(arrays) -> Library:
    meta = json.loads(str(np.asarray(arrays["meta"])))
    lib = Library()
    for name in arrays.keys() if hasattr(arrays, "keys") else arrays:
        if name.startswith("v:"):
            key = name[2:]
            mesh = (
                np.asarray(arrays[name], dtype=np.float64),
                np.asarray(arrays[f"f:{key}"], dtype=np.int32),
            )
            lib.prototypes[key] = Prototype(key, *mesh)
    lib.radius = {k: float(v) for k, v in meta["radius"].items()}
    lib.trees = {k: [(str(a), float(b), float(c)) for a, b, c in v] for k, v in meta["trees"].items()}
    return lib


def draw_library(seed: int, detail: str, vegetation: str) -> Library:
    """Draw the shared meshes (each family from its own generator)."""
    d, porous, lib = detail_level(detail), vegetation == "porous", Library()
    rng = stage_rng(seed, "endless.library.trees")
    for kind, make in TREE_KINDS.items():
        for v in range(VARIANTS):
            t = make(rng, d)
            key = f"tree_{kind}{v}"
            trunk, crown = t.trunk, t.crown
            if porous:
                trunk, crown = POROUS_KINDS[kind](t, stage_rng(seed, f"endless.library.foliage.{kind}{v}"), d)
            lib.add(f"{key}_trunk", trunk, t.trunk_radius)
            lib.add(f"{key}_crown", crown, t.crown_radius)
            lib.trees.setdefault(kind, []).append((key, t.trunk_radius, t.crown_radius))
    rng = stage_rng(seed, "endless.library.bushes")
    for v in range(VARIANTS):
        mesh, radius = bush(rng, d)
        if porous:
            mesh = porous_bush(radius, stage_rng(seed, f"endless.library.bushes.foliage.{v}"), d)
        lib.add(f"bush{v}", mesh, radius)
    rng = stage_rng(seed, "endless.library.rocks")
    for v in range(VARIANTS + 1):
        mesh, radius = rock(rng, d)
        lib.add(f"rock{v}", mesh, radius)
    rng = stage_rng(seed, "endless.library.grass")
    for v in range(VARIANTS):
        lib.add(f"low_grass{v}", tuft(rng, 0.28, 0.32, d.tuft_planes, d.tuft_blades), 0.2)
        high = blade_tuft(rng, 0.95, 0.45) if porous else tuft(rng, 0.95, 0.45, d.tuft_planes, d.tuft_blades)
        lib.add(f"high_grass{v}", high, 0.3)
        lib.add(f"reed{v}", blade_tuft(rng, 1.5, 0.35) if porous else tuft(rng, 1.5, 0.35, 3, 3), 0.25)
    rng = stage_rng(seed, "endless.library.deadwood")
    for v in range(VARIANTS):
        length, radius = rng.uniform(1.5, 3.5), rng.uniform(0.08, 0.25)
        lib.add(f"log{v}", log_mesh(length, radius), length / 2)
        r, h = rng.uniform(0.15, 0.35), rng.uniform(0.2, 0.6)
        lib.add(f"stump{v}", cylinder(r, h, 10, base=(0.0, 0.0, -0.1)), r)
    lib.add("table", table(), 1.0)
    lib.add("bench", bench(), 0.8)
    lib.add("fence_section", fence_section(FENCE_SECTION), FENCE_SECTION / 2)
    lib.add("fence_post", fence_post(), 0.1)
    lib.add("pole", pole(d), 0.15)
    return lib
