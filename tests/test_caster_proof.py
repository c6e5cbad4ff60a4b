"""Every caster is proven on a tiny known scene before it is used (raycast/proof.py), and the
order casters are tried in inside Blender (raycast/select.py): issue 31."""

import sys

import numpy as np
import pytest

from wildscan.core.placement import Pose, place
from wildscan.raycast import proof, select
from wildscan.raycast.embree_backend import EmbreeBackend
from wildscan.raycast.geometry import from_triangles

from tests.helpers.open3d_stub import debian_open3d


@pytest.fixture(autouse=True)
def fresh_proofs():
    """Each test proves its casters itself, and leaves no proof of a stand-in behind."""
    proof.forget_proofs()
    yield
    proof.forget_proofs()


def ground(half: float = 20.0):
    """A flat 40 m square of terrain at z = 0, two triangles."""
    a, b, c, d = (-half, -half, 0), (half, -half, 0), (half, half, 0), (-half, half, 0)
    return from_triangles([(a, b, c), (a, c, d)], class_id=1, instance=1)


def test_every_caster_here_passes_its_proof_and_leaves_no_blender_data_behind():
    import bpy

    before = {kind: len(getattr(bpy.data, kind)) for kind in ("scenes", "objects", "meshes")}
    scene = bpy.context.scene
    for name in select.FALLBACK_ORDER:
        assert select.refusal(name) is None, name
    assert select.available_backends() == list(select.FALLBACK_ORDER)
    assert {kind: len(getattr(bpy.data, kind)) for kind in before} == before
    assert bpy.context.scene == scene


def test_the_known_scene_answers_are_what_the_float64_geometry_says():
    # The expected answers are computed by hand in proof.py; a float64 ray-triangle test over
    # the same triangles must agree, or the proof itself would be wrong.
    scene = proof.known_scene()
    for ray in scene.rays:
        o = np.array(ray.origin) + proof.CENTRE
        d = np.array(ray.direction)
        best, cls = np.inf, 0
        for tri, c in zip(scene.triangles, scene.class_id):
            t = _moller_trumbore(o, d, tri)
            if t is not None and t <= ray.max_range and t < best:
                best, cls = t, int(c)
        assert best == pytest.approx(ray.distance, abs=1e-12) or (np.isinf(best) and np.isinf(ray.distance))
        assert cls == ray.class_id, ray.what


def _moller_trumbore(o, d, tri, eps=1e-12):
    a, b, c = tri
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = e1 @ p
    if abs(det) < eps:
        return None
    s = o - a
    u = (s @ p) / det
    q = np.cross(s, e1)
    v = (d @ q) / det
    t = (e2 @ q) / det
    if u < -eps or v < -eps or u + v > 1 + eps or t < 0:
        return None
    return t


def test_debians_open3d_is_refused_in_one_line_and_the_fallback_moves_on(monkeypatch):
    # The stand-in misses every ray, as Debian's python3-open3d 0.16.1 does.
    monkeypatch.setitem(sys.modules, "embreex", None)
    monkeypatch.setitem(sys.modules, "open3d", debian_open3d("0.16.1"))
    for asked in ("auto", "open3d"):
        proof.forget_proofs()
        lines = []
        backend = select.make_backend(asked, geometry=ground(), notify=lines.append)
        assert backend.name == "bvh"
        refused = [ln for ln in lines if "'open3d'" in ln]
        assert len(refused) == 1, lines
        line = refused[0]
        assert "Open3D 0.16.1" in line and "failed its proof" in line and "\n" not in line
        assert "a ray straight down onto a vertex four triangles share missed" in line
        # ... and the placement's downward lasers find the ground through what was picked
        placement = place(backend, Pose(1.0, 2.0, 30.0), None)
        assert placement.optical_centre[2] > 0
    assert select.available_backends() == ["bvh", "blender"]


