"""`--backend blender` gives the fast casters' bytes on a ground-cover scan at r_h = 1 (issue 31,
raycast/settled_blender.py). Blender's scene.ray_cast casts in float32 world coordinates, so a
ray passing micrometres from a leaf's edge far from the origin is a coin toss for it; the
settled casters decide it in float64. The sward medium draws its depths in ray order, so one
such ray used to move the stops of every later beam in its part of the scan."""

import numpy as np
import pytest

from wildscan.app.scan import scan_effects
from wildscan.core.placement import Pose, place
from wildscan.core.scan import NOISE_MARGIN_SIGMAS, run_scan
from wildscan.core.sensors import SensorConfig, rotated_beam_directions
from wildscan.core.world.cover import CoverGrid
from wildscan.raycast.blender_backend import BlenderRayCastBackend
from wildscan.raycast.extract import extract_scene
from wildscan.raycast.select import make_backend

from tests.helpers.scene_helpers import fresh_scene

pytestmark = pytest.mark.slow  # three r_h = 1 scans through scene.ray_cast: tens of seconds

CORNER = np.array([1000.0, -1000.0, 0.0])  # the scene's object origin: float32-exact, far out
HALF = 20.0  # m: half the side of the square of ground
POSE = Pose(1020.2513, -979.4987, 30.0)  # its middle, where float32 rounds the sensor a few um off
SENSOR = SensorConfig(rh_deg=1.0, noise_sigma=0.0)
GRASS, GRASS_HEIGHT = 8, 0.3  # low grass, m
LEAVES = 48  # beams given a leaf whose edge they pass 2e-7 m inside or outside of
EDGE_GAP = 5e-6  # m: past float32 rounding of the leaves (1e-6 m), within the sensor's (3e-5 m)
LEAF_AT = 0.8  # m along the beam (the optical centre is 0.723 m above the ground)


def add_object(name: str, world_triangles: np.ndarray, tag: str, instance: int):
    """A tagged mesh at CORNER whose vertices are the triangles' float64 corners less CORNER
    (small local coordinates: float32 keeps them to ~1e-6 m)."""
    import bpy

    local = (np.asarray(world_triangles, dtype=np.float64).reshape(-1, 3) - CORNER).tolist()
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(local, [], [(k, k + 1, k + 2) for k in range(0, len(local), 3)])
    obj = bpy.data.objects.new(name, mesh)
    obj.location = CORNER.tolist()
    obj["wildscan_class"], obj["wildscan_instance"] = tag, instance
    bpy.context.scene.collection.objects.link(obj)


def leaf_across(point, direction, inside: bool) -> np.ndarray:
    """A 4 mm leaf square to the beam whose nearest edge passes EDGE_GAP from `point` (the beam
    enters it just inside that edge, or passes just beside it)."""
    u = np.cross(direction, (0.0, 0.0, 1.0))
    u /= np.linalg.norm(u)
    w = np.cross(direction, u)
    edge = point - (EDGE_GAP if inside else -EDGE_GAP) * u
    return np.array([edge - 0.002 * w, edge + 0.002 * w, edge + 0.004 * u])


@pytest.fixture(scope="module")
def scene():
    fresh_scene()
    c = CORNER + (HALF, HALF, 0.0)
    a, b, d, e = (c + (sx * HALF, sy * HALF, 0.0) for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)))
    add_object("ground", np.array([a, b, d, a, d, e]), "terrain", 1)
    # the beams the leaves go across: downward ones of the first sweeps, well above the sward
    probe = make_backend("embree", geometry=extract_scene(), notify=None)
    placement = place(probe, POSE)
    centre = placement.optical_centre
    dirs = rotated_beam_directions(placement.rotation, SENSOR.rh_deg, SENSOR.device)
    high = np.flatnonzero(centre[2] + LEAF_AT * dirs[:, 2] > 1.5 * GRASS_HEIGHT)
    down = high[dirs[high, 2] < -0.15]  # on to the ground within 5 m, through the sward
    # one beam a 2D scan (1 deg apart: 1.4 cm at LEAF_AT, the leaves 4 mm), in the first part
    beams = np.array([down[down // 1080 == m][0] for m in range(LEAVES)])
    at = centre + LEAF_AT * dirs[beams]
    leaves = [leaf_across(at[i], dirs[k], i % 2 == 0) for i, k in enumerate(beams.tolist())]
    add_object("leaves", np.array(leaves), "treetop", 2)
    cover = CoverGrid(
        CORNER[0],
        CORNER[1],
        1.0,
        np.full((40, 40), GRASS, dtype=np.uint8),
        np.full((40, 40), GRASS_HEIGHT, dtype=np.float32),
        CORNER[0] + np.arange(41.0),
        CORNER[1] + np.arange(41.0),
        np.zeros((41, 41)),
    )
    return placement, dirs, beams, cover


def scan_bytes(backend, cover) -> bytes:
    result = run_scan(backend, POSE, SENSOR, "world", None, None, scan_effects(None, SENSOR, cover))
    cloud = result.cloud
    return b"".join(a.tobytes() for a in (cloud.xyz, cloud.label, cloud.instance, cloud.range, cloud.sweep))


def test_scene_ray_cast_gives_the_settled_casters_bytes_on_a_ground_cover_scan(scene):
    placement, dirs, beams, cover = scene
    geometry = extract_scene()
    embree = make_backend("embree", geometry=geometry, notify=None)
    bvh = make_backend("bvh", geometry=geometry, notify=None)
    blender = make_backend("blender", geometry=geometry, notify=None)
    # the premise: scene.ray_cast's own float32 answers differ for some of these beams
    cast_range = SENSOR.max_range + NOISE_MARGIN_SIGMAS * SENSOR.max_noise_sigma
    raw = BlenderRayCastBackend().cast(placement.optical_centre, dirs[beams], cast_range)
    fast = embree.cast(placement.optical_centre, dirs[beams], cast_range)
    assert (raw.class_id != fast.class_id).sum() >= 2, "no leaf edge made scene.ray_cast toss a coin"
    assert (fast.class_id == 3).sum() == LEAVES // 2  # the settled casters: hit inside, pass beside
    expected = scan_bytes(embree, cover)
    assert scan_bytes(bvh, cover) == expected
    assert scan_bytes(blender, cover) == expected
    assert blender.disputed >= 2  # ... settled in float64
