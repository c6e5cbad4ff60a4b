"""The beam's footprint: the sub-rays that sample the UTM-30LX-EW's diverging beam (numpy only).

A laser beam is not a line: it leaves the scanner as a cone of full angle θ (the
divergence, at 1/e² of the peak intensity) whose Gaussian profile falls as
exp(−2r²/w²) with w = θ/2. Where part of that cone meets a leaf and the rest passes on
to a trunk, the scanner receives two pulses (two echoes); where it straddles an edge it
receives one blurred pulse between the two ranges (a mixed pixel). The footprint is
sampled by SUBRAYS = 5 sub-rays carrying equal shares of the beam's energy:

    the axis            the central disc holding 1/5 of the energy (radius 0.334 w)
    a ring of RING = 4  one per 90 deg quadrant of the rest, each at the radius that
                        halves its quadrant's energy (0.677 w), so each carries 1/5 too

Equal weights keep the energy bookkeeping exact: every echo's energy is a whole number
of fifths of the beam's, and `label_purity` is how many of them the labeled class took.
Why five and not more: casting is nearly all of a realistic scan's time (a sub-ray in a
forest crosses crowns of thousands of leaf clusters), and five keeps a full r_h = 1 deg
scan near the paper model's order of time while still splitting the footprint along both
of its axes. A divergence of 0 leaves the axis alone: the paper's thin ray, bit for bit.

The ring is laid out in each beam's own frame: u along the scan line (increasing θ,
from one beam of a 2D scan to the next), v along the head's rotation (increasing φ).

Deterministic math: the transcendental calls of this module are all in `_ring_layout`
(the pattern, once per divergence) and sensors/beams.py (the beams' sines and cosines,
once per device and r_h); everything else is products and sums.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from .. import detmath as dm
from ..sensors import DEFAULT_DEVICE, Device, beam_directions, sweep_count
from ..sensors.beams import beam_frames

RING = 4  # sub-rays around the axis, along +u, +v, -u, -v
SUBRAYS = 1 + RING
# Energy shares: the axis holds the central 1/SUBRAYS of the Gaussian, each ring sub-ray
# the median radius of one sector of the rest (see the module docstring).
_AXIS_ENERGY = 1.0 / SUBRAYS
_RING_MEDIAN_ENERGY = _AXIS_ENERGY + 0.5 * (1.0 - _AXIS_ENERGY)


def subray_count(divergence_mrad: float) -> int:
    """Sub-rays per beam: the axis alone for a thin beam, else the axis and the ring."""
    return 1 if divergence_mrad == 0 else SUBRAYS


def subray_weights(count: int) -> np.ndarray:
    """(S,) energy share of each of `count` sub-rays (equal; they sum to 1)."""
    return np.full(count, 1.0 / count)


def _ring_layout(divergence_mrad: float) -> tuple[float, float, np.ndarray, np.ndarray]:
    """The pattern's transcendentals: (cos, sin) of the ring's angle off the axis and the
    (cos, sin) of each ring sub-ray's direction around it, from u (the scan line) to v."""
    w = 0.5 * divergence_mrad * 1e-3  # 1/e^2 radius, radians
    # exp(-2 r^2 / w^2) = 1 - E  <=>  r = w sqrt(-ln(1 - E) / 2)
    off_axis = w * ring_radius_fraction()
    around = 2.0 * np.pi * np.arange(RING) / RING
    sin_around, cos_around = dm.sincos(around)
    return dm.cos(off_axis), dm.sin(off_axis), cos_around, sin_around


def ring_radius_fraction() -> float:
    """The ring's angle off the axis as a fraction of the 1/e^2 radius w (0.677)."""
    return math.sqrt(-dm.log(1.0 - _RING_MEDIAN_ENERGY) / 2.0)


def subray_directions(rh_deg: float, divergence_mrad: float, device: Device = DEFAULT_DEVICE) -> np.ndarray:
    """(S, N, 3) unit directions of every beam's sub-rays in the sensor frame, sub-ray-major
    (all axes, then every beam's first ring sub-ray...), beams in the order of
    sensors.beam_directions(rh_deg, device); sub-ray 0 is the axis, that beam's direction
    bit for bit. The ring's u and v are sensors.beams.beam_frames'. Cached (a few scans
    share them) and read-only."""
    m_count = sweep_count(rh_deg, device.mount)
    return _subray_directions(device, float(rh_deg), m_count, float(divergence_mrad))


@functools.lru_cache(maxsize=2)
def _subray_directions(device: Device, rh_deg: float, m_count: int, divergence_mrad: float) -> np.ndarray:
    dirs = beam_directions(rh_deg, device)[0]
    if subray_count(divergence_mrad) == 1:
        out = dirs[None].copy()
    else:
        out = subrays_around(dirs, *beam_frames(device, rh_deg, m_count), divergence_mrad)
    out.flags.writeable = False
    return out


def ring_columns(rh_deg: float, divergence_mrad: float, device: Device = DEFAULT_DEVICE):
    """The x, y and z components of subray_directions' ring sub-rays (rows 1..), each an
    (S - 1, N) contiguous array: what turning them into the world takes, gathered once (the
    strided gather of the three components took two thirds of the turn). Cached, read-only."""
    m_count = sweep_count(rh_deg, device.mount)
    return _ring_columns(device, float(rh_deg), m_count, float(divergence_mrad))


@functools.lru_cache(maxsize=2)
def _ring_columns(device: Device, rh_deg: float, m_count: int, divergence_mrad: float):
    ring = _subray_directions(device, rh_deg, m_count, divergence_mrad)[1:]
    columns = tuple(np.ascontiguousarray(ring[..., k]) for k in range(3))
    for c in columns:
        c.flags.writeable = False
    return columns


def turn_rings(rotation: np.ndarray, columns, out: np.ndarray, beams: slice = slice(None)) -> None:
    """out[:, beams] = the ring sub-rays (`ring_columns`) of beams `beams` turned by `rotation`:
    detmath.apply's products and sums ((m_i0 x + m_i1 y) + m_i2 z), the same bits."""
    m = np.asarray(rotation, dtype=np.float64)
    x, y, z = (c[:, beams] for c in columns)
    for i in range(3):
        component = x * m[i, 0]
        component += y * m[i, 1]
        component += z * m[i, 2]
        out[:, beams, i] = component


def subrays_around(dirs: np.ndarray, e_u: np.ndarray, e_v: np.ndarray, divergence_mrad: float) -> np.ndarray:
    """(S, N, 3) sub-ray directions around beams `dirs` (N, 3) whose footprints' u and v axes
    are the unit vectors e_u, e_v (N, 3), all three orthonormal; sub-ray 0 is `dirs`.
    Sub-ray-major: each sub-ray's beams are contiguous, so per-beam sums over sub-rays are
    sums of rows."""
    dirs = np.asarray(dirs, dtype=np.float64)
    if subray_count(divergence_mrad) == 1:
        return dirs[None].copy()
    cos_a, sin_a, cos_b, sin_b = _ring_layout(divergence_mrad)
    out = np.empty((SUBRAYS, len(dirs), 3))
    out[0] = dirs
    for k in range(RING):
        out[1 + k] = cos_a * dirs + sin_a * (cos_b[k] * e_u + sin_b[k] * e_v)
    return out
