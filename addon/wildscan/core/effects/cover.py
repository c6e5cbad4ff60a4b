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
their hit) are left out before any cell is looked up. Each cell's fields are gathered from
contiguous per-world arrays (core/world/cover_lookup.py), and most rays are decided by their
cell's bounds (lowest and highest corner, steepest slope) without interpolating the terrain:
a point surely inside the layer, a ray surely coming down. Only the rest are looked at
closely, with CoverGrid.surface_at's own operations, so every decision is the one the
interpolated terrain gives (core/effects/cover_cells.py: the cells along the rays).

Determinism: every uniform a ray draws is a hash of (the scan's noise seed, the ray's index in
the scan, which of its two runs: from the sensor or to its hit, and the draw's number: 0 the
first stop, 1..SETTLE its redraws) (rng.hash_unit, splitmix64), not the next number of a
stream. So a ray's stops depend on that ray alone: another ray's hit changing (an element left
out of a far tile, core/world/endless) moves no other ray's stop, and a scan's bytes do not
depend on the threads or on the parts (PART rays) the rays are taken in. Each optical depth is
-log(1 - u) with detmath's log, so the same scan gives the same bytes on every machine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..hits import RayHits
from ..rng import hash_unit
from ..runtime.threads import in_parts
from ..world.cover import BOTTOM_SLACK, COVER_INSTANCE_BASE, CoverGrid
from ..world.cover_lookup import CoverLookup, cover_lookup
from .base import Effect, Rays
from .cover_cells import (
    TRAMPLED,
    CoverRays,
    cell_exit,
    cells,
    ground_at,
    hits_near,
    in_layer,
    inside,
    slope_at,
    surface,
    trampled,
)

