"""Weather: fog, rain, dust and snow between the sensor and the scene (numpy only).

    Weather.parse("rain=10,fog=200")        keys and units: KEYS below
    weather.medium(rays, hits) -> hits      the effects seam (base.py), every scan path

What each ray sees (the physics and its sources: particles.py; derivations and the bench
against the published curves: docs/weather.md):

  1. every effect draws its events along the ray, a Poisson process of rate lambda(r) from
     the device's minimum range (nearer returns are blanked by the sensor) to the cast range:
     the first event of effect e lies at H_e^-1(E), E = -ln u, u uniform, H_e the cumulative
     rate; the nearest event over all effects is the ray's;
  2. an event before the surface takes the beam: a point of class `particle` when its
     return is detectable (drops and flakes within their echo range; every fog and dust
     event is a detection), a lost return otherwise;
  3. a surface past R_max of the total extinction is lost (particles.max_range).

The instance of a particle hit is the code of the effect that made it (CODES); scans turn
it into the point's `weather` field (weather_fields) and write instance 0. Its intensity
is the particle's equivalent reflectance in Table I units (100: a white target).

Determinism: draw i of effect e is draw (index0 + i) of the generator seeded by (seed,
"weather.<e>") (core/rng.py), -ln u and the rates by detmath: the same seed, the same
particles, on every machine. Every ray of a drive has its own index (sweep.py passes the
run's first ray), so consecutive 2D scans meet different drops: a drop falls ~0.2 m in a
2D scan's 25 ms (terminal speed 4-9 m/s, Gunn & Kinzer 1949), far more than its size, so
independent draws per ray and per time are what falling rain looks like to a thin beam.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..checks import decimal
from ..classes import PARTICLE_ID
from ..errors import UserError
from ..hits import MISS_CLASS, MISS_INSTANCE, RayHits
from ..rng import stage_rng
from . import particles as P
from .base import Effect, Effects, Rays
from .dust_cloud import Cylinder, first_events, optical_depth, parse_region, surface_lost

# key -> (code in the `weather` field, unit, lowest, highest). 0 is "off" for every key.
KEYS: dict[str, tuple[int, str, float, float]] = {
    "fog": (1, "m of visibility", 5.0, 100_000.0),
    "rain": (2, "mm/h", 0.0, 500.0),
    "dust": (3, "g/m^3 of dust", 0.0, 10.0),
    "snow": (4, "mm/h of melted snow", 0.0, 100.0),
}
CODES = {key: code for key, (code, *_) in KEYS.items()}
GRID_STEP = 0.01  # m between the samples of the cumulative rates (the inverse is linear between)
TABLE_UNITS = 100.0  # Table I reflectivity of a white target: equivalent reflectances times this


def check_value(key: str, value: object) -> float:
    """A key's value as a float, or a UserError naming the key, the value and its range."""
    if key not in KEYS:
        raise UserError(
            f"has no key {key!r}; the keys are {', '.join(KEYS)} (e.g. rain=10,fog=200)",
            setting="weather",
            allowed=tuple(KEYS),
        )
    _, unit, low, high = KEYS[key]
    allowed = f"0 (none) or {low:g} to {high:g} {unit}" if key == "fog" else f"{low:g} to {high:g} {unit}"
    try:  # typed text by the one rule for numbers (core/checks.py); a spec's TOML numbers as they are
        number = decimal(value) if isinstance(value, str) else float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        number = math.nan
    if isinstance(value, bool) or not math.isfinite(number):
        raise UserError(
            f"{key}={value!r} is not a number (digits 0-9, a point for decimals); {key} is {allowed}",
            setting="weather",
        )
    if number != 0 and not low <= number <= high:
        raise UserError(f"{key}={value!r} is out of range; {key} is {allowed}", setting="weather")
    return number


REGION = "dust_at"  # the settings' key of a dust cloud: [X, Y, RADIUS] or [X, Y, RADIUS, TOP] (dust_cloud.py)


