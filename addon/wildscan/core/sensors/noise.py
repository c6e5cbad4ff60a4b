"""Range noise (numpy only): the paper model's fixed σ drawn once per beam from the scan's
noise seed, and the datasheet's accuracy by range for the realistic model. The draws are
core.rng's (Marsaglia's polar method on detmath), the same on every machine."""

from __future__ import annotations

import functools

import numpy as np

from ..rng import seeded
from .config import SensorConfig
from .device import Noise
from .load import DEFAULT_DEVICE


def range_noise(sensor: SensorConfig, beam_count: int) -> np.ndarray:
    """Gaussian range noise per beam (zero bias, σ = the fixed noise) from the sensor's own
    seed (the paper model).

    One draw per beam, hit or not, so a beam's noise depends only on the noise seed and its
    (beam, column), not on what the scene happens to contain.
    """
    sigma = sensor.fixed_noise
    if sigma == 0:
        return np.zeros(beam_count)
    return _scaled_normals(sigma, int(sensor.noise_seed), beam_count)


@functools.lru_cache(maxsize=4)
def _scaled_normals(sigma: float, seed: int, count: int) -> np.ndarray:
    """σ times the noise seed's draws, kept read-only: every scan of one sensor draws the same
    noise, so its product is made once, not once a scan."""
    noise = sigma * _standard_normals(seed, count)
    noise.flags.writeable = False
    return noise


@functools.lru_cache(maxsize=4)
def _standard_normals(seed: int, count: int) -> np.ndarray:
    """The noise seed's draws, kept: scans with the same seed (the default 0) reuse them."""
    z = seeded(seed).standard_normal(count)
    z.flags.writeable = False
    return z


def noise_draws(sensor: SensorConfig, beam_count: int, per_beam: int) -> np.ndarray | None:
    """Standard normal draws (beam_count, per_beam) from the noise seed, one row per beam
    whatever it hit (as `range_noise`, whose draws are the first column's when per_beam
    is 1); None when the noise is off."""
    if sensor.fixed_noise == 0:
        return None
    return seeded(int(sensor.noise_seed)).standard_normal((beam_count, per_beam))


def datasheet_sigma(true_range: np.ndarray, noise: Noise = DEFAULT_DEVICE.noise) -> np.ndarray:
    """σ of the range noise by range, from the datasheet's accuracy table read as
    `accuracy_sigmas` σ (the UTM-30LX-EW: ±30 mm to 10 m, ±50 mm beyond, 2σ: 0.015 m up to
    10 m, 0.025 m beyond). A range past the table's last row takes its last σ."""
    r = np.asarray(true_range, dtype=np.float64)
    rows = noise.accuracy
    sigma = np.full(r.shape, rows[-1][1] / noise.accuracy_sigmas)
    for up_to, pm in reversed(rows[:-1]):
        sigma = np.where(r <= up_to, pm / noise.accuracy_sigmas, sigma)
    return sigma


def range_sigma(sensor: SensorConfig, true_range: np.ndarray) -> np.ndarray:
    """σ of each range's noise: the fixed one, or the device's datasheet's by range."""
    fixed = sensor.fixed_noise
    if fixed is not None:
        return np.full(np.shape(true_range), fixed)
    return datasheet_sigma(true_range, sensor.device.noise)
