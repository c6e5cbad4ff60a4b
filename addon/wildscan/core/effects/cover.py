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

Cost: a constant number of array operations a ray, whatever its range.

Determinism: each ray's optical depth is -log(1 - u) with u from a PCG64 generator seeded from
(the scan's noise seed, "cover"), in ray order, and the log is detmath's, so the same scan gives
the same bytes on every machine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..hits import RayHits
from ..rng import stage_rng
from ..world.cover import BOTTOM_SLACK, COVER_INSTANCE_BASE, CoverGrid, extinction
from .base import Effect, Rays

# The robot flattens what it stands on: within this horizontal distance of the sensor no cover
# stops a beam (about the half-diagonal of the paper's robot, Andabata: 0.67 m x 0.54 m).
TRAMPLED = 0.45  # m
LONGEST_RUN = 30.0  # m of one run at most (a beam running level inside a tall sward)
BEFORE_HIT = 1e-4  # m before a hit, where the hit's cell and layer are read
SETTLE = 2  # times a stop above its own cell's sward is moved down into it


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
        # each ray's origin and direction as x, y, z arrays (an origin: 3 numbers, or n each)
        ray = _Rays(
            *(o[k] if o.ndim == 1 else np.ascontiguousarray(o[:, k]) for k in range(3)),
            *(np.ascontiguousarray(d[:, k]) for k in range(3)),
        )
        end = np.minimum(hits.distance, rays.max_range)
        u = stage_rng(self.seed, "cover").random((2, n))
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            horizontal = np.sqrt(ray.dx * ray.dx + ray.dy * ray.dy)
            t0 = np.minimum(np.where(horizontal > 0, TRAMPLED / horizontal, np.inf), end)
            a, leave, stop_a = self._run_from_sensor(ray, t0, end, u[0])
            # the run that ends at the hit, for the rays that did not stop in the first one
            start = t0.copy()  # where a run to the hit may begin: past the run from the sensor
            start[a] = leave
            unstopped = np.isfinite(hits.distance)
            unstopped[a[np.isfinite(stop_a)]] = False
            b, stop_b = self._run_to_hit(ray, end, start, np.flatnonzero(unstopped), u[1])
            # every stop, in ray order: a ray stops in one run at most
            stopped_a, stopped_b = np.isfinite(stop_a), np.isfinite(stop_b)
            rows = np.concatenate([a[stopped_a], b[stopped_b]])
            order = np.argsort(rows, kind="stable")
            rows = rows[order]
            stop = np.concatenate([stop_a[stopped_a], stop_b[stopped_b]])[order]
            run_end = np.concatenate([np.full(stopped_a.sum(), np.inf), end[b[stopped_b]]])[order]
            cls_rows = self._settle(ray.rows(rows), stop, run_end, u[1][rows])
        kept = cls_rows > 0
        if not kept.any():
            return hits
        return _with_cover_hits(hits, rows[kept], stop[kept], cls_rows[kept], d)

    def _run_from_sensor(self, ray: _Rays, t0, end, u):
        """The run from the sensor, past the trampled ground, until the ray rises out of the
        layer (or reaches its hit): (the rays that start it inside the layer, where each leaves
        the layer, where each stops in it or inf)."""
        rows = np.flatnonzero((t0 < end) & self._may_start_inside(ray, t0))
        rows, t, (cls, above, height, rate) = self._inside(ray, rows, t0[rows])
        leave = np.where(rate > 0, t + (height - above) / rate, np.inf)
        leave = np.minimum(np.minimum(leave, t + LONGEST_RUN), end[rows])
        return rows, leave, _stop(t, leave, cls, height, u[rows])

    def _run_to_hit(self, ray: _Rays, end, start, rows, u):
        """The run that ends at the hit of each of `rows`, from where the ray came down into
        the layer (not before `start`): (the rays whose hit lies in the layer, where each stops
        in it or inf)."""
        rows, _, (cls, above, height, rate) = self._inside(ray, rows, np.maximum(end[rows] - BEFORE_HIT, 0.0))
        back = np.minimum(np.where(rate < 0, (height - above) / -rate, LONGEST_RUN), LONGEST_RUN)
        stop_end = end[rows]
        begin = np.maximum(stop_end - back, start[rows])
        return rows, _stop(begin, stop_end, cls, height, u[rows])

    def _inside(self, ray: _Rays, rows, t):
        """Of `rows`, those whose point t along lies inside the layer: (those rows, their t,
        _layer's class, height above the terrain, layer height and rate there)."""
        x, y, z = ray.at(rows, t)
        near = self.grid.may_be_inside_at(x, y, z)
        rows, t, x, y, z = rows[near], t[near], x[near], y[near], z[near]
        cls, above, height, rate, inside = self._layer(x, y, z, ray.rows(rows))
        return rows[inside], t[inside], (cls[inside], above[inside], height[inside], rate[inside])

    def _settle(self, ray: _Rays, stop, end, u):
        """The class at each stop (of `ray`'s rays) inside the layer as the grid has it (0:
        none); `stop` is updated in place. A stop that came out above its own cell's sward (the
        run's length was taken from its end cell, and the sward is lower here) moves down to
        where the ray enters this cell's layer and is drawn again from there (at most SETTLE
        times; then the ray passes on to its hit). Only stops of a run to the hit (finite `end`)
        move."""
        cls = np.zeros(len(stop), dtype=np.int16)
        todo = np.arange(len(stop))
        for attempt in range(SETTLE + 1):
            if len(todo) == 0:
                break
            x, y, z = ray.at(todo, stop[todo])
            c, above, height, _, inside = self._layer(x, y, z, None)
            cls[todo[inside]] = c[inside]
            # below its cell's top, or moving away from the layer: the stop is dropped
            high = ~inside & (c > 0) & (above > height) & np.isfinite(end[todo])
            if attempt == SETTLE:
                high[:] = False
            high = np.flatnonzero(high)
            rate = self._rate(x[high], y[high], ray.rows(todo[high]))
            lower = high[rate < 0]
            again = todo[lower]
            begin = stop[again] + (above[lower] - height[lower]) / -rate[rate < 0]
            stop[todo[~inside]] = np.inf
            stop[again] = _stop(begin, end[again], c[lower], height[lower], u[again])
            todo = again[np.isfinite(stop[again])]
        return cls

    def _layer(self, x, y, z, ray: _Rays | None):
        """At points (x, y, z) along rays `ray`: the cover class, the height above the
        terrain, the layer's height, how fast the height above the terrain changes along the
        ray (its climb less the terrain's slope along it, per metre; None without `ray`) and
        whether the point is inside the layer."""
        cls, height, ground, gx, gy = self.grid.surface_at(x, y, slopes=ray is not None)
        above = z - ground
        rate = None if ray is None else ray.dz - (gx * ray.dx + gy * ray.dy)
        inside = (cls > 0) & (above >= -BOTTOM_SLACK) & (above <= height)
        return cls, above, height, rate, inside

    def _rate(self, x, y, ray: _Rays):
        """_layer's rate alone."""
        _, _, _, gx, gy = self.grid.surface_at(x, y)
        return ray.dz - (gx * ray.dx + gy * ray.dy)

    def _may_start_inside(self, ray: _Rays, t0) -> np.ndarray:
        """Rays whose point t0 along (TRAMPLED from a single origin, in x and y) can lie in the
        layer: not above the highest terrain node plus the tallest cell around the origin (a
        cheap bound that spares the upward rays). Origins per ray (a drive): every ray."""
        if np.ndim(ray.ox) != 0:
            return np.ones(len(t0), dtype=bool)
        g = self.grid
        reach = int(np.ceil(TRAMPLED / g.cell)) + 1
        i = int(np.floor((ray.ox - g.x0) / g.cell))
        j = int(np.floor((ray.oy - g.y0) / g.cell))
        ny, nx = g.shape
        i0, i1, j0, j1 = max(i - reach, 0), min(i + reach + 1, nx), max(j - reach, 0), min(j + reach + 1, ny)
        if i0 >= i1 or j0 >= j1:
            return np.zeros(len(t0), dtype=bool)
        top = g.node_ground()[j0 : j1 + 1, i0 : i1 + 1].max() + g.height[j0:j1, i0:i1].max() + BOTTOM_SLACK
        return ray.oz + ray.dz * t0 <= top


@dataclass(frozen=True)
class _Rays:
    """Rays as x, y, z arrays: origins (numbers: one origin for all, or arrays) and directions."""

    ox: np.ndarray | float
    oy: np.ndarray | float
    oz: np.ndarray | float
    dx: np.ndarray
    dy: np.ndarray
    dz: np.ndarray

    def rows(self, rows: np.ndarray) -> _Rays:
        def pick(v):
            return v if np.ndim(v) == 0 else v.take(rows)

        return _Rays(*(pick(v) for v in (self.ox, self.oy, self.oz, self.dx, self.dy, self.dz)))

    def at(self, rows: np.ndarray, t: np.ndarray):
        """(x, y, z) of the points t along `rows`."""
        r = self.rows(rows)
        return r.ox + r.dx * t, r.oy + r.dy * t, r.oz + r.dz * t


def _stop(begin, end, cls, height, u):
    """Where each ray's optical depth runs out in its run [begin, end) (inf: it passes): the
    depth -log(1 - u), Exp(1), over the extinction per metre of its class and layer height."""
    rate = extinction(cls, height)
    # -log(1 - u) >= u: where u / rate already reaches past the run's end (a nanometre and a
    # relative 1e-12 to spare, far above the log's and the sum's rounding) the ray passes, and
    # its log need not be taken (the same result, most runs from the sensor being short)
    go = (begin < end) & (rate > 0) & (u < rate * (end - begin + 1e-9) * (1.0 + 1e-12))
    t = np.full(len(begin), np.inf)
    t[go] = begin[go] - dm.log(1.0 - u[go]) / rate[go]
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
