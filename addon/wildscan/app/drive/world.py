"""The world a drive sees, the path through it, and one crop of its triangles around the path.

A seed's world is planned and turned into triangles without Blender (raycast/from_plan.py),
only the elements that may reach the path's corridor; a .blend file is opened and extracted
(bpy). Its trail is the one the seed's layout drew
(recorded on the world's collection): the layout is the same at every detail level.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core import detmath as dm
from ...core.errors import UserError
from ...core.motion.trajectory import Path, polyline_path, step_lengths, straight_path
from ...raycast.geometry import SceneGeometry, local_origin
from .request import DriveRequest

TRAIL_STAGE = "trail"
CROP_STEP = 1.0  # m between the path's points whose neighbourhoods make the crop
CORRIDOR_MARGIN = 1.0  # m: elements this much beyond the crop's reach are still made into triangles


@dataclass
class DriveWorld:
    """The world a drive sees: where it came from, its trail, and its triangles near a path."""

    provenance: dict
    trail: np.ndarray | None  # the trail's centre line, or None
    instances: np.ndarray  # every instance of the whole world (SemanticKITTI numbers them)
    cover: object  # the ground cover (core/world/cover.py), or None
    geometry: SceneGeometry | None = None  # a .blend's triangles, all of them
    plan: object = None  # or a seed's plan, turned into triangles only near the path

    def crop(self, xy: np.ndarray, radius: float) -> SceneGeometry:
        """`crop_along` of the world's triangles: a seed's world makes triangles only of the
        elements that may reach the path's corridor (the crop is the same, byte for byte)."""
        if self.plan is None:
            return crop_along(self.geometry, xy, radius)
        from ...raycast.from_plan import plan_geometry

        lo, hi = corridor_box(xy, radius)
        prototypes = self.plan.prototypes
        return crop_along(plan_geometry(self.plan, keep=_elements_within(prototypes, lo, hi)), xy, radius)


def drive_world(request: DriveRequest) -> DriveWorld:
    """The world the request names: a seed's planned (its triangles made later, near the
    path: `DriveWorld.crop`), or a .blend file's extracted."""
    if request.seed is not None:
        from ...core.world import plan_world

        plan = plan_world(request.seed, request.detail, vegetation=request.vegetation)
        provenance = {
            "seed": request.seed,
            "detail": request.detail,
            "vegetation": request.vegetation,
            "world": None,
        }
        with_faces = [el.instance for el in plan.elements if len(plan.prototypes[el.proto].faces)]
        instances = np.unique(np.asarray(with_faces, dtype=np.int32))
        return DriveWorld(provenance, plan.layout.trail.path, instances, plan.cover, plan=plan)
    from ...blender.scene_io import open_world, scene_provenance
    from ...raycast.extract import extract_scene

    open_world(request.world, quiet=request.quiet)
    seed, blend = scene_provenance()
    geometry = extract_scene()
    provenance = {"seed": seed, "detail": None, "vegetation": None, "world": blend}
    trail = _trail_of_blend(seed, geometry)
    return DriveWorld(provenance, trail, np.unique(geometry.instance), geometry.cover, geometry=geometry)


def _trail_of_blend(seed: int | None, geometry: SceneGeometry) -> np.ndarray | None:
    """The trail of a WildScan world saved as .blend: drawn by its seed's layout, if the
    file still holds the trail's flooring."""
    if seed is None or not any(name.startswith(f"{TRAIL_STAGE}.") for name in geometry.object_names):
        return None
    return layout_of(seed).trail.path


def layout_of(seed: int):
    """The zone layout of a seed's world (its first stage only: the trail, the zones' cells)."""
    from ...core.rng import stage_rng
    from ...core.world.detail import detail_level
    from ...core.world.pipeline import WorldParams
    from ...core.world.plan import WorldPlan
    from ...core.world.stages import layout

    plan = WorldPlan(seed, detail_level("default"), WorldParams())
    layout.run(plan, stage_rng(seed, f"world.{layout.STAGE}"))
    return plan.layout


def drive_path(request: DriveRequest, trail: np.ndarray | None) -> Path:
    """The path the request names."""
    if request.trail:
        if trail is None:
            where = request.world if request.world is not None else f"seed {request.seed}"
            raise UserError(
                f"needs a WildScan world with a trail; {where} has none (use {{waypoints}} or {{from}})",
                setting="trail",
                related=("waypoints", "from"),
            )
        return polyline_path(trail, "trail", "trail")
    if request.waypoints is not None:
        from ...core.io.waypoints import read_waypoints

        return polyline_path(read_waypoints(request.waypoints), "waypoints", "waypoints")
    x, y, yaw = request.start
    return straight_path(x, y, yaw, request.distance)


