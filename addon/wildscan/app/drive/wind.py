"""The scene at a time behind the ray-caster interface: the caster of an effect that moves
the scene (core/effects, the first one the drive's wind, core/effects/wind.py).

Everything that stands still is one ray caster built once. The effect's moving objects are
posed anew for every 2D scan, at its start time (the device's timing), and only those a 2D
scan can reach are posed: the objects whose bounding sphere comes near the plane its beams
sweep and within its range (a planar fan's plane: the UTM-30LX-EW's). Each 2D scan's rays
are cast at both and the nearer hit wins.
"""

from __future__ import annotations

import numpy as np

from ...core import detmath as dm
from ...core.backend import SCAN_TIMES, RayBackend
from ...core.effects import CLEAR_AIR, Effects, ObjectMotion, Wind
from ...core.effects.wind import pivots_of
from ...core.hits import RayHits
from ...core.sensors import SensorConfig
from ...raycast.geometry import SceneGeometry

# How far a swaying object may be from a 2D scan's plane at its start and still be reached:
# the robot moves, turns and the head turns a little during the 18.75 ms of a sweep.
PLANE_SLACK = 0.3  # m


def drive_effects(wind_deg: float, wind_seed: int) -> Effects:
    """The effects of a drive: wind when it blows, else clear air."""
    return Effects((Wind(wind_deg, wind_seed),)) if wind_deg else CLEAR_AIR


class MovingScene:
    """Static triangles in `static`, moving ones rebuilt per 2D scan with `make(geometry)`."""

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
        self.capabilities = frozenset({SCAN_TIMES})  # cast_scans; no normals (the paper model)
        self.static = static
        self.swaying = swaying
        self.sway = sway
        self.make = make
        self.rh = dm.radians(sensor.rh_deg)
        self.timing = sensor.device.timing
        self.per_column = sensor.device.beams.count
        corners = swaying.vertices[swaying.faces]
        objects = len(sway.pivots)
        self.face_object = swaying.object_index
        reach = np.zeros(objects)
        far = dm.norm(corners - sway.pivots[self.face_object][:, None, :]).max(axis=1)
        np.maximum.at(reach, self.face_object, far)
        self.reach = reach  # every vertex stays within this of the pivot, whatever the tilt
        self.rest = make(swaying) if swaying.triangle_count else None

    def cast(self, origins, directions, max_range) -> RayHits:
        """Rays at no particular time (the placement lasers): foliage at rest."""
        hits = self.static.cast(origins, directions, max_range)
        return hits if self.rest is None else nearer(hits, self.rest.cast(origins, directions, max_range))

    def cast_scans(self, origins, directions, max_range, ks) -> RayHits:
        """The rays of 2D scans `ks` (a column of beams each, in order), each at its 2D scan's time."""
        hits = self.static.cast(origins, directions, max_range)
        if self.rest is None:
            return hits
        origins = np.broadcast_to(np.asarray(origins, dtype=np.float64), np.shape(directions))
        n = self.per_column
        for row, k in enumerate(ks):
            rays = slice(row * n, (row + 1) * n)
            part = self._posed_near(
                origins[rays], directions[rays], max_range, k * self.timing.column_period_s
            )
            if part is not None:
                scan_hits = part.cast(origins[rays], directions[rays], max_range)
                merged = nearer(_rows(hits, rays), scan_hits)
                hits.distance[rays], hits.class_id[rays], hits.instance[rays] = (
                    merged.distance,
                    merged.class_id,
                    merged.instance,
                )
        return hits

    def _posed_near(self, origins, dirs, max_range, t):
        centre = origins[0]
        normal = dm.cross(dirs[0], dirs[len(dirs) // 2])
        normal /= dm.norm(normal)
        offset = self.sway.pivots - centre
        slack = self.reach + PLANE_SLACK + max_range * dm.sin(self.rh)
        near = (np.abs(dm.dot3(offset, normal)) <= slack) & (dm.norm(offset) <= max_range + self.reach)
        if not np.any(near):
            return None
        faces = near[self.face_object]
        part = self.swaying.subset(faces)
        used = np.unique(self.swaying.faces[faces])
        vertex_object = np.zeros(len(self.swaying.vertices), dtype=np.int64)
        vertex_object[self.swaying.faces.ravel()] = np.repeat(self.face_object, 3)
        part.vertices = self.sway.posed(self.swaying.vertices[used], vertex_object[used], t)
        return self.make(part)


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


def _rows(hits: RayHits, rows: slice) -> RayHits:
    return hits.rows(rows)


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
