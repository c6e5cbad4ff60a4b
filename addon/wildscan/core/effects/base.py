"""What an effect is and the collection a scan takes (numpy only).

An effect changes what the sensor measures through one or both of two hooks:

  the medium   `medium(rays, hits) -> hits`: given the rays a scan cast and their first
               hits, the hits the sensor sees through the air between (fog, rain, dust
               attenuate a beam into a miss, or return it from a particle: a hit at the
               particle's range with class `particle`). Same rows, same fields. In the
               realistic model the rays are the beams' sub-rays, so a particle met by part
               of a footprint becomes an extra echo. Every scan path calls it once, on its
               first hits, before ranges are measured: core/scan.py (paper), core/realism/realistic.py,
               core/motion/sweep.py.
  the scene    `moving_classes` and `motion(class_ids, pivots)`: which objects move with
  at a time    time and where they are at time t (the drive's wind). Posing triangles needs a
               ray caster, so the caster lives with the backends (raycast/wind.py
               `moving_scene`) and asks the effect; the scan paths see a backend whose
               `cast_scans` answers for each column's time.

`Effects()` is clear air: no effect, and `medium` returns the very hits it was given
(nothing computed, nothing copied), so every scan without effects keeps its bytes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from ..errors import UserError
from ..hits import RayHits


@dataclass(frozen=True)
class Rays:
    """The rays a scan cast: origins (3,) shared or (N, 3), unit directions (N, 3) in the
    world frame, cast to `max_range`; `times` (N,) each ray's time, seconds since the run's
    first column (a drive's start), where the path has them (the motion sweep; a static
    scan gives None); `index0` the number of the first ray in its run (a drive's rays are
    numbered from its start), so an effect's random draws can be keyed on each ray;
    `beam_count`: the rays are the sub-rays of that many beams, sub-ray-major (the realistic
    model's footprint: sub-ray k of beam j is ray k * beam_count + j), None: a ray a beam."""

    origins: np.ndarray
    directions: np.ndarray
    max_range: float
    times: np.ndarray | None = None
    index0: int = 0
    beam_count: int | None = None

    @property
    def beams(self) -> np.ndarray:
        """int64 (N,) each ray's beam: its number in the run (a drive's from its start), shared by
        a beam's sub-rays, so a per-beam effect treats a beam's whole footprint alike."""
        ray = np.arange(len(self.directions), dtype=np.int64)
        return self.index0 + (ray if self.beam_count is None else ray % self.beam_count)


class ObjectMotion(Protocol):
    """Where moving objects are at a time: E objects turning about their pivots."""

    pivots: np.ndarray  # (E, 3)

    def posed(self, vertices: np.ndarray, vertex_object: np.ndarray, t: float) -> np.ndarray:
        """Vertices (V, 3) of objects `vertex_object` (V,) where they are at time t (s)."""
        ...

    def turns(self, t, objects: np.ndarray) -> np.ndarray:
        """(P, 3, 3) the rotation of objects[i] about its pivot at time t[i] (s): a rigid turn,
        so a ray meets the posed object where the ray turned back meets the object at rest."""
        ...


@dataclass(frozen=True)
class EffectSetting:
    """One setting of an effect a user sets (core/effects/table.py): its key, unit, limits and
    help, from which the command line, SPEC.toml and the panel are built. 0 is "off"."""

    key: str
    unit: str
    low: float
    high: float
    help: str

    def check(self, value: object, setting: str) -> float:
        """`value` as a number within the limits, or UserError naming `setting` and the limits."""
        ok = isinstance(value, (int, float)) and not isinstance(value, bool) and np.isfinite(value)
        if not ok or not self.low <= float(value) <= self.high:
            raise UserError(
                f"must be a number from {self.low:g} to {self.high:g} {self.unit}, got {value!r}",
                setting=setting,
                allowed=(self.low, self.high),
            )
        return float(value)


@dataclass(frozen=True)
class EffectEntry:
    """An effect a user sets, as the effects table lists it: `name` (the command line's
    --NAME, SPEC.toml's key, the panel's field), `title` (the panel's label), `settings`,
    `make(values, sensor) -> Effect | None` (values: the settings' values, by key for several
    settings, the one number for one; None: off, clear air), and for an effect of several
    settings `parse(text) -> values`, its command-line text (weather's "rain=10,fog=200")."""

    name: str
    title: str
    settings: tuple[EffectSetting, ...]
    make: Callable
    parse: Callable[[str], dict] | None = None
    text: str = ""  # the command line's help when the settings' own do not say enough

    @property
    def help(self) -> str:
        """The command line's help: `text`, or each setting's help, limits and unit (0: off)."""
        own = "; ".join(f"{s.help}, {s.low:g} to {s.high:g} {s.unit}" for s in self.settings)
        return self.text or f"{own} (default 0: off)"


class Effect:
    """The base of every effect: no hook until a subclass sets its flag and method.

    name            what files and messages call it ("wind", "fog")
    changes_medium  True when `medium` is overridden
    moves_scene     True when `moving_classes` and `motion` are
    classes         the optional class ids (core/classes.py) its scans can carry: the files of
                    a scan with this effect list them (classes.listed_classes)
    """

    name = "effect"
    classes: tuple[int, ...] = ()
    changes_medium = False
    moves_scene = False
    moving_classes: tuple[int, ...] = ()

    def describe(self) -> dict:
        """The effect's settings, as files record them."""
        return {}

    def medium(self, rays: Rays, hits: RayHits) -> RayHits:
        return hits

    def motion(self, class_ids: np.ndarray, pivots: np.ndarray) -> ObjectMotion:
        raise NotImplementedError(f"{self.name} does not move the scene")


@dataclass(frozen=True)
class Effects:
    """The effects of a scan, applied in the order given. Empty: clear air."""

    items: tuple[Effect, ...] = ()

    def __post_init__(self):
        movers = [e.name for e in self.items if e.moves_scene]
        if len(movers) > 1:
            raise UserError(f"effects {', '.join(movers)} both move the scene; only one may so far")

    def __bool__(self) -> bool:
        return bool(self.items)

    @property
    def changes_medium(self) -> bool:
        return any(e.changes_medium for e in self.items)

    @property
    def scene_mover(self) -> Effect | None:
        """The one effect that moves the scene, if any."""
        return next((e for e in self.items if e.moves_scene), None)

    def medium(self, rays: Rays, hits: RayHits) -> RayHits:
        """The hits seen through every effect's medium in turn; clear air: `hits` itself."""
        for effect in self.items:
            if effect.changes_medium:
                hits = effect.medium(rays, hits)
        return hits

    def describe(self) -> dict:
        return {e.name: e.describe() for e in self.items}

    @property
    def classes(self) -> tuple[int, ...]:
        """The class ids the effects declare they can produce (Effect.classes), each once."""
        return tuple(dict.fromkeys(i for e in self.items for i in e.classes))


CLEAR_AIR = Effects()
