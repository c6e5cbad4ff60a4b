"""Coarse to fine: a scan's footprint sub-rays cast only where the beam's surroundings are
ambiguous (numpy only).

The realistic model samples each beam's footprint with SUBRAYS sub-rays (footprint.py), and
casting them is most of a realistic scan's time. But most beams of a scan land whole on one
smooth surface (a slope of terrain, a rock's face, a trunk's side): there the ring sub-rays
only meet the plane the axis met, a hair beside it. So the axes are cast first, for every
beam; then a beam's ring is cast only where its neighbourhood says the footprint may hold more
than one surface (`needs_footprint`):

  - its axis met porous vegetation (a crown's leaves, a bush, grass blades) or a thin element
    (a wire): the footprint there is a mix by nature;
  - one of its four neighbours on the scan's grid (the next beams along the scan line and
    along the head's turn, which lie farther from its axis than its ring does) met another
    element, or nothing where it met something, or a point off its plane by more than
    FLAT_TOLERANCE (an edge, a step, a curved surface's facets);
  - its plane faces the axis at grazing incidence (|cos| below GRAZING_COS): a ring sub-ray's
    point would then lie far from the axis's;
  - it has no neighbour on some side (the first and last columns, the ends of the fan);
  - a thin element (a wire, a pole) was met by an axis within THIN_REACH beams of it, which a
    ring sub-ray may meet where the axes miss it (a wire runs between the rows of beams).

Elsewhere (a beam whose neighbours all met the same element on its plane, or all met nothing)
the ring's hits are those of the axis's plane, computed (`planar_ring`): each ring sub-ray
meets the plane n·x = n·p of the axis's hit at t_k = t_0 (n·a)/(n·s_k), with the axis's
element, normal and reflectivity; a beam whose neighbourhood met nothing has a ring that meets
nothing. Those hits then go on exactly as cast ones do: through the medium (the ground cover's
sward stops each sub-ray at its own depth, as before), into the echoes and the settling.

What this can miss, measured against casting every sub-ray on the realism suite's poses
(bench/realism.py; docs/realism.md): an object no axis met and smaller than the gap between
two neighbouring axes (a twig, a slat's edge) that a ring sub-ray would have met. The cast
beams get the very hits they got before (each ray's answer is its own, core/threads.py);
the computed ones differ from cast ones by round-off on one triangle, by the terrain's fold
between facets elsewhere (a fraction of FLAT_TOLERANCE).

Determinism: which beams are cast follows from the float64-settled axis hits alone, and the
computed hits are products and sums in a fixed order (detmath): the same bytes on every machine.
"""

from __future__ import annotations

import functools
import os

import numpy as np

from . import detmath as dm
from .classes import PARTICLE_ID, class_by_name
from .hits import RayHits
from .sensors import Device, sweep_count

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
EMPTY_REACH = tuple(int(x) for x in os.environ.get("C2F_EMPTY_REACH", "3,2").split(","))
# Elements whose footprint is a mix by nature, or thin enough to lie between two axes.
POROUS = tuple(n for n in os.environ.get("C2F_POROUS", "treetop,bush,low grass,high grass").split(",") if n)
THIN = ("wire", "pole")


def _class_mask(names) -> np.ndarray:
    mask = np.zeros(PARTICLE_ID + 1, dtype=bool)
    for name in names:
        mask[class_by_name(name).id] = True
    return mask


_POROUS = _class_mask(POROUS)
_THIN = _class_mask(THIN)


