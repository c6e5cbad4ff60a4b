"""The realistic sensor model's scan: footprint, echoes, physical intensity, datasheet noise,
and a label that stays exact or says it is not (numpy only).

    sub-rays (footprint.py) -> first hit of each, with its surface normal (backend.cast)
    -> echoes per beam (echoes.py) -> datasheet noise and range limits
    -> which echoes lie on their labeled surface (`mixed`) -> points

Labels stay exact. An echo's point is on an element of its class when the beam axis
itself meets a surface of that class at the echo's range (within MIXED_TOLERANCE,
noise off): the axis is followed through the surfaces it meets (AXIS_STEP past each)
until every echo is settled. Every other point — a range merged between surfaces, an
edge the axis missed, a curved surface's facets averaged — is flagged `mixed`, so no
point is ever silently off its class. With divergence 0 and one echo the model casts
the paper's very rays and keeps their first hits: the same points and labels.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import detmath as dm
from ..backend import RayBackend, with_normals
from ..classes import PARTICLE_ID, WATER_ID
from ..effects import CLEAR_AIR, Effects, Rays
from ..errors import UserError
from ..hits import RayHits
from ..runtime.threads import in_parts, started
from ..sensors import SensorConfig, noise_draws, range_sigma, rotated_beam_directions
from ..sensors.returns import select_returns
from ..world.cover import is_cover_instance
from .coarse_footprint import BeamGrid, footprint_hits, scan_grid
from .echoes import Echoes, SubrayReturns, form_echoes
from .footprint import ring_columns, subray_directions, subray_weights, turn_rings
from .lost_returns import TALLY, Detecting, lost_echoes, tally, tally_stats

MIXED_TOLERANCE = 1e-3  # m: a point this close to a surface of its class along the axis is on it
AXIS_STEP = 1e-4  # m past a surface before following the axis on (far above float32 round-off)
MAX_AXIS_STEPS = 16  # surfaces followed along one axis (leaves, twigs, a trunk's two sides...)
BEAM_BLOCK = 32_768  # beams a block of echo_points' work: 5 sub-rays' arrays in cache


@dataclass
class RealisticPoints:
    """The points of a realistic scan, one per kept echo, beam-major then by range."""

    beam: np.ndarray  # int64
    range: np.ndarray  # float64 measured (noise included)
    intensity: np.ndarray  # float64
    label: np.ndarray  # int16
    instance: np.ndarray  # int32
    echo: np.ndarray  # uint8 1..3, 1 nearest
    echoes: np.ndarray  # uint8 echoes its beam returned
    purity: np.ndarray  # float64
    mixed: np.ndarray  # bool
    stats: dict
    # the beams of the echoes the detection step dropped (lost_returns.py), one entry an echo
    lost_beam: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    # (blocks, 2, TALLY): the echoes weighed and lost by class, range and incidence, per block
    lost_tally: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, TALLY), dtype=np.int64))
    # uint8 which return of its beam each point is in a strongest, last or dual scan
    # (sensors/returns.py RETURN_TYPES); 0 in a multi-echo scan
    return_type: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.uint8))

    @staticmethod
    def joined(parts: list["RealisticPoints"]) -> "RealisticPoints":
        """The points of consecutive blocks of beams, in order (their stats left empty)."""
        if len(parts) == 1:
            return parts[0]
        fields = [f for f in RealisticPoints.__dataclass_fields__ if f != "stats"]
        return RealisticPoints(
            **{f: np.concatenate([getattr(p, f) for p in parts]) for f in fields}, stats={}
        )

    @property
    def beams_returning(self) -> int:
        """How many beams returned a point (`beam` is in beam order: a count of its runs)."""
        return int(np.count_nonzero(self.beam[1:] != self.beam[:-1])) + 1 if len(self.beam) else 0


def check_backend(backend: RayBackend) -> None:
    if with_normals(backend) is None:
        raise UserError(
            f"{backend.name} cannot give surface normals, which the realistic model needs; use embree or bvh "
            "(or auto)",
            setting="backend",
        )


def subray_returns(hits: RayHits, sub_world: np.ndarray, beams: slice = slice(None)) -> SubrayReturns:
    """Per (sub-ray, beam) what was hit, with the incidence cosine and the axis ratio; of the
    beams `beams` (a block of them) when given."""
    s, n, _ = sub_world.shape
    sub_world = sub_world[:, beams]
    normal = hits.normal.reshape(s, n, 3)[:, beams]
    along_sub = dm.dot3(normal, sub_world)
    along_axis = dm.dot3(normal, sub_world[0][None])
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(along_axis != 0, along_sub / along_axis, np.inf)
    return SubrayReturns(
        distance=hits.distance.reshape(s, n)[:, beams],
        class_id=hits.class_id.reshape(s, n)[:, beams],
        instance=hits.instance.reshape(s, n)[:, beams],
        cos_incidence=np.abs(along_sub),
        axis_cos=np.abs(along_axis),
        axis_ratio=ratio,
        reflectivity=None if hits.reflectivity is None else hits.reflectivity.reshape(s, n)[:, beams],
    )


def realistic_points(
    cast,
    origin: np.ndarray,
    rotation: np.ndarray,
    sensor: SensorConfig,
    cast_range: float,
    effects: Effects = CLEAR_AIR,
    threads: int | None = None,
    detecting: Detecting | None = None,
) -> RealisticPoints:
    """Every point of a realistic scan over the beams of sensor.beam_directions (their
    order). `cast(origins, dirs_world, max_range, normals)` is the backend's cast (maybe
    reporting progress); `rotation` turns the sensor frame to the world's; `threads`: those
    its casts use (threads.backend_threads; None: threads.cast_threads()); `detecting`: the
    detection step's settings (lost_returns.py; None: every echo in the range window kept)."""
    sub_sensor = subray_directions(sensor.rh_deg, sensor.divergence_mrad, sensor.device)
    sub_world = np.empty(sub_sensor.shape)

    # The axis sub-ray is cast along the paper model's own beam, bit for bit, so a thin
    # single-echo realistic scan hits exactly where the paper's does; the ring is turned.
    def turn_axes() -> None:
        sub_world[0] = rotated_beam_directions(rotation, sensor.rh_deg, sensor.device)

    axes = started(turn_axes, threads)  # on a pool thread, beside the rings' turn
    columns = ring_columns(sensor.rh_deg, sensor.divergence_mrad, sensor.device)
    ring = sub_world[1:]
    in_parts(lambda beams: turn_rings(rotation, columns, ring, beams), ring.shape[1], BEAM_BLOCK, threads)
    axes()
    grid = scan_grid(sensor.device, float(sensor.rh_deg), float(sensor.divergence_mrad))
    return echo_points(cast, origin, sub_world, sensor, cast_range, effects, threads, grid, detecting)


