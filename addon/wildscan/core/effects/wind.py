"""Wind: foliage swaying over time (numpy only), the first effect that moves the scene.

Treetops, bushes and grass tilt about their base (the bottom centre of the object's
bounding box: where a crown sits on its trunk, where a bush or a tuft meets the ground) by
small rotations that change with time: each object oscillates along the wind's direction
at its own seeded frequency and phase, with a weaker crosswind component. Grass moves
most and fastest, crowns least and slowest. Everything else stands still, and every
triangle keeps its class and instance, so labels stay exact. The sway is detmath's (the
posed foliage decides hits: the same bits on every CPU). The caster that casts each
column's rays at the foliage as it is at the column's time is raycast/wind.py
`moving_scene`, which asks the effect (`moving_classes`, `motion`) as base.py describes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import detmath as dm
from ..classes import class_by_name
from ..rng import stage_rng
from ..spatial.rotations import matrix
from .base import Effect

# class -> (amplitude relative to the treetops', lowest and highest frequency in Hz)
SWAY = {
    "treetop": (1.0, 0.2, 0.5),
    "bush": (1.5, 0.5, 1.2),
    "high grass": (3.0, 0.8, 2.0),
    "low grass": (3.0, 1.0, 2.5),
}
SWAYING_IDS = tuple(class_by_name(name).id for name in SWAY)
CROSSWIND = 0.3  # the crosswind component's share of the amplitude


@dataclass(frozen=True)
class Wind(Effect):
    amplitude_deg: float  # peak sway of the treetops
    seed: int = 0

    name = "wind"
    moves_scene = True
    moving_classes = SWAYING_IDS

    def describe(self) -> dict:
        return {"amplitude_deg": self.amplitude_deg, "seed": self.seed}

    def motion(self, class_ids: np.ndarray, pivots: np.ndarray) -> "Sway":
        return Sway(self, class_ids, pivots)


class Sway:
    """The sway of E objects: (E,) class ids, (E, 3) pivots; parameters drawn per object in
    the order given (callers pass objects in a fixed order: the same wind, the same sway)."""

    def __init__(self, wind: Wind, class_ids: np.ndarray, pivots: np.ndarray):
        rng = stage_rng(int(wind.seed), "drive.wind")
        count = len(class_ids)
        self.pivots = np.asarray(pivots, dtype=np.float64).reshape(-1, 3)
        heading = rng.uniform(0, 2 * math.pi)
        self.along = np.array([dm.cos(heading), dm.sin(heading)])
        scale = np.zeros(count)
        low, high = np.zeros(count), np.zeros(count)
        for name, (factor, f_low, f_high) in SWAY.items():
            mine = np.asarray(class_ids) == class_by_name(name).id
            scale[mine], low[mine], high[mine] = factor, f_low, f_high
        self.amplitude = dm.radians(wind.amplitude_deg) * scale * rng.uniform(0.7, 1.3, count)
        self.frequency = rng.uniform(low, high)
        self.phase = rng.uniform(0, 2 * math.pi, (count, 2))

    def rotvecs(self, t, objects=None) -> np.ndarray:
        """(E, 3) each object's rotation at time t (s): a tilt about a horizontal axis. With
        `objects` (P,) given, `t` scalar or (P,): the rotation of objects[i] at t[i]."""
        if objects is None:
            objects = np.arange(len(self.frequency))
        frequency, amplitude, phase = self.frequency[objects], self.amplitude[objects], self.phase[objects]
        w = 2 * math.pi * frequency * t
        along = amplitude * dm.sin(w + phase[:, 0])
        across = CROSSWIND * amplitude * dm.sin(1.7 * w + phase[:, 1])
        tilt = along[:, None] * self.along + across[:, None] * np.array([-self.along[1], self.along[0]])
        # tilting the top towards `tilt` is a rotation about z x tilt
        return np.column_stack([-tilt[:, 1], tilt[:, 0], np.zeros(len(tilt))])

    def turns(self, t, objects: np.ndarray) -> np.ndarray:
        """(P, 3, 3) the rotation of objects[i] (about its pivot) at time t[i] (or t)."""
        return matrix(self.rotvecs(t, objects))

    def posed(self, vertices: np.ndarray, vertex_object: np.ndarray, t: float) -> np.ndarray:
        """Vertices (V, 3) of the objects `vertex_object` (V,) where they are at time t."""
        # one matrix an object (the sines per object, not per vertex), applied in a fixed order
        turn = matrix(self.rotvecs(t))[vertex_object]
        pivot = self.pivots[vertex_object]
        return pivot + dm.apply(turn, vertices - pivot)


def pivots_of(vertices: np.ndarray, faces: np.ndarray, face_object: np.ndarray, count: int) -> np.ndarray:
    """(count, 3) the bottom centre of each object's bounding box (its base)."""
    corners = vertices[faces]  # (T, 3, 3)
    owner = np.repeat(face_object, 3)
    flat = corners.reshape(-1, 3)
    lo = np.full((count, 3), np.inf)
    hi = np.full((count, 3), -np.inf)
    np.minimum.at(lo, owner, flat)
    np.maximum.at(hi, owner, flat)
    return np.column_stack([(lo[:, :2] + hi[:, :2]) / 2, lo[:, 2]])
