"""Coarse to fine: a scan's ring sub-rays cast only where the footprint may hold more than one
surface (numpy only).

The realistic model samples each beam's footprint with SUBRAYS sub-rays (footprint.py): the
axis and a ring of four around it, along the scan line (u) and along the head's turn (v).
Casting them was most of a realistic scan's time, yet most beams land whole on one smooth
surface (a slope of terrain, a rock's face, a trunk's side), where a ring sub-ray only meets
the plane the axis met, a hair beside it. So every beam's axis is cast first; then each ring
sub-ray is judged by the beam's neighbour on its side on the scan's grid (the next beam along
the scan line for ±u, the same beam of the next column for ±v), which lies farther out than
the sub-ray (4.4 and ~17 mrad against 1.5 for the UTM-30LX-EW at r_h = 1 deg). The sub-ray
lies between the axis and that neighbour, so:

  - where both met the same element on one plane (same class and instance, each point within
    FLAT_TOLERANCE of the other's plane, the planes parallel within PARALLEL_COS, facing the
    axis more squarely than GRAZING_COS, the element neither porous nor thin), the sub-ray
    meets that plane too: its hit is computed, t_k = t_0 (n·a)/(n·s_k), with the axis's
    element, normal and reflectivity;
  - where no axis met anything within EMPTY_REACH beams and columns around, the sub-ray meets
    nothing either (the sky);
  - everywhere else it is cast: an edge, a step, a fold between facets, porous vegetation
    (a crown's leaves, a bush, grass blades: a mix by nature), anything within THIN_REACH of
    an axis that met a wire or a pole (a wire runs between the rows of beams), a beam at the
    edge of the grid on that side.

Computed and cast hits then go on alike: through the medium (the ground cover's sward stops
each sub-ray at its own depth, as before: a beam in grass still returns 2-3 echoes as often),
into the echoes and the settling of labels.

What this misses, measured against casting every sub-ray on the realism suite's poses
(docs/realism.md, "Coarse to fine"): an object no axis met and smaller than the gap between
neighbouring axes that a ring sub-ray would have met, or one in front of a plane whose edge
lies between an axis and its neighbour; a computed hit differs from the cast one by
round-off on the same triangle, by a fraction of FLAT_TOLERANCE across a fold. Cast sub-rays
get the very hits they got before (each ray's answer is its own).

Determinism: which sub-rays are cast follows from the float64-settled axis hits alone, and the
computed hits are products and sums in a fixed order: the same bytes on every machine.
"""

from __future__ import annotations

import copy
import functools
import threading

import numpy as np

from .. import detmath as dm
from ..classes import PARTICLE_ID, class_by_name
from ..hits import RayHits
from ..runtime.threads import in_parts
from ..sensors import Device, sweep_count
from .footprint import subray_directions

# A neighbour's point this far off the plane of the axis's hit (m) marks an edge or a fold. A
# ring sub-ray lies a third of the way to its nearest neighbour (1.5 of 4.4 mrad for the
# UTM-30LX-EW), so on a surface that bends between them its plane point is off by a fraction of
# this: well under the sensor's range noise (30 mm, datasheet), and under 1/SUBRAYS of it in
# the echo's energy-weighted range.
FLAT_TOLERANCE = 0.01
# |cos| of the hit plane to the axis below which a beam is cast whole: the same bound as the
# echoes' (echoes.MIN_AXIS_COS), past which a sub-ray's point on the plane runs far off.
GRAZING_COS = 0.3
# Neighbours' planes this close to parallel to the axis's (cos of 0.5 deg): the ring's sub-rays
# then meet one plane, so their incidence and their echo's intensity are the axis's (a fold
# of the terrain between facets changes cos of incidence, so the intensity, by up to the
# angle's sine: 1 % at 0.5 deg).
PARALLEL_COS = 0.99996
THIN_REACH = (2, 2)  # beams along the scan line and columns around a thin element's, cast whole
# A beam whose axis met nothing, nor did any axis this many beams along the scan line and
# columns around it, has a ring that meets nothing: a twig, a blade or a wire against the sky
# is met by some axis near it (measured on the realism poses: 8 and 8 lose under 1 % of the
# high grass and wire points a cast ring finds, 2 and 2 up to 20 %).
EMPTY_REACH = (8, 8)
# rows (columns of the scan) around a block whose axes decide its rings: the reaches, and the
# neighbour a plane is compared with
HALO = max(EMPTY_REACH[1], THIN_REACH[1], 1)
# Elements whose footprint is a mix by nature, or thin enough to lie between two axes.
POROUS = ("treetop", "bush", "low grass", "high grass")
THIN = ("wire", "pole")
BLOCK = 16_384  # beams (whole columns) a block of footprint_hits' rings (any size: the same bytes)
SIDES = 4  # a beam's neighbours: before and after along the scan line, the columns before and after


