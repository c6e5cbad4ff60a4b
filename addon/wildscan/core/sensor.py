"""The emulated 3D laser rangefinder of Andabata: a Hokuyo UTM-30LX-EW 2D scanner
turned 180° about its vertical axis (paper section II, Eq. 1). Numpy only.

Sensor frame: origin at the optical centre, Z along the column (up), X along
the structure's X arm (the heading). Beam n of 2D scan m points along

    Rz(m·r_h) · (sin θn, 0, cos θn),   θn = n·r_v − 135°   (angle from the column)

so n = 0 looks 45° away from straight down behind, n = 540 straight up, and the
90° wedge around −Z is never scanned (the blind cone).
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass

import numpy as np

from . import detmath as dm
from .errors import UserError
from .rng import seeded

BEAMS_PER_2D_SCAN = 1080
R_V_DEG = 0.25
FIRST_BEAM_DEG = -135.0
SWEEP_DEG = 180.0
# The blind cone: no beam comes closer than this to straight down.
BLIND_CONE_HALF_ANGLE_DEG = 45.0

DEFAULT_MIN_RANGE = 0.1
DEFAULT_MAX_RANGE = 15.0  # the UTM-30LX-EW under direct sunlight
MAX_RANGE_LIMIT = 30.0  # the UTM-30LX-EW's range in the dark
DEFAULT_NOISE_SIGMA = 0.015
MAX_NOISE_SIGMA = 1.0  # m; far past any real rangefinder, and rays are cast 6 sigma past max range
DEFAULT_RH_DEG = 1.0
MIN_RH_DEG = 0.05  # 3,600 2D scans, 3.9 M beams: finer would need gigabytes of beams


@dataclass(frozen=True)
class SensorConfig:
    rh_deg: float = DEFAULT_RH_DEG
    min_range: float = DEFAULT_MIN_RANGE
    max_range: float = DEFAULT_MAX_RANGE
    noise_sigma: float = DEFAULT_NOISE_SIGMA
    noise_seed: int = 0

    @property
    def sweeps(self) -> int:
        """M, the number of 2D scans in a 180° turn."""
        return sweep_count(self.rh_deg)

    @property
    def beam_count(self) -> int:
        return BEAMS_PER_2D_SCAN * self.sweeps

    def validate(self) -> "SensorConfig":
        sweep_count(self.rh_deg)
        _check_finite("min_range", self.min_range, "m")
        _check_finite("max_range", self.max_range, "m")
        _check_finite("noise", self.noise_sigma, "m")
        if self.min_range < 0:
            raise UserError(f"must be >= 0 m, got {self.min_range:g}", setting="min_range", allowed=(0, None))
        if self.max_range <= 0 or self.max_range > MAX_RANGE_LIMIT:
            raise UserError(
                f"must be in (0, {MAX_RANGE_LIMIT:g}] m (the UTM-30LX-EW's limit), got {self.max_range:g}",
                setting="max_range",
                allowed=(0, MAX_RANGE_LIMIT),
            )
        if self.min_range >= self.max_range:
            raise UserError(
                f"({self.min_range:g} m) must be below {{max_range}} ({self.max_range:g} m)",
                setting="min_range",
                related=("max_range",),
            )
        if not 0 <= self.noise_sigma <= MAX_NOISE_SIGMA:
            raise UserError(
                f"must be from 0 (off) to {MAX_NOISE_SIGMA:g} m, got {self.noise_sigma:g}",
                setting="noise",
                allowed=(0, MAX_NOISE_SIGMA),
            )
        if not (0 <= int(self.noise_seed) < 2**63):
            raise UserError(
                f"must be an integer in [0, 2^63), got {self.noise_seed}",
                setting="noise_seed",
                allowed=(0, 2**63 - 1),
            )
        return self

    def to_dict(self) -> dict:
        d = asdict(self)
        d.update(
            model="Hokuyo UTM-30LX-EW",
            rv_deg=R_V_DEG,
            beams_per_2d_scan=BEAMS_PER_2D_SCAN,
            sweeps=self.sweeps,
        )
        return d


def _check_finite(setting: str, value: float, unit: str) -> None:
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        raise UserError(f"must be a finite number of {unit}, got {value}", setting=setting)


def sweep_count(rh_deg: float) -> int:
    """M = 180 / r_h, which must come out whole."""
    if not isinstance(rh_deg, (int, float)) or not math.isfinite(rh_deg) or rh_deg <= 0:
        raise UserError(
            f"must be a positive number of degrees dividing 180 (e.g. 0.25, 0.5, 1, 2), got {rh_deg}",
            setting="rh",
        )
    if rh_deg < MIN_RH_DEG:
        raise UserError(
            f"must be at least {MIN_RH_DEG:g} deg (finer scans need gigabytes), got {rh_deg:g}",
            setting="rh",
            allowed=(MIN_RH_DEG, SWEEP_DEG),
        )
    m = SWEEP_DEG / rh_deg
    whole = round(m)
    if whole < 1 or abs(m - whole) > 1e-9 * max(1.0, m):
        raise UserError(
            f"must divide 180 into a whole number of 2D scans (e.g. 0.25, 0.5, 1, 2, 4), got {rh_deg:g} "
            f"(180/{rh_deg:g} = {m:g})",
            setting="rh",
        )
    return int(whole)


def elevation_angles_rad() -> np.ndarray:
    """θn = n·r_v − 135°, the angle of beam n from the column (+Z), n = 0…1079."""
    n = np.arange(BEAMS_PER_2D_SCAN, dtype=np.float64)
    return dm.deg2rad(n * R_V_DEG + FIRST_BEAM_DEG)


def beam_directions(rh_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit beam directions of a full 3D scan in the sensor frame (Eq. 1 with ρ = 1).

    Returns (dirs (N,3) float64, ring n (N,) uint16, sweep m (N,) uint16), ordered
    sweep-major: all 1080 beams of 2D scan 0, then of scan 1, … The arrays are
    cached per r_h (many scans share them) and read-only.
    """
    return _beam_directions(float(rh_deg), sweep_count(rh_deg))


