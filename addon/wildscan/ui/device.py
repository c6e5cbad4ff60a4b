"""The Sensor panel's device: a preset menu (core/sensors presets, `preset_names()`) and a
sensor file of the user's own (a device TOML written like the presets), as
`scene.wildscan.device` and `scene.wildscan.sensor_file`.

Choosing a device sets the sensor fields to its defaults (its r_h, range window, noise and
divergence), as `wildscan scan` takes a device's defaults where no option says otherwise;
the fields stay editable. A file that cannot be read or holds a wrong value is named by the
panel and refused by the Scan operator, in the loader's words (key, value, what is allowed).
"""

from __future__ import annotations

import bpy

from ..core.errors import UserError
from ..core.sensors import DEFAULT_DEVICE, Device, device_named, load_device, preset_names
from ..core.sensors.config import device_mount_height

DEFAULT_DEVICE_ID = DEFAULT_DEVICE.id
FILE_CHOICE = "FILE"  # the menu's "sensor file" entry (preset names are lower case)


def device_items() -> list[tuple[str, str, str]]:
    """The menu: every preset by its vendor and model, then the sensor file."""
    items = []
    for name in preset_names():
        device = device_named(name)
        items.append((name, device.name, f"The {device.name} preset ({name}.toml)"))
    items.append((FILE_CHOICE, "Sensor file", "A device file (.toml) of your own, written like the presets"))
    return items


def device_from(settings) -> Device:
    """The device the settings choose; UserError when it is a file that cannot be used."""
    if settings.device != FILE_CHOICE:
        return device_named(settings.device)
    path = str(settings.sensor_file).strip()
    if not path:
        raise UserError("is empty: choose a device file (.toml)", setting="sensor_file")
    return load_device(bpy.path.abspath(path))


def take_device_defaults(settings, context=None) -> None:
    """The `update` of the device menu: the sensor fields take the chosen device's defaults
    (nothing changes while the file cannot be read: the panel names why)."""
    try:
        device = device_from(settings)
    except UserError:
        return
    settings.rh = device.mount.step_deg
    settings.min_range = device.ranges.min_m
    settings.max_range = device.ranges.max_m
    settings.noise = device.noise.sigma_m
    settings.divergence = device.optics.divergence_mrad
    settings.mount_height = device_mount_height(device)


def take_file_defaults(settings, context=None) -> None:
    """The `update` of the sensor-file field: a new file counts only while it is the choice."""
    if settings.device == FILE_CHOICE:
        take_device_defaults(settings, context)
