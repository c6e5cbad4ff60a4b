"""Ground cover as a medium (numpy only): where a beam stops inside the sward layer.

The cover (core/world/cover.py CoverGrid) is a turbid layer over the terrain, not geometry:
after the cast, each ray's run through the layer is found analytically (GroundCover), and the
ray stops inside it at an exponentially distributed optical depth
(Beer-Lambert: the chance of passing a path s through leaf area density LAD is exp(-G LAD s)).
That is the turbid-medium model HELIOS++ uses for vegetation voxels (Winiwarter et al. 2022,
"Virtual laser scanning with HELIOS++", Remote Sensing of Environment 269:112772, section
2.3.3, after Ross's G function). A ray that stops becomes a hit at that depth with the class of
the cell it stopped in, so a grass point lies inside the grass layer and every label stays
exact. Rays that do not stop keep their surface hit.

Cost: a constant number of array operations a ray in the layer, whatever its range; the rays
that cannot be in it (above every cell's top within reach, or whose run from the sensor reaches
their hit) are left out before any cell is looked up.

Determinism: the rays are taken in fixed parts of PART rays (on the cast's threads); each part
draws from its own PCG64 generator seeded from (the scan's noise seed, "cover.part.K"), in ray
order: the uniforms of the rays that start in the layer, of those whose hit is in it, then (at
once, as many as SETTLE redraws could take) of the stops drawn again. The redraws (a few grazing
beams) are settled after the parts, every part's at once, each pass taking the next uniforms of
each ray's own part: the numbers a part drawing pass by pass would take. Each optical depth is
-log(1 - u) with detmath's log, so the same scan gives the same bytes on every machine, however
many threads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..hits import RayHits
from ..rng import stage_rng
from ..threads import in_parts
from ..world.cover import BOTTOM_SLACK, COVER_INSTANCE_BASE, CoverGrid, extinction
from .base import Effect, Rays

# The robot flattens what it stands on: within this horizontal distance of the sensor no cover
# stops a beam (about the half-diagonal of the paper's robot, Andabata: 0.67 m x 0.54 m).
TRAMPLED = 0.45  # m
LONGEST_RUN = 30.0  # m of one run at most (a beam running level inside a tall sward)
BEFORE_HIT = 1e-4  # m before a hit, where the hit's cell and layer are read
SETTLE = 4  # times a stop outside its own cell's sward goes on along its run (_settle)
# rays a part of the medium, on the cast's threads (core/threads.py in_parts); fixed, so a scan's
# bytes do not depend on the threads
PART = 49_152
CELL_EXIT = 1e-6  # m past a cell's edge, where a ray going on from it starts (in the next cell)


class GroundCover(Effect):
    """The medium of a world's ground cover; `seed` keys the random depths (the noise seed).

    A ray meets the layer in at most two runs that matter: the one that ends at its surface hit
    (a beam coming down through the sward to the ground, or to the foot of a trunk) and the one
    from the sensor (a robot standing in tall grass). Each run is found analytically from the
    cell where it ends (or starts): the terrain there as a plane (its slope) and the layer's
    height there, so the ray's height above the terrain changes linearly along it and the run
    is where that height lies between 0 and the layer's. The ray stops at its drawn optical
    depth into the run (Exp(1) / (G LAD), LAD = LAI / the layer's height); the stop is kept
    only where it lies inside the layer as the grid says (CoverGrid.class_inside), labelled
    with the class of its own cell. A constant number of array operations a ray: the cost does
    not grow with the runs' lengths. What this leaves out: a beam skimming through a sward and
    out again before a farther hit (a crest's grass tops), and a layer whose height or class
    changes along one run (the run's end cell decides its length)."""

    name = "cover"
    changes_medium = True

    def __init__(self, grid: CoverGrid, seed: int = 0):
        self.grid = grid
        self.seed = int(seed)

    def describe(self) -> dict:
        return {"model": "beer-lambert", "cell_m": self.grid.cell, "trampled_m": TRAMPLED}

    def medium(self, rays: Rays, hits: RayHits) -> RayHits:
        n = len(hits.distance)
        o = np.asarray(rays.origins, dtype=np.float64)
        d = np.asarray(rays.directions, dtype=np.float64)
        # each ray's origin and direction as x, y, z arrays (an origin: 3 numbers, or n each),
        # made contiguous a part at a time, on the part's thread
        ray = _Rays(*(o[k] if o.ndim == 1 else o[:, k] for k in range(3)), *(d[:, k] for k in range(3)))
        end = np.minimum(hits.distance, rays.max_range)
        hit = np.isfinite(hits.distance)

        def stops(part: slice):
            return self._stops(ray.part(part), end[part], hit[part], part.start)

        found = [_PartStops(part.start, *f) for part, f in zip(_slices(n), in_parts(stops, n, PART))]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            self._redraw_all(o, d, found)
        rows, at, cls = _kept(found, n)
        if not len(rows):
            return hits
        return _with_cover_hits(hits, rows, at, cls, d)

    def _stops(self, ray: _Rays, end, hit, first: int):
        """The stops in the layer of one part of the rays (from ray `first` on; `end` each
        one's hit or max range, `hit` whether it hit), as far as one part settles them:
        (rows in the part, how many of them are runs from the sensor (first), where each
        stops, its class (0: none yet), the redraws it leaves (_Redraws: _redraw_all settles
        those of every part at once)).

        Both runs of a ray are found first and their stops settled together (one _settle, so
        its passes are paid once a part); a ray whose run from the sensor holds keeps that
        stop, else its run to the hit's (_kept)."""
        # a stream a part, drawn only for the rays in the layer: the same bytes however many
        # threads share the parts
        rng = stage_rng(self.seed, f"cover.part.{first // PART}")
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            horizontal = np.sqrt(ray.dx * ray.dx + ray.dy * ray.dy)
            t0 = np.minimum(np.where(horizontal > 0, TRAMPLED / horizontal, np.inf), end)
            a, t_a, leave, cls_a, height_a = self._run_from_sensor(ray, t0, end)
            # a run to the hit begins past the run from the sensor: none where that reaches
            # the hit (a beam coming down through the sward near the robot, most of them)
            start = t0
            start[a] = leave
            to_hit = np.flatnonzero(hit & (start < end))
            b, begin_b, end_b, cls_b, height_b = self._run_to_hit(ray, end, start, to_hit)
            # both runs' stops at once: the uniforms of the runs from the sensor, then of the
            # runs to the hit, as two draws would give them
            rows, begin, run_end = (
                np.concatenate([a, b]),
                np.concatenate([t_a, begin_b]),
                np.concatenate([leave, end_b]),
            )
            anchor_cls, anchor_height = np.concatenate([cls_a, cls_b]), np.concatenate([height_a, height_b])
            stop = _stop(begin, run_end, anchor_cls, anchor_height, rng.random(len(rows)))
            k = np.flatnonzero(np.isfinite(stop))
            rows, stop, run_end = rows.take(k), stop.take(k), run_end.take(k)
            anchor_cls, anchor_height = anchor_cls.take(k), anchor_height.take(k)
            cls, redraws = self._settle(ray.rows(rows), stop, run_end, anchor_cls, anchor_height, rng)
        return rows, int(np.searchsorted(k, len(a))), stop, cls, redraws

    def _run_from_sensor(self, ray: _Rays, t0, end):
        """The run from the sensor, past the trampled ground, until the ray rises out of the
        layer (or reaches its hit): (the rays that start it inside the layer, where each starts
        and leaves the layer, the class and layer height where it starts)."""
        rows = np.flatnonzero((t0 < end) & self._may_start_inside(ray, t0))
        rows, t, (cls, above, height, rate) = self._inside(ray, rows, t0.take(rows))
        leave = np.where(rate > 0, t + (height - above) / rate, np.inf)
        leave = np.minimum(np.minimum(leave, t + LONGEST_RUN), end.take(rows))
        return rows, t, leave, cls, height

    def _run_to_hit(self, ray: _Rays, end, start, rows):
        """The run that ends at the hit of each of `rows`, from where the ray came down into
        the layer (not before `start`): (the rays whose hit lies in the layer, where each one's
        run begins and ends, the class and layer height at the hit)."""
        at = np.maximum(end.take(rows) - BEFORE_HIT, 0.0)
        if np.ndim(ray.oz) == 0 and len(rows):  # one origin: none above the layer's top within reach
            reach = float(at.max())
            low = ray.oz + ray.dz.take(rows) * at <= self.grid.top_within(ray.ox, ray.oy, reach)
            rows, at = rows[low], at[low]
        rows, _, (cls, above, height, rate) = self._inside(ray, rows, at)
        back = np.minimum(np.where(rate < 0, (height - above) / -rate, LONGEST_RUN), LONGEST_RUN)
        stop_end = end.take(rows)
        begin = np.maximum(stop_end - back, start.take(rows))
        return rows, begin, stop_end, cls, height

    def _inside(self, ray: _Rays, rows, t):
        """Of `rows`, those whose point t along lies inside the layer: (those rows, their t,
        class, height above the terrain, layer height and rate there: the height above the
        terrain changes along the ray at that rate, its climb less the slope of the terrain)."""
        r = ray.rows(rows)
        x, y, z = r.ox + r.dx * t, r.oy + r.dy * t, r.oz + r.dz * t
        near, (cls, height, ground, gx, gy) = self.grid.surface_near(x, y, z)
        r, above = r.rows(near), z.take(near) - ground
        rate = r.dz - (gx * r.dx + gy * r.dy)
        inside = (cls > 0) & (above >= -BOTTOM_SLACK) & (above <= height)
        rows, t = rows.take(near), t.take(near)
        return rows[inside], t[inside], (cls[inside], above[inside], height[inside], rate[inside])

    def _settle(self, ray: _Rays, stop, end, anchor_cls, anchor_height, rng):
        """The class at each stop (of `ray`'s rays) inside the layer as the grid has it (0:
        none), and the redraws left (_Redraws); `stop` is updated in place (inf where the stop
        came out of the layer). A run's length and medium are its anchor cell's (where
        it ends, or starts); along a long run (a grazing beam over several cells) a stop can come
        out where this cell's sward is lower, or bare ground (a trail, a rock), or another class.
        Such a ray goes on from there (from where it comes down into this cell's sward, when it
        is above it): its depth is drawn again (from `rng`), in this cell's sward or, where this
        cell has none, in the anchor's, until its run's `end`; at most SETTLE times, then it
        passes (_redraw_all). (Dropping such stops instead would let grazing beams through a
        meadow far more often than Beer-Lambert says.) The uniforms of the redraws are drawn
        here, as many as they could take: the stream is the part's own and nothing draws from
        it after, so they are the numbers a pass at a time would draw."""
        x, y, z = ray.at(stop)
        c, height, ground, _, _ = self.grid.surface_at(x, y, slopes=False)
        inside = _in_layer(c, z - ground, height)
        cls = np.where(inside, c, 0).astype(np.int16, copy=False)
        out = np.flatnonzero(~inside)
        t = stop.take(out)
        stop[out] = np.inf
        medium = (end.take(out), anchor_cls.take(out), anchor_height.take(out))
        return cls, _Redraws(out, t, *medium, rng.random(len(out) * SETTLE))

    def _redraw_all(self, origins: np.ndarray, dirs: np.ndarray, found: list[_PartStops]) -> None:
        """The redraws of every part's stops that came out of the layer (_settle), at once: a
        few rays (grazing beams), so a pass costs its array operations once, not once a part.
        Their arrays are kept compact, one cell lookup (with the terrain's slopes) a pass; each
        pass takes the next uniforms of each ray's part in the rays' order. A redrawn stop that
        holds is set in its part's `stop` and `cls`."""
        parts = [f for f in found if len(f.redraws.slot)]
        if not parts:
            return
        # each pending stop: its part (k), its place in its part's arrays (slot), its ray
        part = np.concatenate([np.full(len(f.redraws.slot), k) for k, f in enumerate(parts)])
        slot = np.concatenate([f.redraws.slot for f in parts])
        rays = np.concatenate([f.first + f.rows.take(f.redraws.slot) for f in parts])
        t, end, anchor_cls, anchor_height = (
            np.concatenate([getattr(f.redraws, name) for f in parts])
            for name in ("t", "end", "cls", "height")
        )
        # whole rows of the (n, 3) arrays (a column's take would copy the whole column first)
        ray = _Rays(
            *(origins if origins.ndim == 1 else origins.take(rays, axis=0).T), *dirs.take(rays, axis=0).T
        ).rows(np.arange(len(rays)))
        drawn = [0] * len(parts)
        x, y, z = ray.at(t)
        c, height, ground, gx, gy = self.grid.surface_at(x, y)
        for _ in range(SETTLE):
            above = z - ground
            # above a lower sward the ray comes down into: on from where it enters it; over
            # bare ground or rising above this cell's sward: on from where it leaves the cell
            # (none of its stops would hold before, and the depths are memoryless: the law of
            # the next stop is that of the stops drawn again and again until one is past it)
            here = c > 0
            high = here & (above > height)
            rate = ray.dz - (gx * ray.dx + gy * ray.dy)
            down = high & (rate < 0)
            on = ~here | (high & (rate >= 0))
            t = np.where(down, t + (above - height) / -rate, t)
            t = np.where(on, self._cell_exit(x, y, ray, t), t)
            medium_cls, medium_height = np.where(here, c, anchor_cls), np.where(here, height, anchor_height)
            t = _stop(t, end, medium_cls, medium_height, _next_uniforms(parts, part, drawn))
            going = np.flatnonzero(np.isfinite(t))
            if not len(going):
                return
            ray, part, slot, t = ray.rows(going), part.take(going), slot.take(going), t.take(going)
            end, anchor_cls, anchor_height = (
                end.take(going),
                anchor_cls.take(going),
                anchor_height.take(going),
            )
            x, y, z = ray.at(t)
            c, height, ground, gx, gy = self.grid.surface_at(x, y)
            inside = _in_layer(c, z - ground, height)
            for k in np.unique(part[inside]).tolist():
                held = inside & (part == k)
                parts[k].stop[slot[held]] = t[held]
                parts[k].cls[slot[held]] = c[held]
            out = np.flatnonzero(~inside)
            if not len(out):
                return
            ray, part, slot, t = ray.rows(out), part.take(out), slot.take(out), t.take(out)
            x, y, z = x.take(out), y.take(out), z.take(out)
            end, anchor_cls, anchor_height = end.take(out), anchor_cls.take(out), anchor_height.take(out)
            c, height, ground, gx, gy = (v.take(out) for v in (c, height, ground, gx, gy))

    def _cell_exit(self, x, y, ray: _Rays, t):
        """Where the rays `ray`, at t along them at (x, y), leave their cell (in x and y; a
        micrometre past its edge): inf for a ray with no way out (straight up or down)."""
        g = self.grid
        ix = np.floor((x - g.x0) / g.cell)
        iy = np.floor((y - g.y0) / g.cell)
        to_x = ((ix + (ray.dx > 0)) * g.cell + g.x0 - x) / ray.dx
        to_y = ((iy + (ray.dy > 0)) * g.cell + g.y0 - y) / ray.dy
        out = t + np.minimum(np.where(ray.dx != 0, to_x, np.inf), np.where(ray.dy != 0, to_y, np.inf))
        return out + CELL_EXIT

    def _may_start_inside(self, ray: _Rays, t0) -> np.ndarray:
        """Rays whose point t0 along (at most TRAMPLED from a single origin, in x and y) can lie
        in the layer: not above the highest layer top of the cells that square around the
        origin touches (CoverGrid.top_within; a cheap bound that spares the upward rays and
        those over a low sward). Origins per ray (a drive): every ray."""
        if np.ndim(ray.ox) != 0:
            return np.ones(len(t0), dtype=bool)
        # a micrometre more than TRAMPLED: a point's own rounding never takes it past the square
        top = self.grid.top_within(ray.ox, ray.oy, TRAMPLED + 1e-6)
        return ray.oz + ray.dz * t0 <= top


@dataclass(frozen=True)
class _Redraws:
    """The stops of a part that came out of the layer at their first try (_settle): their
    places in the part's stops (slot), where they came out (t), their runs' ends, their anchors'
    classes and layer heights, and the part's uniforms for their redraws."""

    slot: np.ndarray
    t: np.ndarray
    end: np.ndarray
    cls: np.ndarray
    height: np.ndarray
    uniforms: np.ndarray


@dataclass(frozen=True)
class _PartStops:
    """One part's stops (_stops): rows in the part (the runs from the sensor first, n_a of
    them), where each stops and its class (0: none), the redraws left; `first` is the part's
    first ray."""

    first: int
    rows: np.ndarray
    n_a: int
    stop: np.ndarray
    cls: np.ndarray
    redraws: _Redraws


def _next_uniforms(parts: list[_PartStops], part: np.ndarray, drawn: list[int]) -> np.ndarray:
    """The next uniform of each ray's part (`part`: index into `parts`, the rays in part
    order), in the rays' order; `drawn` counts each part's uniforms taken, updated."""
    counts = np.bincount(part, minlength=len(parts)).tolist()
    out = []
    for k, count in enumerate(counts):
        out.append(parts[k].redraws.uniforms[drawn[k] : drawn[k] + count])
        drawn[k] += count
    return np.concatenate(out)


def _kept(found: list[_PartStops], n: int):
    """(rays, where, class) of the stops that hold, of every part: a ray whose run from the
    sensor holds keeps that stop, else its run to the hit's."""
    rows = np.concatenate([f.first + f.rows for f in found])
    stop = np.concatenate([f.stop for f in found])
    cls = np.concatenate([f.cls for f in found])
    from_sensor = np.concatenate([np.arange(len(f.rows)) < f.n_a for f in found])
    held = cls > 0
    taken = np.zeros(n, dtype=bool)
    taken[rows[held & from_sensor]] = True
    keep = held & (from_sensor | ~taken[rows])  # the run from the sensor's stop first
    return rows[keep], stop[keep], cls[keep]


@dataclass(frozen=True)
class _Rays:
    """Rays as x, y, z arrays: origins (numbers: one origin for all, or arrays) and directions."""

    ox: np.ndarray | float
    oy: np.ndarray | float
    oz: np.ndarray | float
    dx: np.ndarray
    dy: np.ndarray
    dz: np.ndarray

    def part(self, part: slice) -> _Rays:
        def cut(v):
            return v if np.ndim(v) == 0 else np.ascontiguousarray(v[part])

        return _Rays(*(cut(v) for v in (self.ox, self.oy, self.oz, self.dx, self.dy, self.dz)))

    def rows(self, rows: np.ndarray) -> _Rays:
        def pick(v):
            return v if np.ndim(v) == 0 else v.take(rows)

        return _Rays(*(pick(v) for v in (self.ox, self.oy, self.oz, self.dx, self.dy, self.dz)))

    def at(self, t: np.ndarray):
        """(x, y, z) of the points t along the rays."""
        return self.ox + self.dx * t, self.oy + self.dy * t, self.oz + self.dz * t


def _in_layer(cls, above, height) -> np.ndarray:
    """Whether points `above` the terrain lie in the layer of their cell (class `cls`, layer
    height `height`): CoverGrid.class_inside's test."""
    return (cls > 0) & (above >= -BOTTOM_SLACK) & (above <= height)


def _slices(count: int) -> list[slice]:
    """The parts in_parts cuts `count` rays into (PART rays each)."""
    return [slice(start, min(start + PART, count)) for start in range(0, count, PART)] or [slice(0, 0)]


def _stop(begin, end, cls, height, u):
    """Where each ray's optical depth runs out in its run [begin, end) (inf: it passes): the
    depth -log(1 - u), Exp(1), over the extinction per metre of its class and layer height.
    (Taken for every ray of the run, whole arrays: most of them stop, and a ray that passes,
    a run that is empty or a medium of no extinction gives a point at or past its end, or
    nan, never a stop.)"""
    return _stop_at(begin, end, cls, height, dm.log(1.0 - u))


def _stop_at(begin, end, cls, height, log_1_u):
    """_stop, given log(1 - u)."""
    t = begin - log_1_u / extinction(cls, height)
    return np.where(t < end, t, np.inf)


def _with_cover_hits(hits: RayHits, rows, t_stop, cls, dirs) -> RayHits:
    """The hits with the rays `rows`, which stopped in the cover at `t_stop` in cells of class
    `cls`, replaced by a hit there."""
    distance = _replaced(hits.distance, rows, t_stop)
    class_id = _replaced(hits.class_id.astype(np.int16, copy=False), rows, cls)
    instance = _replaced(
        hits.instance.astype(np.int32, copy=False), rows, COVER_INSTANCE_BASE + cls.astype(np.int32)
    )
    normal = None
    if hits.normal is not None:  # a sward faces every beam: its normal is the beam's reverse
        normal = _replaced(hits.normal, rows, -dirs[rows])
    reflectivity = None
    if hits.reflectivity is not None:
        reflectivity = _replaced(hits.reflectivity.astype(np.float32, copy=False), rows, np.float32(np.nan))
    return RayHits(distance, class_id, instance, hits.untagged_objects, normal, reflectivity)


def _replaced(values: np.ndarray, rows: np.ndarray, new) -> np.ndarray:
    """A copy of `values` (in the type that holds both) with `rows` set to `new`."""
    out = np.array(values, dtype=np.result_type(values, new))
    out[rows] = new
    return out
