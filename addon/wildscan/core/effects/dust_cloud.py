"""A dust cloud: dust in a vertical cylinder, clear air outside (numpy only).

    --weather "dust=0.5@12,-3,8"      0.5 g/m^3 within 8 m of world (12, -3), at every height
    --weather "dust=0.5@12,-3,8,4"    ... up to world height 4 m (dust rises from the ground)

A beam meets the dust only on the part of its path inside the cylinder: `segments` gives
that part exactly (the ray against the circle in xy and the top plane, no sampling), and
the cloud's extinction and backscatter act on it alone (particles.py's models with the
optical depth alpha * (path length inside) in place of alpha * r). A beam that never enters
the cloud draws no dust event and loses no transmission: its hit is the clear air's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..checks import decimal
from ..errors import UserError
from . import particles as P

CHUNK_SAMPLES = 2_000_000  # samples of the rate evaluated at once (rays x steps): bounds the memory


@dataclass(frozen=True)
class Cylinder:
    """x, y: the axis in the world (m); radius (m); top: the world height of its top (inf: none)."""

    x: float
    y: float
    radius: float
    top: float = math.inf

    def describe(self) -> list[float]:
        return [self.x, self.y, self.radius] + ([] if math.isinf(self.top) else [self.top])

    def segments(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(t0, t1) per ray: where the ray origin + t * direction (t >= 0) is inside; t0 >= t1
        when it never is."""
        d = np.asarray(directions, dtype=np.float64)
        o = np.broadcast_to(np.asarray(origins, dtype=np.float64), d.shape)
        px, py = o[:, 0] - self.x, o[:, 1] - self.y
        a = d[:, 0] ** 2 + d[:, 1] ** 2
        b = px * d[:, 0] + py * d[:, 1]
        c = px**2 + py**2 - self.radius**2
        disc = b * b - a * c
        flat = a == 0  # a vertical ray: inside the circle everywhere or nowhere
        root = np.sqrt(np.where(disc > 0, disc, 0.0))
        safe = np.where(flat, 1.0, a)
        t0 = np.where(flat, np.where(c <= 0, -np.inf, np.inf), (-b - root) / safe)
        t1 = np.where(flat, np.where(c <= 0, np.inf, -np.inf), (-b + root) / safe)
        missed = ~flat & (disc <= 0)
        t0, t1 = np.where(missed, np.inf, t0), np.where(missed, -np.inf, t1)
        t0, t1 = _below_top(self.top, o[:, 2], d[:, 2], t0, t1)
        return np.maximum(t0, 0.0), t1  # the ray starts at its origin


def _below_top(top: float, oz, dz, t0, t1) -> tuple[np.ndarray, np.ndarray]:
    """(t0, t1) cut to where the ray is below the world height `top`."""
    if math.isinf(top):
        return t0, t1
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = (top - oz) / dz
    rising, falling, level = dz > 0, dz < 0, dz == 0
    t1 = np.where(rising, np.minimum(t1, cross), t1)
    t0 = np.where(falling, np.maximum(t0, cross), t0)
    above = level & (oz > top)
    return np.where(above, np.inf, t0), np.where(above, -np.inf, t1)


def parse_region(text: str) -> Cylinder:
    """ "12,-3,8" or "12,-3,8,4" -> the Cylinder (X, Y, RADIUS[, TOP]); a UserError otherwise."""
    parts = [s.strip() for s in str(text).split(",")]
    form = "X,Y,RADIUS[,TOP] in metres (e.g. dust=0.5@12,-3,8)"
    try:
        numbers = [decimal(s) for s in parts]
    except ValueError:
        numbers = []
    if len(numbers) not in (3, 4) or not all(math.isfinite(v) for v in numbers):
        raise UserError(f"dust region {text!r} is not {form}", setting="weather")
    if numbers[2] <= 0:
        why = f"dust region {text!r} has radius {numbers[2]:g}; it must be above 0"
        raise UserError(why, setting="weather")
    return Cylinder(*numbers)


def optical_depth(r: np.ndarray, alpha_air: float, alpha_cloud: float, t0, t1) -> np.ndarray:
    """tau(r): the extinction integrated from the sensor to range r, the cloud's only on its
    segment [t0, t1]."""
    inside = np.clip(r, t0, t1) - t0
    return alpha_air * r + alpha_cloud * np.maximum(inside, 0.0)


