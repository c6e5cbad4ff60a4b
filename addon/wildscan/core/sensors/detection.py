"""Detection by received power (numpy only): a device file's `[detection]` table of
(reflectance, range) pairs from its datasheet, and the threshold they fix.

A return's received power, for an extended Lambertian target filling the beam (the lidar
range equation; Kashani et al., "A Review of LIDAR Radiometric Processing", Sensors 15(11),
2015, doi:10.3390/s151128099, Eq. 1-4; Goodin et al., "Predicting the Influence of Rain on
LIDAR in ADAS", Electronics 8(1) 89, 2019, Eq. 1-2 for the transmission), is in relative units

    P = rho * cos(theta) * exp(-2 alpha R) / R^2

rho the surface's reflectance (0-1) at the laser's wavelength, theta the incidence, alpha the
air's extinction (1/m; clear air 0) and R the range. A datasheet pair (rho_i, R_i) says a
flat target of reflectance rho_i at normal incidence in clear air is detected out to R_i:
the detection limit at R_i is P_i = rho_i / R_i^2. Between pairs the limit is interpolated
linearly in (ln R, ln P); beyond the first and last pair it goes on with the slope of the
nearest segment; one pair gives a constant limit (the 1/R^2 law alone). A limit that rises
with range (the HDL-64E's: 10 % to 50 m but 80 % only to 120 m, where 1/R^2 alone would
give 141 m) stands for what the Lambertian law leaves out: sunlight's shot noise, the
stretched pulse of a far footprint, the datasheet's own detection criterion.

A pair is measured (the datasheet states it) or an estimate (`estimate = [...]` lists the
reflectances whose range the datasheet does not state; the device file says how each was
derived). A flat target's farthest range, `farthest_range`, inverts the limit: rho/R^2
falls faster than any limit the loader accepts (reflectance and range rising together),
so the crossing is unique.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

REFERENCE_REFLECTANCES = (0.10, 0.80)  # the flat targets `wildscan bench --suite detection` scans


@dataclass(frozen=True)
class Detection:
    """(reflectance 0-1, range m) pairs, rising in both, and which of them are estimates."""

    reflectance: tuple[float, ...]
    range_m: tuple[float, ...]
    estimate: tuple[bool, ...]

    @property
    def pairs(self) -> tuple[tuple[float, float], ...]:
        return tuple(zip(self.reflectance, self.range_m, strict=True))

    def _knots(self) -> tuple[np.ndarray, np.ndarray]:
        """(ln R_i, ln P_i) of the pairs."""
        r = np.asarray(self.range_m, dtype=np.float64)
        return np.log(r), np.log(np.asarray(self.reflectance, dtype=np.float64)) - 2.0 * np.log(r)

    def threshold(self, range_m) -> np.ndarray:
        """The received power (rho cos theta / R^2 units) below which a return at `range_m` is
        lost (see the module docstring)."""
        x = np.log(np.maximum(np.asarray(range_m, dtype=np.float64), 1e-6))
        xs, ys = self._knots()
        if len(xs) == 1:
            return np.full(x.shape, math.exp(ys[0]))
        y = np.interp(x, xs, ys)
        low_slope = (ys[1] - ys[0]) / (xs[1] - xs[0])
        high_slope = (ys[-1] - ys[-2]) / (xs[-1] - xs[-2])
        y = np.where(x < xs[0], ys[0] + low_slope * (x - xs[0]), y)
        y = np.where(x > xs[-1], ys[-1] + high_slope * (x - xs[-1]), y)
        return np.exp(y)

    def farthest_range(self, reflectance: float, alpha: float = 0.0) -> float:
        """The range where a flat target of `reflectance` at normal incidence through extinction
        `alpha` meets the limit (its detection probability is one half there: module
        core/realism/lost_returns.py). Bisection in ln R: the margin falls monotonically."""

        def margin(r: float) -> float:
            power = reflectance * math.exp(-2.0 * alpha * r) / (r * r)
            return math.log(power) - math.log(float(self.threshold(r)))

        lo, hi = 1e-3, 1e5
        for _ in range(200):
            mid = math.sqrt(lo * hi)
            if margin(mid) >= 0:
                lo = mid
            else:
                hi = mid
        return lo

    def describe(self) -> list[dict]:
        """The pairs as the sidecar and the bench state them."""
        return [
            {"reflectance": rho, "range_m": r, "source": "estimate" if est else "datasheet"}
            for rho, r, est in zip(self.reflectance, self.range_m, self.estimate, strict=True)
        ]


def detection_from_table(t) -> Detection:
    """A `[detection]` table (load.py's _Table) -> Detection, or the loader's UserError."""
    t.only("pairs", "estimate")
    rows = t.get("pairs")
    shape = (
        "a list of [reflectance 0-1, range m] pairs, reflectance and range both rising "
        "(a brighter target is seen farther)"
    )
    if not isinstance(rows, list) or not rows:
        raise t.fail("pairs", shape, rows)
    pairs = []
    for row in rows:
        ok = isinstance(row, list) and len(row) == 2 and all(_is_number(v) for v in row)
        if not ok or not (0 < row[0] <= 1) or not (0 < row[1] <= 10_000):
            raise t.fail("pairs", shape, rows)
        if pairs and not (row[0] > pairs[-1][0] and row[1] > pairs[-1][1]):
            raise t.fail("pairs", shape, rows)
        pairs.append((float(row[0]), float(row[1])))
    estimate = t.get("estimate", [])
    given = [p[0] for p in pairs]
    if not isinstance(estimate, list) or any(not _is_number(v) or v not in given for v in estimate):
        raise t.fail(
            "estimate", f"a list of the reflectances of pairs that are estimates (of {given})", estimate
        )
    return Detection(
        reflectance=tuple(p[0] for p in pairs),
        range_m=tuple(p[1] for p in pairs),
        estimate=tuple(p[0] in estimate for p in pairs),
    )


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
