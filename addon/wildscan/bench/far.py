"""`wildscan bench --suite far`: how far from the world origin every backend and frame still
meets 1e-4 m (float32 precision far from the origin).

A small scene (a flat terrain quad, one rock box, and one very large single face: a wall
`WALL_LENGTH` long) is built in Blender at each offset along x and y, scanned from one pose
by every backend in every frame with the noise off, and every point as the PLY stores it
(float32) is compared with the exact float64 hit of its beam on the same triangles
(raycast/reference.py, brute force) from the same placement. All vertices are whole metres
and every offset is a whole number below 2^24, so the float32 mesh Blender holds is exactly
the float64 geometry the truth is computed on: what is measured is the ray casting and the
frames, not the scene's own rounding.
"""

from __future__ import annotations

import numpy as np

from ..core.backend import RayBackend

OFFSETS = (0.0, 1e2, 1e3, 2e3, 4e3, 1e4, 1e5, 999_000.0)
QUICK_OFFSETS = (0.0, 1e3, 1e4, 999_000.0)
FRAMES = ("sensor", "leveled", "world")
BACKENDS = ("embree", "bvh", "blender")
TOLERANCE = 1e-4  # m, what every point must meet
EDGE_BAND = 1e-3  # m: beams this close to an edge are counted apart (face choice, not precision)
RH_DEG = 5.0  # 36 2D scans of 1080 beams: enough beams on every surface, quick with scene.ray_cast
POSE_SHIFT = (0.37, 0.61, 30.0)  # pose = offset + this (x, y) and yaw in degrees: off the axes
GROUND_HALF = 40  # m, the terrain quad
WALL_LENGTH = 100  # m, the wall of the range table: one quad
LARGE_FACE = 100_000  # m, the wall of the large-face table: float32 ray tests are at their worst here


def far_scene_parts(
    offset: float, wall_length: int = WALL_LENGTH
) -> list[tuple[str, np.ndarray, np.ndarray, str]]:
    """(name, world vertices, faces, class) of the scene at `offset` (whole metres)."""
    from ..core.world.shapes import primitives

    o = float(offset)
    g = GROUND_HALF
    ground = np.array([[o - g, o - g, 0], [o + g, o - g, 0], [o + g, o + g, 0], [o - g, o + g, 0]], float)
    box_vertices, box_faces = primitives.box((o + 4.0, o + 3.0, 1.0), (2.0, 2.0, 2.0))
    half = wall_length // 2
    wall = np.array(
        [[o - half, o - 7, 0], [o + half, o - 7, 0], [o + half, o - 7, 12], [o - half, o - 7, 12]], float
    )
    quad = np.array([[0, 1, 2, 3]])
    return [
        ("far_ground", ground, quad, "terrain"),
        ("far_rock", np.asarray(box_vertices, float), np.asarray(box_faces), "rock"),
        ("far_wall", wall, quad, "rock"),
    ]


def build_far_scene(offset: float, wall_length: int = WALL_LENGTH) -> None:
    """The scene at `offset` in Blender's current (emptied) scene: object-space vertices
    around 0 and the offset as each object's location, as a user's far-away scene has."""
    from ..blender.mesh import mesh_object, wildscan_collection
    from ..blender.scene_io import empty_scene

    empty_scene()
    shift = np.array([offset, offset, 0.0])
    for name, vertices, faces, cls in far_scene_parts(offset, wall_length):
        obj = mesh_object(name, vertices - shift, faces, wildscan_collection(), cls, 1)
        obj.location = tuple(shift.tolist())


def point_errors(result, geometry, rh_deg: float, frame: str) -> tuple[np.ndarray, np.ndarray]:
    """(N,) distance of each point as stored (float32) from the exact hit of its beam, and
    (N,) whether the beam passes within EDGE_BAND of an edge before its hit (where a float32
    caster may take the other face: the edge leaks tests/test_stability.py counts)."""
    from ..core.sensors import rotated_beam_directions
    from ..core.spatial.frames import from_world
    from ..raycast.reference import reference_hits

    placement, cloud = result.placement, result.cloud
    dirs = rotated_beam_directions(placement.rotation, rh_deg)
    beam = cloud.sweep.astype(np.int64) * 1080 + cloud.ring.astype(np.int64)
    exact = reference_hits(geometry, placement.optical_centre, dirs[beam], 1e3, edge_tol=0.0)["distance"]
    near_edge = reference_hits(geometry, placement.optical_centre, dirs[beam], 1e3, edge_tol=EDGE_BAND)
    edge = near_edge["ambiguous_before"] | ~np.isfinite(near_edge["distance"])
    truth = exact
    with np.errstate(invalid="ignore"):  # a point whose beam the float64 geometry misses: inf
        exact_world = placement.optical_centre + dirs[beam] * truth[:, None]
        exact = from_world(exact_world, frame, placement)
    stored = np.asarray(cloud.xyz, dtype=np.float32).astype(np.float64)
    gap = stored - exact
    return np.sqrt(gap[:, 0] * gap[:, 0] + gap[:, 1] * gap[:, 1] + gap[:, 2] * gap[:, 2]), edge


def expected_points(result, geometry, rh_deg: float, sensor) -> int:
    """How many points the exact float64 hits give from the scan's placement (noise off)."""
    from ..core.sensors import rotated_beam_directions
    from ..raycast.reference import reference_hits

    placement = result.placement
    dirs = rotated_beam_directions(placement.rotation, rh_deg)
    exact = reference_hits(geometry, placement.optical_centre, dirs, 1e3, edge_tol=0.0)["distance"]
    return int(((exact >= sensor.min_range) & (exact <= sensor.max_range)).sum())