def echo_points(
    cast,
    origin: np.ndarray,
    sub_world: np.ndarray,
    sensor: SensorConfig,
    cast_range: float,
    effects: Effects = CLEAR_AIR,
    threads: int | None = None,
    grid: tuple[BeamGrid, np.ndarray] | None = None,
    detecting: Detecting | None = None,
):
    """The points of beams whose sub-rays (S, N, 3; sub-ray 0 the axis) leave `origin` in
    world directions `sub_world` (footprint.subrays_around): any beams, not only a scan's.
    The sub-rays' first hits pass through `effects`' medium; following the axis to settle
    labels (AxisHits) looks at the surfaces alone, so a surface behind a particle keeps its
    exact label, and a particle's echo is on its particle unless it merged with a surface.
    `grid`: how the beams and their ring sub-rays lie on the scan's grid
    (coarse_footprint.scan_grid): ring sub-rays are then cast only where the footprint may
    hold more than one surface (coarse to fine); None: every sub-ray is cast."""
    s, n, _ = sub_world.shape
    rays = sub_world.reshape(-1, 3)
    # a multi-echo device keeps its strongest `echoes`; a device with return modes chooses among
    # every echo a beam forms (its last may be the weakest): at most one a sub-ray
    formed = sensor.echoes if sensor.return_mode == "multi" else s
    noise = started(lambda: noise_draws(sensor, n, formed), threads)  # beside the casts
    if grid is None or s == 1:
        clear, fine = cast(origin, rays, cast_range, True), None
    else:
        clear, fine = footprint_hits(cast, origin, sub_world, cast_range, *grid, threads)
    hits = effects.medium(Rays(origin, rays, cast_range), clear)
    draws = noise()
    axis = AxisHits(clear.rows(slice(0, n)), sub_world[0], origin, cast_range)
    weights = subray_weights(s)

    def block(beams: slice) -> RealisticPoints:
        return _block_points(hits, sub_world, sensor, weights, draws, axis, cast, beams, detecting, formed)

    # a block of beams at a time, each from its sub-rays' hits to its points in its own thread:
    # a beam's echoes, noise and axis are its own, so the blocks joined are one pass's bytes
    pts = RealisticPoints.joined(in_parts(block, n, BEAM_BLOCK, threads))
    per_beam = np.bincount(pts.beam, minlength=n)
    pts.stats = {
        "subrays_per_beam": s,
        "beams_by_echoes": {str(k): int((per_beam == k).sum()) for k in range(1, sensor.echoes + 1)},
        "mixed_points": int(np.count_nonzero(pts.mixed)),
        "water_subrays": int(np.count_nonzero(hits.class_id == WATER_ID)),
    }
    if fine is not None:
        pts.stats["ring_subrays_cast"] = int(np.count_nonzero(fine))
    if hits is not clear:
        pts.stats["particle_points"] = int(np.count_nonzero(pts.label == PARTICLE_ID))
    if detecting is not None:
        pts.stats["lost_returns"] = tally_stats(pts.lost_tally.sum(axis=0))
    return pts