def _class_mask(names) -> np.ndarray:
    mask = np.zeros(PARTICLE_ID + 1, dtype=bool)
    for name in names:
        mask[class_by_name(name).id] = True
    return mask


_POROUS = _class_mask(POROUS)
_THIN = _class_mask(THIN)


class BeamGrid:
    """Beams as a scan lays them out (sensors.beam_directions' order): columns, one a head
    angle, of `per_column` beams in firing order; `sweeps` head sweeps of `columns` columns
    one after another. `view` lays an array over the beams out as (columns, beams) with the
    beams of a column in order of their angle from the axis, so a beam's neighbours are the
    next entries: along the scan line within a row, across columns (of one sweep) between
    rows."""

    def __init__(self, from_axis_deg, columns: int, sweeps: int = 1):
        order = np.argsort(np.asarray(from_axis_deg, dtype=np.float64), kind="stable")
        self.per_column = len(order)
        self.columns = columns
        self.shape = (columns * sweeps, self.per_column)
        self._order = None if (order == np.arange(len(order))).all() else order
        self._back = None if self._order is None else np.argsort(order)
        # pairs of consecutive columns within one sweep (rows i, i + 1 of `view`)
        self.same_sweep = (np.arange(self.shape[0] - 1) + 1) % columns != 0

    def __len__(self) -> int:
        return self.shape[0] * self.shape[1]

    def rows(self, first: int, stop: int) -> "BeamGrid":
        """The grid of rows (columns of the scan) first..stop - 1 alone: its `view` takes the
        values of those rows' beams."""
        part = copy.copy(self)
        part.shape = (stop - first, self.per_column)
        part.same_sweep = self.same_sweep[first : max(stop - 1, first)]
        return part

    def view(self, values: np.ndarray) -> np.ndarray:
        """(N, ...) values of the beams as (columns, beams by angle, ...)."""
        grid = values.reshape(self.shape + values.shape[1:])
        return grid if self._order is None else grid[:, self._order]

    def unview(self, grid: np.ndarray) -> np.ndarray:
        """`view`'s inverse: (N, ...) in the beams' order."""
        if self._order is not None:
            grid = grid[:, self._back]
        return grid.reshape((len(self),) + grid.shape[2:])

    def sides(self, sub_dirs: np.ndarray) -> np.ndarray:
        """(S - 1, columns, beams) int8: for each ring sub-ray of the footprints `sub_dirs`
        (S, N, 3 in the beams' order, sub-ray 0 the axis), the side its offset from the axis
        points to most nearly: 0 the beam before along the scan line, 1 the one after, 2 the
        column before, 3 the one after (whether or not that neighbour exists). Which it is
        changes over a scan: the UTM-30LX-EW's fan crosses the head's axis, where the way
        across columns turns round."""
        axis = self.view(sub_dirs[0])
        unit = []
        for along in (1, 0):  # along the scan line, then across columns: central differences
            step = np.empty_like(axis)
            inner = [slice(None)] * 2
            inner[along] = slice(1, -1)
            ahead, behind = list(inner), list(inner)
            ahead[along], behind[along] = slice(2, None), slice(None, -2)
            step[tuple(inner)] = axis[tuple(ahead)] - axis[tuple(behind)]
            first, second, last, before_last = ([slice(None)] * 2 for _ in range(4))
            first[along], second[along], last[along], before_last[along] = 0, 1, -1, -2
            step[tuple(first)] = axis[tuple(second)] - axis[tuple(first)]
            step[tuple(last)] = axis[tuple(last)] - axis[tuple(before_last)]
            with np.errstate(invalid="ignore"):  # where columns meet (the head's axis): no way across
                unit.append(np.nan_to_num(step / dm.norm(step)[..., None]))
        out = np.empty((len(sub_dirs) - 1,) + self.shape, dtype=np.int8)
        for k, ring in enumerate(sub_dirs[1:]):
            offset = self.view(ring) - axis
            line, across = dm.dot3(offset, unit[0]), dm.dot3(offset, unit[1])
            out[k] = np.where(np.abs(line) >= np.abs(across), (line > 0) * 1, 2 + (across > 0) * 1)
        return out


