"""Sensors (numpy only): a device as data (device.py, read from presets/*.toml by load.py),
the settings of one scan (config.py), beam directions (beams.py) and range noise (noise.py).

The UTM-30LX-EW on Andabata's rotating head (presets/utm30lx-ew.toml) is the default device;
`SensorConfig(device=...)` scans with another. The physics model (`paper` | `realistic`) is
a separate choice, `SensorConfig.model`.
"""

from .beams import beam_directions, directions_at, from_axis_rad, rotated_beam_directions, rotated_beams
from .config import MODELS, Limits, SensorConfig, setting_defaults, setting_limits, sweep_count
from .device import BeamTable, Device, Mount, Noise, Optics, RangeLimits, Timing
from .load import DEFAULT_DEVICE, device_choice, device_from_dict, device_named, load_device, preset_names
from .noise import datasheet_sigma, noise_draws, range_noise, range_sigma

__all__ = [
    "DEFAULT_DEVICE",
    "MODELS",
    "BeamTable",
    "Device",
    "Limits",
    "Mount",
    "Noise",
    "Optics",
    "RangeLimits",
    "SensorConfig",
    "Timing",
    "beam_directions",
    "datasheet_sigma",
    "device_choice",
    "device_from_dict",
    "device_named",
    "directions_at",
    "from_axis_rad",
    "load_device",
    "noise_draws",
    "preset_names",
    "range_noise",
    "range_sigma",
    "rotated_beam_directions",
    "rotated_beams",
    "setting_defaults",
    "setting_limits",
    "sweep_count",
]
