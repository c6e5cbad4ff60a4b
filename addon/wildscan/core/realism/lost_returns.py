"""Returns lost to the receiver (numpy only): the realistic model's detection step, which drops
an echo whose received power falls below the limit the device's datasheet fixes
(core/sensors/detection.py), and the tally of what it dropped by class, range and incidence.

Each echo's received power, in the units of that limit (rho cos theta / R^2), is

    P = rho_s * C * exp(-2 alpha R) / R^2 * speckle

- rho_s, the reflectance (0-1) of the surface at the laser's wavelength: the physical
  intensity's per-class material model (core/realism/intensity.py MATERIALS, read off the ECOSTRESS
  spectral library at 0.9 um: Meerdink et al., Remote Sens. Environ. 230, 2019), drawn per
  instance (per spot of ground for the terrain and the sward) from the world's seed, so a
  dataset's physical intensity and its lost returns see the same surface; an object's own
  `wildscan_reflectance` (0-1) where it carries one.
- C = sum of w_k cos theta_k over the echo's sub-rays (core/realism/echoes.py Echoes.cover): the
  footprint's share on the surface times its incidence.
- alpha the weather's extinction (core/effects/weather.py; clear air 0), R the echo's range.
- speckle, the physical intensity's pulse-to-pulse factor in [1 - SPECKLE, 1 + SPECKLE]
  (core/realism/intensity.py), drawn per (noise seed, beam, echo): near the limit the loss is a
  matter of chance, seeded and deterministic. At the datasheet's range a flat target of its
  reflectance is detected one time in two; every time where P is SPECKLE above the limit.

A weather particle's echo is left to the weather's own detection (core/effects/weather.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..classes import NUM_IDS, PARTICLE_ID
from ..sensors.detection import Detection
from . import intensity as I

SPECKLE_KEY = 0xDE7EC7  # the detection's own stream of speckle draws
RANGE_EDGES = (10.0, 20.0, 40.0, 60.0, 80.0, 100.0)  # m: the card's range bins
INCIDENCE_EDGES = (30.0, 45.0, 60.0, 75.0)  # deg: the card's incidence bins
RANGE_BINS = len(RANGE_EDGES) + 1
INCIDENCE_BINS = len(INCIDENCE_EDGES) + 1
TALLY = NUM_IDS + RANGE_BINS + INCIDENCE_BINS  # columns of a tally: class, range, incidence


@dataclass(frozen=True)
class Detecting:
    """What the detection step of one scan needs beside its echoes."""

    table: Detection
    seed: int  # the world's seed: each surface's reflectance (intensity.surface_reflectance)
    noise_seed: int  # the scan's noise seed: the speckle draws
    alpha: float = 0.0  # the air's extinction, 1/m
    # ((class id, instance, reflectance 0-1), ...): the objects that carry `wildscan_reflectance`
    reflectances: tuple[tuple[int, int, float], ...] = ()

    def override(self, label: np.ndarray, instance: np.ndarray) -> np.ndarray | None:
        """The reflectance of each (label, instance) an object's own value sets (nan: none)."""
        if not self.reflectances:
            return None
        key = np.asarray(label, dtype=np.int64) << 32 | np.asarray(instance, dtype=np.int64) & 0xFFFFFFFF
        known = np.array([c << 32 | i & 0xFFFFFFFF for c, i, _ in self.reflectances], dtype=np.int64)
        value = np.array([r for _, _, r in self.reflectances], dtype=np.float64)
        order = np.argsort(known, kind="stable")
        known, value = known[order], value[order]
        at = np.clip(np.searchsorted(known, key), 0, len(known) - 1)
        return np.where(known[at] == key, value[at], np.nan)


def object_reflectances(class_id, instance, reflectance) -> tuple[tuple[int, int, float], ...]:
    """((class id, instance, reflectance), ...) of the triangles whose object carries
    `wildscan_reflectance` (per triangle, nan: none; raycast/geometry.py), each (class,
    instance) once: its first triangle's (Detecting.reflectances)."""
    own = np.flatnonzero(~np.isnan(np.asarray(reflectance, dtype=np.float64)))
    if not len(own):
        return ()
    keys = np.stack([np.asarray(class_id)[own], np.asarray(instance)[own]], axis=1).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    at = own[np.sort(first)]
    return tuple(
        (int(c), int(i), float(r))
        for c, i, r in zip(
            np.asarray(class_id)[at], np.asarray(instance)[at], np.asarray(reflectance)[at], strict=True
        )
    )


