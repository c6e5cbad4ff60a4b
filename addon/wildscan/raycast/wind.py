"""The scene at a time behind the ray-caster interface: the caster of an effect that moves
the scene (core/effects, the first one the drive's wind, core/effects/wind.py).

Everything that stands still is one ray caster built once, and so are the moving objects,
at rest: nothing is rebuilt while the drive runs. Each moving object turns rigidly about
its pivot (`ObjectMotion.turns`), so a ray meets the object as it is at time t where the
ray, turned back about the pivot by the object's turn at t, meets the object at rest. Per
2D scan (at its start time, the device's timing) the objects its rays can reach are found
(near its plane, then ray by ray against each posed object's bounding sphere), each such
ray is turned into the object's rest frame and cast at the objects at rest, cut to the
object's bounding sphere, and the nearest answer of the still scene and every object wins.

The objects at rest are split into layers whose bounding spheres keep apart (SEPARATION):
a ray cut to one object's sphere can meet no other object of its layer, so the rays of a
whole chunk of 2D scans go to each layer's caster in one batch.
"""

from __future__ import annotations

import numpy as np

from ..core import detmath as dm
from ..core.backend import SCAN_TIMES, THREADS, RayBackend
from ..core.effects import CLEAR_AIR, Effects, ObjectMotion, Wind
from ..core.effects.wind import pivots_of
from ..core.hits import MISS_CLASS, MISS_INSTANCE, RayHits
from ..core.sensors import SensorConfig
from .geometry import SceneGeometry

# The bounding spheres of two objects in one layer are at least this far apart: far above
# a float32 cast's error, so a ray cut to one object's sphere cannot be answered by another.
SEPARATION = 0.01  # m
# Every sphere and bound grown by this against float64 rounding (a ray grazing a sphere is
# cast, never dropped).
MARGIN = 1e-6  # m
PAIR_BLOCK = 256  # (2D scan, object) pairs tested ray by ray at once (memory: 256 x 1080 rays)


def drive_effects(wind_deg: float, wind_seed: int) -> Effects:
    """The effects of a drive: wind when it blows, else clear air."""
    return Effects((Wind(wind_deg, wind_seed),)) if wind_deg else CLEAR_AIR