@functools.lru_cache(maxsize=4)
def scan_grid(device: Device, rh_deg: float, divergence_mrad: float) -> tuple[BeamGrid, np.ndarray] | None:
    """(the grid of the beams of sensors.beam_directions(rh_deg, device), the side of each
    ring sub-ray of a footprint of `divergence_mrad`: BeamGrid.sides), cached; None where the
    scan is too small a grid (fewer than 3 beams or columns): then every sub-ray is cast."""
    columns = sweep_count(rh_deg, device.mount)
    sweeps = device.head.steps if device.head is not None else 1
    grid = BeamGrid(device.beams.from_axis_deg, columns, sweeps)
    if min(grid.shape) < 3:
        return None
    sides = grid.sides(subray_directions(rh_deg, divergence_mrad, device))
    sides.flags.writeable = False
    return grid, sides


def rings_to_cast(
    axis: RayHits, axis_dirs: np.ndarray, grid: BeamGrid, sides: np.ndarray, rows: slice | None = None
) -> np.ndarray:
    """(S - 1, N) bool: the ring sub-rays that must be cast (see the module docstring), from
    the hits of every beam's axis (with normals) and the side of each ring sub-ray; with
    `rows` (of the grid), those of these rows' beams alone (S - 1, their beams): the same
    answer, a block at a time, found from the rows within HALO of them (whether an axis met
    something, a thin element) and within one of them (the planes)."""
    total, per_column = grid.shape
    low, high = (0, total) if rows is None else (rows.start, rows.stop)
    # which axes met something, or a thin element, over the reaches around the rows
    first, stop = max(low - HALO, 0), min(high + HALO, total)
    around = grid.rows(first, stop)
    beams = slice(first * per_column, stop * per_column)
    distance, cls = around.view(axis.distance[beams]), around.view(axis.class_id[beams])
    hit = np.isfinite(distance)
    known = (cls >= 0) & (cls < len(_POROUS))
    cls_index = np.where(known, cls, 0)
    thin = hit & known & _THIN[cls_index]
    empty = ~_grown(hit, EMPTY_REACH)[low - first : high - first]
    near_thin = _grown(thin, THIN_REACH)[low - first : high - first]
    computed = empty & ~near_thin
    # the planes of the rows' axes and of their neighbours' (a row before and after)
    before, after = max(low - 1, 0), min(high + 1, total)
    planes = grid.rows(before, after)
    beams = slice(before * per_column, after * per_column)
    near = slice(before - first, after - first)
    distance, cls, cls_index = distance[near], cls[near], cls_index[near]
    instance = planes.view(axis.instance[beams])
    normal = [np.ascontiguousarray(planes.view(axis.normal[beams, k])) for k in range(3)]
    direction = [planes.view(axis_dirs[beams, k]) for k in range(3)]
    with np.errstate(invalid="ignore", over="ignore"):
        point = [distance * direction[k] for k in range(3)]  # from the optical centre
        facing = (normal[0] * direction[0] + normal[1] * direction[1]) + normal[2] * direction[2]
        solid = hit[near] & known[near] & ~_POROUS[cls_index] & ~thin[near] & (np.abs(facing) >= GRAZING_COS)
        same = _same_plane(planes, solid, cls, instance, point, normal)
    mine = slice(low - before, high - before)
    block = grid.rows(low, high)
    cast = np.empty((len(sides), len(block)), dtype=bool)
    for k, toward in enumerate(sides[:, low:high]):
        on_plane = np.zeros(block.shape, dtype=bool)
        for side in range(SIDES):
            pointing = toward == side
            if pointing.any():  # (a ring sub-ray points to one or two sides over a scan)
                on_plane |= pointing & same[side][mine]
        cast[k] = block.unview(~(computed | (on_plane & ~near_thin)))
    return cast


