"""Beam directions of a device (numpy only): Eq. 1 for the UTM-30LX-EW, and any beam table.

Beam i of column m points along Rz(ψ) · (sin θi, 0, cos θi), ψ = φm + αi (device.py). The
sines and cosines are detmath's (np.sin is the C library's, which differs by CPU), taken
once per beam (θ) and once per column (φ), then multiplied in a fixed order: the same bits
on every machine. A planar table (every α 0, the UTM-30LX-EW's fan) keeps ψ = φm, one
angle a column, which is Eq. 1's arithmetic exactly; a table with offsets takes one ψ a
beam and column. Either way the head's sines and cosines come as (M, 1) or (M, N) arrays
that broadcast against the beams' (N,).

A device on a [head] (device.py) has those M columns once per head step: its beams are
tilted, then turned about the head's axis by Rodrigues' formula, elementwise in a fixed
order (no BLAS), K device sweeps one after the other. Without a head nothing here changes.
"""

from __future__ import annotations

import functools

import numpy as np

from .. import detmath as dm
from ..errors import UserError
from .config import column_count, sweep_count
from .device import BeamTable, Device
from .load import DEFAULT_DEVICE


def from_axis_rad(beams: BeamTable) -> np.ndarray:
    """θ of each beam, radians: for the UTM-30LX-EW θn = n·r_v − 135° (Eq. 1)."""
    return dm.deg2rad(np.asarray(beams.from_axis_deg, dtype=np.float64))


@functools.lru_cache(maxsize=8)
def _beam_sincos(beams: BeamTable) -> tuple[np.ndarray, np.ndarray]:
    return dm.sincos(from_axis_rad(beams))


