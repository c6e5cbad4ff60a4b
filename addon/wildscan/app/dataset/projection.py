"""The projection a dataset's labels.yaml ships for semantic-kitti-api (core/projection.py):
one for every scan the spec may draw, so the finest r_h it allows decides the columns and
every device it may draw the field of view."""

from __future__ import annotations

from ...core.io.projection import Projection, combined, projection_for
from ...core.sensors import DEFAULT_DEVICE, Device, device_choice
from .spec import DatasetSpec, rh_choices


def spec_devices(spec: DatasetSpec) -> list[Device]:
    """The devices a spec may draw: `[sensor] device`, a preset name or a device file or a
    tuple of them (app/dataset/devices.py)."""
    names = spec.sensor.device
    return [device_choice(name) for name in (names if isinstance(names, tuple) else (names,))]


def finest_rh(spec: DatasetSpec, device: Device) -> float:
    """The finest r_h the spec may draw for `device`: the default device's from its value or
    range; another device's as given, or its own (the spec leaves it None)."""
    rh = spec.sensor.rh
    if device == DEFAULT_DEVICE:
        return min(rh_choices(rh))
    if rh is None:
        return device.mount.step_deg
    return float(rh[0] if isinstance(rh, tuple) else rh)


def dataset_projection(spec: DatasetSpec) -> Projection | None:
    """None when the scans are in the world frame (no projection around the sensor fits them)."""
    frame = spec.sensor.frame
    found = [projection_for(d, finest_rh(spec, d), frame) for d in spec_devices(spec)]
    return combined([p for p in found if p is not None])