def _same_plane(grid: BeamGrid, solid, cls, instance, point, normal) -> list[np.ndarray]:
    """Per side (0 before, 1 after along the scan line, 2 the column before, 3 after), an array
    (columns, beams): the beam and its neighbour on that side met the same element on one
    plane (each point within FLAT_TOLERANCE of the other's plane, the planes parallel within
    PARALLEL_COS), both `solid`."""
    out = [np.zeros(grid.shape, dtype=bool) for _ in range(SIDES)]
    lower = ((slice(None), slice(None, -1)), (slice(None, -1), slice(None)))
    upper = ((slice(None), slice(1, None)), (slice(1, None), slice(None)))
    for along, (a, b) in enumerate(zip(lower, upper)):
        gap = [point[k][b] - point[k][a] for k in range(3)]
        off_a = (normal[0][a] * gap[0] + normal[1][a] * gap[1]) + normal[2][a] * gap[2]
        off_b = (normal[0][b] * gap[0] + normal[1][b] * gap[1]) + normal[2][b] * gap[2]
        parallel = (normal[0][a] * normal[0][b] + normal[1][a] * normal[1][b]) + normal[2][a] * normal[2][b]
        pair = solid[a] & solid[b] & (cls[a] == cls[b]) & (instance[a] == instance[b])
        pair &= (np.abs(off_a) <= FLAT_TOLERANCE) & (np.abs(off_b) <= FLAT_TOLERANCE)
        pair &= np.abs(parallel) >= PARALLEL_COS
        if along == 1:
            pair &= grid.same_sweep[:, None]
        out[2 * along + 1][a] = pair  # the neighbour after (along the line, or the next column)
        out[2 * along][b] = pair  # the one before
    return out


def _grown(mark: np.ndarray, reach: tuple[int, int]) -> np.ndarray:
    """`mark` (columns, beams) grown by reach[0] beams each way along the scan line, then by
    reach[1] columns each way: true wherever a marked beam lies in that rectangle around."""
    grown = mark.copy()
    for step in range(1, reach[0] + 1):
        grown[:, step:] |= mark[:, :-step]
        grown[:, :-step] |= mark[:, step:]
    rows = grown.copy()
    for step in range(1, reach[1] + 1):
        grown[step:] |= rows[:-step]
        grown[:-step] |= rows[step:]
    return grown


