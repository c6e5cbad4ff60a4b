"""One labeled 3D scan from a pose: placement, sweep, ranges, labels, leveling. Numpy only.

The scene enters only through `backend.cast` (core/backend.py; it returns core.hits.RayHits), so this module
runs the same with Blender's scene.ray_cast or a fast backend.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from .. import __version__
from . import detmath as dm
from .backend import RayBackend, with_normals
from .classes import (
    LABEL_BY_ID,
    REFLECTIVITY_BY_ID,
    WATER_ID,
    carries_ground_materials,
    class_table_dict,
    reflectivity_of,
)
from .effects import CLEAR_AIR, Effects, Rays, weather_of
from .effects.weather import weather_fields
from .hits import RayHits
from .placement import Placement, Pose, place
from .pointcloud import PointCloud
from .runtime.cast_clock import scanning
from .runtime.pause import pause_here
from .runtime.threads import backend_threads, cast_parts
from .sensors import (
    DEFAULT_DEVICE,
    SensorConfig,
    beam_directions,
    range_noise,
    rotated_beam_directions,
    rotated_beams,
)
from .sensors.beams import beam_columns, beam_times
from .spatial.frames import check_frame, to_world
from .spatial.leveling import leveling_matrix
from .spatial.reach import check_reach

# Rays are cast a little past max range so a true range just beyond it can
# still come back inside after noise; the limit applies to the measured range.
NOISE_MARGIN_SIGMAS = 6.0
PROGRESS_CHUNK = 64_800  # rays per progress report (60 2D scans)
_WATER_LABELED = np.flatnonzero(LABEL_BY_ID == WATER_ID)  # the class ids read back as water

Progress = Callable[[int, int], None]


@dataclass
class ScanResult:
    cloud: PointCloud
    placement: Placement
    metadata: dict
    untagged_objects: frozenset[str] = field(default=frozenset())
    beams: int = 0
    hits: int = 0
    # |cos θ| between each point's beam and the surface along it (behind a sward's or a weather
    # particle's point; 1 where none): a paper scan's, when run_scan was asked for it
    incidence: np.ndarray | None = None
    # (row, column) range-image cells (core/rangeimage.py) of the beams whose every echo the
    # realistic model's detection step dropped: no point, though a surface was there
    # (core/realism/lost_returns.py); None: no detection step
    lost_cells: tuple[np.ndarray, np.ndarray] | None = None


def cast_in_chunks(
    backend: RayBackend,
    origin: np.ndarray,
    dirs: np.ndarray,
    max_range: float,
    progress: Progress | None,
    normals: bool = False,
):
    """Cast all rays, reporting progress between chunks when asked (with each hit's surface
    normal when `normals`: the realistic model's), in parallel threads where the backend
    allows it (core/threads.py: the same bytes)."""
    pause_here("casting")
    cast = _caster(backend, normals)
    chunk = None if progress is None else PROGRESS_CHUNK
    return cast_parts(backend, cast, origin, dirs, max_range, chunk, progress)


def _caster(backend: RayBackend, normals: bool) -> Callable[[np.ndarray, np.ndarray, float], RayHits]:
    """The backend's cast, asking for normals when `normals` (run_scan has checked, with
    realistic.check_backend, that a backend asked for them can give them)."""
    if not normals:
        return backend.cast
    capable = with_normals(backend)
    assert capable is not None, f"{backend.name} casts no normals"
    return lambda origins, dirs, max_range: capable.cast(origins, dirs, max_range, normals=True)


@dataclass
class Returns:
    """What the rangefinder reports for each beam: whether it returned a point, the measured
    range (noise included), and the reflectivity, class and instance of what it hit."""

    keep: np.ndarray  # bool (N,)
    range: np.ndarray  # float64 (N,) metres
    intensity: np.ndarray  # (N,) reflectivity (0 where no point)
    label: np.ndarray  # (N,) class id read back from the reflectivity
    instance: np.ndarray  # (N,) instance of the element hit (-1 for none)

    def cloud(self, xyz: np.ndarray, ring: np.ndarray, sweep: np.ndarray, frame: str, **extra) -> PointCloud:
        """The labeled cloud of the kept beams, at `xyz` (one row per kept beam); ring and
        sweep are per beam, `extra` per beam too (PointCloud.extra fields)."""
        keep = np.flatnonzero(self.keep)  # gathered by index: faster than by mask, field by field
        return PointCloud(
            xyz=xyz,
            intensity=self.intensity.take(keep).astype(np.float32),
            label=self.label.take(keep).astype(np.uint16),
            instance=np.maximum(self.instance.take(keep), 0).astype(np.uint32),
            ring=ring.take(keep),
            sweep=sweep.take(keep),
            range=self.range.take(keep).astype(np.float32),
            frame=frame,
            extra={name: values.take(keep, axis=0) for name, values in extra.items()},
        )


def measure(hits: RayHits, noise: np.ndarray, sensor: SensorConfig) -> Returns:
    """Ranges, limits and labels of a batch of beams: the hit distance plus noise, kept inside
    the range window; the label read from the reflectivity of what was hit (paper IV-C); an
    object's reflectivity override changes the intensity, not the label."""
    measured = hits.distance + noise
    keep = hits.hit & (measured >= sensor.min_range) & (measured <= sensor.max_range)
    kept_class = np.where(keep, hits.class_id, 0)
    intensity = reflectivity_of(kept_class)
    label = LABEL_BY_ID[kept_class]  # = label_from_reflectivity(intensity), class by class
    if hits.reflectivity is not None:
        # a `wildscan_reflectivity` override changes what is measured, not the label
        override = keep & ~np.isnan(hits.reflectivity)
        intensity = np.where(override, hits.reflectivity, intensity).astype(intensity.dtype)
    # A beam whose first hit is water returns nothing (the paper drops them).
    keep &= label != WATER_ID
    return Returns(keep, measured, intensity, label, hits.instance)