def _block_points(hits, sub_world, sensor, weights, draws, axis: "AxisHits", cast, beams, detecting, formed):
    """The points of the beams `beams` (a block): their echoes (echoes.form_echoes), measured
    with noise, kept within the range limits and above the detection limit, numbered, their
    labels settled along the axis."""
    echoes = form_echoes(subray_returns(hits, sub_world, beams), weights, sensor.echo_separation, formed)
    local = echoes.beam  # the block's own beam indices, from 0
    echoes.beam = local + beams.start
    measured = _measured_ranges(echoes, sensor, draws)
    keep = (measured >= sensor.min_range) & (measured <= sensor.max_range)
    echoes, measured, local = echoes.subset(keep), measured[keep], local[keep]
    lost_beam, counts = np.zeros(0, dtype=np.int64), np.zeros((0, 2, TALLY), dtype=np.int64)
    if detecting is not None:
        xy = axis.origin[:2] + sub_world[0, echoes.beam, :2] * echoes.range[:, None]
        lost, cover = lost_echoes(detecting, echoes, _rank_in_beam(local), xy)
        counts = tally(echoes.label, echoes.range, cover, lost)
        lost_beam = echoes.beam[lost]
        kept = ~lost
        echoes, measured, local = echoes.subset(kept), measured[kept], local[kept]
    kinds = np.zeros(len(local), dtype=np.uint8)
    if sensor.return_mode != "multi":  # the returns the mode reports, of those detected
        chosen, kinds = select_returns(local, echoes.intensity, sensor.return_mode, sensor.device.optics.dual)
        echoes, measured, local = echoes.subset(chosen), measured[chosen], local[chosen]
    number = _rank_in_beam(local) + 1
    count = np.bincount(local, minlength=beams.stop - beams.start)[local]
    on_surface, instance = axis.settle(echoes, lambda o, d, r: cast(o, d, r, False), beams)
    # a pure echo from a medium lies where the medium returned it: a particle (its instance the
    # effect's code) or the ground cover's sward (core/effects/cover.py; its instance the cover's)
    from_medium = (echoes.label == PARTICLE_ID) | is_cover_instance(echoes.instance)
    if from_medium.any():
        on_surface[from_medium] = echoes.purity[from_medium] >= 1.0
        instance[from_medium] = echoes.instance[from_medium]
    return RealisticPoints(
        beam=echoes.beam,
        range=measured,
        intensity=echoes.intensity,
        label=echoes.label,
        instance=np.where(on_surface, instance, echoes.instance),
        echo=number.astype(np.uint8),
        echoes=count.astype(np.uint8),
        purity=echoes.purity,
        mixed=~on_surface,
        stats={},
        lost_beam=lost_beam,
        lost_tally=counts,
        return_type=kinds,
    )


