"""Stability of the ray backends where ray casting usually breaks.

Rays aimed exactly at mesh vertices and shared edges, grazing rays, a sensor right
beside a thin wire and a pole, a pose on a steep slope, and a world moved 10 km
from the origin. Every backend is measured; where one fails, the test records the
measured count (so a change in it is noticed) and asserts the default backend
(`auto`, i.e. sealed Embree) has none. "raw" variants are Embree/BVHTree without
sealed edges (padding.pad_triangles): they show why sealing is on.

Ground truth is the float64 geometry as Blender stores it (test_backends.world_geometry)
judged by brute force (reference.check_hits).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from wildscan.core.hits import RayHits
from wildscan.core.sensors import beam_directions
from wildscan.raycast.bvh_backend import BVHBackend
from wildscan.raycast.embree_backend import EmbreeBackend
from wildscan.raycast.extract import extract_scene
from wildscan.raycast.reference import check_hits, reference_hits
from wildscan.raycast.select import resolve_backend

from tests.helpers.backend_scenes import (
    add_mesh,
    box_mesh,
    cylinder_mesh,
    empty_scene,
    grid_mesh,
    make_all,
    random_dirs,
    unit,
    uv_sphere,
    world_geometry,
)

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

RANGE_TOL = 1e-4
DEFAULT = resolve_backend("auto", notify=None)


def all_variants(geometry) -> dict:
    """The backends as users get them, plus the unsealed ones and scene.ray_cast unsettled."""
    out = with_raw_blender(make_all(geometry=geometry))
    out["embree raw robust"] = EmbreeBackend(geometry, robust=True, seal=False)
    out["embree raw fast"] = EmbreeBackend(geometry, robust=False, seal=False)
    out["bvh raw"] = BVHBackend(geometry, seal=False)
    return out


def with_raw_blender(backends: dict) -> dict:
    """`backends` plus "blender raw": scene.ray_cast's own float32 answers, which `blender` (as
    users get it, raycast/settled_blender.py) settles in float64."""
    from wildscan.raycast.blender_backend import BlenderRayCastBackend

    return dict(backends, **{"blender raw": BlenderRayCastBackend()})


# -- rays aimed exactly at vertices and shared edges ------------------------------------------

# Leaks measured on this machine (bpy 5.0.1 wheel, embreex 4.4) for the rays below: a
# change means a backend's robustness changed; update with care.
KNOWN_LEAKS = {"blender": 0, "blender raw": 19, "bvh": 0, "embree": 0, "open3d": 0}
LEAKY_RAW = ("embree raw fast", "embree raw robust", "bvh raw", "blender raw")


def _terrain_heights(x, y):
    """Gently tilted, irregular: every ray below descends faster than the surface."""
    return 0.05 * x + 0.02 * np.sin(3.1 * x + 1.3) * np.cos(2.3 * y)


def _leak_scene():
    empty_scene()
    terrain = add_mesh("terrain", *grid_mesh(60, 60, 30.0, 30.0, _terrain_heights), "terrain", 1)
    sphere = add_mesh("ball", *uv_sphere(1.0, 16, 32), "rock", 2, location=(6.0, 20.0, 1.5))
    return world_geometry([terrain, sphere])


def _aimed_rays(truth):
    """(origins, dirs, expected distance): rays aimed at terrain vertices, at points on
    shared terrain edges, and at the ball's front-facing vertices."""
    rng = np.random.default_rng(5)
    terrain = truth.faces[truth.instance == 1]
    verts = truth.vertices
    used = np.unique(terrain)
    inner = used[(np.abs(verts[used, 0]) < 14.6) & (np.abs(verts[used, 1]) < 14.6)]
    edges = np.sort(np.concatenate([terrain[:, [0, 1]], terrain[:, [1, 2]], terrain[:, [2, 0]]]), axis=1)
    edges, uses = np.unique(edges, axis=0, return_counts=True)
    edges = edges[uses == 2]  # shared edges only: a ray through a border edge may miss
    frac = rng.random(len(edges))[:, None]
    on_edges = verts[edges[:, 0]] * (1 - frac) + verts[edges[:, 1]] * frac
    targets = np.concatenate([verts[inner], on_edges])
    origins, dirs, dist = [], [], []
    for o in ((0.3, 0.2, 1.7), (5.0, -3.0, 2.8), (-9.0, 1.0, 3.5)):
        d = targets - o
        r = np.linalg.norm(d, axis=1)
        d /= r[:, None]
        keep = (r < 25.0) & (-d[:, 2] > 0.3)  # descends much faster than the terrain rises
        origins.append(np.tile(o, (keep.sum(), 1)))
        dirs.append(d[keep])
        dist.append(r[keep])
    ball = np.flatnonzero(truth.instance == 2)
    bv = np.unique(truth.faces[ball])
    centre = verts[bv].mean(axis=0)
    o = np.array([0.0, 15.0, 2.0])
    d = verts[bv] - o
    r = np.linalg.norm(d, axis=1)
    d /= r[:, None]
    front = np.einsum("ij,ij->i", unit(verts[bv] - centre), -d) > 0.3
    origins.append(np.tile(o, (front.sum(), 1)))
    dirs.append(d[front])
    dist.append(r[front])
    return np.concatenate(origins), np.concatenate(dirs), np.concatenate(dist)


