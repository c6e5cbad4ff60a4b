"""The ground cover on a Blender world (bpy; thin): the CoverGrid (core/world/cover.py) kept as
custom properties of the world's root collection, so a saved .blend scans with its sward."""

from __future__ import annotations

import numpy as np

from ..core.world.cover import CoverGrid
from .mesh import world_root

COVER_PREFIX = "wildscan_"
SHAPE_PROP = "wildscan_cover_shape"


def store_cover(root, cover: CoverGrid | None) -> None:
    """Record `cover` on the root collection (nothing for a world without cover)."""
    if cover is None:
        return
    for name, values in cover.to_arrays().items():
        values = np.asarray(values).reshape(-1)
        root[COVER_PREFIX + name] = values.astype(
            np.int32 if values.dtype.kind in "iu" else np.float64
        ).tolist()
    root[SHAPE_PROP] = list(cover.shape)


def scene_cover(scene=None) -> CoverGrid | None:
    """The cover of the world in `scene` (the current one), None when it has none."""
    root = world_root(scene)
    if root is None or root.get(SHAPE_PROP) is None:
        return None
    names = (
        "cover_origin",
        "cover_class",
        "cover_height",
        "cover_terrain_xs",
        "cover_terrain_ys",
        "cover_terrain_z",
    )
    arrays = {name: np.array(root[COVER_PREFIX + name]) for name in names}
    return CoverGrid.from_arrays(arrays, tuple(int(v) for v in root[SHAPE_PROP]))
