"""The Blender-free path (raycast/from_plan.py) equals the Blender path, byte for byte.

Blender path:       build_world(seed, detail) in the bpy wheel -> extract_scene() -> scan
Blender-free path:  plan_geometry(plan_world(seed, detail))     -> the same scan

For four worlds that cover seeds 0-2 and every detail level, the two geometries are the
same arrays bit for bit (vertices, faces, tags, object names, local origin), and scans
from each (embree, the default sensor with its noise) give identical PLY files: the first
valid pose of three zones per world, rotating so every zone is scanned in two of the four
worlds, and one of them also scanned the way `wildscan scan --world` does, cropped while
extracting.
"""

from __future__ import annotations

import hashlib
import inspect
import subprocess
import sys

import numpy as np
import pytest

from wildscan.app.poses import valid_poses
from wildscan.app.scan import scan_current_scene
from wildscan.blender.builder import build_world
from wildscan.blender.scene_io import empty_scene
from wildscan.core.io.ply import write_scan_files
from wildscan.core.placement import Pose
from wildscan.core.sensors import SensorConfig
from wildscan.core.world import ZONES, plan_world
from wildscan.raycast.extract import extract_scene
from wildscan.raycast.from_plan import blender_matrices, blender_order, plan_geometry, world_geometry
from wildscan.raycast.select import make_backend

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

# each seed and each detail level at least once (every pair, nine worlds, took ~100 s)
WORLDS = ((0, "low"), (1, "default"), (2, "high"), (1, "low"))


def geometry_digest(g) -> str:
    h = hashlib.sha256()
    for a in (g.vertices, g.faces, g.class_id, g.instance, g.object_index, g.offset):
        h.update(str(a.dtype).encode() + str(a.shape).encode() + a.tobytes())
    h.update("\n".join(g.object_names).encode())
    return h.hexdigest()


def ply_bytes(result, path) -> bytes:
    ply, _ = write_scan_files(path, result.cloud, dict(result.metadata, seed=0))
    return ply.read_bytes()


@pytest.mark.parametrize("seed, detail", WORLDS)
def test_blender_free_scans_equal_blender_scans_byte_for_byte(seed, detail, tmp_path):
    empty_scene()
    plan = build_world(seed, detail)
    extracted = extract_scene()
    planned = plan_geometry(plan)
    assert geometry_digest(planned) == geometry_digest(extracted)

    turn = 3 * WORLDS.index((seed, detail))
    zones = tuple(ZONES[(turn + k) % len(ZONES)] for k in range(3))
    poses = valid_poses(plan, make_backend("embree", geometry=planned, notify=None), 1, zones)
    assert all(len(found) == 1 for found in poses.values()), poses
    sensor = SensorConfig()
    for zone, found in poses.items():
        for k, p in enumerate(found):
            pose, z_start = Pose(p["x"], p["y"], p["yaw"]), p.get("z_start")
            files = [
                ply_bytes(
                    scan_current_scene(pose, sensor, "leveled", z_start, "embree", notify=None, geometry=g),
                    tmp_path / f"{zone}{k}_{name}.ply",
                )
                for name, g in (("blender", extracted), ("plan", planned))
            ]
            assert files[0] == files[1], (seed, detail, zone, p)
    # `wildscan scan --world`: the crop is made while extracting
    p = poses[zones[0]][0]
    pose = Pose(p["x"], p["y"], p["yaw"])
    cropped = scan_current_scene(pose, sensor, "world", p.get("z_start"), "embree", notify=None)
    free = scan_current_scene(
        pose, sensor, "world", p.get("z_start"), "embree", notify=None, geometry=planned
    )
    assert ply_bytes(cropped, tmp_path / "crop_blender.ply") == ply_bytes(free, tmp_path / "crop_plan.ply")


def test_world_matrices_and_object_order_are_blenders(tmp_path):
    """What the equality rests on, checked directly: every object's matrix_world bit for
    bit (signs of zeros included) and the depsgraph's object order."""
    import bpy

    empty_scene()
    plan = build_world(3, "low")
    ordered = blender_order(plan.elements)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    assert [i.object.original.name for i in depsgraph.object_instances] == [el.name for el in ordered]
    ours = blender_matrices(
        [e.location for e in ordered], [e.yaw for e in ordered], [e.scale for e in ordered]
    )
    for el, matrix in zip(ordered, ours):
        theirs = np.array(bpy.data.objects[el.name].matrix_world, dtype=np.float64)
        assert theirs.tobytes() == matrix.tobytes(), el.name


def test_the_blender_free_path_needs_no_bpy():
    """world_geometry in a Python where bpy, mathutils and bmesh cannot be imported gives
    the geometry the Blender path extracts."""
    code = (
        "import hashlib, sys\n"
        "for m in ('bpy', 'mathutils', 'bmesh'): sys.modules[m] = None\n"
        "from wildscan.raycast.from_plan import world_geometry\n"
        + inspect.getsource(geometry_digest)
        + "print(geometry_digest(world_geometry(4, 'low')))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    empty_scene()
    build_world(4, "low")
    assert out.stdout.strip() == geometry_digest(extract_scene())


def test_world_geometry_is_plan_geometry_of_the_seeds_plan():
    assert geometry_digest(world_geometry(1, "low")) == geometry_digest(plan_geometry(plan_world(1, "low")))


def test_all_elements_moved_at_once_equal_each_moved_alone_bit_for_bit():
    from wildscan.raycast.from_plan import _moved_vertices
    from wildscan.raycast.geometry import world_vertices

    rng = np.random.default_rng(5)
    locals_ = [rng.normal(size=(n, 3)) * 7 for n in (4, 1, 9)]
    matrices = np.zeros((3, 4, 4))
    matrices[:, :3, :] = rng.normal(size=(3, 3, 4)) * 1e3
    matrices[:, 3, 3] = 1.0
    together = _moved_vertices(locals_, matrices, np.array([4, 1, 9]))
    alone = np.concatenate([world_vertices(v, m) for v, m in zip(locals_, matrices)])
    assert together.tobytes() == alone.tobytes()
