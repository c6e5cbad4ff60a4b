"""The names the sensor had before devices were data (numpy only): kept for the modules and
scripts that import them. New code imports core/sensors (the device, SensorConfig, beams,
noise); every value here is the default device's (presets/utm30lx-ew.toml)."""

from __future__ import annotations

import numpy as np

from .sensors import DEFAULT_DEVICE as _D
from .sensors import SensorConfig, beam_directions, directions_at, rotated_beam_directions, sweep_count
from .sensors.beams import from_axis_rad
from .sensors.config import (
    DEFAULT_MODEL,
    MAX_DIVERGENCE_MRAD,
    MAX_ECHO_SEPARATION,
    MAX_NOISE_SIGMA,
    MODELS,
    REALISTIC_SETTINGS,
    SENSOR_SETTINGS,
)
from .sensors.noise import datasheet_sigma, noise_draws, range_noise, range_sigma
from .sensors.returns import RETURN_MODES

BEAMS_PER_2D_SCAN = _D.beams.count
FIRST_BEAM_DEG, R_V_DEG = _D.beams.fan
SWEEP_DEG = _D.mount.sweep_deg
BLIND_CONE_HALF_ANGLE_DEG = _D.beams.blind_cone_half_angle_deg
DEFAULT_MIN_RANGE = _D.ranges.min_m
DEFAULT_MAX_RANGE = _D.ranges.max_m
MAX_RANGE_LIMIT = _D.ranges.max_dark_m
DEFAULT_NOISE_SIGMA = _D.noise.sigma_m
DEFAULT_RH_DEG = _D.mount.step_deg
MIN_RH_DEG = _D.mount.min_step_deg
DEFAULT_DIVERGENCE_MRAD = _D.optics.divergence_mrad
MAX_ECHOES = _D.optics.echoes
DEFAULT_ECHO_SEPARATION = _D.optics.echo_separation_m
DATASHEET_ACCURACY = _D.noise.accuracy
ACCURACY_SIGMAS = _D.noise.accuracy_sigmas


def elevation_angles_rad() -> np.ndarray:
    """θn = n·r_v − 135°, the angle of beam n from the column (+Z), n = 0…1079."""
    return from_axis_rad(_D.beams)


__all__ = [
    "ACCURACY_SIGMAS",
    "BEAMS_PER_2D_SCAN",
    "BLIND_CONE_HALF_ANGLE_DEG",
    "DATASHEET_ACCURACY",
    "DEFAULT_DIVERGENCE_MRAD",
    "DEFAULT_ECHO_SEPARATION",
    "DEFAULT_MAX_RANGE",
    "DEFAULT_MIN_RANGE",
    "DEFAULT_MODEL",
    "DEFAULT_NOISE_SIGMA",
    "DEFAULT_RH_DEG",
    "FIRST_BEAM_DEG",
    "MAX_DIVERGENCE_MRAD",
    "MAX_ECHOES",
    "MAX_ECHO_SEPARATION",
    "MAX_NOISE_SIGMA",
    "MAX_RANGE_LIMIT",
    "MIN_RH_DEG",
    "MODELS",
    "REALISTIC_SETTINGS",
    "RETURN_MODES",
    "R_V_DEG",
    "SENSOR_SETTINGS",
    "SWEEP_DEG",
    "SensorConfig",
    "beam_directions",
    "datasheet_sigma",
    "directions_at",
    "elevation_angles_rad",
    "noise_draws",
    "range_noise",
    "range_sigma",
    "rotated_beam_directions",
    "sweep_count",
]