class _Wrong:
    """A real caster over the known scene whose answers are spoiled by `spoil(hits)`."""

    name = "spoilt"
    capabilities = frozenset()

    def __init__(self, scene, spoil):
        self.inner = EmbreeBackend(proof.known_geometry(scene))
        self.spoil = spoil

    def cast(self, origins, directions, max_range):
        hits = self.inner.cast(origins, directions, max_range)
        self.spoil(hits)
        return hits


def _farther(hits):
    hits.distance += 0.01


def _other_class(hits):
    hits.class_id[np.isfinite(hits.distance)] = 5


def _leaks_at_shared_vertices(hits):
    hits.distance[0] = np.inf  # the first ray: straight down onto a vertex four triangles share
    hits.class_id[0] = -1


@pytest.mark.parametrize(
    "spoil, said",
    [
        (_farther, "straight down onto a vertex four triangles share hit class 1 instance 1 at 10.01 m"),
        (_other_class, "hit class 5 instance 1 at 10 m (expected terrain at 10 m)"),
        (_leaks_at_shared_vertices, "straight down onto a vertex four triangles share missed"),
    ],
    ids=["a centimetre off", "another class", "a leak"],
)
def test_a_caster_that_answers_wrongly_is_refused_saying_what_it_got_wrong(spoil, said):
    failure = proof.proof_failure("spoilt", lambda scene: _Wrong(scene, spoil))
    assert failure is not None and said in failure


def test_a_caster_that_raises_on_the_known_scene_is_refused_with_what_it_raised():
    def broken(scene):
        raise RuntimeError("embree error: 3 invalid argument\nmore")

    assert proof.proof_failure("broken", broken) == "it raised RuntimeError: embree error: 3 invalid argument"


def test_a_caster_is_proven_once_per_process():
    built = []

    def build(scene):
        built.append(1)
        return EmbreeBackend(proof.known_geometry(scene))

    assert proof.proof_failure("counted", build) is None
    assert proof.proof_failure("counted", build) is None
    assert len(built) == 1


def test_inside_blender_an_optional_caster_of_an_untested_version_comes_after_the_bvh(monkeypatch):
    assert select.candidates("auto") == select.FALLBACK_ORDER  # the wheel: not inside Blender
    monkeypatch.setattr(select, "inside_blender", lambda: True)
    assert select.candidates("auto") == select.FALLBACK_ORDER  # embreex 4.4 and Open3D 0.20: covered
    monkeypatch.setitem(sys.modules, "open3d", debian_open3d("0.16.1"))
    assert select.candidates("auto") == ("embree", "bvh", "open3d", "blender")
    monkeypatch.setattr(select, "COVERED_VERSIONS", {})
    assert select.candidates("auto") == ("bvh", "embree", "open3d", "blender")
    # asked by name, a caster is tried first whatever its version (and proven)
    assert select.candidates("open3d") == ("open3d", "bvh", "blender")


def test_inside_means_a_blender_executable_not_the_bpy_wheel():
    import bpy

    assert bpy.app.binary_path == "" and not select.inside_blender()


class _MissesEverything:
    """A caster that misses every ray (as Debian's Open3D did), counting its casts."""

    name = "misses"
    capabilities = frozenset()

    def __init__(self, limit: int):
        self.casts, self.limit = 0, limit

    def cast(self, origins, directions, max_range):
        from wildscan.core.hits import RayHits

        self.casts += 1
        assert self.casts <= self.limit, "valid_poses kept on trying (it hung `wildscan world`)"
        return RayHits.empty(len(np.asarray(directions).reshape(-1, 3)))


def test_valid_poses_ends_when_placement_rejects_every_candidate():
    from wildscan.app.poses import CANDIDATES_PER_POSE, valid_poses
    from wildscan.core.world import ZONES, plan_world

    plan = plan_world(2, "low")
    zones = ZONES[:2]
    # each rejected candidate costs the placement a cast or two; every zone gets its budget
    caster = _MissesEverything(limit=3 * len(zones) * (CANDIDATES_PER_POSE + len(plan.sites)))
    poses = valid_poses(plan, caster, 1, zones)
    assert poses == {zone: [] for zone in zones}
    assert caster.casts >= len(zones) * CANDIDATES_PER_POSE  # each zone did look
