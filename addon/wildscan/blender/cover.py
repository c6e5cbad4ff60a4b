"""The ground cover on a Blender world (bpy; thin): the CoverGrid (core/world/cover.py) kept as
custom properties of the world's root collection, so a saved .blend scans with its sward."""

from __future__ import annotations

from ..core.world.cover import CoverGrid
from .mesh import world_root


def store_cover(root, cover: CoverGrid | None) -> None:
    """Record `cover` on the root collection (nothing for a world without cover)."""
    if cover is not None:
        for name, values in cover.to_props().items():
            root[name] = values


def scene_cover(scene=None) -> CoverGrid | None:
    """The cover of the world in `scene` (the current one), None when it has none."""
    root = world_root(scene)
    return None if root is None else CoverGrid.from_props(root)
