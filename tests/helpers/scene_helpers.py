"""Helpers for tests that build or inspect Blender scenes (bpy wheel)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
WILDSCAN = str(Path(sys.executable).with_name("wildscan"))
BLENDER = "/usr/bin/blender"


def fresh_scene():
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def world_triangles_by_class() -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """World-space triangles of every evaluated mesh in the scene, grouped by class id."""
    import bpy

    from wildscan.core.classes import class_id_for_tag

    depsgraph = bpy.context.evaluated_depsgraph_get()
    groups: dict[int, list] = {}
    for obj in bpy.context.scene.objects:
        if obj.type != "MESH":
            continue
        ev = obj.evaluated_get(depsgraph)
        mesh = ev.to_mesh()
        mesh.calc_loop_triangles()
        co = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", co)
        tris = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
        m = np.array(ev.matrix_world)
        verts = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
        ev.to_mesh_clear()
        groups.setdefault(class_id_for_tag(obj.get("wildscan_class")), []).append(
            (verts, tris.reshape(-1, 3))
        )
    out = {}
    for cid, parts in groups.items():
        offset, vs, fs = 0, [], []
        for v, f in parts:
            vs.append(v)
            fs.append(f + offset)
            offset += len(v)
        out[cid] = (np.concatenate(vs), np.concatenate(fs))
    return out


def point_triangle_distance(p: np.ndarray, tri: np.ndarray) -> float:
    """Exact (float64) distance from point p to the triangle tri (3,3)."""
    a, b, c = tri
    n = np.cross(b - a, c - a)
    area2 = np.linalg.norm(n)
    if area2 > 0:
        n = n / area2
        q = p - ((p - a) @ n) * n
        # Inside test with barycentric signs on the projected point.
        if all(np.cross(v1 - v0, q - v0) @ n >= 0 for v0, v1 in ((a, b), (b, c), (c, a))):
            return float(abs((p - a) @ n))
    return min(point_segment_distance(p, v0, v1) for v0, v1 in ((a, b), (b, c), (c, a)))


def point_segment_distance(p, a, b) -> float:
    ab = b - a
    t = np.clip(((p - a) @ ab) / max(ab @ ab, 1e-300), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * ab)))


def distance_to_class(points: np.ndarray, labels: np.ndarray, refine_above: float = 1e-4) -> np.ndarray:
    """Distance from each point to the nearest surface of its own class.

    BVHTree.find_nearest works in float32 and is off by up to ~2 mm next to
    long sliver triangles (a 7 m pole facet 5 cm wide), so every distance above
    `refine_above` is recomputed exactly over the triangles near the point.
    """
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    geometry = world_triangles_by_class()
    trees = {
        cid: BVHTree.FromPolygons([tuple(v) for v in verts], [tuple(f) for f in faces])
        for cid, (verts, faces) in geometry.items()
    }
    dist = np.full(len(points), np.inf)
    for cid in np.unique(labels):
        tree = trees.get(int(cid))
        if tree is None:
            continue
        verts, faces = geometry[int(cid)]
        idx = np.flatnonzero(labels == cid)
        dist[idx] = [tree.find_nearest(Vector(points[i]))[3] for i in idx]
        for i in idx[dist[idx] > refine_above]:
            near = tree.find_nearest_range(Vector(points[i]), dist[i] + 0.01)
            dist[i] = min(point_triangle_distance(points[i], verts[faces[k]]) for _, _, k, _ in near)
    return dist


def run(cmd: list[str], timeout: float = 300, **kw) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=REPO, **kw)


def blender_scan(
    args: list[str], blend: str | None = None, timeout: float = 300
) -> subprocess.CompletedProcess:
    cmd = (
        [BLENDER, "-b"]
        + ([blend] if blend else [])
        + ["--factory-startup", "-P", "blender_scripts/scan.py", "--", *args]
    )
    return run(cmd, timeout)


def user_error_line(proc: subprocess.CompletedProcess) -> str:
    """The one stderr line a user mistake must produce (Blender's own chatter is on stdout)."""
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, f"expected one line on stderr, got: {proc.stderr!r}"
    assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout
    return lines[0]


# the paper layout: the tests that read the paper island's zones and poses say so
PAPER = ("--layout", "paper")


def save_seed_2_low(directory: Path) -> Path:
    """The world of seed 2 at low detail saved by the wheel as w.blend (+ w.json) and w.npz."""
    from tests.helpers.processes import finished

    for cmd in (["world", "--out", "w.blend"], ["extract", "--out", "w.npz"]):
        what = f"`wildscan {cmd[0]}` of seed 2 (low detail) for the tests' worlds"
        finished(
            [WILDSCAN, *cmd, *PAPER, "--seed", "2", "--detail", "low", "--quiet"], what, 600, cwd=directory
        )
    return directory


# Where the add-on tests look for a valid pose of the seed-5 world (test_addon.py, and
# test_extension.py inside Blender 5), in order: the first one placement accepts is used.
CANDIDATE_XY = [
    (0.0, 0.0),
    (2.0, 1.0),
    (-3.0, 2.0),
    (4.0, -4.0),
    (-5.0, -5.0),
    (6.0, 3.0),
    (1.0, 7.0),
    (-8.0, 6.0),
]