def parse_settings(text: str) -> dict:
    """ "rain=10,fog=200" -> {"rain": 10.0, "fog": 200.0} (each key at most once; "" or
    "none": no weather); "dust=0.5@12,-3,8[,4]" -> {"dust": 0.5, "dust_at": [12, -3, 8(, 4)]},
    a dust cloud (the numbers after @ run on to the next KEY=VALUE)."""
    text = str(text).strip()
    if text.lower() in ("", "none", "clear"):
        return {}
    out: dict = {}
    for part in _entries(text):
        key, eq, value = (s.strip() for s in part.partition("="))
        key = key.lower()
        if not eq or not key:
            raise UserError(
                f"entry {part.strip()!r} is not KEY=VALUE; write e.g. rain=10,fog=200 "
                f"(keys: {', '.join(KEYS)})",
                setting="weather",
            )
        if key in out:
            raise UserError(f"names {key} twice", setting="weather")
        value, at, region = value.partition("@")
        if at and key != "dust":
            why = f"{part.strip()!r}: only dust takes a region (dust=C@X,Y,RADIUS[,TOP])"
            raise UserError(why, setting="weather")
        out[key] = check_value(key, value.strip())
        if at:
            out[REGION] = parse_region(region).describe()
    return out


def _entries(text: str) -> list[str]:
    """The KEY=VALUE entries of `text`: split at commas, a region's numbers kept with its entry."""
    entries: list[str] = []
    for part in text.split(","):
        if entries and "=" not in part and "@" in entries[-1]:
            entries[-1] += "," + part
        else:
            entries.append(part)
    return entries


@dataclass(frozen=True)
class Component:
    """One kind of particle at one strength: its extinction, event rate and echo."""

    key: str
    value: float
    region: Cylinder | None = None  # dust only: a cloud, clear air outside (dust_cloud.py)

    @property
    def code(self) -> int:
        return CODES[self.key]

    @property
    def extinction(self) -> float:
        """alpha (1/m) of the unresolved particles (rain and snow: none, their drops are events)."""
        if self.key == "fog":
            return P.fog_extinction(self.value)
        if self.key == "dust":
            return P.dust_extinction(self.value)
        return 0.0

    @property
    def backscatter(self) -> float:
        if self.key == "fog":
            return P.fog_backscatter(self.extinction)
        return P.dust_backscatter(self.extinction)

    @property
    def drops(self) -> bool:
        return self.key in ("rain", "snow")

    def rate(self, r: np.ndarray, alpha: float, budget: float, cell: float, min_range: float) -> np.ndarray:
        """Events per metre at ranges r (total extinction alpha, detection range `budget`)."""
        if self.drops:
            return np.full(len(r), P.hit_rate(self.key, self.value))
        return P.volume_rate(r, self.backscatter, alpha, budget, cell, min_range)

    def reflectance(self, cell: float) -> float:
        """The equivalent diffuse reflectance of one event's return."""
        if self.key == "rain":
            return P.RHO_DROP
        if self.key == "snow":
            return P.RHO_FLAKE
        return math.pi * self.backscatter * cell