def footprint_hits(
    cast, origin: np.ndarray, sub_world: np.ndarray, cast_range: float, grid, sides, threads=None
):
    """(the first hits of every sub-ray (S·N, sub-ray-major, as one cast of them all gives,
    with normals), the ring sub-rays that were cast ((S - 1, N) bool)). `cast(origins, dirs,
    max_range, normals)` is the backend's cast: the axes are cast, then the ring sub-rays
    `rings_to_cast` names; the others meet the plane of their axis's hit (module docstring).
    The rings are done a block of about BLOCK beams (whole columns of the scan) at a time on
    `threads` (None: threads.cast_threads()), each block's choice, planes, cast and scatter in
    its own thread (a cast from a pool thread is one call, threads.in_worker): nothing serial
    but the axes' cast. Each ray's answer is its own, and a block's choice is made from the
    axes around it as from all: the bytes of one cast of every ring."""
    s, n, _ = sub_world.shape
    axis = cast(origin, sub_world[0], cast_range, True)
    fine = np.empty((s - 1, n), dtype=bool)
    hits = _AxisPlanes(axis, s, n)
    untagged = []
    per_column = grid.per_column

    def block(rows: slice) -> None:
        b = slice(rows.start * per_column, rows.stop * per_column)
        fine[:, b] = rings_to_cast(axis, sub_world[0], grid, sides, rows)
        hits.fill(sub_world, cast_range, b)
        # cast beam by beam (a beam's ring sub-rays one after another: Embree finds the same
        # nodes in its cache; 13 % off the forest's ring cast), each ray's answer its own
        beam, ring = np.nonzero(fine[:, b].T)
        if not len(beam):
            return
        beam += b.start
        ring += 1
        cast_hits = cast(origin, sub_world[ring, beam], cast_range, True)
        hits.put(ring * n + beam, cast_hits)
        untagged.append(cast_hits.untagged_objects)

    in_parts(block, grid.shape[0], max(BLOCK // per_column, 1), threads)
    out = hits.joined()
    out.untagged_objects = out.untagged_objects.union(*untagged)
    return out, fine


class _AxisPlanes:
    """The hits of every sub-ray (S·N, sub-ray-major), filled a block of beams at a time:
    first each on the plane of its beam's axis hit (`fill`), then the cast ones (`put`)."""

    def __init__(self, axis: RayHits, s: int, n: int):
        self.axis = axis
        self.distance = np.empty((s, n))
        self.cls = np.empty((s, n), dtype=axis.class_id.dtype)
        self.instance = np.empty((s, n), dtype=axis.instance.dtype)
        self.normals = np.empty((s, n, 3))
        overrides = axis.reflectivity
        self.reflectivity = None if overrides is None else np.empty((s, n), dtype=np.float32)
        self._lock = threading.Lock()

    def fill(self, sub_world: np.ndarray, cast_range: float, b: slice) -> None:
        """The sub-rays of beams `b` on the plane of their axis's hit: t_k = t_0 (n·a)/(n·s_k),
        with the axis's element, normal and reflectivity; none where the axis met nothing or
        t_k is past `cast_range` (or the plane is parallel to the sub-ray)."""
        s = len(sub_world)
        axis, distance, cls, instance, normals = (
            self.axis,
            self.distance,
            self.cls,
            self.instance,
            self.normals,
        )
        normal = axis.normal[b]
        t0 = axis.distance[b]
        distance[0, b] = t0
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            # an axis that met nothing has a zero normal: inf * 0 / 0 = nan, fixed below
            along = t0 * dm.dot3(normal, sub_world[0, b])
            for k in range(1, s):
                distance[k, b] = along / dm.dot3(normal, sub_world[k, b])
        ring = distance[1:, b]
        cls[:, b] = axis.class_id[b]
        instance[:, b] = axis.instance[b]
        normals[:, b] = normal
        reflectivity = None if axis.reflectivity is None else self.reflectivity
        if reflectivity is not None:
            reflectivity[:, b] = axis.reflectivity[b]
        # none where the axis met nothing (its class, instance and normal say none already),
        # nor past cast_range, behind the origin or parallel (nan and inf fail both tests)
        missed = ~((ring > 0) & (ring <= cast_range))
        ring[missed] = np.inf
        k, j = np.nonzero(missed & np.isfinite(t0))  # the axis met something, not the sub-ray: rare
        for out, none in ((cls, -1), (instance, -1), (normals, 0.0)):
            out[1:, b][k, j] = none
        if reflectivity is not None:
            reflectivity[1:, b][k, j] = np.nan

    def put(self, rows: np.ndarray, new: RayHits) -> None:
        """Rows `rows` (of the S·N, sub-ray-major) set to `new`'s hits (an override array made
        where `new` has overrides and the axes had none)."""
        self.distance.reshape(-1)[rows] = new.distance
        self.cls.reshape(-1)[rows] = new.class_id
        self.instance.reshape(-1)[rows] = new.instance
        self.normals.reshape(-1, 3)[rows] = new.normal
        if new.reflectivity is not None or self.reflectivity is not None:
            with self._lock:  # made once, by whichever block needs it first
                if self.reflectivity is None:
                    self.reflectivity = np.full(self.distance.shape, np.nan, dtype=np.float32)
            self.reflectivity.reshape(-1)[rows] = new.overrides()

    def joined(self) -> RayHits:
        flat = (self.distance.ravel(), self.cls.ravel(), self.instance.ravel(), self.axis.untagged_objects)
        overridden = None if self.reflectivity is None else self.reflectivity.ravel()
        return RayHits(*flat, normal=self.normals.reshape(-1, 3), reflectivity=overridden)