def _rank_in_beam(beam: np.ndarray) -> np.ndarray:
    """0, 1, 2... for the entries of each beam in order (entries are grouped by beam)."""
    if not len(beam):
        return np.zeros(0, dtype=np.int64)
    first = np.ones(len(beam), dtype=bool)
    first[1:] = beam[1:] != beam[:-1]
    index = np.arange(len(beam))
    return index - np.maximum.accumulate(np.where(first, index, 0))


def _measured_ranges(echoes: Echoes, sensor: SensorConfig, draws: np.ndarray | None) -> np.ndarray:
    """Each echo's range with noise: draw j of its beam for the beam's j-th echo (`draws`:
    noise_draws' rows, one per beam whatever it hit, as the paper model; None: no noise), σ
    by the noise model."""
    if draws is None:
        return echoes.range.copy()
    rank = _rank_in_beam(echoes.beam)
    return echoes.range + range_sigma(sensor, echoes.range) * draws[echoes.beam, rank]


class AxisHits:
    """The surfaces along each beam axis, followed as far as the echoes need."""

    def __init__(self, axis_hits: RayHits, axis_world: np.ndarray, origin: np.ndarray, cast_range: float):
        """`axis_hits`: the surfaces the axis sub-rays met first (before any medium)."""
        self.axis = axis_world
        self.origin = np.asarray(origin, dtype=np.float64)
        self.cast_range = cast_range
        self.last = axis_hits.distance.copy()  # the farthest axis hit found so far
        self.first = (self.last.copy(), axis_hits.class_id, axis_hits.instance)

    def settle(self, echoes: Echoes, cast, beams: slice | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(on its labeled surface, that surface's instance) for each echo; `beams`: the block
        of beams the echoes are of (None: all), whose axes alone are followed (blocks on
        different threads touch different beams)."""
        lo = 0 if beams is None else beams.start
        hi = len(self.last) if beams is None else beams.stop
        local = echoes.beam - lo
        last = self.last[lo:hi]  # a view: followed in place
        on = np.zeros(len(echoes), dtype=bool)
        instance = np.zeros(len(echoes), dtype=np.int32)
        first = tuple(a[lo:hi] for a in self.first)
        self._match(echoes, local, first, np.arange(len(echoes)), on, instance)
        for _ in range(MAX_AXIS_STEPS):
            pending = np.flatnonzero(~on & (echoes.range > last[local] + MIXED_TOLERANCE))
            if not len(pending):
                break
            ids = np.unique(local[pending])
            hit = self._follow(ids, lo, last, cast)
            followed = np.zeros(len(last), dtype=bool)  # np.isin(local, ids), no sort
            followed[ids] = True
            self._match(echoes, local, hit, np.flatnonzero(followed[local] & ~on), on, instance)
        return on, instance

    def _follow(self, ids: np.ndarray, lo: int, last: np.ndarray, cast):
        """The next surface along the axis of each beam lo + `ids`, past the last one (`last`:
        the block's farthest axis hits, from beam lo)."""
        start = last[ids] + AXIS_STEP
        distance = np.full(len(last), np.inf)
        cls = np.full(len(last), -1, dtype=np.int16)
        inst = np.zeros(len(last), dtype=np.int32)
        room = start < self.cast_range
        go = ids[room]
        if len(go):
            axis = self.axis[go + lo]
            origins = self.origin + axis * start[room][:, None]
            hits = cast(origins, axis, self.cast_range - float(start[room].min()))
            reach = hits.distance + start[room]
            ok = np.isfinite(reach) & (reach <= self.cast_range)
            distance[go[ok]] = reach[ok]
            cls[go[ok]] = hits.class_id[ok]
            inst[go[ok]] = hits.instance[ok]
        last[ids] = distance[ids]
        return distance, cls, inst

    @staticmethod
    def _match(
        echoes: Echoes, local: np.ndarray, hit, which: np.ndarray, on: np.ndarray, instance: np.ndarray
    ):
        """Mark the echoes `which` lying on `hit` (per beam of the block: `local` each echo's)."""
        distance, cls, inst = hit
        b = local[which]
        close = (np.abs(echoes.range[which] - distance[b]) <= MIXED_TOLERANCE) & (
            cls[b] == echoes.label[which]
        )
        on[which[close]] = True
        instance[which[close]] = inst[b[close]]
