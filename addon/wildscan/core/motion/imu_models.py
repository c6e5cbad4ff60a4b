"""IMU models from datasheets, and their errors on the exact readings (numpy only).

Each axis of the gyroscope and of the accelerometer reads

    measured = true + b0 + b(t) + n

    b0    a constant (turn-on) bias, drawn once per axis: N(0, turn_on)
    b(t)  a bias random walk from 0: every sample adds N(0, K^2 dt), K = stability / sqrt(1 h),
          so its 1-sigma wander reaches the datasheet's in-run bias stability after an hour
          (the stability is the Allan-deviation floor; a datasheet gives no random-walk
          coefficient, and one hour is the span those floors are quoted over: this rule is
          ours, the stability is the datasheet's)
    n     white noise, N(0, density^2 * rate): the datasheet's noise density (or its angular
          / velocity random walk, the same quantity in per-root-hour units) sampled at `rate`

(the discrete form of the continuous model Kalibr and OpenVINS use: J. Rehder et al.,
"Extending kalibr", ICRA 2016; ethz-asl/kalibr wiki "IMU Noise Model"). Draws come from one
generator seeded from the drive's noise seed and the stage "drive.imu", in a fixed order:
turn-on biases, then the walks, then the white noise: the same seed gives the same bytes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..checks import one_of
from ..errors import UserError
from ..rng import stage_rng
from .imu import ImuMount

G = 9.80665  # m/s^2 per g (imu.GRAVITY): datasheets give accelerometer figures in g
DEG = math.pi / 180
HOUR = 3600.0  # s
WANDER_SPAN = HOUR  # s over which the bias walk's 1-sigma wander equals the in-run stability
MIN_RATE, MAX_RATE = 1, 2000  # Hz: the BMI088's gyro output data rate goes to 2 kHz (DS001 5.5.5)
DEFAULT_RATE = 200  # Hz


@dataclass(frozen=True)
class ImuModel:
    """An IMU's error figures, SI units, one sigma per axis."""

    name: str
    title: str
    gyro_noise: float  # rad/s/sqrt(Hz)
    gyro_stability: float  # rad/s, in-run bias stability
    gyro_turn_on: float  # rad/s, constant bias
    accel_noise: float  # m/s^2/sqrt(Hz)
    accel_stability: float  # m/s^2 (0: the datasheet gives none; no walk)
    accel_turn_on: float  # m/s^2
    source: str

    def white_sigmas(self, rate_hz: float) -> tuple[float, float]:
        """(gyro, accel) sigma of one sample's white noise at `rate_hz`."""
        root = math.sqrt(rate_hz)
        return self.gyro_noise * root, self.accel_noise * root

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "title": self.title,
            "gyro_noise_density_rad_s_sqrt_hz": self.gyro_noise,
            "gyro_bias_stability_rad_s": self.gyro_stability,
            "gyro_turn_on_bias_rad_s": self.gyro_turn_on,
            "accel_noise_density_m_s2_sqrt_hz": self.accel_noise,
            "accel_bias_stability_m_s2": self.accel_stability,
            "accel_turn_on_bias_m_s2": self.accel_turn_on,
            "source": self.source,
        }


# Bosch Sensortec BMI088 data sheet (BST-BMI088-DS001, rev. 1.x, table "gyroscope" and
# "accelerometer" specifications, typical values): rate noise density 0.014 deg/s/sqrt(Hz),
# zero-rate offset +-1 deg/s, bias stability 2 deg/h; accelerometer noise density
# 175 ug/sqrt(Hz), zero-g offset +-20 mg. It states no in-run accelerometer bias stability,
# so the accelerometer's bias is its constant offset alone.
BMI088 = ImuModel(
    name="bmi088",
    title="Bosch BMI088 (consumer MEMS)",
    gyro_noise=0.014 * DEG,
    gyro_stability=2.0 * DEG / HOUR,
    gyro_turn_on=1.0 * DEG,
    accel_noise=175e-6 * G,
    accel_stability=0.0,
    accel_turn_on=20e-3 * G,
    source="Bosch Sensortec BMI088 data sheet BST-BMI088-DS001 (typical values)",
)

# Analog Devices ADIS16495-1 data sheet (rev. C, features and table 1): angular random walk
# 0.09 deg/sqrt(h), in-run bias stability 0.8 deg/h; accelerometer in-run bias stability
# 3.2 ug, velocity random walk 0.008 m/s/sqrt(h). It is factory calibrated for bias, so its
# constant bias is taken at the in-run stability (our assumption).
ADIS16495 = ImuModel(
    name="adis16495",
    title="Analog Devices ADIS16495-1 (tactical grade)",
    gyro_noise=0.09 * DEG / math.sqrt(HOUR),
    gyro_stability=0.8 * DEG / HOUR,
    gyro_turn_on=0.8 * DEG / HOUR,
    accel_noise=0.008 / math.sqrt(HOUR),
    accel_stability=3.2e-6 * G,
    accel_turn_on=3.2e-6 * G,
    source="Analog Devices ADIS16495 data sheet, rev. C (ADIS16495-1)",
)

MODELS: dict[str, ImuModel] = {m.name: m for m in (BMI088, ADIS16495)}
IMU_CHOICES = (*MODELS, "none")
DEFAULT_IMU = "bmi088"

# The IMU on the robot's chassis (our choice, not Andabata's drawing): 0.15 m behind the
# column, 0.35 m above where it meets the ground, axes along base_link's (x ahead, z up).
DEFAULT_MOUNT = ImuMount((-0.15, 0.0, 0.35), np.eye(3))


def check_imu(name: str) -> str:
    return one_of(name, "imu", IMU_CHOICES)


def check_rate(rate) -> int:
    if isinstance(rate, bool) or not isinstance(rate, (int, np.integer)) or not MIN_RATE <= rate <= MAX_RATE:
        raise UserError(
            f"must be a whole number of hertz from {MIN_RATE} to {MAX_RATE}, got {rate}",
            setting="imu_rate",
            allowed=(MIN_RATE, MAX_RATE),
        )
    return int(rate)


def with_errors(
    gyro: np.ndarray, accel: np.ndarray, rate_hz: int, model: ImuModel, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """The readings an IMU of `model` gives for the exact (n, 3) `gyro` and `accel`."""
    rng = stage_rng(seed, "drive.imu")
    n = len(gyro)
    turn_on = rng.standard_normal(6) * np.repeat([model.gyro_turn_on, model.accel_turn_on], 3)
    step = math.sqrt(1.0 / rate_hz / WANDER_SPAN)  # K sqrt(dt) per unit of stability
    stability = np.repeat([model.gyro_stability, model.accel_stability], 3)
    walk = np.cumsum(rng.standard_normal((n, 6)) * (stability * step), axis=0)
    white = rng.standard_normal((n, 6)) * np.repeat(model.white_sigmas(rate_hz), 3)
    error = (walk + turn_on) + white
    return gyro + error[:, :3], accel + error[:, 3:]