def received_power(reflectance, cover, distance, alpha: float = 0.0) -> np.ndarray:
    """rho * C * exp(-2 alpha R) / R^2 (the detection limit's units)."""
    r = np.maximum(np.asarray(distance, dtype=np.float64), 1e-6)
    return np.asarray(reflectance) * np.asarray(cover) * np.exp(-2.0 * alpha * r) / (r * r)


def speckle(noise_seed: int, beam: np.ndarray, rank: np.ndarray) -> np.ndarray:
    """The pulse-to-pulse factor of each echo (beam, its rank within the beam's echoes)."""
    u = I.hash_unit(np.int64(noise_seed), np.int64(SPECKLE_KEY), beam, rank)
    return 1.0 - I.SPECKLE + 2.0 * I.SPECKLE * u


def lost_echoes(
    d: Detecting, echoes, rank: np.ndarray, world_xy: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(lost, C) for each echo of `echoes` (core/realism/echoes.py Echoes): lost when its received
    power with speckle falls below the limit; `rank` its place in its beam, `world_xy` where it
    lies."""
    label = np.asarray(echoes.label, dtype=np.intp)
    cover = np.minimum(echoes.cover, 1.0)
    rho = I.surface_reflectance(d.seed, label, echoes.instance, world_xy)
    override = d.override(label, echoes.instance)
    if override is not None:
        rho = np.where(np.isnan(override), rho, override)
    power = received_power(rho, cover, echoes.range, d.alpha) * speckle(d.noise_seed, echoes.beam, rank)
    lost = (power < d.table.threshold(echoes.range)) & (label != PARTICLE_ID)
    return lost, cover


def tally(label: np.ndarray, distance: np.ndarray, cover: np.ndarray, lost: np.ndarray) -> np.ndarray:
    """(2, TALLY) counts: row 0 every echo weighed, row 1 those lost; columns the class ids,
    then the range bins, then the incidence bins (C read as cos theta)."""
    angle = np.degrees(np.arccos(np.clip(cover, 0.0, 1.0)))
    column = np.concatenate(
        [
            np.asarray(label, dtype=np.int64),
            NUM_IDS + np.searchsorted(RANGE_EDGES, distance, side="right"),
            NUM_IDS + RANGE_BINS + np.searchsorted(INCIDENCE_EDGES, angle, side="right"),
        ]
    )
    weighed = np.bincount(column, minlength=TALLY)
    gone = np.bincount(column[np.tile(lost, 3)], minlength=TALLY)
    return np.stack([weighed, gone])[None]


def range_bin_names() -> list[str]:
    edges = (0.0, *RANGE_EDGES)
    return [f"{a:g}-{b:g} m" for a, b in zip(edges, RANGE_EDGES, strict=False)] + [f">{RANGE_EDGES[-1]:g} m"]


def incidence_bin_names() -> list[str]:
    edges = (0.0, *INCIDENCE_EDGES)
    names = [f"{a:g}-{b:g} deg" for a, b in zip(edges, INCIDENCE_EDGES, strict=False)]
    return names + [f">{INCIDENCE_EDGES[-1]:g} deg"]


def tally_stats(counts: np.ndarray) -> dict:
    """The sidecar's `lost_returns`: echoes weighed and lost, and both by class id, range bin
    and incidence bin (only the bins with echoes)."""
    weighed, gone = (np.asarray(c, dtype=np.int64) for c in counts)

    def part(lo: int, names: list[str]) -> dict:
        return {
            name: [int(weighed[lo + k]), int(gone[lo + k])] for k, name in enumerate(names) if weighed[lo + k]
        }

    return {
        "weighed": int(weighed[:NUM_IDS].sum()),
        "lost": int(gone[:NUM_IDS].sum()),
        "by_class": part(0, [str(i) for i in range(NUM_IDS)]),
        "by_range": part(NUM_IDS, range_bin_names()),
        "by_incidence": part(NUM_IDS + RANGE_BINS, incidence_bin_names()),
    }


def add_stats(total: dict, more: dict) -> dict:
    """Two `lost_returns` blocks summed (a dataset's scans)."""
    if not total:
        return {k: (dict(v) if isinstance(v, dict) else v) for k, v in more.items()}
    total["weighed"] += more["weighed"]
    total["lost"] += more["lost"]
    for key in ("by_class", "by_range", "by_incidence"):
        for name, (w, g) in more[key].items():
            have = total[key].get(name, [0, 0])
            total[key][name] = [have[0] + w, have[1] + g]
    return total