LONGEST_RUN = 30.0  # m of one run at most (a beam running level inside a tall sward)
BEFORE_HIT = 1e-4  # m before a hit, where the hit's cell and layer are read
SETTLE = 4  # times a stop outside its own cell's sward goes on along its run (_settle)
# rays a part of the medium, on the cast's threads (core/threads.py in_parts); fixed, so a scan's
# bytes do not depend on the threads
PART = 49_152


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
        if not n:
            return hits
        look = cover_lookup(self.grid)
        d = np.asarray(rays.directions, dtype=np.float64)
        o = np.asarray(rays.origins, dtype=np.float64)
        end = np.minimum(hits.distance, rays.max_range)
        hit = np.isfinite(hits.distance)

        def stops(part: slice) -> _Stops:
            """The stops of one part of the rays, as far as the part settles them."""
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                ray = CoverRays(o if o.ndim == 1 else o[part], d[part], rays.max_range)
                e = end[part]
                a = self._from_sensor(look, ray, e)
                b = self._to_hit(look, ray, e, hit[part], a)
                found = _Stops.first(a, b, self.seed, part.start)
                _settle(look, ray, found)
            found.rows += part.start  # the part's rays, numbered in the scan
            return found

        found = _Stops.joined(in_parts(stops, n, PART))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            _redraw(look, CoverRays(o, d, rays.max_range), found, self.seed)
        rows, at, cls = found.kept(n)
        if not len(rows):
            return hits
        return _with_cover_hits(hits, rows, at, cls, d)

    def _from_sensor(self, look: CoverLookup, ray: CoverRays, end: np.ndarray) -> _Run:
        """The runs from the sensor, past the trampled ground, until each ray rises out of the
        layer (or reaches its hit): of the rays whose point TRAMPLED from the sensor (in x and
        y) lies in the layer. One origin: only rays that can come that low are looked at (the
        highest layer top of the cells within TRAMPLED of it, CoverGrid.top_within; a bound on
        the direction's z first, then the exact test), and the cells there are in the grid.
        Most rays are decided by their cell's bounds (CoverLookup: surely inside the layer,
        surely coming down, so the run reaches the hit or LONGEST_RUN); the rest are looked at
        closely (inside)."""
        top, contained = np.inf, False
        if ray.single:
            # a micrometre more than TRAMPLED: a point's own rounding never takes it past the square
            reach = TRAMPLED + 1e-6
            top = self.grid.top_within(ray.ox, ray.oy, reach)
            if top == -np.inf:
                return _Run.empty()
            # oz + dz t0 <= top with t0 = TRAMPLED / horizontal: dz / horizontal <= s, so (unit
            # directions) dz <= s / sqrt(1 + s^2); with margins far above any rounding
            s = (top - ray.oz + 1e-9) / TRAMPLED
            rows = np.flatnonzero(ray.dz <= s / math.sqrt(1.0 + s * s) + 1e-6)
            contained = look.contains(ray.ox - reach, ray.ox + reach, ray.oy - reach, ray.oy + reach)
        else:
            rows = np.arange(len(end))
        dx, dy, dz = ray.cols(rows)
        e = end.take(rows)
        horizontal = np.sqrt(dx * dx + dy * dy)
        t0 = np.minimum(TRAMPLED / horizontal, e)  # finite (TRAMPLED / 0 is inf: `e`)
        ox, oy, oz = ray.origin(rows)
        z = oz + dz * t0
        x, y = ox + dx * t0, oy + dy * t0
        wanted = (t0 < e) & (z <= top)
        _, _, _, _, flat, ok = cells(look, x, y, contained)
        if ok is not None:
            wanted &= ok
        # surely in the layer and coming down: the run ends at the hit (or LONGEST_RUN on)
        sure = (z <= look.below_top.take(flat)) & (z >= look.bottom.take(flat))
        sure &= dz + look.steepest.take(flat) * horizontal < 0
        sure &= wanted
        leave = np.minimum(t0 + LONGEST_RUN, e)
        # the rest, not above their cell's top (CoverGrid.surface_near's test), looked at closely
        close = np.flatnonzero(wanted & ~sure & (z <= look.top.take(flat)))
        if len(close):
            dx, dy, dz = dx.take(close), dy.take(close), dz.take(close)
            ox, oy = _taken(close, ox, oy)
            t = t0.take(close)
            # (in the grid: `wanted` holds only points in it)
            k, (above, height, rate, _) = inside(
                look, x.take(close), y.take(close), z.take(close), dx, dy, dz
            )
            t = t.take(k)
            up = np.where(rate > 0, t + (height - above) / rate, np.inf)
            close = close.take(k)
            leave[close] = np.minimum(np.minimum(up, t + LONGEST_RUN), e.take(close))
            sure[close] = True
        k = np.flatnonzero(sure)
        return _Run(rows.take(k), t0.take(k), leave.take(k), look.ext.take(flat.take(k)))

    def _to_hit(self, look: CoverLookup, ray: CoverRays, end, hit, a: _Run) -> _Run:
        """The runs that end at the hits, from where each ray came down into the layer (not
        before the run from the sensor, or the trampled ground, ends): of the rays whose hit
        (BEFORE_HIT short of it) lies in the layer and that a run from the sensor does not
        reach (most of those that start in it: tested first, over all the rays at once). One
        origin: none above the highest layer top within reach looked at."""
        n = len(end)
        at = np.maximum(end - BEFORE_HIT, 0.0)
        wanted = hit.copy()
        if len(a.rows):  # a run from the sensor that reaches the hit leaves none to it
            wanted[a.rows.take(np.flatnonzero(a.end >= end.take(a.rows)))] = False
        contained = False
        if ray.single:
            reach = float(np.max(at, where=hit, initial=0.0))
            top = self.grid.top_within(ray.ox, ray.oy, reach)
            wanted &= ray.oz + ray.dz * at <= top
            contained = look.contains(ray.ox - reach, ray.ox + reach, ray.oy - reach, ray.oy + reach)
        rows, (z, flat, tx, ty) = hits_near(look, ray, at, wanted, contained)
        dx, dy, dz = ray.cols(rows)
        e = end.take(rows)
        t0 = trampled(dx, dy, e)
        sx, sy = 1.0 - tx, 1.0 - ty
        ground, corners = ground_at(look, flat, tx, ty, sx, sy)
        above = z - ground
        height = look.height.take(flat)
        m = np.flatnonzero((above >= -BOTTOM_SLACK) & (above <= height) & (t0 < e))
        rows, e, t0, above, height, flat = (v.take(m) for v in (rows, e, t0, above, height, flat))
        corners = [v.take(m) for v in corners]
        gx, gy = slope_at(look, corners, tx.take(m), ty.take(m), sx.take(m), sy.take(m))
        rate = dz.take(m) - (gx * dx.take(m) + gy * dy.take(m))
        # where the run may begin: the run from the sensor's end, or the trampled ground's
        start = t0
        if len(a.rows) and len(rows):
            leave = np.full(n, np.nan)
            leave[a.rows] = a.end
            from_a = leave.take(rows)
            start = np.where(np.isnan(from_a), t0, from_a)
        back = np.minimum(np.where(rate < 0, (height - above) / -rate, LONGEST_RUN), LONGEST_RUN)
        return _Run(rows, np.maximum(e - back, start), e, look.ext.take(flat))