def _psi_sincos(device: Device, phi_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sin and cos of ψ for head angles `phi_rad`: (K,) one a column or (K, N) one a beam,
    returned (K, 1) or (K, N) to broadcast against the beams. A mount turning clockwise
    (seen from +Z, as Velodyne and Ouster lidars spin) turns by −φ; its beams' offsets stay."""
    beams = device.beams
    phi = np.asarray(phi_rad, dtype=np.float64)
    if phi.ndim == 1:
        phi = phi[:, None]
    if device.mount.direction == "cw":
        phi = -phi
    if not beams.planar:
        phi = phi + dm.deg2rad(np.asarray(beams.azimuth_offset_deg, dtype=np.float64))[None, :]
    return dm.sincos(phi)


@functools.lru_cache(maxsize=8)
def beam_angles(device: Device, rh_deg: float, m_count: int):
    """(sin θ (N,), cos θ (N,), sin ψ, cos ψ ((M, 1) or (M, N))), φm = m·r_h, cached."""
    sin_t, cos_t = _beam_sincos(device.beams)
    sin_p, cos_p = _psi_sincos(device, dm.deg2rad(np.arange(m_count, dtype=np.float64) * rh_deg))
    return sin_t, cos_t, sin_p, cos_p


def beam_directions(rh_deg: float, device: Device = DEFAULT_DEVICE):
    """Unit beam directions of a full 3D scan in the sensor frame (Eq. 1 with ρ = 1).

    Returns (dirs (N,3) float64, ring (N,) uint16, column m (N,) uint16), column-major: all
    beams of column 0, then of column 1, … Cached per (device, r_h) and read-only.
    """
    return _beam_directions(device, float(rh_deg), sweep_count(rh_deg, device.mount))


@functools.lru_cache(maxsize=8)
def _beam_directions(device: Device, rh_deg: float, m_count: int):
    sin_t, cos_t, sin_p, cos_p = beam_angles(device, rh_deg, m_count)
    n = device.beams.count
    dirs = np.empty((m_count, n, 3))
    dirs[:, :, 0] = cos_p * sin_t[None, :]
    dirs[:, :, 1] = sin_p * sin_t[None, :]
    dirs[:, :, 2] = cos_t[None, :]
    ring = np.tile(np.asarray(device.beams.ring, dtype=np.uint16), m_count)
    column = np.repeat(np.arange(m_count, dtype=np.uint16), n)
    dirs = dirs.reshape(-1, 3)
    if device.head is not None:  # the same sweep once per head step, turned by the head
        dirs = turned_by_head(device, dirs, m_count)
        ring, column = np.tile(ring, device.head.steps), np.tile(column, device.head.steps)
    arrays = (dirs, ring, column)
    for a in arrays:
        a.flags.writeable = False
    return arrays


def rotated_beam_directions(
    rotation: np.ndarray, rh_deg: float, device: Device = DEFAULT_DEVICE
) -> np.ndarray:
    """The beams of `beam_directions(rh_deg, device)` turned by `rotation` (3x3; the
    placement's sensor -> world), (N, 3) float64 in the same order.

    Beam (i, m) is R·Rz(ψ)·(sin θi, 0, cos θi) = a sin θi + R[:, 2] cos θi with
    a = R[:, 0] cos ψ + R[:, 1] sin ψ: three products a beam in a fixed order, where
    R @ dirs would take nine and let the BLAS kernel (so the CPU) choose their order. A
    device on a head: each turned beam's three products, in the same fixed order."""
    if device.head is not None:
        return _rotated(rotation, beam_directions(rh_deg, device)[0])
    m_count = sweep_count(rh_deg, device.mount)
    sin_t, cos_t, sin_p, cos_p = beam_angles(device, float(rh_deg), m_count)
    r = np.asarray(rotation, dtype=np.float64)
    out = np.empty((m_count, device.beams.count, 3))
    component = np.empty(out.shape[:2])  # computed contiguous, then summed into place
    for i in range(3):
        a = cos_p * r[i, 0] + sin_p * r[i, 1]
        np.multiply(a, sin_t[None, :], out=component)
        np.add(component, r[i, 2] * cos_t, out=out[:, :, i])
    return out.reshape(-1, 3)


def rotated_beams(
    rotation: np.ndarray, rh_deg: float, device: Device, beams: np.ndarray, ranges: np.ndarray | None = None
) -> np.ndarray:
    """Rows `beams` (indices, column-major) of `rotated_beam_directions(rotation, rh_deg,
    device)`, the same bits, computed for those beams alone: a scan's points need the
    directions of the beams that returned one (a third of a Hokuyo scan's), each from the
    same products in the same order. With `ranges` (one a beam): each direction times its
    range, the points (the same products as `rotated_beams(...) * ranges[:, None]`)."""
    beams = np.asarray(beams, dtype=np.intp)
    if device.head is not None:
        out = _rotated(rotation, beam_directions(rh_deg, device)[0][beams])
        return out if ranges is None else out * ranges[:, None]
    m_count = sweep_count(rh_deg, device.mount)
    sin_t, cos_t, sin_p, cos_p = beam_angles(device, float(rh_deg), m_count)
    planar = sin_p.shape[1] == 1  # one ψ a column (gathered after), or one a beam (before)
    # (making every beam's direction and gathering the rows asked for took 1.6x longer, even
    # for an HDL-64E scan's 88 % of its beams: strided writes, the rows' gather)
    # each beam's column and its place in it read from tables made once per device and r_h
    # (gathers), where divmod's integer division took a third of the work
    column, beam = (table.take(beams) for table in _beam_index(device, float(rh_deg), m_count))
    if not planar:
        sin_p, cos_p = sin_p.ravel().take(beams)[:, None], cos_p.ravel().take(beams)[:, None]
    st, ct = sin_t.take(beam), cos_t.take(beam)  # r cos θ of each beam is r times its cos θ
    r = np.asarray(rotation, dtype=np.float64)
    out = np.empty((len(beams), 3))
    component = np.empty(len(beams))
    along = np.empty(len(beams))
    for i in range(3):
        a = cos_p[:, 0] * r[i, 0] + sin_p[:, 0] * r[i, 1]  # R[i, 0] cos ψ + R[i, 1] sin ψ
        np.multiply(a.take(column) if planar else a, st, out=component)
        np.multiply(ct, r[i, 2], out=along)
        if ranges is None:
            np.add(component, along, out=out[:, i])
        else:
            component += along
            np.multiply(component, ranges, out=out[:, i])
    return out


@functools.lru_cache(maxsize=8)
def _beam_index(device: Device, rh_deg: float, m_count: int) -> tuple[np.ndarray, np.ndarray]:
    """(column, beam within the column) of every beam of a 3D scan, column-major as
    beam_directions, intp, read-only."""
    n = device.beams.count
    tables = (np.repeat(np.arange(m_count, dtype=np.intp), n), np.tile(np.arange(n, dtype=np.intp), m_count))
    for table in tables:
        table.flags.writeable = False
    return tables


def directions_at(head_rad: np.ndarray, device: Device = DEFAULT_DEVICE) -> np.ndarray:
    """Beam directions (sensor frame, unit) for head angles `head_rad`: (K,) one angle a
    column (the stepped head of Eq. 1) or (K, N) one a beam (a head that turns while the
    beams fire). Returns (K, N, 3). Not for a device on a head (a drive refuses those)."""
    if device.head is not None:
        raise UserError(
            f"{device.id}: a device on a [head] scans with `wildscan scan` and datasets only so far",
            setting="device",
        )
    sin_t, cos_t = _beam_sincos(device.beams)
    sin_p, cos_p = _psi_sincos(device, head_rad)
    dirs = np.empty((len(sin_p), device.beams.count, 3))
    dirs[:, :, 0] = cos_p * sin_t[None, :]
    dirs[:, :, 1] = sin_p * sin_t[None, :]
    dirs[:, :, 2] = cos_t[None, :]
    return dirs


@functools.lru_cache(maxsize=4)
def beam_frames(device: Device, rh_deg: float, m_count: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors across each beam, column-major as beam_directions: e_u = d(dir)/dθ (along
    the scan line) and e_v = d(dir)/dψ / sin θ (along the head's turn), both (N, 3)."""
    sin_t, cos_t, sin_p, cos_p = beam_angles(device, rh_deg, m_count)
    n = device.beams.count
    e_u = np.empty((m_count, n, 3))
    e_u[:, :, 0] = cos_p * cos_t[None, :]
    e_u[:, :, 1] = sin_p * cos_t[None, :]
    e_u[:, :, 2] = -sin_t[None, :]
    e_v = np.zeros((m_count, n, 3))
    e_v[:, :, 0] = -sin_p
    e_v[:, :, 1] = cos_p
    arrays = (e_u.reshape(-1, 3), e_v.reshape(-1, 3))
    if device.head is not None:
        arrays = tuple(turned_by_head(device, a, m_count) for a in arrays)
    for a in arrays:
        a.flags.writeable = False
    return arrays


def _rotated(rotation: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """`rotation` (3x3) applied to each row of `dirs`: three products a component, in order."""
    r = np.asarray(rotation, dtype=np.float64)
    out = np.empty_like(dirs)
    for i in range(3):
        component = out[:, i]
        np.multiply(dirs[:, 0], r[i, 0], out=component)
        component += dirs[:, 1] * r[i, 1]
        component += dirs[:, 2] * r[i, 2]
    return out


def sweep_fractions(device: Device, m_count: int) -> np.ndarray:
    """(M·N,) how far through one device sweep each beam fires (column-major, as the beams):
    (m·S + step_i) / (M·S), S the device's steps a column."""
    steps = device.timing.steps_per_column
    fired = np.arange(m_count, dtype=np.int64)[:, None] * steps + np.asarray(device.timing.beam_step)[None, :]
    return fired.ravel() / float(m_count * steps)


def head_angles_deg(device: Device, m_count: int) -> np.ndarray:
    """The head's angle (degrees) at each beam of each head step: (K, 1) stepped, (K, M·N)
    continuous (the head turns step_deg over each device sweep, evenly in time)."""
    head = device.head
    k = np.arange(head.steps, dtype=np.float64)[:, None]
    if head.turn == "stepped":
        return k * head.step_deg
    return (k + sweep_fractions(device, m_count)[None, :]) * head.step_deg


def turned_by_head(device: Device, vectors: np.ndarray, m_count: int) -> np.ndarray:
    """(K·M·N, 3): the (M·N, 3) vectors of one device sweep tilted by the head's tilt (about
    the sensor's X) and turned about its axis by each head step's angle (Rodrigues:
    v cos φ + (a × v) sin φ + a (a · v)(1 − cos φ)), elementwise in a fixed order."""
    head = device.head
    sin_t, cos_t = (float(v[0]) for v in dm.sincos(dm.deg2rad(np.array([head.tilt_deg]))))
    x, y, z = vectors[:, 0], vectors[:, 1], vectors[:, 2]
    v = np.stack((x, y * cos_t - z * sin_t, y * sin_t + z * cos_t), axis=-1)
    a0, a1, a2 = head.axis
    cross = np.stack(
        (a1 * v[:, 2] - a2 * v[:, 1], a2 * v[:, 0] - a0 * v[:, 2], a0 * v[:, 1] - a1 * v[:, 0]), axis=-1
    )
    dot = a0 * v[:, 0] + a1 * v[:, 1] + a2 * v[:, 2]
    sin_p, cos_p = dm.sincos(dm.deg2rad(head_angles_deg(device, m_count)))
    out = np.empty((head.steps, len(v), 3))
    for c, a in enumerate(head.axis):
        out[:, :, c] = v[None, :, c] * cos_p + cross[None, :, c] * sin_p + (a * dot)[None, :] * (1.0 - cos_p)
    return out.reshape(-1, 3)


def beam_columns(rh_deg: float, device: Device) -> np.ndarray:
    """(B,) uint32 each beam's column in its 3D scan, column-major as beam_directions: the
    firing (or 2D scan) index, counted on across a head's device sweeps."""
    return np.repeat(np.arange(column_count(rh_deg, device), dtype=np.uint32), device.beams.count)


def beam_times(rh_deg: float, device: Device) -> np.ndarray:
    """(B,) float64 seconds from the 3D scan's first firing to each beam's, by the device's
    timing: column c's beam i at (c·S + step_i) · period / S."""
    timing = device.timing
    columns = np.arange(column_count(rh_deg, device), dtype=np.int64)[:, None] * timing.steps_per_column
    fired = columns + np.asarray(timing.beam_step, dtype=np.int64)[None, :]
    return (fired * timing.step_interval_s).ravel()