def first_events(
    e: np.ndarray, t0: np.ndarray, t1: np.ndarray, alpha_air: float, alpha_cloud: float, weather, step: float
) -> np.ndarray:
    """Each ray's first dust event inside its segment [t0, t1] (inf: none) for the exponential
    draws `e`: the cumulative rate (particles.volume_rate's model, with the cloud's optical
    depth) sampled every `step` m along the segment, inverted linearly, as Weather.events."""
    out = np.full(len(e), np.inf)
    if len(e) == 0:
        return out
    beta = P.dust_backscatter(alpha_cloud)
    t1 = np.minimum(t1, _reach(t0, t1, alpha_air, alpha_cloud, beta, weather, step))
    rows = np.flatnonzero(t0 < t1)
    if len(rows):
        out[rows] = _events(e[rows], t0[rows], t1[rows], alpha_air, alpha_cloud, beta, weather, step)
    return out


# Where the threshold ratio exceeds this, the rate (e^-ratio per cell) is below 1e-26 /m: taken
# as 0, since no draw of 53 bits resolves it (the smallest E = -ln u above 0 is 1.1e-16).
NEGLIGIBLE_RATIO = 60.0


def _reach(t0, t1, alpha_air: float, alpha_cloud: float, beta: float, weather, step: float) -> np.ndarray:
    """Per ray, a range past which the cloud's rate is negligible: the ratio of particles.
    volume_rate grows with r (r^2 e^(2 tau)) and is smallest at full overlap, so the first grid
    range where its full-overlap value, e^(-2 alpha t0) q(r), passes NEGLIGIBLE_RATIO, plus a step."""
    grid = weather.min_range + step * np.arange(int(math.ceil((t1.max() - weather.min_range) / step)) + 2)
    log_q = (
        math.log(P.RHO_REF / (weather.detection_range**2 * math.pi * beta * weather.cell))
        + 2.0 * np.log(grid)
        + 2.0 * (alpha_air + alpha_cloud) * grid
    )
    at = np.searchsorted(log_q, math.log(NEGLIGIBLE_RATIO) + 2.0 * alpha_cloud * t0, side="right")
    return grid[np.minimum(at, len(grid) - 1)] + step


def _events(e, t0, t1, alpha_air: float, alpha_cloud: float, beta: float, weather, step: float) -> np.ndarray:
    out = np.full(len(e), np.inf)
    steps = np.ceil((t1 - t0) / step).astype(np.int64) + 1
    per_chunk = max(1, CHUNK_SAMPLES // int(steps.max()))
    for lo in range(0, len(e), per_chunk):
        sl = slice(lo, lo + per_chunk)
        k = np.arange(int(steps[sl].max()), dtype=np.float64)
        r = np.minimum(t0[sl, None] + step * k[None, :], t1[sl, None])
        tau = optical_depth(r, alpha_air, alpha_cloud, t0[sl, None], t1[sl, None])
        lam = _rate(r, tau, beta, weather)
        steps_h = np.cumsum(0.5 * (lam[:, 1:] + lam[:, :-1]) * np.diff(r), axis=1)
        h = np.concatenate([np.zeros((len(r), 1)), steps_h], axis=1)
        out[sl] = _invert(e[sl], h, r)
    return out


def _rate(r: np.ndarray, tau: np.ndarray, beta: float, weather) -> np.ndarray:
    """particles.volume_rate with exp(2 alpha r) replaced by exp(2 tau(r))."""
    seen = P.overlap(r, weather.min_range) * (math.pi * beta * weather.cell)
    rho_min = P.RHO_REF * (r / weather.detection_range) ** 2 * dm.exp(2.0 * tau)
    ratio = np.where(seen > 0, rho_min / np.where(seen > 0, seen, 1.0), np.inf)
    return np.where(np.isfinite(ratio), dm.exp(-np.minimum(ratio, 700.0)), 0.0) / weather.cell


def _invert(e: np.ndarray, h: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Per row, the range where the cumulative h first reaches e (inf: never)."""
    out = np.full(len(e), np.inf)
    found = e < h[:, -1]
    if not found.any():
        return out
    rows = np.flatnonzero(found)
    k = np.argmax(h[rows] >= e[rows, None], axis=1)  # first sample at or past e (k >= 1: e > 0 = h[0])
    k = np.maximum(k, 1)
    h0, h1 = h[rows, k - 1], h[rows, k]
    r0, r1 = r[rows, k - 1], r[rows, k]
    share = np.where(h1 > h0, (e[rows] - h0) / np.where(h1 > h0, h1 - h0, 1.0), 0.0)
    out[rows] = r0 + share * (r1 - r0)
    return out


def surface_lost(distance: np.ndarray, tau: np.ndarray, detection_range: float) -> np.ndarray:
    """A surface at `distance` behind optical depth tau is past the budget: r e^tau > R_DET
    (particles.max_range's condition with the path's own depth)."""
    return distance * dm.exp(tau) > detection_range