@pytest.fixture(scope="module")
def leak_counts():
    truth = _leak_scene()
    origins, dirs, dist = _aimed_rays(truth)
    counts = {}
    for name, backend in all_variants(extract_scene()).items():
        hits = backend.cast(origins, dirs, 40.0)
        leaked = ~hits.hit | (np.abs(hits.distance - dist) > RANGE_TOL)
        counts[name] = int(leaked.sum())
    print("\nleaks per backend over", len(dirs), "aimed rays:", counts)
    return counts, len(dirs)


def test_the_default_backend_never_leaks_through_vertices_or_edges(leak_counts):
    counts, rays = leak_counts
    assert rays > 3000
    assert counts[DEFAULT] == 0


def test_leaks_are_recorded_per_backend(leak_counts):
    counts, _ = leak_counts
    for name, known in KNOWN_LEAKS.items():
        assert counts[name] == known, f"{name} now leaks {counts[name]} times (recorded {known})"
    # without sealed edges Embree and BVHTree do leak: the reason sealing is on
    for name in LEAKY_RAW:
        assert counts[name] > 0, name


def test_check_hits_catches_leaks():
    """The judge used below must see a leak when there is one."""
    truth = _leak_scene()
    origins, dirs, dist = _aimed_rays(truth)
    raw = EmbreeBackend(truth, robust=False, seal=False).cast(origins, dirs, 40.0)
    leaked = ~raw.hit | (np.abs(raw.distance - dist) > RANGE_TOL)
    some = np.flatnonzero(leaked)[::4]
    fine = np.flatnonzero(~leaked)[::20]
    for rays, want in ((some, False), (fine, True)):
        hits = RayHits(raw.distance[rays], raw.class_id[rays], raw.instance[rays])
        ok = check_hits(truth, origins[rays], dirs[rays], 40.0, hits)
        assert len(rays) > 100 and (ok == want).all()


# -- grazing rays ----------------------------------------------------------------------------


def test_grazing_rays_on_a_plane_and_a_terrain_grid():
    empty_scene()
    plane = add_mesh(
        "plane",
        [(-60, -60, 0), (60, -60, 0), (60, 60, 0), (-60, 60, 0)],
        [(0, 1, 2), (0, 2, 3)],
        "terrain",
        1,
    )
    truth = world_geometry([plane])
    height = 0.25
    rng = np.random.default_rng(11)
    elevation = np.radians(rng.uniform(0.5, 3.0, 4000))  # hits 4.8 m to 28.6 m away
    azimuth = rng.uniform(0, 2 * math.pi, 4000)
    dirs = np.stack(
        [np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), -np.sin(elevation)], 1
    )
    origin = np.array([0.37, -0.21, height])
    exact = height / np.sin(elevation)  # the analytic plane: it is exactly these two triangles
    errors = {}
    for name, backend in all_variants(extract_scene()).items():
        hits = backend.cast(origin, dirs, 30.0)
        assert hits.hit.all(), name
        errors[name] = float(np.abs(hits.distance - exact).max())
        assert check_hits(truth, origin, dirs, 30.0, hits).all(), name
    print("\nmax grazing range error per backend (m):", errors)
    for name in ("bvh", "embree", "embree raw robust", "bvh raw"):  # float64-refined ranges
        assert errors[name] <= 1e-9, name
    assert errors["blender"] <= 1e-9  # settled, float64-refined
    assert errors["blender raw"] <= RANGE_TOL  # float32 hits, yet within tolerance at these ranges