@dataclass
class Returning:
    """The points of a scan's beams that returned one (measure_returning): a row each, in beam
    order, in the cloud's own types."""

    beams: np.ndarray  # (P,) the beam of each point
    range: np.ndarray  # float64 (P,) measured range, noise included
    intensity: np.ndarray  # float32 (P,) reflectivity measured
    label: np.ndarray  # uint16 (P,) class id read back from the reflectivity
    instance: np.ndarray  # uint32 (P,) instance of the element hit (0 for none)
    hits: int  # beams that hit something (returned a point or not)


def measure_returning(hits: RayHits, noise: np.ndarray, sensor: SensorConfig) -> Returning:
    """`measure` of the beams that hit something, the only ones that can return a point, and
    of those the ones that do: the values of their rows of `measure` and of Returns.cloud,
    each field gathered once, straight from the cast's arrays (a Hokuyo's beams are two
    thirds sky; a Velodyne's points are nearly all its beams)."""
    hit = np.flatnonzero(np.isfinite(hits.distance))
    measured = hits.distance.take(hit)
    measured += noise.take(hit)
    class_id = hits.class_id.take(hit).astype(np.intp)
    # A beam whose first hit is water returns nothing (the paper drops them): the classes
    # whose label is water's, told apart by class before any label is looked up
    keep = (measured >= sensor.min_range) & (measured <= sensor.max_range)
    keep &= ~np.isin(class_id, _WATER_LABELED) if len(_WATER_LABELED) > 1 else class_id != _WATER_LABELED[0]
    kept = np.flatnonzero(keep)
    beams = hit
    if len(kept) < len(hit):
        beams, measured, class_id = (a.take(kept) for a in (hit, measured, class_id))
    label = LABEL_BY_ID.take(class_id)
    intensity = REFLECTIVITY_BY_ID.take(class_id)
    if hits.reflectivity is not None:
        # a `wildscan_reflectivity` override changes what is measured, not the label
        override = hits.reflectivity.take(beams)
        intensity = np.where(np.isnan(override), intensity, override).astype(np.float32)
    instance = np.maximum(hits.instance.take(beams), 0).astype(np.uint32)
    return Returning(beams, measured, intensity, label, instance, len(hit))


