"""What a ray backend answers for a batch of rays (numpy only).

`RayHits` is the one result type every backend returns (core/backend.py defines the
backend protocol); it lives in the core because the scan (core/scan.py) consumes it
and the core imports nothing from raycast/.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MISS_CLASS = -1
MISS_INSTANCE = -1


@dataclass
class RayHits:
    """Per-ray results. A miss has distance = inf, class_id = -1, instance = -1."""

    distance: np.ndarray  # float64 (N,) metres along the unit direction
    class_id: np.ndarray  # int16 (N,) internal class id (classes.BY_ID; WATER_ID for water, 0 untagged)
    instance: np.ndarray  # int32 (N,) the hit object's `wildscan_instance` (0 when untagged)
    untagged_objects: frozenset[str] = frozenset()  # names of untagged objects that were hit
    # float64 (N,3) unit normal of the hit triangle (zeros on a miss; its sign is the
    # triangle's winding, not the ray's side). Only when asked for (`cast(..., normals=True)`):
    # the realistic sensor model needs each hit's incidence angle.
    normal: np.ndarray | None = None
    # float32 (N,) the hit object's `wildscan_reflectivity` override, nan where the class's
    # applies; None: no override on any ray (the paper's case, the common one)
    reflectivity: np.ndarray | None = None

    def overrides(self) -> np.ndarray:
        """float32 (N,) reflectivity overrides, nan where none."""
        if self.reflectivity is None:
            return np.full(len(self.distance), np.nan, dtype=np.float32)
        return self.reflectivity

    def rows(self, index) -> "RayHits":
        """The hits of the rays `index` selects (a slice, mask or index array)."""
        return RayHits(
            self.distance[index],
            self.class_id[index],
            self.instance[index],
            self.untagged_objects,
            normal=None if self.normal is None else self.normal[index],
            reflectivity=None if self.reflectivity is None else self.reflectivity[index],
        )

    def missing(self, gone: np.ndarray) -> "RayHits":
        """These hits with misses where `gone` (bool (N,)): a medium that takes the beam."""
        return RayHits(
            distance=np.where(gone, np.inf, self.distance),
            class_id=np.where(gone, MISS_CLASS, self.class_id).astype(np.int16),
            instance=np.where(gone, MISS_INSTANCE, self.instance).astype(np.int32),
            untagged_objects=self.untagged_objects,
            normal=self.normal,
            reflectivity=None if self.reflectivity is None else np.where(gone, np.nan, self.reflectivity),
        )

    @property
    def hit(self) -> np.ndarray:
        return np.isfinite(self.distance)

    @staticmethod
    def empty(n: int) -> "RayHits":
        return RayHits(
            distance=np.full(n, np.inf),
            class_id=np.full(n, MISS_CLASS, dtype=np.int16),
            instance=np.full(n, MISS_INSTANCE, dtype=np.int32),
        )

    @staticmethod
    def joined(parts: list["RayHits"]) -> "RayHits":
        """The hits of several consecutive batches of rays, in order."""
        normals = [p.normal for p in parts]
        return RayHits(
            distance=np.concatenate([p.distance for p in parts]),
            class_id=np.concatenate([p.class_id for p in parts]),
            instance=np.concatenate([p.instance for p in parts]),
            untagged_objects=frozenset().union(*(p.untagged_objects for p in parts)),
            normal=None if any(n is None for n in normals) else np.concatenate(normals),
            reflectivity=None
            if all(p.reflectivity is None for p in parts)
            else np.concatenate([p.overrides() for p in parts]),
        )
