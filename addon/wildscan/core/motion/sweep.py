"""The beams of a run of 2D scans in motion: their rays, their returns, and the raw and the
deskewed cloud they make (numpy only).

Beam n of 2D scan k is measured at its own time (timing.py), from where the sensor is then:
the pose at the start of 2D scan k moved on by the fraction n/1440 of the step to the pose
at k + 1 (the optical centre along a straight line, the attitude turning about one axis).
Its direction is Eq. (1)'s for the head angle of that beam, turned with the sensor.

raw       what a driver that knows nothing of the motion makes of the ranges: range times
          the beam's Eq. (1) direction, in the sensor frame at the 3D scan's start.
deskewed  every point where it truly is, expressed in the same frame: range times the
          beam's true direction from the sensor's true position at the beam's time.

A drive standing still takes the same rays as a static scan, bit for bit: rays of 2D
scans that share one attitude are turned by one matrix product (as run_scan turns them),
and a motion of exactly zero is never applied, so even the sign of a zero is the same.
Every product is detmath's (dm.apply, dm.matmul: summed in a fixed order), every sine
and cosine too (via sensors.directions_at and rotations.py): the same bytes on every CPU.
Beams, their timing and the head's modes are the sensor's device's (sensors/device.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..backend import RayBackend, with_scan_times
from ..effects import CLEAR_AIR, Effects, Rays, weather_of
from ..pointcloud import PointCloud
from ..runtime.cast_clock import scanning
from ..scan import NOISE_MARGIN_SIGMAS, Returns, measure, points_in_frame, with_weather_field
from ..sensors import SensorConfig, directions_at
from ..spatial.rotations import rotate_columns
from .placements import Motion
from .timing import beam_fractions, beam_times, head_angles_rad

CAST_CHUNK = 64_800  # rays per cast and progress report (60 2D scans)


@dataclass
class Sweep:
    """The 2D scans k0 ... k1 - 1 of a drive (a 3D scan when k1 - k0 = M)."""

    k0: int
    k1: int
    returns: Returns  # per beam, (k1 - k0) * beams a column (1080) of them, scan-major
    raw: PointCloud  # in `frame` at the start of 2D scan k0
    deskewed: PointCloud
    times: np.ndarray  # (N,) beam times, seconds after the start of 2D scan k0


@dataclass
class Beams:
    """The rays of the 2D scans k0 ... k1 - 1, before any is cast: a pure function of the
    motion (a drive makes the next sweep's while this one casts, app/drive/run.py)."""

    k0: int
    k1: int
    believed: np.ndarray  # (K, N, 3) Eq. 1's directions in the sensor frame
    true_local: np.ndarray  # (K, N, 3) turned by the motion during each 2D scan
    dirs_world: np.ndarray  # (K * N, 3)
    origins: np.ndarray  # (3,) or (K * N, 3)


def beams_of(motion: Motion, k0: int, k1: int, sensor: SensorConfig, head: str) -> Beams:
    device = sensor.device
    ks = np.arange(k0, k1)
    fraction = beam_fractions(device.timing)
    believed = directions_at(head_angles_rad(ks, sensor.rh_deg, head, device.timing), device)  # Eq. 1
    true_local = _turned_during_scan(believed, motion.step[k0:k1], fraction)
    dirs_world = _by_attitude(true_local, motion.rotation[k0:k1])
    return Beams(k0, k1, believed, true_local, dirs_world, _origins(motion, k0, k1, fraction))


@scanning
def sweep(
    backend: RayBackend,
    motion: Motion,
    k0: int,
    k1: int,
    sensor: SensorConfig,
    head: str,
    noise: np.ndarray,
    frame: str = "sensor",
    progress=None,
    effects: Effects = CLEAR_AIR,
    beams: Beams | None = None,
) -> Sweep:
    """Cast the beams of 2D scans k0 ... k1 - 1 and make their clouds. `noise` (N,) is the
    range noise of each beam; `progress(rays)` hears of each chunk cast; the first hits pass
    through `effects`' medium (none: clear air). `beams`: beams_of(motion, k0, k1, sensor,
    head), made beforehand (else here)."""
    device = sensor.device
    ks = np.arange(k0, k1)
    fraction = beam_fractions(device.timing)
    if beams is None:
        beams = beams_of(motion, k0, k1, sensor, head)
    assert (beams.k0, beams.k1) == (k0, k1), "the beams of another sweep"
    believed, true_local, dirs_world, origins = (
        beams.believed,
        beams.true_local,
        beams.dirs_world,
        beams.origins,
    )
    cast_range = sensor.max_range + NOISE_MARGIN_SIGMAS * sensor.max_noise_sigma
    hits = cast_in_chunks(backend, origins, dirs_world, cast_range, ks, progress)
    if effects.changes_medium:  # the beams' times since the drive's start, for the medium
        drive_times = beam_times(ks, timing=device.timing).ravel()
        first_ray = k0 * device.beams.count  # the drive's rays are numbered from its start
        hits = effects.medium(Rays(origins, dirs_world, cast_range, drive_times, first_ray), hits)

    returns = measure(hits, noise, sensor)
    keep, rho = returns.keep, returns.range[returns.keep]
    raw_sensor = believed.reshape(-1, 3)[keep] * rho[:, None]
    true_sensor = _deskewed(motion, k0, k1, true_local.reshape(-1, 3)[keep] * rho[:, None], keep, fraction)

    times = beam_times(ks, since=k0, timing=device.timing).ravel()
    ring = np.tile(np.asarray(device.beams.ring, dtype=np.uint16), len(ks))
    sweep_index = np.repeat(np.arange(len(ks), dtype=np.uint16), device.beams.count)
    start = motion.placement(k0)
    raw = returns.cloud(points_in_frame(raw_sensor, start, frame), ring, sweep_index, frame, time=times)
    deskewed = returns.cloud(points_in_frame(true_sensor, start, frame), ring, sweep_index, frame, time=times)
    if weather_of(effects) is not None:
        with_weather_field(raw)
        with_weather_field(deskewed)
    return Sweep(k0, k1, returns, raw, deskewed, times)


def cast_in_chunks(backend: RayBackend, origins, dirs, max_range, ks, progress):
    """All rays, in chunks of whole 2D scans (columns: `dirs` holds len(ks) of them), on the
    cast's threads where the backend allows it (core/runtime/threads.py: each ray's answer is its own,
    so the joined answer is the same bytes however many threads). A backend that casts at
    scan times (a scene that moves with time: an effect's, raycast/wind.py) is told which 2D
    scan each chunk's rows belong to."""
    from ..hits import RayHits
    from ..runtime.threads import backend_threads, in_parts

    per_column = len(dirs) // len(ks)
    per_chunk = max(1, CAST_CHUNK // per_column) * per_column
    timed_backend = with_scan_times(backend)

    def chunk(rows: slice) -> RayHits:
        o = origins if origins.ndim == 1 else origins[rows]
        if timed_backend is not None:
            scans = ks[rows.start // per_column : rows.stop // per_column]
            return timed_backend.cast_scans(o, dirs[rows], max_range, scans)
        return backend.cast(o, dirs[rows], max_range)

    parts = in_parts(chunk, len(dirs), per_chunk, backend_threads(backend))
    if progress is not None:
        for part in parts:
            progress(len(part.distance))
    return RayHits.joined(parts) if len(parts) != 1 else parts[0]


def _turned_during_scan(dirs: np.ndarray, step: np.ndarray, fraction: np.ndarray) -> np.ndarray:
    """Beam directions in the sensor frame at the start of their 2D scan, turned by the part
    of the attitude step done by the beam's time (2D scans that do not turn are left as they are)."""
    turning = np.flatnonzero(np.any(step != 0, axis=1))
    if not len(turning):
        return dirs
    out = dirs.copy()
    # beam n of 2D scan k turns by fraction[n] * step[k] (rotate's products, column by column)
    rotvec = [fraction[None, :] * step[turning, i][:, None] for i in range(3)]
    turned = dirs[turning]
    out[turning] = np.stack(rotate_columns([turned[..., i] for i in range(3)], rotvec), axis=-1)
    return out


def _runs(matrices: np.ndarray):
    """(start, stop) of the runs of consecutive identical matrices."""
    if not len(matrices):
        return []
    change = np.flatnonzero(np.any(matrices[1:] != matrices[:-1], axis=(1, 2))) + 1
    edges = [0, *change.tolist(), len(matrices)]
    return list(zip(edges[:-1], edges[1:]))


def _by_attitude(local: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """(K, N, 3) directions in each 2D scan's sensor frame -> (K * N, 3) world directions,
    2D scans sharing one attitude turned by one product."""
    if len(_runs(rotation)) == 1:
        return dm.apply(rotation[0], local.reshape(-1, 3))
    # one matrix a ray: the same products in the same order as one matrix a run (detmath's
    # apply: ((m_i0 v0 + m_i1 v1) + m_i2 v2)), without a Python loop over the 2D scans, each
    # component over whole (K, N) columns, the matrices' entries broadcast along each 2D scan
    v = [local[..., j] for j in range(3)]
    out = np.empty(local.shape)
    for i in range(3):
        component = v[0] * rotation[:, i, 0, None]
        component += v[1] * rotation[:, i, 1, None]
        component += v[2] * rotation[:, i, 2, None]
        out[..., i] = component
    return out.reshape(-1, 3)


def _origins(motion: Motion, k0: int, k1: int, fraction: np.ndarray) -> np.ndarray:
    """The optical centre at every beam's time: (3,) when it does not move, else (N, 3)."""
    centre = motion.centre[k0 : k1 + 1]
    if np.all(centre == centre[0]):
        return centre[0]
    step = centre[1:] - centre[:-1]
    out = np.empty((len(step), len(fraction), 3))
    for i in range(3):  # c + f s, column by column: numpy's loops over N values, not 3
        out[..., i] = centre[:-1, i, None] + fraction[None, :] * step[:, i, None]
    return out.reshape(-1, 3)


def _deskewed(
    motion: Motion, k0: int, k1: int, vectors: np.ndarray, keep: np.ndarray, fraction
) -> np.ndarray:
    """Points measured from the true pose at their time (`vectors`: range times the true
    direction in the sensor frame at the start of the point's 2D scan), in the sensor frame
    at the start of 2D scan k0."""
    scan_of = np.repeat(np.arange(k1 - k0), len(fraction))[keep]
    frac = np.tile(fraction, k1 - k0)[keep]
    rotation, centre = motion.rotation, motion.centre
    start_r, start_c = rotation[k0], centre[k0]
    out = vectors.copy()
    relative = dm.matmul(start_r.T, rotation[k0:k1])  # R_k0^T R_k
    relative[np.all(rotation[k0:k1] == start_r, axis=(1, 2))] = np.eye(3)
    # the points of 2D scans that turned, each by its own scan's matrix (a point of a scan at the
    # start's attitude is left exactly as it is: no product, so even the sign of a zero stays)
    turned = np.flatnonzero(~np.all(relative == np.eye(3), axis=(1, 2))[scan_of])
    if len(turned):
        out[turned] = dm.apply(relative[scan_of[turned]], vectors[turned])
    offset = dm.apply(start_r.T, centre[k0:k1] - start_c)  # R_k0^T (c_k - c_k0), one row a 2D scan
    step = dm.apply(start_r.T, centre[k0 + 1 : k1 + 1] - centre[k0:k1])
    if np.any(offset != 0) or np.any(step != 0):
        out += offset[scan_of] + frac[:, None] * step[scan_of]
    return out