def with_weather_field(cloud: PointCloud) -> None:
    """Give a cloud scanned in weather its `weather` field (which effect made each particle;
    0: a surface) and its particles instance 0 (their hits carried the effect's code)."""
    cloud.instance, cloud.extra["weather"] = weather_fields(cloud.label, cloud.instance)


def points_in_frame(points_sensor: np.ndarray, placement: Placement, frame: str) -> np.ndarray:
    """A scan's points in its output frame: leveled by Eq. 2 itself (the paper's leveling),
    the world frame by the frame conversion every other user of frames shares."""
    if frame == "sensor":
        return points_sensor
    if frame == "leveled":
        from .spatial.leveling import level_points

        return level_points(points_sensor, placement.roll_rad, placement.pitch_rad)
    return to_world(points_sensor, "sensor", placement)


def frame_directions(
    placement: Placement, frame: str, sensor: SensorConfig, dirs_world: np.ndarray, beams: np.ndarray
) -> np.ndarray:
    """The directions of `beams` (indices) in the output frame: Eq. 1's in the sensor frame,
    turned by Eq. 2 (the paper's leveling) in the leveled frame, the cast directions in the
    world frame. A point is then its range times its beam's direction (plus the optical
    centre in the world frame): three products, in a fixed order, on every machine."""
    if frame == "sensor":
        return beam_directions(sensor.rh_deg, sensor.device)[0][beams]
    if frame == "leveled":
        leveling = leveling_matrix(placement.roll_rad, placement.pitch_rad)
        return rotated_beams(leveling, sensor.rh_deg, sensor.device, beams)
    return dirs_world[beams]


def _points(placement: Placement, frame: str, sensor: SensorConfig, dirs_world, beams, ranges) -> np.ndarray:
    """The points of `beams` (indices) at their `ranges` (one each) in the output frame: range
    times the beam's direction, plus the optical centre in the world frame."""
    if frame == "leveled":  # Eq. 2's directions, each times its range as it is made
        leveling = leveling_matrix(placement.roll_rad, placement.pitch_rad)
        return rotated_beams(leveling, sensor.rh_deg, sensor.device, beams, ranges)
    points = frame_directions(placement, frame, sensor, dirs_world, beams) * ranges[:, None]
    if frame == "world":
        points += placement.optical_centre
    return points


@scanning
def run_scan(
    backend: RayBackend,
    pose: Pose,
    sensor: SensorConfig,
    frame: str = "leveled",
    z_start: float | None = None,
    progress: Progress | None = None,
    effects: Effects = CLEAR_AIR,
    incidence: bool = False,
    world_seed: int = 0,
) -> ScanResult:
    """One 3D scan from `pose` with `sensor`, through `effects`' medium (none: clear air).
    `incidence`: a paper scan also gives each point's |cos θ| (ScanResult.incidence), from the
    normals of the sweep's own hits (a dataset's physical intensity: no second cast).
    `world_seed`: the seed of the world's surface reflectances (core/intensity.py), which the
    realistic model's detection step weighs (core/realism/lost_returns.py; 0 for a scene of no seed)."""
    sensor.validate()
    check_frame(frame)
    if sensor.realistic:
        from .realism.realistic import check_backend

        check_backend(backend)
    placement = place(backend, pose, z_start)
    check_reach(placement.optical_centre, sensor.max_range, frame, backend.name)
    beam_count = sensor.beam_count
    cast_range = sensor.max_range + NOISE_MARGIN_SIGMAS * sensor.max_noise_sigma
    if sensor.realistic:
        cloud, facts = _realistic_cloud(
            backend, placement, sensor, frame, cast_range, progress, effects, world_seed
        )
    else:
        cloud, facts = _paper_cloud(
            backend, placement, sensor, frame, cast_range, progress, effects, incidence
        )
    untagged = facts.pop("untagged")
    cos_incidence = facts.pop("incidence", None)
    lost_cells = facts.pop("lost_cells", None)
    metadata = {
        "wildscan_version": __version__,
        "pose": pose.to_dict(),
        "z_start": z_start,
        "frame": frame,
        "sensor": sensor.to_dict(),
        "backend": backend.name,
        "placement": placement.to_dict(),
        "beams": int(beam_count),
        **{k: v for k, v in facts.items() if k != "hits"},
        "points": int(len(cloud)),
        "untagged_objects_hit": sorted(untagged),
        "classes": class_table_dict(
            particles=weather_of(effects) is not None,
            logs=any(e.name == "cover" for e in effects.items),
            grounds=carries_ground_materials(cloud.label),
        ),
    }
    if effects:  # clear air says nothing, so scans without effects keep their bytes
        metadata["effects"] = effects.describe()
    return ScanResult(
        cloud=cloud,
        placement=placement,
        metadata=metadata,
        untagged_objects=untagged,
        beams=beam_count,
        hits=facts["hits"],
        incidence=cos_incidence,
        lost_cells=lost_cells,
    )