class _Unnamed:
    """A backend under another name: core.reach does not know it, so it does not refuse."""

    name = "measured"

    def __init__(self, backend: RayBackend):
        self.cast = backend.cast
        self.capabilities = backend.capabilities


def unchecked_scan(backend: RayBackend, pose, sensor, frame: str):
    """What a refused scan would have written: scanned in the sensor frame by the backend
    under another name, its points then taken to `frame` as run_scan would."""
    from dataclasses import replace

    from ..core.scan import points_in_frame, run_scan

    result = run_scan(_Unnamed(backend), pose, sensor, frame="sensor")
    xyz = points_in_frame(result.cloud.xyz, result.placement, frame)
    result.cloud = replace(result.cloud, xyz=xyz, frame=frame)
    return result


def measure_offset(
    offset: float, backends, frames=FRAMES, rh_deg: float = RH_DEG, wall_length: int = WALL_LENGTH
) -> list[dict]:
    """One row per backend and frame at `offset`: points, max and median error (m)."""
    import bpy

    from ..core.errors import UserError
    from ..core.placement import Pose
    from ..core.scan import run_scan
    from ..core.sensors import SensorConfig
    from ..raycast.blender_backend import BlenderRayCastBackend
    from ..raycast.extract import extract_scene
    from ..raycast.select import make_backend

    build_far_scene(offset, wall_length)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    geometry = extract_scene(depsgraph)
    pose = Pose(offset + POSE_SHIFT[0], offset + POSE_SHIFT[1], POSE_SHIFT[2])
    sensor = SensorConfig(rh_deg=rh_deg, noise_sigma=0.0)
    rows = []
    for name in backends:
        if name == "blender":  # scene.ray_cast itself: what float32 world coordinates do far out
            # (make_backend's blender settles its answers against a fast caster: theirs)
            backend = BlenderRayCastBackend(depsgraph=depsgraph)
        else:
            backend = make_backend(name, depsgraph=depsgraph, geometry=geometry, notify=None)
        for frame in frames:
            refused = None
            try:
                result = run_scan(backend, pose, sensor, frame=frame)
            except UserError as exc:
                refused = str(exc)
                result = unchecked_scan(backend, pose, sensor, frame)
            errors, edge = point_errors(result, geometry, rh_deg, frame)
            clear = errors[~edge]
            expected = expected_points(result, geometry, rh_deg, sensor)
            rows.append(
                {
                    "offset": offset,
                    "backend": name,
                    "frame": frame,
                    "points": len(errors),
                    "max_error": float(clear.max()) if len(clear) else 0.0,
                    "median_error": float(np.median(clear)) if len(clear) else 0.0,
                    "edge_points": int(edge.sum()),
                    "edge_misses": int((errors[edge] > TOLERANCE).sum()),
                    "refused": refused,
                    "missing": expected - len(errors),
                }
            )
    return rows


def bench_far(offsets=OFFSETS, backends=None, say=print) -> list[dict]:
    """The range table (every offset, a 100 m wall) and the large-face table (a 100 km wall
    at the origin); returns every row (`table` says which)."""
    from ..core.checks import one_of
    from ..raycast.select import available_backends

    here = [name for name in available_backends() if name in BACKENDS]
    backends = [one_of(name, "backends", BACKENDS) for name in backends or here]
    rows = []
    for offset in offsets:
        rows += [dict(r, table="range") for r in measure_offset(offset, backends)]
    large = [dict(r, table="large face") for r in measure_offset(0.0, backends, wall_length=LARGE_FACE)]
    say("Largest error of a point clear of edges (mm; x: over 0.1 mm; refused: core.reach refuses that scan)")
    say(far_table(rows, backends))
    say(f"\nOne {LARGE_FACE / 1000:g} km single face at the origin, sensor frame:")
    say(large_face_table([r for r in large if r["frame"] == "sensor"]))
    return rows + large


def far_table(rows: list[dict], backends) -> str:
    """Offset down, backend x frame across: the largest error of a point clear of edges, in mm."""
    from .report import text_table

    columns = [(b, f) for b in backends for f in FRAMES]
    headers = ["offset m"] + [f"{b} {f}" for b, f in columns]
    table = []
    for offset in sorted({r["offset"] for r in rows}):
        cells = [f"{offset:g}"]
        for b, f in columns:
            row = next(
                (r for r in rows if r["offset"] == offset and r["backend"] == b and r["frame"] == f), None
            )
            cells.append("-" if row is None else _cell(row))
        table.append(cells)
    return text_table(headers, table)


def large_face_table(rows: list[dict]) -> str:
    from .report import text_table

    headers = ["backend", "points", "missing", "max error mm", "median mm"]
    table = [
        [
            r["backend"],
            r["points"],
            r["missing"],
            f"{r['max_error'] * 1e3:.4f}",
            f"{r['median_error'] * 1e3:.6f}",
        ]
        for r in rows
    ]
    return text_table(headers, table, right=[False, True, True, True, True])


def _cell(row: dict) -> str:
    """The largest error in mm; `x` over TOLERANCE, `refused` where core.reach refuses the scan."""
    error = row["max_error"]
    mark = " refused" if row["refused"] else (" x" if error > TOLERANCE else "")
    return f"{error * 1e3:.4f}{mark}"