def test_grazing_rays_along_a_triangulated_slope():
    empty_scene()
    terrain = add_mesh(
        "terrain", *grid_mesh(20, 20, 40.0, 40.0, lambda x, y: 0.03 * x - 0.02 * y), "terrain", 1
    )
    truth = world_geometry([terrain])
    rng = np.random.default_rng(12)
    # rays that skim the slope at 0.3 to 2 degrees above its surface
    normal = unit(np.array([-0.03, 0.02, 1.0]))
    along = unit(rng.normal(size=(3000, 3)) * [1, 1, 0])
    along = unit(along - (along @ normal)[:, None] * normal)
    angle = np.radians(rng.uniform(0.3, 2.0, 3000))
    dirs = unit(along * np.cos(angle)[:, None] - normal * np.sin(angle)[:, None])
    origin = np.array([0.1, 0.2, 0.0]) + 0.12 * normal
    failures = {}
    for name, backend in all_variants(extract_scene()).items():
        hits = backend.cast(origin, dirs, 30.0)
        failures[name] = int((~check_hits(truth, origin, dirs, 30.0, hits)).sum())
    print("\nwrong grazing rays on a triangulated slope:", failures)
    assert failures[DEFAULT] == 0 and failures["bvh"] == 0
    assert failures["blender"] == 0 and failures["blender raw"] == 0


# -- a sensor right beside a thin wire and a pole ------------------------------------------------


def _wire_and_pole_scene():
    empty_scene()
    v, f = cylinder_mesh(0.006, 10.0, 8)  # a 6 mm wire, 10 m long, along x
    wire = add_mesh("wire", v, f, "wire", 1, location=(-5.0, 0.4, 2.0), rotation=(0, math.pi / 2, 0))
    v, f = cylinder_mesh(0.05, 4.0, 12)
    pole = add_mesh("pole", v, f, "pole", 2, location=(0.6, -0.3, 0.0))
    ground = add_mesh("ground", *grid_mesh(10, 10, 20.0, 20.0), "terrain", 3)
    return world_geometry([wire, pole, ground])


def _rays_across_wire_and_pole(origin):
    """Rays swept densely across the wire (at angles from square-on to 8 deg) and the pole."""
    targets = []
    for x in np.linspace(-4.5, 4.5, 181):
        for dz in np.linspace(-0.009, 0.009, 25):
            targets.append((x, 0.4, 2.0 + dz))
    for z in np.linspace(0.2, 3.8, 73):
        for du in np.linspace(-0.07, 0.07, 29):
            targets.append((0.6 + du * 0.6, -0.3 + du * 0.8, z))
    return unit(np.array(targets) - origin)


# scene.ray_cast and BVHTree intersect in float32: on the wire's long thin facets
# (10 m x 2.3 mm) scene.ray_cast's own distances are off by up to 2.4 cm (277 rays
# before the blender backend recomputed distances against the hit face in float64),
# and the raw BVHTree once picks the facet behind (0.66 mm further). Every backend
# now reports float64 plane distances, so only the choice of facet matters.
KNOWN_WIRE_FAILURES = {"blender": 0, "blender raw": 0, "bvh": 0, "embree": 0, "bvh raw": 1}


def test_thin_wire_and_pole_beside_the_sensor():
    truth = _wire_and_pole_scene()
    origin = np.array([0.0, 0.0, 1.6])
    dirs = _rays_across_wire_and_pole(origin)
    failures, wire_hits = {}, {}
    for name, backend in all_variants(extract_scene()).items():
        hits = backend.cast(origin, dirs, 15.0)
        failures[name] = int((~check_hits(truth, origin, dirs, 15.0, hits)).sum())
        wire_hits[name] = int((hits.instance == 1).sum())
    print("\nwrong rays beside wire and pole:", failures, "wire hits:", wire_hits)
    assert failures[DEFAULT] == 0
    for name, known in KNOWN_WIRE_FAILURES.items():
        assert failures[name] == known, f"{name}: {failures[name]} wrong rays (recorded {known})"
    ref = reference_hits(truth, origin, dirs, 15.0)
    sure_wire = np.count_nonzero(truth.instance[ref["triangle"][ref["triangle"] >= 0]] == 1)
    assert wire_hits[DEFAULT] >= sure_wire > 1000


# -- a pose on a steep slope -------------------------------------------------------------------


