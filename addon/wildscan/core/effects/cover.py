"""Ground cover as a medium (numpy only): where a beam stops inside the sward layer.

The cover (core/world/cover.py CoverGrid) is a turbid layer over the terrain, not geometry:
after the cast, each ray's path up to its first surface hit is walked through the layer in
steps of STEP metres, and the ray stops inside it at an exponentially distributed optical depth
(Beer-Lambert: the chance of passing a path s through leaf area density LAD is exp(-G LAD s)).
That is the turbid-medium model HELIOS++ uses for vegetation voxels (Winiwarter et al. 2022,
"Virtual laser scanning with HELIOS++", Remote Sensing of Environment 269:112772, section
2.3.3, after Ross's G function). A ray that stops becomes a hit at that depth with the class of
the cell it stopped in, so a grass point lies inside the grass layer and every label stays
exact. Rays that do not stop keep their surface hit.

Cost: only rays that come below the layer's highest top within the crop are walked, and only
over the part of their path below it; for the rest nothing is computed.

Determinism: each ray's optical depth is -log(1 - u) with u from a PCG64 generator seeded from
(the scan's noise seed, "cover"), in ray order, and the log is detmath's, so the same scan gives
the same bytes on every machine.
"""

from __future__ import annotations

import numpy as np

from .. import detmath as dm
from ..hits import RayHits
from ..rng import stage_rng
from ..world.cover import COVER_INSTANCE_BASE, EXTINCTION, CoverGrid
from .base import Effect, Rays

STEP = 0.1  # m: the walk's step, a fifth of a cell and under half the shortest mean free path
# The robot flattens what it stands on: within this horizontal distance of the sensor no cover
# stops a beam (about the half-diagonal of the paper's robot, Andabata: 0.67 m x 0.54 m).
TRAMPLED = 0.45  # m
MAX_STEPS = 2_000  # at most 200 m of one run (a safety stop; no scan reaches that far)