class BeamGrid:
    """Beams as a scan lays them out: columns (one a head angle, `per_column` beams each, in
    firing order), several head sweeps of `columns` columns one after another. `neighbours`
    (4, N): the beam before and after along the scan line (by angle from the axis) and the
    same beam in the column before and after (of the same sweep); -1 where there is none."""

    def __init__(self, from_axis_deg, columns: int, sweeps: int = 1):
        per_column = len(from_axis_deg)
        order = np.argsort(np.asarray(from_axis_deg, dtype=np.float64), kind="stable")
        before = np.full(per_column, -1, dtype=np.int64)
        after = np.full(per_column, -1, dtype=np.int64)
        before[order[1:]] = order[:-1]
        after[order[:-1]] = order[1:]
        total = columns * sweeps
        column = np.repeat(np.arange(total, dtype=np.int64), per_column)
        beam = np.tile(np.arange(per_column, dtype=np.int64), total)
        start = column * per_column
        in_sweep = column % columns
        out = np.empty((4, total * per_column), dtype=np.int64)
        out[0] = np.where(before[beam] >= 0, start + before[beam], -1)
        out[1] = np.where(after[beam] >= 0, start + after[beam], -1)
        out[2] = np.where(in_sweep > 0, start - per_column + beam, -1)
        out[3] = np.where(in_sweep < columns - 1, start + per_column + beam, -1)
        self.per_column = per_column
        self.neighbours = out
        out.flags.writeable = False

    def __len__(self) -> int:
        return self.neighbours.shape[1]


@functools.lru_cache(maxsize=4)
def scan_grid(device: Device, rh_deg: float) -> BeamGrid:
    """The grid of the beams of sensors.beam_directions(rh_deg, device), cached."""
    columns = sweep_count(rh_deg, device.mount)
    sweeps = device.head.steps if device.head is not None else 1
    return BeamGrid(device.beams.from_axis_deg, columns, sweeps)


def needs_footprint(axis: RayHits, axis_dirs: np.ndarray, grid: BeamGrid) -> np.ndarray:
    """(N,) bool: the beams whose ring sub-rays must be cast (see the module docstring), from
    the hits of every beam's axis (with normals) in the grid's order."""
    nb = grid.neighbours
    present = np.logical_and.reduce(nb >= 0, axis=0)
    at = np.where(nb >= 0, nb, 0)
    distance, cls, instance = axis.distance, axis.class_id, axis.instance
    hit = np.isfinite(distance)
    # nothing met in a window around: the ring meets nothing either
    empty = ~_grown(hit, grid, EMPTY_REACH)
    known = (cls >= 0) & (cls < len(_POROUS))
    cls_index = np.where(known, cls, 0)
    smooth = hit & known & ~_POROUS[cls_index] & ~_THIN[cls_index]
    for k in range(nb.shape[0]):
        smooth &= (instance[at[k]] == instance) & (cls[at[k]] == cls) & hit[at[k]]
    normal = axis.normal
    facing = dm.dot3(normal, axis_dirs)
    smooth &= np.abs(facing) >= GRAZING_COS
    # each neighbour's point measured off the axis's plane: n·(t' a' - t a), from the optical
    # centre both leave (the origin cancels)
    with np.errstate(invalid="ignore"):
        own = facing * distance
        for k in range(nb.shape[0]):
            off = dm.dot3(normal, axis_dirs[at[k]]) * distance[at[k]] - own
            smooth &= np.abs(off) <= FLAT_TOLERANCE
            smooth &= np.abs(dm.dot3(normal, normal[at[k]])) >= PARALLEL_COS
    thin = hit & known & _THIN[cls_index]
    coarse = present & (empty | smooth) & ~_grown(thin, grid, THIN_REACH)
    return ~coarse


def _grown(mark: np.ndarray, grid: BeamGrid, reach: tuple[int, int]) -> np.ndarray:
    """`mark` grown by reach[0] beams each way along the scan line, then by reach[1] columns
    each way (a rectangle of the grid around every marked beam)."""
    grown = mark
    for side, steps in ((0, reach[0]), (2, reach[1])):
        for _ in range(steps):
            step = grown.copy()
            for k in (side, side + 1):
                nb = grid.neighbours[k]
                has = nb >= 0
                step[has] |= grown[nb[has]]
            grown = step
    return grown


