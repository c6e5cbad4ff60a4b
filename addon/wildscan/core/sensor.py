"""The emulated 3D laser rangefinder of Andabata: a Hokuyo UTM-30LX-EW 2D scanner
turned 180° about its vertical axis (paper section II, Eq. 1). Numpy only.

Sensor frame: origin at the optical centre, Z along the column (up), X along
the structure's X arm (the heading). Beam n of 2D scan m points along

    Rz(m·r_h) · (sin θn, 0, cos θn),   θn = n·r_v − 135°   (angle from the column)

so n = 0 looks 45° away from straight down behind, n = 540 straight up, and the
90° wedge around −Z is never scanned (the blind cone).

Two sensor models share these beams (`SensorConfig.model`):

  paper       the paper's emulation: one infinitely thin ray per beam, its first hit is the
              point, intensity is the element's Table I reflectivity (which carries the
              label), Gaussian range noise of 1.5 cm. The default; its files never change.
  realistic   the beam as the UTM-30LX-EW sends it (core/footprint.py, core/echoes.py):
              a footprint of `divergence_mrad` sampled by sub-rays, up to `echoes`
              echoes split `echo_separation` apart (closer surfaces merge into one mixed
              pixel), intensity from reflectivity, incidence and range, and the
              datasheet's range accuracy as noise (`datasheet_sigma`).

Realistic settings and where their values come from
---------------------------------------------------
Range accuracy: the UTM-30LX-EW datasheet gives ±30 mm from 0.1 to 10 m and ±50 mm
from 10 to 30 m (Hokuyo, "Scanning range finder UTM-30LX-EW" specification,
https://www.hokuyo-aut.jp/02sensor/07scanner/download/pdf/UTM-30LX-EW_spec_en.pdf). We
read ± as a 95 % bound, two standard deviations: σ = 15 mm up to 10 m (exactly the
paper's 1.5 cm, which its authors took for the same sensor) and σ = 25 mm beyond.

Beam divergence: the datasheet states none. The default, 4.4 mrad (0.25°, full angle
at 1/e²), is an estimate: scanners of this class size the spot to cover one angular
step so that consecutive footprints leave no gap (SICK's LMS1xx operating instructions
state that rule and give 15 mrad for the LMS1xx, section 3.6.2; the TiM4xx instructions
give 8.6 mrad, section 3.6.4), and the UTM-30LX-EW's step is 0.25°. It is a setting: 0
gives the paper's thin ray.

Echo separation: the multi-echo receiver separates two returns whose ranges differ by
more than the pulse can resolve, about c·τ/2 for a pulse of width τ; the datasheet gives
no pulse width. The default 0.3 m stands for a 2 ns pulse, typical of 905 nm pulsed
diodes of this size; surfaces closer than it merge into one range between them.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from . import detmath as dm
from .checks import one_of
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

MODELS = ("paper", "realistic")
DEFAULT_MODEL = "paper"
DEFAULT_DIVERGENCE_MRAD = 4.4  # full angle at 1/e^2; an estimate (module docstring)
MAX_DIVERGENCE_MRAD = 50.0  # ~3 deg: far wider than any scanning rangefinder's beam
MAX_ECHOES = 3  # the UTM-30LX-EW's multi-echo
DEFAULT_ECHO_SEPARATION = 0.3  # m, ~ c * 2 ns / 2 (module docstring)
MAX_ECHO_SEPARATION = 10.0  # m
# The datasheet's range accuracy: (up to this range in m, +- metres), read as 2 sigma.
DATASHEET_ACCURACY = ((10.0, 0.030), (MAX_RANGE_LIMIT, 0.050))
ACCURACY_SIGMAS = 2.0


@dataclass(frozen=True)
class SensorConfig:
    rh_deg: float = DEFAULT_RH_DEG
    min_range: float = DEFAULT_MIN_RANGE
    max_range: float = DEFAULT_MAX_RANGE
    # m; None: the model's own noise (paper: 0.015 m; realistic: the datasheet's, by range)
    noise_sigma: float | None = None
    noise_seed: int = 0
    model: str = DEFAULT_MODEL
    # the realistic model's own settings (the paper model has a thin ray and one echo)
    divergence_mrad: float = DEFAULT_DIVERGENCE_MRAD
    echoes: int = MAX_ECHOES
    echo_separation: float = DEFAULT_ECHO_SEPARATION

    @property
    def realistic(self) -> bool:
        return self.model == "realistic"

    @property
    def fixed_noise(self) -> float | None:
        """The one σ of every range (metres), or None when σ depends on the range (the
        realistic model's datasheet noise)."""
        if self.noise_sigma is not None:
            return self.noise_sigma
        return None if self.realistic else DEFAULT_NOISE_SIGMA

    @property
    def max_noise_sigma(self) -> float:
        """The largest σ any range gets: how far past max range rays are cast."""
        fixed = self.fixed_noise
        return fixed if fixed is not None else DATASHEET_ACCURACY[-1][1] / ACCURACY_SIGMAS

    @property
    def sweeps(self) -> int:
        """M, the number of 2D scans in a 180° turn."""
        return sweep_count(self.rh_deg)

    @property
    def beam_count(self) -> int:
        return BEAMS_PER_2D_SCAN * self.sweeps

    def validate(self) -> "SensorConfig":
        sweep_count(self.rh_deg)
        one_of(self.model, "model", MODELS)
        _check_finite("min_range", self.min_range, "m")
        _check_finite("max_range", self.max_range, "m")
        if self.noise_sigma is not None:
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
        if self.noise_sigma is not None and not 0 <= self.noise_sigma <= MAX_NOISE_SIGMA:
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
        self._validate_realistic()
        return self

    def _validate_realistic(self) -> None:
        _check_finite("divergence", self.divergence_mrad, "mrad")
        if not 0 <= self.divergence_mrad <= MAX_DIVERGENCE_MRAD:
            raise UserError(
                f"must be from 0 (a thin ray) to {MAX_DIVERGENCE_MRAD:g} mrad, got {self.divergence_mrad:g}",
                setting="divergence",
                allowed=(0, MAX_DIVERGENCE_MRAD),
            )
        if isinstance(self.echoes, bool) or not isinstance(self.echoes, int) or not 1 <= self.echoes <= 3:
            raise UserError(
                f"must be a whole number from 1 to {MAX_ECHOES}, got {self.echoes!r}",
                setting="echoes",
                allowed=(1, MAX_ECHOES),
            )
        _check_finite("echo_separation", self.echo_separation, "m")
        if not 0 < self.echo_separation <= MAX_ECHO_SEPARATION:
            raise UserError(
                f"must be in (0, {MAX_ECHO_SEPARATION:g}] m, got {self.echo_separation:g}",
                setting="echo_separation",
                allowed=(0, MAX_ECHO_SEPARATION),
            )

    def to_dict(self) -> dict:
        """The sensor as file headers and sidecars state it. A paper-model scan says exactly
        what it said before the realistic model existed (so its files stay byte for byte
        the same): a sensor without `scan_model` is the paper model."""
        d = {
            "rh_deg": self.rh_deg,
            "min_range": self.min_range,
            "max_range": self.max_range,
            "noise_sigma": self.fixed_noise,
            "noise_seed": self.noise_seed,
            "model": "Hokuyo UTM-30LX-EW",
            "rv_deg": R_V_DEG,
            "beams_per_2d_scan": BEAMS_PER_2D_SCAN,
            "sweeps": self.sweeps,
        }
        if self.realistic:
            d.update(
                scan_model=self.model,
                divergence_mrad=self.divergence_mrad,
                echoes=self.echoes,
                echo_separation=self.echo_separation,
                noise_model="fixed" if self.noise_sigma is not None else "datasheet",
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
    """Gaussian range noise per beam (zero bias, σ = the fixed noise) from the sensor's own
    seed (the paper model).

    One draw per beam, hit or not, so a beam's noise depends only on the noise
    seed and its (n, m) — not on what the scene happens to contain. The draws are
    core.rng's (Marsaglia's polar method on detmath), the same on every machine.
    """
    sigma = sensor.fixed_noise
    if sigma == 0:
        return np.zeros(beam_count)
    return sigma * _standard_normals(int(sensor.noise_seed), beam_count)


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


def datasheet_sigma(true_range: np.ndarray) -> np.ndarray:
    """σ of the range noise by range, from the datasheet's accuracy (±30 mm to 10 m, ±50 mm
    beyond) read as 2σ: 0.015 m up to 10 m, 0.025 m beyond."""
    (near, near_pm), (_, far_pm) = DATASHEET_ACCURACY
    r = np.asarray(true_range, dtype=np.float64)
    return np.where(r <= near, near_pm / ACCURACY_SIGMAS, far_pm / ACCURACY_SIGMAS)


def range_sigma(sensor: SensorConfig, true_range: np.ndarray) -> np.ndarray:
    """σ of each range's noise: the fixed one, or the datasheet's by range."""
    fixed = sensor.fixed_noise
    if fixed is not None:
        return np.full(np.shape(true_range), fixed)
    return datasheet_sigma(true_range)