class MovingScene:
    """Static triangles in `static`; the moving objects at rest in one caster for rays at no
    particular time (`rest`) and in layers for the 2D scans' rays (module docstring)."""

    def __init__(
        self,
        static: RayBackend,
        swaying: SceneGeometry,
        sway: ObjectMotion,
        make,
        sensor: SensorConfig,
        name: str,
    ):
        self.name = f"{static.name}+{name}"
        # cast_scans; no normals (the paper model); threads as the still scene's caster allows
        # (every ray's answer its own, the casters read-only once built)
        self.capabilities = frozenset({SCAN_TIMES}) | (static.capabilities & {THREADS})
        self.threads = getattr(static, "threads", None)
        self.static = static
        self.swaying = swaying
        self.sway = sway
        self.period = sensor.device.timing.column_period_s
        self.per_column = sensor.device.beams.count
        objects = len(sway.pivots)
        face_object = swaying.object_index
        corners = swaying.vertices[swaying.faces]
        # every vertex stays within `reach` of its pivot, whatever the turn
        far = dm.norm(corners - sway.pivots[face_object][:, None, :]).max(axis=1)
        self.reach = np.zeros(objects)
        np.maximum.at(self.reach, face_object, far)
        self.centre, self.radius = bounding_spheres(corners, face_object, objects)
        self.layer = sphere_layers(self.centre, self.radius)
        self.rest = make(swaying) if swaying.triangle_count else None
        self.layers = []
        for layer in range(int(self.layer.max()) + 1 if objects else 0):
            part = swaying.subset(self.layer[face_object] == layer)
            self.layers.append(make(part))

    def cast(self, origins, directions, max_range) -> RayHits:
        """Rays at no particular time (the placement lasers): foliage at rest."""
        hits = self.static.cast(origins, directions, max_range)
        return hits if self.rest is None else nearer(hits, self.rest.cast(origins, directions, max_range))

    def cast_scans(self, origins, directions, max_range, ks) -> RayHits:
        """The rays of 2D scans `ks` (a column of beams each, in order), each at its 2D scan's time."""
        hits = self.static.cast(origins, directions, max_range)
        if self.rest is None:
            return hits
        dirs = np.asarray(directions, dtype=np.float64).reshape(len(ks), self.per_column, 3)
        origins = np.broadcast_to(np.asarray(origins, dtype=np.float64), np.shape(directions))
        origins = origins.reshape(dirs.shape)
        scans, objects = self._near_pairs(origins, dirs, max_range)
        if not len(scans):
            return hits
        times = np.asarray(ks, dtype=np.float64)[scans] * self.period
        turns = self.sway.turns(times, objects)
        entries = [
            self._rays_meeting(origins, dirs, max_range, scans[b], objects[b], turns[b])
            for b in _blocks(len(scans), PAIR_BLOCK)
        ]
        ray, obj, turn, near, chord = (np.concatenate(part) for part in zip(*entries))
        flat_o, flat_d = origins.reshape(-1, 3), dirs.reshape(-1, 3)
        found = [
            self._cast_layer(layer, flat_o, flat_d, max_range, ray, obj, turn, near, chord)
            for layer in range(len(self.layers))
        ]
        return _nearest(hits, [f for f in found if f is not None])

    def _near_pairs(self, origins, dirs, max_range):
        """(2D scan row, object) pairs whose object a ray of the scan may reach, whatever its
        turn: within reach of the pivot of the plane the scan's beams sweep and of its origin.
        The bounds are the scan's own (how far its origins and directions leave the plane its
        first and middle beam span), so no reachable object is dropped."""
        first = origins[:, 0]
        normal = dm.cross(dirs[:, 0], dirs[:, dirs.shape[1] // 2])
        length = dm.norm(normal)
        flat = length > 1e-9  # else (a fan of one beam, or a straight line): no plane, range only
        normal = np.where(flat[:, None], normal / np.where(flat, length, 1.0)[:, None], 0.0)
        away = np.abs(dm.dot3(origins - first[:, None, :], normal[:, None, :])).max(axis=1)
        tilt = np.abs(dm.dot3(dirs, normal[:, None, :])).max(axis=1)
        spread = dm.norm(origins - first[:, None, :]).max(axis=1)
        offset = self.sway.pivots[None, :, :] - first[:, None, :]  # (K, E, 3)
        slab = np.abs(dm.dot3(offset, normal[:, None, :])) <= (
            self.reach[None, :] + (away + max_range * tilt)[:, None] + MARGIN
        )
        slab |= ~flat[:, None]
        ball = dm.norm(offset) <= self.reach[None, :] + (spread + max_range)[:, None] + MARGIN
        return np.nonzero(slab & ball)

    def _rays_meeting(self, origins, dirs, max_range, scans, objects, turns):
        """The rays of these (scan, object) pairs that pass through the object's bounding
        sphere as the object is posed: (ray index, object, turn, where the ray enters the
        sphere (0 from inside), the length of its chord from there)."""
        pivot = self.sway.pivots[objects]
        centre = pivot + dm.apply(turns, self.centre[objects] - pivot)  # (P, 3) posed
        radius = self.radius[objects] + MARGIN
        o, d = origins[scans], dirs[scans]  # (P, n, 3)
        rel = centre[:, None, :] - o
        along = dm.dot3(rel, d)
        miss = dm.dot3(rel, rel) - along * along  # squared distance of the centre from the ray line
        r2 = (radius * radius)[:, None]
        half = np.sqrt(np.maximum(r2 - miss, 0.0))
        enter = np.maximum(along - half, 0.0)
        leave = along + half
        meets = (miss <= r2) & (leave >= 0.0) & (enter <= max_range)
        pair, beam = np.nonzero(meets)
        ray = scans[pair] * dirs.shape[1] + beam
        return (
            ray,
            objects[pair],
            turns[pair],
            enter[pair, beam],
            leave[pair, beam] - enter[pair, beam] + MARGIN,
        )

    def _cast_layer(self, layer, origins, dirs, max_range, ray, obj, turn, near, chord):
        """Hits on this layer's objects of the entries meeting them: (ray, RayHits)."""
        mine = np.flatnonzero(self.layer[obj] == layer)
        if not len(mine):
            return None
        ray, turn, near, chord = ray[mine], turn[mine], near[mine], chord[mine]
        pivot = self.sway.pivots[obj[mine]]
        back = np.swapaxes(turn, 1, 2)  # the inverse turn
        d = dirs[ray]
        start = origins[ray] + near[:, None] * d
        rest_o = pivot + dm.apply(back, start - pivot)
        rest_d = dm.apply(back, d)
        found = self.layers[layer].cast(rest_o, rest_d, float(chord.max()))
        # an answer past the object's own chord is another object of the layer: not this one
        distance = near + found.distance
        keep = (found.distance <= chord) & (distance <= max_range)
        found.distance = np.where(keep, distance, np.inf)
        found.class_id = np.where(keep, found.class_id, MISS_CLASS).astype(np.int16)
        found.instance = np.where(keep, found.instance, MISS_INSTANCE).astype(np.int32)
        return ray, found


def nearer(a: RayHits, b: RayHits) -> RayHits:
    """Per ray, the nearer of two answers."""
    take = b.distance < a.distance
    return RayHits(
        distance=np.where(take, b.distance, a.distance),
        class_id=np.where(take, b.class_id, a.class_id),
        instance=np.where(take, b.instance, a.instance),
        untagged_objects=a.untagged_objects | b.untagged_objects,
        reflectivity=None
        if a.reflectivity is None and b.reflectivity is None
        else np.where(take, b.overrides(), a.overrides()),
    )


def _nearest(hits: RayHits, found: list) -> RayHits:
    """`hits` with each ray's answer replaced by a nearer one of `found` ((ray, RayHits) each,
    several answers a ray): the nearest wins, the still scene on a tie, then the first found."""
    if not found:
        return hits
    ray = np.concatenate([r for r, _ in found])
    part = RayHits.joined([h for _, h in found])
    order = np.lexsort((part.distance, ray))  # by ray, nearest first; stable on ties
    ray, part = ray[order], part.rows(order)
    first = np.flatnonzero(np.r_[True, ray[1:] != ray[:-1]])
    ray, part = ray[first], part.rows(first)
    better = part.distance < hits.distance[ray]
    ray, part = ray[better], part.rows(better)
    out = hits.rows(slice(None))
    out.distance, out.class_id, out.instance = out.distance.copy(), out.class_id.copy(), out.instance.copy()
    out.distance[ray], out.class_id[ray], out.instance[ray] = part.distance, part.class_id, part.instance
    if part.reflectivity is not None or hits.reflectivity is not None:
        out.reflectivity = hits.overrides().copy()
        out.reflectivity[ray] = part.overrides()
    out.untagged_objects = hits.untagged_objects | part.untagged_objects
    return out


def _blocks(count: int, size: int):
    return [slice(a, min(a + size, count)) for a in range(0, count, size)]


def bounding_spheres(corners: np.ndarray, face_object: np.ndarray, count: int):
    """(count, 3) centres and (count,) radii of spheres holding each object's triangles
    (`corners` (T, 3, 3)): about the centre of the object's bounding box."""
    flat = corners.reshape(-1, 3)
    owner = np.repeat(face_object, 3)
    lo = np.full((count, 3), np.inf)
    hi = np.full((count, 3), -np.inf)
    np.minimum.at(lo, owner, flat)
    np.maximum.at(hi, owner, flat)
    centre = (lo + hi) / 2
    radius = np.zeros(count)
    np.maximum.at(radius, owner, dm.norm(flat - centre[owner]))
    return centre, radius


def sphere_layers(centre: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """(E,) a layer per object such that the spheres of one layer stay SEPARATION apart:
    greedy, the objects in order, each into the first layer it fits."""
    count = len(radius)
    layer = np.full(count, -1, dtype=np.int64)
    for e in range(count):
        gap = dm.norm(centre[:e] - centre[e]) - radius[:e] - radius[e]
        taken = set(layer[:e][gap < SEPARATION].tolist())
        layer[e] = next(n for n in range(count + 1) if n not in taken)
    return layer


def moving_scene(static_geometry: SceneGeometry, effects: Effects, make, sensor: SensorConfig):
    """The scene of `static_geometry` as `effects` move it (the wind: treetops, bushes and grass
    sway), behind a caster `make(geometry)` builds; a backend of its own when nothing moves."""
    effect = effects.scene_mover
    if effect is None:
        return make(static_geometry)
    moving = np.isin(static_geometry.class_id, effect.moving_classes)
    still = static_geometry.subset(~moving)
    still.offset = static_geometry.offset
    swaying = static_geometry.subset(moving)
    swaying.offset = static_geometry.offset
    # one sway object per element: renumber the swaying objects 0..E-1 in their first order
    objects, first, face_object = np.unique(swaying.object_index, return_index=True, return_inverse=True)
    swaying.object_index = face_object.astype(np.int32)
    class_ids = swaying.class_id[first]
    pivots = pivots_of(swaying.vertices, swaying.faces, swaying.object_index, len(objects))
    return MovingScene(make(still), swaying, effect.motion(class_ids, pivots), make, sensor, effect.name)