def planar_ring(axis: RayHits, sub_world: np.ndarray, beams: np.ndarray, cast_range: float) -> RayHits:
    """The hits of the ring sub-rays (S - 1 of them, sub-ray-major as `sub_world[1:]`) of
    `beams`, computed on the plane of each one's axis hit: t_k = t_0 (n·a)/(n·s_k) (none past
    `cast_range`, none where the axis met nothing), the axis's element, normal and
    reflectivity."""
    ring = sub_world[1:, beams]
    rings = ring.shape[0]
    t0 = axis.distance.take(beams)
    normal = axis.normal.take(beams, axis=0)
    facing = dm.dot3(normal, sub_world[0].take(beams, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (t0 * facing)[None] / dm.dot3(normal[None], ring)
    met = np.isfinite(t) & (t > 0) & (t <= cast_range)
    distance = np.where(met, t, np.inf).ravel()
    met = met.ravel()

    def tiled(values, missing):
        out = np.tile(values.take(beams, axis=0), (rings,) + (1,) * (values.ndim - 1))
        out[~met] = missing
        return out

    return RayHits(
        distance=distance,
        class_id=tiled(axis.class_id, -1),
        instance=tiled(axis.instance, -1),
        untagged_objects=axis.untagged_objects,
        normal=tiled(axis.normal, 0.0),
        reflectivity=None if axis.reflectivity is None else tiled(axis.reflectivity, np.nan),
    )


def footprint_hits(cast, origin: np.ndarray, sub_world: np.ndarray, cast_range: float, grid: BeamGrid):
    """(the first hits of every sub-ray (S·N, sub-ray-major, as one cast of them all would
    give, with normals), the beams whose ring was cast). `cast(origins, dirs, max_range,
    normals)` is the backend's cast; the axes are cast, then the rings of the beams
    `needs_footprint` names; the other rings are `planar_ring`'s."""
    s, n, _ = sub_world.shape
    axis = cast(origin, sub_world[0], cast_range, True)
    fine = needs_footprint(axis, sub_world[0], grid)
    cast_beams = np.flatnonzero(fine)
    computed = np.flatnonzero(~fine)
    ring_cast = cast(origin, sub_world[1:, cast_beams].reshape(-1, 3), cast_range, True)
    ring_planar = planar_ring(axis, sub_world, computed, cast_range)
    return _assembled(axis, [(cast_beams, ring_cast), (computed, ring_planar)], s, n), fine


def _assembled(axis: RayHits, rings, s: int, n: int) -> RayHits:
    """One RayHits of S·N sub-rays, sub-ray-major: row 0 the axes, rows 1.. the rings, each of
    `rings` ((beams, their ring's hits sub-ray-major)) put in its beams' columns."""
    overrides = axis.reflectivity is not None or any(h.reflectivity is not None for _, h in rings)
    distance = np.empty((s, n))
    cls = np.empty((s, n), dtype=axis.class_id.dtype)
    instance = np.empty((s, n), dtype=axis.instance.dtype)
    normal = np.empty((s, n, 3))
    reflectivity = np.empty((s, n), dtype=np.float32) if overrides else None
    distance[0], cls[0], instance[0], normal[0] = axis.distance, axis.class_id, axis.instance, axis.normal
    if overrides:
        reflectivity[0] = axis.overrides()
    untagged = set(axis.untagged_objects)
    for beams, hits in rings:
        shape = (s - 1, len(beams))
        distance[1:, beams] = hits.distance.reshape(shape)
        cls[1:, beams] = hits.class_id.reshape(shape)
        instance[1:, beams] = hits.instance.reshape(shape)
        normal[1:, beams] = hits.normal.reshape(shape + (3,))
        if overrides:
            reflectivity[1:, beams] = hits.overrides().reshape(shape)
        untagged |= hits.untagged_objects
    return RayHits(
        distance=distance.ravel(),
        class_id=cls.ravel(),
        instance=instance.ravel(),
        untagged_objects=frozenset(untagged),
        normal=normal.reshape(-1, 3),
        reflectivity=None if reflectivity is None else reflectivity.ravel(),
    )
