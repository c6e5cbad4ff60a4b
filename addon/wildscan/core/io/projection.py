"""The spherical projection a dataset's labels.yaml ships for semantic-kitti-api (numpy only).

semantic-kitti-api's `LaserScan`/`SemLaserScan(project=True, H, W, fov_up, fov_down)`
(auxiliary/laserscan.py, github.com/PRBonn/semantic-kitti-api) turns a scan into an H x W
image: column x = floor(W · (1 − yaw/π) / 2) over the full turn, row y = floor(H · (1 −
(pitch − fov_down)/(fov_up − fov_down))), both clamped into the image; a pixel keeps the
nearest of its points. With its defaults (64 x 1024, +3° to −25°: an HDL-64E) a UTM-30LX-EW
scan, which sees from 45° below the horizon to the zenith, keeps about a fifth of its points:
the rest fall outside the field of view and pile up on the border rows.

`projection_for` chooses the four numbers from the device: the field of view its beams
span (plus, in the leveled frame, the most the robot may tilt: placement.MAX_TILT_DEG, by
which Eq. 2 turns the beams), and pixels `k` times finer than the beams' own spacing (the
vertical gap between beam elevations, the head's turn r_h across). k is the smallest of
OVERSAMPLING whose projection keeps PROBE_KEPT of the scan's beams in the sensor frame,
where beam (n, m) lies at yaw φm and pitch 90° − |θn|, on the beams' own grid: k = 1 would
put them on pixel borders, where float rounding decides, so k starts at 2. In the leveled
frame the sensor's zenith moves off the image's top row and the beams that converge on it
share pixels: the scans measured (tests/test_rangeimage_dataset.py) keep over 99.8 %.

A scan in the world frame has no projection (its points are not around the sensor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..placement import MAX_TILT_DEG
from ..sensors import Device, beam_directions

OVERSAMPLING = (2, 3, 4)  # pixels per beam spacing, tried in this order (4: ~5 M pixels for a Hokuyo)
PROBE_KEPT = 0.995  # share of a sensor-frame scan's beams the chosen projection must keep
DECIMALS = 6  # of the field of view written (degrees)


@dataclass(frozen=True)
class Projection:
    """semantic-kitti-api's projection parameters: `LaserScan(project=True, **p.to_dict())`."""

    H: int  # rows
    W: int  # columns
    fov_up: float  # degrees above the horizon of the top row's upper edge
    fov_down: float  # degrees (negative below the horizon) of the bottom row's lower edge
    # the share of an untilted scan's beams it keeps (projection_for's probe; 1.0: not probed)
    kept: float = 1.0

    def to_dict(self) -> dict:
        """The four parameters, named as LaserScan's arguments."""
        return {"H": self.H, "W": self.W, "fov_up": self.fov_up, "fov_down": self.fov_down}


def spherical_cells(xyz: np.ndarray, p: Projection) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) of each point under projection `p`, by semantic-kitti-api's formula
    (LaserScan.do_range_projection)."""
    xyz = np.asarray(xyz, dtype=np.float64)
    depth = np.linalg.norm(xyz, axis=1)
    yaw = -np.arctan2(xyz[:, 1], xyz[:, 0])
    pitch = np.arcsin(xyz[:, 2] / (depth + 1e-8))
    up, down = math.radians(p.fov_up), math.radians(p.fov_down)
    x = np.floor(0.5 * (yaw / np.pi + 1.0) * p.W)
    y = np.floor((1.0 - (pitch + abs(down)) / (abs(down) + abs(up))) * p.H)
    return np.clip(y, 0, p.H - 1).astype(np.int64), np.clip(x, 0, p.W - 1).astype(np.int64)


def kept_share(xyz: np.ndarray, p: Projection) -> float:
    """The share of the points that keep a pixel of their own under projection `p`."""
    if not len(xyz):
        return 1.0
    row, column = spherical_cells(xyz, p)
    return len(np.unique(row * p.W + column)) / len(xyz)


def beam_pitch_step_deg(device: Device) -> float:
    """The smallest gap between the elevations of a device's beams, degrees (the UTM-30LX-EW:
    r_v, its beams at 90° − |θn| either side of the zenith)."""
    dirs = beam_directions(device.mount.step_deg, device)[0][: device.beams.count]
    pitch = np.unique(np.round(np.degrees(np.arcsin(np.clip(dirs[:, 2], -1.0, 1.0))), DECIMALS))
    return float(np.min(np.diff(pitch))) if len(pitch) > 1 else 1.0


def projection_for(device: Device, rh_deg: float, frame: str) -> Projection | None:
    """The projection that keeps a scan of `device` at r_h = `rh_deg` in `frame` whole (module
    doc); None in the world frame."""
    if frame == "world":
        return None
    dirs = beam_directions(rh_deg, device)[0]
    pitch = np.degrees(np.arcsin(np.clip(dirs[:, 2], -1.0, 1.0)))
    tilt = MAX_TILT_DEG if frame == "leveled" else 0.0
    top, bottom = min(90.0, float(pitch.max()) + tilt), max(-90.0, float(pitch.min()) - tilt)
    step = beam_pitch_step_deg(device)
    probe = dirs.astype(np.float32)  # as a .bin stores the points
    for k in OVERSAMPLING:
        p = _grid(top, bottom, step / k, rh_deg / k)
        kept = kept_share(probe, p)
        if kept >= PROBE_KEPT:
            break
    return replace(p, kept=round(kept, 4))


def _grid(top: float, bottom: float, pitch_cell: float, yaw_cell: float) -> Projection:
    """Rows of `pitch_cell` from half a cell above `top` to half a cell below `bottom` (so the
    beams of a sensor-frame scan sit at pixel centres), columns of `yaw_cell` round the turn."""
    up, down = top + pitch_cell / 2, bottom - pitch_cell / 2
    rows = max(1, round((up - down) / pitch_cell))
    return Projection(rows, math.ceil(360.0 / yaw_cell - 1e-9), round(up, DECIMALS), round(down, DECIMALS))


def combined(projections: list[Projection]) -> Projection | None:
    """One projection for scans of several settings (a dataset's drawn r_h, devices): the
    widest field of view at the finest pixels of any."""
    if not projections:
        return None
    up = max(p.fov_up for p in projections)
    down = min(p.fov_down for p in projections)
    pitch_cell = min((p.fov_up - p.fov_down) / p.H for p in projections)
    rows, columns = max(1, round((up - down) / pitch_cell)), max(p.W for p in projections)
    return Projection(rows, columns, up, down, min(p.kept for p in projections))
