"""The interface every ray backend implements (no bpy here); its result type, RayHits,
is in core/hits.py.

A backend answers one question: for each ray (origin, unit direction), what is
the first surface within `max_range`, and which class and instance is it?
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..core.hits import RayHits


class RayBackend(Protocol):
    name: str

    def cast(self, origins: np.ndarray, directions: np.ndarray, max_range: float) -> RayHits:
        """origins (N,3) or (3,) world metres; directions (N,3) unit vectors; hits beyond
        max_range are misses. A backend whose `supports_normals` is true also takes
        `normals=True` and then fills `RayHits.normal` (the realistic sensor model needs it)."""
        ...


def broadcast_origins(origins: np.ndarray, n: int) -> np.ndarray:
    origins = np.asarray(origins, dtype=np.float64)
    if origins.ndim == 1:
        origins = np.broadcast_to(origins, (n, 3))
    return origins


def tags_from(sources) -> tuple[int, int, float]:
    """(class id, instance id, reflectivity) from the WildScan custom properties of
    `sources`, each property taken from the first source that has it: an instanced
    object, then its instancer, so a tagged template instanced by empties that carry
    their own `wildscan_instance` gives every copy its own id. Untagged: (0, 0, nan);
    the reflectivity is nan unless `wildscan_reflectivity` overrides the class's.
    A wrong tag is a UserError naming the object that carries it."""
    from ..core.classes import CLASS_PROP, INSTANCE_PROP, REFLECTIVITY_PROP, object_tags

    keys = (CLASS_PROP, INSTANCE_PROP, REFLECTIVITY_PROP)
    values = []
    for k, key in enumerate(keys):
        value, owner = _first_prop(sources, key)
        if value is not None:
            # checked with the name of the object that carries it
            alone = [None, None, None]
            alone[k] = value
            object_tags(owner.name, *alone)
        values.append(value)
    class_id, instance, reflectivity = object_tags(sources[0].name, *values)
    return class_id, instance, float("nan") if reflectivity is None else reflectivity


def _first_prop(objects, key: str):
    """(value, object carrying it), or (None, None)."""
    for obj in objects:
        value = obj.get(key)
        if value is not None:
            return value, obj
    return None, None
