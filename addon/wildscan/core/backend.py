"""The interface every ray backend implements (numpy only), beside its result type RayHits.

A backend answers one question: for each ray (origin, unit direction), what is the first
surface within `max_range`, and which class and instance is it? It lives in the core
because the core casts through it (placement, scan, drive sweeps) and imports nothing from
raycast/, where the backends themselves are.

Beyond `cast`, a backend may do more; it says so in `capabilities`, and the core asks that
set, never the object's attributes:

NORMALS     `cast(..., normals=True)` fills `RayHits.normal` (the realistic sensor model
            needs each hit's incidence angle): the embree and bvh backends.
SCAN_TIMES  `cast_scans(..., ks)` casts the rays of 2D scans `ks` (1080 each, in order),
            each at its own 2D scan's time: a scene that moves (raycast/wind.py).
THREADS     `cast` may be called from several threads at once and releases the GIL while it
            traces, each ray's answer its own (core/runtime/threads.py): the embree backend.
"""

from __future__ import annotations

from typing import Protocol, cast

import numpy as np

from .hits import RayHits

NORMALS = "normals"
SCAN_TIMES = "scan_times"
THREADS = "threads"


class RayBackend(Protocol):
    name: str  # as the scan's metadata and its messages name it ("embree", "bvh", "blender", ...)
    capabilities: frozenset[str]  # of NORMALS, SCAN_TIMES: what it can do beyond `cast`

    def cast(self, origins: np.ndarray, directions: np.ndarray, max_range: float) -> RayHits:
        """origins (N,3) or (3,) world metres; directions (N,3) unit vectors; hits beyond
        max_range are misses."""
        ...


class NormalsBackend(RayBackend, Protocol):
    """A backend whose capabilities hold NORMALS."""

    def cast(
        self, origins: np.ndarray, directions: np.ndarray, max_range: float, normals: bool = False
    ) -> RayHits: ...


class ScanTimesBackend(RayBackend, Protocol):
    """A backend whose capabilities hold SCAN_TIMES."""

    def cast_scans(
        self, origins: np.ndarray, directions: np.ndarray, max_range: float, ks: np.ndarray
    ) -> RayHits: ...


def with_normals(backend: RayBackend) -> NormalsBackend | None:
    """The backend as one that casts with normals, or None when it cannot."""
    return cast(NormalsBackend, backend) if NORMALS in backend.capabilities else None


def with_scan_times(backend: RayBackend) -> ScanTimesBackend | None:
    """The backend as one that casts each 2D scan at its own time, or None when it cannot."""
    return cast(ScanTimesBackend, backend) if SCAN_TIMES in backend.capabilities else None
