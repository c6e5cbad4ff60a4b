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


def tags_from(sources) -> tuple[int, int]:
    """(class id, instance id) from the WildScan custom properties of `sources`, each
    property taken from the first source that has it: an instanced object, then its
    instancer, so a tagged template instanced by empties that carry their own
    `wildscan_instance` gives every copy its own id. Untagged: (0, 0)."""
    from ..core.classes import CLASS_PROP, INSTANCE_PROP, class_id_for_tag

    class_id = class_id_for_tag(_first_prop(sources, CLASS_PROP))
    try:
        instance = int(_first_prop(sources, INSTANCE_PROP) or 0)
    except (TypeError, ValueError):
        instance = 0
    return class_id, instance


def _first_prop(objects, key: str):
    for obj in objects:
        value = obj.get(key)
        if value is not None:
            return value
    return None
