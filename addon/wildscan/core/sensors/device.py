"""A sensor device as data (numpy only): its beams, when they fire, its range limits, noise,
optics and mount. A device file (presets/*.toml, read by load.py) fills these; the scan
paths read them, never module constants.

Beams. One *column* of beams fires per step of the mount: for a 2D scanner on a rotating
head a column is one 2D scan (the UTM-30LX-EW's 1080 beams), for a spinning multi-beam
lidar one firing of its lasers. Beam i of a column points along

    Rz(ψ) · (sin θi, 0, cos θi),   ψ = the mount's angle for the column + αi

θi its angle from the mount's axis (+Z of the sensor frame; signed, in the plane at
azimuth αi) and αi its azimuth offset. The UTM-30LX-EW is a *planar fan*: θn = first +
n·step, every α 0 (Eq. 1). A multi-beam lidar lists θ (as elevation, 90° − θ) and α per
beam, and rings number its beams from the lowest elevation (0) up.

Mount: what turns the columns. `rotating`: the device on a head turning about the axis by
`step_deg` (r_h) a column, stepped or continuously, through `sweep_deg` a 3D scan (Eq. 1:
180°; the UTM-30LX-EW). `spinning`: the device turns itself about its axis, `step_deg` a
firing, through `sweep_deg` (360°: a Velodyne or Ouster revolution); the same arithmetic,
ψ = m·step. `fixed`: one column, nothing turns (a 2D scanner on a [head], say).

Head (optional): a rotating head carrying the whole device, as 3D-mapping payloads turn a
multi-beam lidar. The device's axis is tilted `tilt_deg` about the sensor's X axis, then the
head turns it about `axis` by `step_deg` per device sweep (one revolution of a spinning
lidar), stepped between sweeps or continuously (each beam at the head angle of its own
time), through the head's `sweep_deg` a 3D scan. A beam (sensor frame) is then

    Rot(axis, φ) · Rx(tilt) · Rz(ψ) · (sin θ, 0, cos θ)

The sensor frame stays the structure's (the paper's placement and leveling apply as they
are); without a head a device's beams are Rz(ψ) · (sin θ, 0, cos θ) exactly as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import UserError
from .detection import Detection

MOUNT_KINDS = ("rotating", "spinning", "fixed")
TURN_DIRECTIONS = ("ccw", "cw")
HEAD_MODES = ("stepped", "continuous")


@dataclass(frozen=True)
class BeamTable:
    """The beams of one column, in firing order (the order of every scan's arrays)."""

    from_axis_deg: tuple[float, ...]  # θ per beam: angle from the mount's axis
    azimuth_offset_deg: tuple[float, ...]  # α per beam
    ring: tuple[int, ...]  # the ring number written with each beam's points
    # a planar fan's (first, step) in degrees (θ = first + n·step), None for a beam table
    fan: tuple[float, float] | None = None

    @property
    def count(self) -> int:
        return len(self.from_axis_deg)

    @property
    def planar(self) -> bool:
        """Every beam in the one plane through the axis at the column's angle (no offsets):
        the fast path of beams.py, Eq. 1's arithmetic bit for bit."""
        return not any(self.azimuth_offset_deg)

    @property
    def elevation_deg(self) -> np.ndarray:
        """(count,) elevation above the plane normal to the axis, 90° − θ."""
        return 90.0 - np.asarray(self.from_axis_deg, dtype=np.float64)

    @property
    def blind_cone_half_angle_deg(self) -> float:
        """How close to straight down (−axis) the nearest beam comes."""
        return 180.0 - float(np.max(np.abs(self.from_axis_deg)))


@dataclass(frozen=True)
class Timing:
    """When beams fire: column k starts at k·column_period_s, beam i of it fires
    beam_step[i] steps of column_period_s / steps_per_column later."""

    column_period_s: float
    steps_per_column: int
    beam_step: tuple[int, ...]

    @property
    def step_interval_s(self) -> float:
        return self.column_period_s / self.steps_per_column

    @property
    def column_period_ns(self) -> int:
        """The period in whole nanoseconds (bag stamps), exact by the loader's check."""
        return round(self.column_period_s * 1e9)

    @property
    def field_time_s(self) -> float:
        """From the first beam of a column to just after its last."""
        return (max(self.beam_step) + 1) * self.step_interval_s


@dataclass(frozen=True)
class RangeLimits:
    min_m: float  # default shortest range kept
    max_m: float  # default longest range kept
    max_dark_m: float  # the device's longest range (in the dark): the limit of max_range


@dataclass(frozen=True)
class Noise:
    sigma_m: float  # the fixed σ of the paper model
    accuracy: tuple[tuple[float, float], ...]  # (up to this range m, ± m): the datasheet's
    accuracy_sigmas: float  # how many σ the datasheet's ± stands for


@dataclass(frozen=True)
class Optics:
    divergence_mrad: float  # full angle at 1/e^2, the realistic model's default
    echoes: int  # the most echoes a beam returns (the default, and the limit)
    echo_separation_m: float  # closer surfaces merge into one echo (default)
    # the return modes the device has (returns.py RETURN_MODES), its default, and what its dual
    # mode pairs (returns.py DUAL_PAIRS; None without a dual mode)
    returns: tuple[str, ...] = ("multi",)
    return_mode: str = "multi"
    dual: str | None = None


@dataclass(frozen=True)
class Mount:
    kind: str  # MOUNT_KINDS
    axis: tuple[float, float, float]  # the turning axis in the sensor frame
    tilt_deg: float  # the device's tilt on the mount
    step_deg: float  # default r_h: the turn per column
    min_step_deg: float  # finest r_h allowed
    sweep_deg: float  # the turn of one 3D scan
    heads: tuple[str, ...] = HEAD_MODES  # how the head may turn: stepped, continuous
    direction: str = "ccw"  # TURN_DIRECTIONS, seen from +Z: ccw (ψ = +φ, Eq. 1) or cw (ψ = −φ)


HEAD_TURNS = ("stepped", "continuous")


@dataclass(frozen=True)
class Head:
    axis: tuple[float, float, float]  # the head's turning axis in the sensor frame (unit)
    tilt_deg: float  # the device's axis tilted from the sensor's Z about its X axis
    step_deg: float  # the head's turn per device sweep
    sweep_deg: float  # the head's turn in one 3D scan
    turn: str  # HEAD_TURNS: stepped between device sweeps, or continuous

    @property
    def steps(self) -> int:
        """K, the device sweeps in one 3D scan (sweep / step, whole by the loader's check)."""
        return round(self.sweep_deg / self.step_deg)


@dataclass(frozen=True)
class Device:
    id: str  # "utm30lx-ew": the name a user asks for
    vendor: str
    model: str
    beams: BeamTable
    timing: Timing
    ranges: RangeLimits
    noise: Noise
    optics: Optics
    mount: Mount
    head: Head | None = None  # a rotating head carrying the device (None: none)
    source: str = ""  # where its numbers come from, in one line (`wildscan sensors` shows it)
    # the datasheet's (reflectance, range) pairs (detection.py); None: every surface returns to
    # the range limit (a user's device file without a [detection] table)
    detection: Detection | None = None

    @property
    def name(self) -> str:
        """How files name the device: "Hokuyo UTM-30LX-EW"."""
        return f"{self.vendor} {self.model}"

    @property
    def vertical_fov_deg(self) -> tuple[float, float]:
        """(lowest, highest) beam elevation above the plane normal to the axis, degrees."""
        elevation = self.beams.elevation_deg
        return float(elevation.min()), float(elevation.max())

    @property
    def sweep_period_s(self) -> float:
        """The time of one device sweep at its default step (a revolution of a spinning lidar,
        180 2D scans of the UTM-30LX-EW's head)."""
        columns = 1 if self.mount.kind == "fixed" else round(self.mount.sweep_deg / self.mount.step_deg)
        return columns * self.timing.column_period_s

    @property
    def columns_named(self) -> str:
        """What the device's columns are, in its own terms: the 2D scans of a scanner on a
        rotating head, the firing cycles of a spinning (or fixed) multi-beam lidar."""
        what = "2D scans" if self.mount.kind == "rotating" else "firing cycles"
        return f"{what} of the {self.model}"

    def check_scannable(self) -> "Device":
        """The device as the scan paths support it: its columns turn about the sensor's Z
        axis, untilted (a tilt or another axis is a [head]'s)."""
        mount = self.mount
        if mount.axis != (0.0, 0.0, 1.0) or mount.tilt_deg != 0:
            raise UserError(
                f"{self.id}: a {mount.kind} mount turns about [0, 0, 1] with tilt 0 (tilt or turn the "
                f"device with a [head] table), got {list(mount.axis)} with tilt {mount.tilt_deg:g}",
                setting="device",
            )
        return self