@dataclass(frozen=True)
class _Run:
    """Runs of rays through the layer: the rays (ascending), where each run begins and ends,
    the extinction of its anchor cell (where it was found: its start, or its hit)."""

    rows: np.ndarray
    begin: np.ndarray
    end: np.ndarray
    ext: np.ndarray

    @staticmethod
    def empty() -> _Run:
        none = np.zeros(0)
        return _Run(np.zeros(0, dtype=np.intp), none, none, none)


@dataclass
class _Stops:
    """The stops drawn in both runs of the rays: of each part (PART rays), the runs from the
    sensor's (`from_sensor`), then the runs to the hit's, each in ray order; where each stops
    and its class (0: none yet), its run's end and anchor's extinction."""

    rows: np.ndarray
    from_sensor: np.ndarray
    stop: np.ndarray
    cls: np.ndarray
    end: np.ndarray
    ext: np.ndarray

    @staticmethod
    def first(a: _Run, b: _Run, seed: int, first: int) -> _Stops:
        """The first stops of the runs of one part (rows in the part), whose first ray is
        `first`: draw 0 of each run (ray_uniform)."""
        rays = np.concatenate([a.rows, b.rows]).astype(np.int64) + first
        run = np.concatenate([np.zeros(len(a.rows), dtype=np.int64), np.ones(len(b.rows), dtype=np.int64)])
        u = ray_uniform(seed, 2 * rays + run, 0)
        stop = _depth(np.concatenate([a.begin, b.begin]), np.concatenate([a.ext, b.ext]), u)
        end = np.concatenate([a.end, b.end])
        k = np.flatnonzero(stop < end)
        rows = np.concatenate([a.rows, b.rows]).take(k)
        from_sensor = k < len(a.rows)
        ext = np.concatenate([a.ext, b.ext]).take(k)
        return _Stops(rows, from_sensor, stop.take(k), np.zeros(len(k), dtype=np.int16), end.take(k), ext)

    @staticmethod
    def joined(parts: list[_Stops]) -> _Stops:
        """The stops of consecutive parts, in order."""
        fields = ("rows", "from_sensor", "stop", "cls", "end", "ext")
        return _Stops(*(np.concatenate([getattr(p, name) for p in parts]) for name in fields))

    def kept(self, n: int):
        """(rays, where, class) of the stops that hold (of `n` rays): a ray whose run from
        the sensor holds keeps that stop, else its run to the hit's."""
        held = self.cls > 0
        taken = np.zeros(n, dtype=bool)
        taken[self.rows[held & self.from_sensor]] = True
        keep = np.flatnonzero(held & (self.from_sensor | ~taken.take(self.rows)))
        return self.rows.take(keep), self.stop.take(keep), self.cls.take(keep)


def _settle(look: CoverLookup, ray: CoverRays, stops: _Stops) -> None:
    """The class at each stop inside the layer as the grid has it (CoverGrid.class_inside's
    test); a stop that came out of it is left to _redraw (marked by cls -1). Most stops are
    decided by their cell's bounds (CoverLookup.below_top, bottom); the rest by the terrain
    interpolated there."""
    dx, dy, dz = ray.cols(stops.rows)
    ox, oy, oz = ray.origin(stops.rows)
    t = stops.stop
    x, y, z = ox + dx * t, oy + dy * t, oz + dz * t
    fx, fy, fi, fj, flat, ok = cells(look, x, y, ray.single and look.contains(*ray.box))
    cls = look.cls.take(flat)
    unsure = (z > look.below_top.take(flat)) | (z < look.bottom.take(flat))
    if ok is not None:
        unsure |= ~ok
    close = np.flatnonzero(unsure)
    if len(close):
        flat, tx, ty = flat.take(close), fx.take(close) - fi.take(close), fy.take(close) - fj.take(close)
        sx, sy = 1.0 - tx, 1.0 - ty
        ground, _ = ground_at(look, flat, tx, ty, sx, sy)
        inside = in_layer(cls.take(close), z.take(close) - ground, look.height.take(flat))
        if ok is not None:
            inside &= ok.take(close)
        cls[close[~inside]] = -1
    stops.cls = cls


def ray_uniform(seed: int, run: np.ndarray, draw: int) -> np.ndarray:
    """The uniform in [0, 1) of draw `draw` of each run (key 2 x ray + 0 from the sensor, + 1
    to the hit) of a scan with noise seed `seed`: a pure function of the four."""
    return hash_unit(np.int64(seed), np.int64(0xC0DE5), np.asarray(run, dtype=np.int64), np.int64(draw))


