"""What the ray backends share (no bpy here): rays from one origin or many, and the tags
read from a scanned object. The backend protocol itself, RayBackend, is in core/backend.py
beside its result type RayHits (core/hits.py).
"""

from __future__ import annotations

import numpy as np


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


def reflectance_from(sources) -> float:
    """The `wildscan_reflectance` of the first of `sources` carrying one (an instanced object,
    then its instancer), checked (a UserError naming the object); nan: none."""
    from ..core.classes import REFLECTANCE_PROP, object_reflectance

    value, owner = _first_prop(sources, REFLECTANCE_PROP)
    return float("nan") if value is None else object_reflectance(owner.name, value)


def _first_prop(objects, key: str):
    """(value, object carrying it), or (None, None)."""
    for obj in objects:
        value = obj.get(key)
        if value is not None:
            return value, obj
    return None, None
