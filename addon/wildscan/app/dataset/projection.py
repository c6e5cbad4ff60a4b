"""The projection a dataset's labels.yaml ships for semantic-kitti-api (core/projection.py):
one for every scan the spec may draw, so the finest r_h it allows decides the columns and
every device it may draw the field of view."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...core.io.projection import Projection, combined, kept_share, projection_for
from ...core.sensors import DEFAULT_DEVICE, Device, beam_directions, device_choice
from .spec import DatasetSpec, rh_choices


def spec_devices(spec: DatasetSpec) -> list[Device]:
    """The devices a spec may draw: `[sensor] device`, a preset name or a device file or a
    tuple of them (app/dataset/devices.py)."""
    names = spec.sensor.device
    return [device_choice(name) for name in (names if isinstance(names, tuple) else (names,))]


def finest_rh(spec: DatasetSpec, device: Device) -> float:
    """The finest r_h the spec may draw for `device`: as given (the default device's from its
    value or range), or the device's own where the spec leaves it None (a list of devices:
    each scan of each device at its own step, app/dataset/draws.py)."""
    rh = spec.sensor.rh
    if rh is None:
        return device.mount.step_deg
    if device == DEFAULT_DEVICE:
        return min(rh_choices(rh))
    return float(rh[0] if isinstance(rh, tuple) else rh)


def dataset_projection(spec: DatasetSpec) -> Projection | None:
    """None when the scans are in the world frame (no projection around the sensor fits them).
    Several devices: the combined projection's `kept` is probed again with each device's own
    beams on the combined grid (labels.yaml says what that grid keeps, not what each device's
    own grid would)."""
    frame = spec.sensor.frame
    drawn = [(d, finest_rh(spec, d)) for d in spec_devices(spec)]
    found = [p for p in (projection_for(d, rh, frame) for d, rh in drawn) if p is not None]
    together = combined(found)
    if together is None or len(found) == 1:
        return together
    kept = min(kept_share(beam_directions(rh, d)[0].astype(np.float32), together) for d, rh in drawn)
    return replace(together, kept=round(kept, 4))