def crop_along(geometry: SceneGeometry, xy: np.ndarray, radius: float) -> SceneGeometry:
    """The triangles a sensor anywhere on the polyline `xy` (n, 2) can reach: those whose xy
    bounding box comes within `radius` of it. A single point crops as `SceneGeometry.cropped`
    does (the same triangles and local origin as a static scan there)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if np.all(xy == xy[0]):
        return geometry.cropped(xy[0], radius)
    samples = _samples(_thinned(xy, CROP_STEP / 2), CROP_STEP)
    reach = radius + CROP_STEP / 2  # every point of the path is within half a step of a sample
    lo, hi = samples.min(axis=0) - reach, samples.max(axis=0) + reach
    candidates, box_lo, box_hi = _boxes_meeting(geometry, lo, hi)
    near = np.zeros(len(candidates), dtype=bool)
    (lo_x, lo_y), (hi_x, hi_y) = box_lo, box_hi
    for px, py in samples.tolist():
        # the box's point nearest the sample, as np.clip finds it: min(max(p, lo), hi)
        gx = np.minimum(np.maximum(px, lo_x), hi_x) - px
        gy = np.minimum(np.maximum(py, lo_y), hi_y) - py
        near |= gx * gx + gy * gy <= reach * reach
    keep = np.zeros(geometry.triangle_count, dtype=bool)
    keep[candidates[near]] = True
    part = geometry.subset(keep)
    centre = 0.5 * (samples.min(axis=0) + samples.max(axis=0))
    part.offset = local_origin(part.vertices, part.faces, centre)
    return part


def corridor_box(xy: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) xy corners of a box holding every triangle box `crop_along` keeps, with
    CORRIDOR_MARGIN to spare."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    if np.all(xy == xy[0]):
        points, reach = xy[:1], radius
    else:
        points, reach = _samples(_thinned(xy, CROP_STEP / 2), CROP_STEP), radius + CROP_STEP / 2
    return points.min(axis=0) - reach - CORRIDOR_MARGIN, points.max(axis=0) + reach + CORRIDOR_MARGIN


def _elements_within(prototypes, lo: np.ndarray, hi: np.ndarray):
    """plan_geometry's `keep`: the elements whose triangles may come inside the box lo..hi.
    An element's vertices are its prototype's turned and scaled by its matrix, so they lie
    within |matrix| (Frobenius, at least its largest stretch) times the prototype's farthest
    vertex of the element's location."""
    far: dict[str, float] = {}

    def keep(elements, matrices) -> np.ndarray:
        for el in elements:
            if el.proto not in far:
                far[el.proto] = float(dm.norm(np.asarray(prototypes[el.proto].vertices).reshape(-1, 3)).max())
        linear = matrices[:, :3, :3]
        stretch = np.sqrt((linear * linear).sum(axis=(1, 2)))
        size = stretch * np.array([far[el.proto] for el in elements])
        centre = matrices[:, :2, 3]
        return np.all((centre - size[:, None] <= hi) & (centre + size[:, None] >= lo), axis=1)

    return keep


def _boxes_meeting(geometry: SceneGeometry, lo: np.ndarray, hi: np.ndarray):
    """(the triangles whose xy bounding box meets the box lo..hi, their boxes' low corners
    (x (C,), y (C,)) and high corners), column by column: a reduction over a (T, 3) axis is slow."""
    faces = geometry.faces
    inside = np.ones(len(faces), dtype=bool)
    columns = []
    for axis in range(2):
        corner = geometry.vertices[:, axis][faces]
        low = np.minimum(np.minimum(corner[:, 0], corner[:, 1]), corner[:, 2])
        high = np.maximum(np.maximum(corner[:, 0], corner[:, 1]), corner[:, 2])
        inside &= (low <= hi[axis]) & (high >= lo[axis])
        columns.append((low, high))
    candidates = np.flatnonzero(inside)
    box_lo = tuple(low[candidates] for low, _ in columns)
    box_hi = tuple(high[candidates] for _, high in columns)
    return candidates, box_lo, box_hi


def _thinned(xy: np.ndarray, step: float) -> np.ndarray:
    """Points of the polyline about `step` apart along it (the robot's positions are a few cm
    apart: the crop needs far fewer), its first and last included."""
    along = np.concatenate([[0.0], np.cumsum(step_lengths(xy))])
    picks = np.searchsorted(along, np.arange(0.0, along[-1], step))
    return xy[np.unique(np.concatenate([picks, [len(xy) - 1]]))]


def _samples(xy: np.ndarray, step: float) -> np.ndarray:
    """Points along the polyline no more than `step` apart, its vertices included."""
    out = [xy[:1]]
    for a, b in zip(xy[:-1], xy[1:]):
        count = max(1, int(np.ceil(step_lengths(np.stack([a, b]))[0] / step)))
        out.append(a + np.outer(np.arange(1, count + 1) / count, b - a))
    return np.concatenate(out)