def device_fields(sensor: SensorConfig) -> dict[str, np.ndarray]:
    """Each beam's `column` and `time` (PointCloud.extra) for a device other than the default;
    none for the default, whose files keep their bytes (its `sweep` is its column). Read-only,
    made once per device and r_h."""
    if sensor.device == DEFAULT_DEVICE:
        return {}
    return dict(_device_fields(sensor.rh_deg, sensor.device))


@functools.lru_cache(maxsize=8)
def _device_fields(rh_deg: float, device) -> tuple[tuple[str, np.ndarray], ...]:
    fields = (("column", beam_columns(rh_deg, device)), ("time", beam_times(rh_deg, device)))
    for _, values in fields:
        values.flags.writeable = False
    return fields


def _paper_cloud(
    backend: RayBackend,
    placement: Placement,
    sensor: SensorConfig,
    frame: str,
    cast_range: float,
    progress,
    effects: Effects,
    incidence: bool = False,
):
    """The paper's scan: one thin ray a beam, its first hit, intensity = reflectivity (with
    `incidence`, the hits' normals asked for and each point's |cos θ| in facts["incidence"])."""
    dirs_sensor, ring, sweep = beam_directions(sensor.rh_deg, sensor.device)
    dirs_world = rotated_beam_directions(placement.rotation, sensor.rh_deg, sensor.device)
    hits = cast_in_chunks(backend, placement.optical_centre, dirs_world, cast_range, progress, incidence)
    surface = hits  # before the medium: the surface along each beam, behind a sward or a particle
    if incidence:
        hits = replace(hits, normal=None)  # the medium need not carry the normals
    hits = effects.medium(Rays(placement.optical_centre, dirs_world, cast_range), hits)

    points = measure_returning(hits, range_noise(sensor, len(dirs_sensor)), sensor)
    beams = points.beams  # the beam of each point
    cloud = PointCloud(
        xyz=_points(placement, frame, sensor, dirs_world, beams, points.range),
        intensity=points.intensity,
        label=points.label,
        instance=points.instance,
        ring=ring.take(beams),
        sweep=sweep.take(beams),
        range=points.range.astype(np.float32),
        frame=frame,
        extra={name: values.take(beams, axis=0) for name, values in device_fields(sensor).items()},
    )
    if weather_of(effects) is not None:
        with_weather_field(cloud)
    facts = {
        "returns": points.hits,
        "water_returns_dropped": int(np.count_nonzero(hits.class_id == WATER_ID)),
        "hits": points.hits,
        "untagged": hits.untagged_objects,
    }
    if incidence:
        facts["incidence"] = _surface_incidence(surface, dirs_world, beams)
    return cloud, facts


def _surface_incidence(surface: RayHits, dirs_world: np.ndarray, beams: np.ndarray) -> np.ndarray:
    """|cos θ| of the surface each of `beams` (a point's beam) meets, 1 where it meets none:
    a point of a sward or a weather particle takes the surface's behind it along its beam, as
    a second cast of the beam through the point would find it."""
    cos = np.abs(dm.dot3(surface.normal.take(beams, axis=0), dirs_world.take(beams, axis=0)))
    return np.where(np.isfinite(surface.distance.take(beams)), cos, 1.0)