@dataclass(frozen=True)
class Weather(Effect):
    """Fog, rain, dust and snow at once (`components`, nonzero only) for a device whose
    reference target is detected to `detection_range` m, pulse cell `cell` m, blanked inside
    `min_range` m; `seed` keys every draw (scans pass their noise seed)."""

    components: tuple[Component, ...]
    seed: int = 0
    detection_range: float = 30.0
    cell: float = 0.3
    min_range: float = 0.1

    name = "weather"
    changes_medium = True

    @staticmethod
    def of(settings: dict[str, float], seed: int = 0, device=None) -> "Weather | None":
        """The weather of `settings` (key -> value) for `device` (core/sensors; None: the
        UTM-30LX-EW's numbers); None when every value is 0 (clear air: today's bytes)."""
        region = Cylinder(*settings[REGION]) if settings.get(REGION) else None
        keys = [k for k in KEYS if settings.get(k, 0)]
        comps = tuple(Component(k, float(settings[k]), region if k == "dust" else None) for k in keys)
        if not comps:
            return None
        extra = {}
        if device is not None:
            extra = dict(
                detection_range=device.ranges.max_dark_m,
                cell=device.optics.echo_separation_m,
                min_range=device.ranges.min_m,
            )
        return Weather(comps, int(seed), **extra)

    @property
    def extinction(self) -> float:
        """alpha (1/m) of the air everywhere (a dust cloud's only inside it: dust_cloud.py)."""
        return sum(c.extinction for c in self.components if c.region is None)

    @property
    def everywhere(self) -> tuple[Component, ...]:
        return tuple(c for c in self.components if c.region is None)

    @property
    def cloud(self) -> Component | None:
        return next((c for c in self.components if c.region is not None), None)

    @property
    def max_range(self) -> float:
        return P.max_range(self.extinction, self.detection_range)

    def describe(self) -> dict:
        cloud = {REGION: self.cloud.region.describe()} if self.cloud else {}
        return {**{c.key: c.value for c in self.components}, **cloud, "seed": self.seed}

    def grid(self, cast_range: float) -> np.ndarray:
        count = max(2, int(math.ceil((cast_range - self.min_range) / GRID_STEP)) + 1)
        return self.min_range + GRID_STEP * np.arange(count, dtype=np.float64)

    def cumulative(self, comp: Component, r: np.ndarray) -> np.ndarray:
        """H(r): the expected events of `comp` from min_range to each r (trapezoids)."""
        lam = comp.rate(r, self.extinction, self.detection_range, self.cell, self.min_range)
        steps = 0.5 * (lam[1:] + lam[:-1]) * (r[1:] - r[:-1])
        return np.concatenate([[0.0], np.cumsum(steps)])

    def lost_fraction(self, comp_ranges: np.ndarray) -> np.ndarray:
        """The model's own curve: the share of a surface's returns at each range lost (an
        event before it, or past R_max), for the paper model's thin ray."""
        r = np.asarray(comp_ranges, dtype=np.float64)
        grid = self.grid(float(r.max()) + GRID_STEP)
        total = sum(self.cumulative(c, grid) for c in self.everywhere)
        kept = dm.exp(-dm.interp(r, grid, total))
        return np.where(r > self.max_range, 1.0, 1.0 - kept)

    def echo_range(self, comp: Component) -> float:
        """How far an event of `comp` is still seen (drops and flakes; fog and dust: always)."""
        if not comp.drops:
            return math.inf
        # rho / RHO_REF (R_DET / r)^2 e^(-2 alpha r) >= 1  <=>  r e^(alpha r) <= R_DET sqrt(rho / RHO_REF)
        budget = self.detection_range * math.sqrt(comp.reflectance(self.cell) / P.RHO_REF)
        return P.max_range(self.extinction, budget)

    def events(self, comp: Component, count: int, index0: int, grid: np.ndarray) -> np.ndarray:
        """Each ray's first event of `comp` (inf: none within the grid)."""
        rng = stage_rng(self.seed, f"weather.{comp.key}")
        if index0:
            rng.bit_generator.advance(int(index0))  # one 64-bit draw a ray: ray i is draw index0 + i
        u = rng.random(count)
        cumulative = self.cumulative(comp, grid)
        e = -dm.log(1.0 - u)  # 1 - u in (0, 1]: E >= 0, finite
        found = np.flatnonzero(e < cumulative[-1])
        r = np.full(count, np.inf)
        if len(found):
            r[found] = dm.interp(e[found], cumulative, grid)
        return r

    def medium(self, rays: Rays, hits: RayHits) -> RayHits:
        count = len(hits.distance)
        grid = self.grid(rays.max_range)
        first = np.full(count, np.inf)
        code = np.zeros(count, dtype=np.int32)
        seen = np.zeros(count, dtype=bool)
        intensity = np.zeros(count, dtype=np.float32)
        cloud = CloudPaths.of(self, rays, count)
        for comp in self.components:
            if comp.region is None:
                r = self.events(comp, count, rays.index0, grid)
            else:
                r = cloud.events(self, comp, rays.index0)
            nearer = r < first
            first[nearer], code[nearer] = r[nearer], comp.code
            seen[nearer] = cloud.seen(self, comp, r[nearer], nearer)
            intensity[nearer] = np.float32(comp.reflectance(self.cell) * TABLE_UNITS)
        takes = first < hits.distance
        echo = takes & seen
        gone = (takes & ~seen) | (~takes & hits.hit & cloud.beyond_range(self, hits.distance))
        return _replaced(hits, echo, gone, first, code, intensity, rays)


