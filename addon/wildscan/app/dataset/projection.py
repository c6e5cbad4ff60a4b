"""The projection a dataset's labels.yaml ships for semantic-kitti-api (core/projection.py):
one for every scan the spec may draw, so the finest r_h it allows decides the columns."""

from __future__ import annotations

from ...core.projection import Projection, combined, projection_for
from ...core.sensors import DEFAULT_DEVICE
from .spec import DatasetSpec, rh_choices


def dataset_projection(spec: DatasetSpec) -> Projection | None:
    """None when the scans are in the world frame (no projection around the sensor fits them)."""
    finest = min(rh_choices(spec.sensor.rh))
    devices = (DEFAULT_DEVICE,)  # the one device a spec scans with so far
    return combined([p for d in devices if (p := projection_for(d, finest, spec.sensor.frame))])