def _realistic_cloud(
    backend: RayBackend,
    placement: Placement,
    sensor: SensorConfig,
    frame: str,
    cast_range: float,
    progress,
    effects: Effects,
    world_seed: int = 0,
):
    """The realistic model's scan (core/realistic.py): a point per echo, with its echo fields."""
    from .realism.realistic import realistic_points

    _, ring, sweep = beam_directions(sensor.rh_deg, sensor.device)
    # the beams' world directions are the points' in the world frame only (the others turn
    # the sensor's beams themselves: _points)
    dirs_world = (
        rotated_beam_directions(placement.rotation, sensor.rh_deg, sensor.device)
        if frame == "world"
        else None
    )
    untagged: set[str] = set()

    def cast(origins, dirs, max_range, normals):
        hits = cast_in_chunks(backend, origins, dirs, max_range, progress if normals else None, normals)
        untagged.update(hits.untagged_objects)
        return hits

    threads = backend_threads(backend)  # the echoes formed on the cast's threads (a dataset worker: 1)
    detecting = detecting_of(sensor, effects, world_seed, backend)
    pts = realistic_points(
        cast, placement.optical_centre, placement.rotation, sensor, cast_range, effects, threads, detecting
    )
    cloud = PointCloud(
        xyz=_points(placement, frame, sensor, dirs_world, pts.beam, pts.range),
        intensity=pts.intensity.astype(np.float32),
        label=pts.label.astype(np.uint16),
        instance=np.maximum(pts.instance, 0).astype(np.uint32),
        ring=ring[pts.beam],
        sweep=sweep[pts.beam],
        range=pts.range.astype(np.float32),
        frame=frame,
        extra={
            "echo": pts.echo,
            "echoes": pts.echoes,
            "label_purity": pts.purity.astype(np.float32),
            "mixed": pts.mixed.astype(np.uint8),
            **({"return_type": pts.return_type} if sensor.return_mode == "dual" else {}),
            **{name: values[pts.beam] for name, values in device_fields(sensor).items()},
        },
    )
    if weather_of(effects) is not None:
        with_weather_field(cloud)
    beams_hit = pts.beams_returning
    facts = {
        "returns": int(len(pts.beam)),
        "hits": beams_hit,
        "echoes": pts.stats,
        "untagged": frozenset(untagged),
    }
    if detecting is not None:
        lost = _beams_without_points(pts.lost_beam, pts.beam, sensor.beam_count)
        columns = device_fields(sensor).get("column", sweep)
        facts["lost_cells"] = (ring.take(lost).astype(np.uint16), columns.take(lost).astype(np.uint32))
    return cloud, facts


def _beams_without_points(lost: np.ndarray, kept: np.ndarray, beams: int) -> np.ndarray:
    """The beams of `lost` echoes that kept no echo, sorted, each once (masks, not a sort)."""
    has = np.zeros(beams, dtype=bool)
    has[lost] = True
    has[kept] = False
    return np.flatnonzero(has)


def detecting_of(sensor: SensorConfig, effects: Effects, world_seed: int, backend=None):
    """The detection step of a realistic scan (core/realism/lost_returns.py), or None: a device without
    a [detection] table, or the step turned off (SensorConfig.detection). The objects of the
    backend's geometry that carry `wildscan_reflectance` keep their own (raycast/geometry.py)."""
    from .realism.lost_returns import Detecting, object_reflectances

    table = sensor.device.detection
    if table is None or not sensor.detection:
        return None
    weather = weather_of(effects)
    alpha = 0.0 if weather is None else float(weather.extinction)
    geometry = getattr(backend, "geometry", None)
    own = (
        ()
        if getattr(geometry, "reflectance", None) is None
        else object_reflectances(geometry.class_id, geometry.instance, geometry.reflectance)
    )
    return Detecting(table, int(world_seed), int(sensor.noise_seed), alpha, own)