@dataclass(frozen=True)
class CloudPaths:
    """Where each ray is inside the dust cloud (dust_cloud.py): its segment [t0, t1] within the
    cast range, `inside` the rays that have one. No cloud: no ray is inside, and every test
    below is the uniform air's (the bytes of a weather without a cloud)."""

    t0: np.ndarray
    t1: np.ndarray
    inside: np.ndarray
    alpha: float  # the cloud's extinction, 1/m

    @staticmethod
    def of(weather: "Weather", rays: Rays, count: int) -> "CloudPaths":
        comp = weather.cloud
        if comp is None:
            return CloudPaths(np.zeros(count), np.zeros(count), np.zeros(count, dtype=bool), 0.0)
        t0, t1 = comp.region.segments(rays.origins, rays.directions)
        t0, t1 = np.maximum(t0, weather.min_range), np.minimum(t1, rays.max_range)
        return CloudPaths(t0, t1, t0 < t1, comp.extinction)

    def tau(self, weather: "Weather", r: np.ndarray, rows) -> np.ndarray:
        return optical_depth(r, weather.extinction, self.alpha, self.t0[rows], self.t1[rows])

    def events(self, weather: "Weather", comp: Component, index0: int) -> np.ndarray:
        """Each ray's first event in the cloud (inf: none); the draws as Weather.events'."""
        rng = stage_rng(weather.seed, f"weather.{comp.key}")
        if index0:
            rng.bit_generator.advance(int(index0))
        e = -dm.log(1.0 - rng.random(len(self.t0)))
        r = np.full(len(self.t0), np.inf)
        rows = np.flatnonzero(self.inside)
        r[rows] = first_events(
            e[rows], self.t0[rows], self.t1[rows], weather.extinction, self.alpha, weather, GRID_STEP
        )
        return r

    def seen(self, weather: "Weather", comp: Component, r: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Whether events of `comp` at ranges r (of the rays `rows` selects) echo: within the echo
        range, or through the cloud within the budget of the drop's reflectance."""
        out = r <= weather.echo_range(comp)
        through = self.inside[rows] & (r > self.t0[rows])
        if comp.drops and through.any():
            idx = np.flatnonzero(rows)[through]
            budget = weather.detection_range * math.sqrt(comp.reflectance(weather.cell) / P.RHO_REF)
            out[through] = ~surface_lost(r[through], self.tau(weather, r[through], idx), budget)
        return out

    def beyond_range(self, weather: "Weather", distance: np.ndarray) -> np.ndarray:
        """Surfaces past the budget: beyond R_max of the air, or through the cloud past r e^tau = R_DET."""
        out = distance > weather.max_range
        through = self.inside & (distance > self.t0) & np.isfinite(distance)
        if through.any():
            idx = np.flatnonzero(through)
            tau = self.tau(weather, distance[idx], idx)
            out[idx] = surface_lost(distance[idx], tau, weather.detection_range)
        return out


def _replaced(hits: RayHits, echo, gone, distance, code, intensity, rays: Rays) -> RayHits:
    """`hits` with particle hits where `echo` and misses where `gone`."""
    normal = hits.normal
    if normal is not None and echo.any():
        normal = normal.copy()
        normal[echo] = -rays.directions[echo]  # a particle faces the beam
    override = hits.overrides().copy()
    override[echo] = intensity[echo]
    override[gone] = np.nan
    return RayHits(
        distance=np.where(echo, distance, np.where(gone, np.inf, hits.distance)),
        class_id=np.where(echo, PARTICLE_ID, np.where(gone, MISS_CLASS, hits.class_id)).astype(np.int16),
        instance=np.where(echo, code, np.where(gone, MISS_INSTANCE, hits.instance)).astype(np.int32),
        untagged_objects=hits.untagged_objects,
        normal=normal,
        reflectivity=override,
    )


def weather_of(effects: Effects) -> Weather | None:
    return next((e for e in effects.items if isinstance(e, Weather)), None)


def weather_fields(label: np.ndarray, instance: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(instance with 0 for particles, the `weather` field: the code of the effect that made
    each particle, 0 for a surface) of points whose particle instances carry the code."""
    particle = np.asarray(label) == PARTICLE_ID
    code = np.where(particle, instance, 0).astype(np.uint8)
    return np.where(particle, 0, instance).astype(instance.dtype), code