def _redraw(look: CoverLookup, ray: CoverRays, stops: _Stops, seed: int) -> None:
    """The stops that came out of the layer at their first try (_settle: cls -1). A run's
    length and medium are its anchor cell's (where it ends, or starts); along a long run (a
    grazing beam over several cells) a stop can come out where this cell's sward is lower, or
    bare ground (a trail, a rock), or another class. Such a ray goes on from there (from where
    it comes down into this cell's sward, when it is above it): its depth is drawn again, in
    this cell's sward or, where this cell has none, in the anchor's, until its run's end; at
    most SETTLE times, then it passes. (Dropping such stops instead would let grazing beams
    through a meadow far more often than Beer-Lambert says.) Pass k draws each run's uniform
    number k + 1 (ray_uniform)."""
    out = np.flatnonzero(stops.cls < 0)
    stops.cls[out] = 0
    if not len(out):
        return
    t = stops.stop.take(out)
    stops.stop[out] = np.inf
    slot = out
    part = 2 * stops.rows.take(slot).astype(np.int64) + ~stops.from_sensor.take(slot)  # each run's key
    end, anchor_ext = stops.end.take(slot), stops.ext.take(slot)
    rows = stops.rows.take(slot)
    dx, dy, dz = ray.cols(rows)
    ox, oy, oz = ray.origin(rows)
    x, y, z = ox + dx * t, oy + dy * t, oz + dz * t
    # every point of a redraw lies before its run's end, within the rays' reach
    contained = ray.single and look.contains(*ray.box)
    c, height, ground, ext, gx, gy = surface(look, x, y, contained=contained)
    for k in range(SETTLE):
        above = z - ground
        # above a lower sward the ray comes down into: on from where it enters it; over
        # bare ground or rising above this cell's sward: on from where it leaves the cell
        # (none of its stops would hold before, and the depths are memoryless: the law of
        # the next stop is that of the stops drawn again and again until one is past it)
        here = c > 0
        high = here & (above > height)
        rate = dz - (gx * dx + gy * dy)
        down = high & (rate < 0)
        on = ~here | (high & (rate >= 0))
        t = np.where(down, t + (above - height) / -rate, t)
        t = np.where(on, cell_exit(look, x, y, dx, dy, t), t)
        depth = dm.log(1.0 - ray_uniform(seed, part, k + 1))
        t = _stop_at(t, end, np.where(here, ext, anchor_ext), depth)
        going = np.flatnonzero(np.isfinite(t))
        if not len(going):
            return
        slot, part, t, end, anchor_ext, dx, dy, dz, ox, oy, oz = _taken(
            going, slot, part, t, end, anchor_ext, dx, dy, dz, ox, oy, oz
        )
        x, y, z = ox + dx * t, oy + dy * t, oz + dz * t
        c, height, ground, ext, gx, gy = surface(look, x, y, contained=contained)
        inside = in_layer(c, z - ground, height)
        held = np.flatnonzero(inside)
        stops.stop[slot.take(held)] = t.take(held)
        stops.cls[slot.take(held)] = c.take(held)
        out = np.flatnonzero(~inside)
        if not len(out):
            return
        slot, part, t, end, anchor_ext, dx, dy, dz, x, y, z, ox, oy, oz = _taken(
            out, slot, part, t, end, anchor_ext, dx, dy, dz, x, y, z, ox, oy, oz
        )
        c, height, ground, ext, gx, gy = _taken(out, c, height, ground, ext, gx, gy)


def _taken(index: np.ndarray, *arrays):
    """Each array's entries at `index`, in order; a 0-d value (an origin every ray shares)
    as it is."""
    return tuple(a if np.ndim(a) == 0 else a.take(index) for a in arrays)


def _depth(begin, ext, u):
    """Where each ray's optical depth -log(1 - u), Exp(1), runs out from `begin` in a medium
    of extinction `ext` (_stop_at without its run's end)."""
    return begin - dm.log(1.0 - u) / ext


def _stop_at(begin, end, ext, log_1_u):
    """Where each ray's optical depth runs out in its run [begin, end) (inf: it passes): the
    depth -log(1 - u), Exp(1), over the extinction per metre `ext` of its medium, given
    log(1 - u). (A ray that passes, a run that is empty or a medium of no extinction gives a
    point at or past its end, or nan, never a stop.)"""
    t = begin - log_1_u / ext
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
