"""When each beam is measured and where the head points then (numpy only).

A device's timing (sensors/device.py `Timing`) says it: column k (a 2D scan) starts at
k * column_period_s and its beam i fires beam_step[i] steps of column_period_s /
steps_per_column later. The Hokuyo UTM-30LX-EW (the default, presets/utm30lx-ew.toml)
turns its mirror at 40 Hz: one 2D scan every SCAN_PERIOD (25 ms), 1440 steps of 0.25 deg a
turn, of which the 1080 beams of the 270 deg field take 1080/1440 of the period (18.75 ms;
the rest of the turn faces the scanner's housing). So beam n of 2D scan k, counting 2D scans
from the start of the drive, is measured at

    t = k * SCAN_PERIOD + n * BEAM_INTERVAL,     BEAM_INTERVAL = SCAN_PERIOD / 1440 (17.4 us)

The head (the column that turns the 2D scanner about its vertical axis) advances r_h per
2D scan, in one of two ways:

    stepped     as Eq. (1): still at k * r_h while 2D scan k sweeps, stepping between scans
    continuous  turning steadily at r_h per period: beam n of 2D scan k is at r_h * (k + n/1440)

A 3D scan is one half-turn of the head, M = 180 / r_h consecutive 2D scans: 3D scan j is
2D scans jM ... jM + M - 1. The head keeps turning the same way (as Andabata's does), so
3D scan j starts at j * 180 deg; for j = 0 every beam is exactly Eq. (1)'s.
"""

from __future__ import annotations

import numpy as np

from .. import detmath as dm
from ..checks import one_of
from ..sensors import DEFAULT_DEVICE
from ..sensors.device import HEAD_MODES, Timing

_T = DEFAULT_DEVICE.timing
# The default device's timing, by the names the drive has always used
SCAN_PERIOD = _T.column_period_s  # s, one 2D scan (40 Hz)
STEPS_PER_TURN = _T.steps_per_column  # mirror steps in one turn (0.25 deg each)
BEAM_INTERVAL = _T.step_interval_s  # s between neighbouring beams
FIELD_SWEEP_TIME = _T.field_time_s  # 18.75 ms: the 270 deg field


def check_head(mode: str, heads: tuple[str, ...] = HEAD_MODES) -> str:
    return one_of(mode, "head", heads)


def beam_fractions(timing: Timing = _T) -> np.ndarray:
    """(N,) how far into its column's period each beam is measured (0 ... 0.749)."""
    return np.asarray(timing.beam_step, dtype=np.float64) / timing.steps_per_column


def beam_times(k: np.ndarray, since: int = 0, timing: Timing = _T) -> np.ndarray:
    """(K, N) time of every beam of 2D scans k, in seconds after the start of 2D scan
    `since` (the drive's start by default, a 3D scan's first 2D scan for its points)."""
    steps = (np.asarray(k, dtype=np.int64) - since)[:, None] * timing.steps_per_column
    return (steps + np.asarray(timing.beam_step, dtype=np.int64)) * timing.step_interval_s


def head_angles_rad(k: np.ndarray, rh_deg: float, mode: str, timing: Timing = _T) -> np.ndarray:
    """Head angle of 2D scans k: (K,) for the stepped head (Eq. 1's m * r_h, counted on from
    the drive's start), (K, N) one per beam for the continuous head."""
    k = np.asarray(k, dtype=np.float64)
    if check_head(mode) == "stepped":
        return dm.deg2rad(k * rh_deg)
    return dm.deg2rad((k[:, None] + beam_fractions(timing)[None, :]) * rh_deg)