def test_scan_from_a_steep_slope():
    empty_scene()
    slope = math.radians(35.0)
    heights = lambda x, y: math.tan(slope) * x + 0.15 * np.sin(0.9 * x) * np.sin(1.3 * y)  # noqa: E731
    terrain = add_mesh("slope", *grid_mesh(16, 16, 30.0, 30.0, heights), "terrain", 1)
    rock = add_mesh(
        "rock", *box_mesh(1.0, 1.0, 1.0), "rock", 2, location=(3.0, 2.0, math.tan(slope) * 3.0 + 0.3)
    )
    truth = world_geometry([terrain, rock])
    # the sensor stands on the slope, tilted with it
    origin = np.array([0.0, 0.0, 1.2])
    dirs = beam_directions(10.0)[0]
    tilt = np.array(
        [[math.cos(slope), 0, -math.sin(slope)], [0, 1, 0], [math.sin(slope), 0, math.cos(slope)]]
    )
    dirs = dirs @ tilt.T
    failures, labels = {}, {}
    for name, backend in make_all().items():
        hits = backend.cast(origin, dirs, 15.0)
        failures[name] = int((~check_hits(truth, origin, dirs, 15.0, hits)).sum())
        labels[name] = hits.class_id * 1000 + hits.instance
    print("\nwrong rays on a 35 deg slope:", failures)
    assert failures[DEFAULT] == 0 and failures["bvh"] == 0 and failures["blender"] == 0
    for name in ("bvh", "embree", "open3d"):
        assert (labels[name] == labels["blender"]).mean() >= 0.9999


# -- a world moved 10 km from the origin ----------------------------------------------------------

SHIFT = np.array([10_000.0, -10_000.0, 30.0])
# scene.ray_cast in this small world, measured: wrong rays (5 mm range tolerance).
# Its float32 distances were off by 0.3 mm near the origin and 1.5 mm at 10 km, where
# float32 spacing is ~1 mm; the blender backend now recomputes them in float64 against
# the hit face, so what remains is the hit itself: at 10 km one ray that clearly hits
# the wire misses it.
BLENDER_WRONG_AT = {"here": 0, "10 km": 1}


def _small_world(shift):
    empty_scene()
    objects = [
        add_mesh(
            "ground",
            *grid_mesh(20, 20, 40.0, 40.0, lambda x, y: 0.1 * np.sin(x / 3) * np.cos(y / 4)),
            "terrain",
            1,
            location=shift,
        ),
        add_mesh(
            "box",
            *box_mesh(1.0, 2.0, 1.5),
            "rock",
            2,
            location=shift + [4.0, 1.0, 0.75],
            rotation=(0, 0, 0.4),
        ),
        add_mesh("ball", *uv_sphere(0.8, 12, 24), "bush", 3, location=shift + [-3.0, 4.0, 0.8]),
        add_mesh(
            "wire",
            *cylinder_mesh(0.006, 10.0, 8),
            "wire",
            4,
            location=shift + [-5.0, -1.0, 2.2],
            rotation=(0, math.pi / 2, 0),
        ),
    ]
    return world_geometry(objects)


def test_a_world_moved_10_km_scans_like_the_original():
    dirs = random_dirs(4000, "10 km")
    origin = np.array([0.25, -0.4, 1.6])
    results = {}
    for label, shift in (("here", np.zeros(3)), ("10 km", SHIFT)):
        truth = _small_world(shift)
        results[label] = {}
        for name, backend in with_raw_blender(make_all()).items():
            hits = backend.cast(origin + shift, dirs, 15.0)
            ok = check_hits(truth, origin + shift, dirs, 15.0, hits, range_tol=5e-3)
            ref = reference_hits(truth, origin + shift, dirs, 15.0)
            sure = np.isfinite(ref["distance"]) & ~ref["ambiguous_before"] & hits.hit
            err = float(np.abs(hits.distance[sure] - ref["distance"][sure]).max())
            results[label][name] = (int((~ok).sum()), err, hits)
    print(
        "\n(wrong rays, max range error m):",
        {k: {n: v[:2] for n, v in r.items()} for k, r in results.items()},
    )
    for name in ("bvh", "embree", "open3d"):
        for label in ("here", "10 km"):
            wrong, err, _ = results[label][name]
            assert wrong == 0 and err <= RANGE_TOL, (name, label)
        a, b = results["here"][name][2], results["10 km"][name][2]
        assert np.array_equal(a.class_id, b.class_id) and np.array_equal(a.instance, b.instance)
        assert np.abs(a.distance[a.hit] - b.distance[b.hit]).max() <= RANGE_TOL
    for label, known_wrong in BLENDER_WRONG_AT.items():
        assert results[label]["blender"][0] == 0, label  # settled in float64
        wrong, err, _ = results[label]["blender raw"]
        assert wrong == known_wrong and err <= RANGE_TOL, (label, wrong, err)