class GroundCover(Effect):
    """The medium of a world's ground cover; `seed` keys the random depths (the noise seed).

    A ray meets the layer in at most two runs that matter: one from the sensor (a robot in
    tall grass), and one that ends at its surface hit (the beam coming down through the sward
    to the ground, or to the foot of a trunk). A run is walked forward from where it begins,
    its optical depth summed sample by sample; the ray stops where that sum passes its drawn
    depth. A ray skimming through a sward and out again before a farther hit is not walked (a
    crest's grass tops): the cost stays proportional to the runs, not to the rays' lengths."""

    name = "cover"
    changes_medium = True

    def __init__(self, grid: CoverGrid, seed: int = 0):
        self.grid = grid
        self.seed = int(seed)
        self.top = grid

    def describe(self) -> dict:
        return {"model": "beer-lambert", "step_m": STEP, "cell_m": self.grid.cell, "trampled_m": TRAMPLED}

    def medium(self, rays: Rays, hits: RayHits) -> RayHits:
        n = len(hits.distance)
        origins = np.broadcast_to(np.asarray(rays.origins, dtype=np.float64), (n, 3))
        dirs = np.asarray(rays.directions, dtype=np.float64)
        end = np.minimum(hits.distance, rays.max_range)
        u = stage_rng(self.seed, "cover").random((2, n))
        depth = -dm.log(1.0 - u)  # optical depth each run lets a ray reach, Exp(1)
        horizontal = np.sqrt(dirs[:, 0] ** 2 + dirs[:, 1] ** 2)
        with np.errstate(divide="ignore"):
            t0 = np.where(horizontal > 0, TRAMPLED / horizontal, np.inf)
        # the run from the sensor: rays starting inside the layer past the trampled ground
        probe = origins + dirs * np.minimum(t0, end)[:, None]
        first = np.flatnonzero(self.top.inside_layer(probe) & (t0 < end))
        t_stop, cls_stop, t_exit = self._forward(origins, dirs, first, t0[first], end[first], depth[0, first])
        # the run that ends at the hit: walked back to where it begins, then forward
        exited = np.full(n, -np.inf)
        exited[first] = t_exit
        rest = np.setdiff1d(np.flatnonzero(np.isfinite(hits.distance)), first[np.isfinite(t_stop)])
        begin = self._run_start(origins, dirs, rest, end[rest], np.maximum(t0[rest], exited[rest]))
        walk = np.isfinite(begin)
        second = rest[walk]
        t2, c2, _ = self._forward(origins, dirs, second, begin[walk], end[second], depth[1, second])
        stop_t = np.full(n, np.inf)
        stop_c = np.zeros(n, dtype=np.int16)
        stop_t[first], stop_c[first] = t_stop, cls_stop
        ok = np.isfinite(t2)
        stop_t[second[ok]], stop_c[second[ok]] = t2[ok], c2[ok]
        stopped = np.isfinite(stop_t)
        if not stopped.any():
            return hits
        return _with_cover_hits(hits, stopped, stop_t, stop_c, dirs)

    def _forward(self, origins, dirs, rays, start, end, depth):
        """Walk `rays` forward from `start` while inside the layer and before `end`: (where each
        stopped, inf if it did not; the class there; where it left the layer)."""
        n = len(rays)
        t_stop, cls_stop, t_exit = np.full(n, np.inf), np.zeros(n, dtype=np.int16), np.full(n, np.inf)
        tau = np.zeros(n)
        active = np.arange(n)
        t = start.copy()
        for _ in range(MAX_STEPS):
            if len(active) == 0:
                break
            r = rays[active]
            seg = np.minimum(STEP, end[active] - t[active])
            mid = t[active] + 0.5 * seg
            cls = self.top.class_inside(origins[r] + dirs[r] * mid[:, None])
            inside = (cls > 0) & (seg > 0)
            ext = EXTINCTION[cls]
            tau[active] += np.where(inside, ext * seg, 0.0)
            done = inside & (tau[active] >= depth[active])
            if done.any():
                a = active[done]
                over = tau[a] - depth[a]
                at = t[a] + seg[done] - over / ext[done]  # exact inside the step
                # ...unless that falls past the layer's edge within the step: then its middle
                edge = self.top.class_inside(origins[rays[a]] + dirs[rays[a]] * at[:, None]) != cls[done]
                t_stop[a] = np.where(edge, mid[done], at)
                cls_stop[a] = cls[done]
            left = ~inside
            t_exit[active[left]] = t[active[left]]
            t[active] += seg
            active = active[~done & ~left]
        return t_stop, cls_stop, t_exit

    def _run_start(self, origins, dirs, rays, end, floor):
        """Where the layer run that ends at each ray's hit begins (inf: the hit is not in the
        layer), walking back from the hit but not before `floor`."""
        n = len(rays)
        begin = np.full(n, np.inf)
        inside_at_hit = self.top.class_inside(origins[rays] + dirs[rays] * (end - 0.5 * STEP)[:, None]) > 0
        t = end.copy()
        active = np.flatnonzero(inside_at_hit)
        for _ in range(MAX_STEPS):
            if len(active) == 0:
                break
            r = rays[active]
            prev = np.maximum(t[active] - STEP, floor[active])
            mid = 0.5 * (prev + t[active])
            inside = (self.top.class_inside(origins[r] + dirs[r] * mid[:, None]) > 0) & (prev < t[active])
            begin[active[~inside]] = t[active[~inside]]
            t[active] = prev
            active = active[inside]
        begin[active] = t[active]  # walked back to the floor inside the layer
        return np.where(np.isfinite(begin) & (begin < end), begin, np.inf)


def _with_cover_hits(hits: RayHits, stopped, t_stop, cls_stop, dirs) -> RayHits:
    """The hits with the rays that stopped in the cover replaced by a hit there."""
    distance = np.where(stopped, t_stop, hits.distance)
    class_id = np.where(stopped, cls_stop, hits.class_id).astype(np.int16)
    instance = np.where(stopped, COVER_INSTANCE_BASE + cls_stop, hits.instance).astype(np.int32)
    normal = None
    if hits.normal is not None:  # a sward faces every beam: its normal is the beam's reverse
        normal = np.where(stopped[:, None], -dirs, hits.normal)
    reflectivity = None
    if hits.reflectivity is not None:
        reflectivity = np.where(stopped, np.float32(np.nan), hits.reflectivity).astype(np.float32)
    return RayHits(distance, class_id, instance, hits.untagged_objects, normal, reflectivity)