@functools.lru_cache(maxsize=8)
def _beam_angles(rh_deg: float, m_count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(sin θn, cos θn, sin φm, cos φm), φm = m·r_h: detmath's, the same bits on every machine
    (np.sin is the C library's, which differs by CPU)."""
    sin_t, cos_t = dm.sincos(elevation_angles_rad())
    sin_p, cos_p = dm.sincos(dm.deg2rad(np.arange(m_count, dtype=np.float64) * rh_deg))
    return sin_t, cos_t, sin_p, cos_p


@functools.lru_cache(maxsize=8)
def _beam_directions(rh_deg: float, m_count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    sin_t, cos_t, sin_p, cos_p = _beam_angles(rh_deg, m_count)
    dirs = np.empty((m_count, BEAMS_PER_2D_SCAN, 3))
    dirs[:, :, 0] = cos_p[:, None] * sin_t[None, :]
    dirs[:, :, 1] = sin_p[:, None] * sin_t[None, :]
    dirs[:, :, 2] = cos_t[None, :]
    ring = np.tile(np.arange(BEAMS_PER_2D_SCAN, dtype=np.uint16), m_count)
    sweep = np.repeat(np.arange(m_count, dtype=np.uint16), BEAMS_PER_2D_SCAN)
    arrays = (dirs.reshape(-1, 3), ring, sweep)
    for a in arrays:
        a.flags.writeable = False
    return arrays


def rotated_beam_directions(rotation: np.ndarray, rh_deg: float) -> np.ndarray:
    """The beams of `beam_directions(rh_deg)` turned by `rotation` (3x3; the placement's sensor
    -> world), (N, 3) float64 in the same order.

    Beam (n, m) is R·Rz(φm)·(sin θn, 0, cos θn) = a_m sin θn + R[:, 2] cos θn with
    a_m = R[:, 0] cos φm + R[:, 1] sin φm: three products a beam in a fixed order, where
    R @ dirs would take nine and let the BLAS kernel (so the CPU) choose their order."""
    m_count = sweep_count(rh_deg)
    sin_t, cos_t, sin_p, cos_p = _beam_angles(float(rh_deg), m_count)
    r = np.asarray(rotation, dtype=np.float64)
    out = np.empty((m_count, BEAMS_PER_2D_SCAN, 3))
    for i in range(3):
        a = cos_p * r[i, 0] + sin_p * r[i, 1]
        component = out[:, :, i]
        np.multiply(a[:, None], sin_t[None, :], out=component)
        component += r[i, 2] * cos_t
    return out.reshape(-1, 3)


def directions_at(head_rad: np.ndarray) -> np.ndarray:
    """Eq. 1 beam directions (sensor frame, unit) for head angles `head_rad`: (K,) one angle a
    2D scan (the stepped head of Eq. 1) or (K, 1080) one a beam (a head that turns while the
    mirror sweeps). Returns (K, 1080, 3)."""
    phi = np.asarray(head_rad, dtype=np.float64)
    if phi.ndim == 1:
        phi = phi[:, None]
    sin_t, cos_t = dm.sincos(elevation_angles_rad())
    sin_p, cos_p = dm.sincos(phi)
    dirs = np.empty((len(phi), BEAMS_PER_2D_SCAN, 3))
    dirs[:, :, 0] = cos_p * sin_t[None, :]
    dirs[:, :, 1] = sin_p * sin_t[None, :]
    dirs[:, :, 2] = cos_t[None, :]
    return dirs


def range_noise(sensor: SensorConfig, beam_count: int) -> np.ndarray:
    """Gaussian range noise per beam (zero bias, σ = noise_sigma) from the sensor's own seed.

    One draw per beam, hit or not, so a beam's noise depends only on the noise
    seed and its (n, m) — not on what the scene happens to contain. The draws are
    core.rng's (Marsaglia's polar method on detmath), the same on every machine.
    """
    if sensor.noise_sigma == 0:
        return np.zeros(beam_count)
    return sensor.noise_sigma * _standard_normals(int(sensor.noise_seed), beam_count)


@functools.lru_cache(maxsize=4)
def _standard_normals(seed: int, count: int) -> np.ndarray:
    """The noise seed's draws, kept: scans with the same seed (the default 0) reuse them."""
    z = seeded(seed).standard_normal(count)
    z.flags.writeable = False
    return z
