"""The realistic sensor model in the porous forest (Blender-free plan geometry): trunks behind
crowns along one beam, multi-echo beams, every unflagged point on an element of its class,
and the porosity figures in their ranges."""

import numpy as np
import pytest

from wildscan.app.poses import plan_backend, valid_poses
from wildscan.app.scan import make_scene_backend
from wildscan.bench.porosity import crown_gap_fractions, sky_fraction
from wildscan.bench.realism import CROWN_TARGET, SKY_TARGET, trunk_behind_crown
from wildscan.core.classes import class_by_name
from wildscan.core.placement import Pose
from wildscan.core.scan import run_scan
from wildscan.core.sensor import SensorConfig
from wildscan.core.world import plan_world
from wildscan.raycast.from_plan import plan_geometry

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

SEED = 0


@pytest.fixture(scope="module")
def forest():
    plan = plan_world(SEED, "default")
    geometry = plan_geometry(plan)
    (p,) = valid_poses(plan, plan_backend(plan), 1, ("forest",))["forest"]
    return plan, geometry, Pose(p["x"], p["y"], p["yaw"])


def scan(forest, **kw):
    _, geometry, pose = forest
    sensor = SensorConfig(**kw)
    backend = make_scene_backend("embree", pose, sensor, notify=None, geometry=geometry)
    return run_scan(backend, pose, sensor, frame="world")


@pytest.fixture(scope="module")
def realistic(forest):
    return scan(forest, model="realistic", noise_sigma=0.0)


def test_in_the_forest_trunks_are_seen_behind_crowns_along_the_same_beam(realistic):
    assert trunk_behind_crown(realistic.cloud) > 100


def test_a_measured_share_of_forest_beams_return_two_or_three_echoes(realistic):
    beams = realistic.metadata["echoes"]["beams_by_echoes"]
    returned = sum(beams.values())
    share = (beams["2"] + beams["3"]) / returned
    assert 0.05 < share < 0.5, beams
    cloud = realistic.cloud
    key = cloud.sweep.astype(np.int64) * 1080 + cloud.ring
    # every beam's echoes are numbered 1..echoes, nearest first
    order = np.lexsort((cloud.extra["echo"], key))
    k, e, n, r = key[order], cloud.extra["echo"][order], cloud.extra["echoes"][order], cloud.range[order]
    first = np.r_[True, k[1:] != k[:-1]]
    assert (e[first] == 1).all() and (e <= n).all() and set(np.unique(n)) <= {1, 2, 3}
    later = ~first
    assert (r[later] > r[np.flatnonzero(later) - 1]).all()


def test_realistic_thin_single_echo_scan_of_the_forest_equals_the_paper_scan(forest):
    paper = scan(forest, noise_sigma=0.0).cloud
    thin = scan(
        forest, model="realistic", noise_sigma=0.0, divergence_mrad=0.0, echoes=1, detection=False
    ).cloud  # the detection step off: the paper model returns every surface to its range limit
    assert len(paper) == len(thin) > 50_000
    for field in ("xyz", "label", "instance", "ring", "sweep", "range"):
        assert np.array_equal(getattr(paper, field), getattr(thin, field)), field


def closest_distances(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Distance from each point (P,3) to the nearest of its triangles (P,K,3,3) (Ericson's
    closest point on a triangle, vectorized)."""
    p = points[:, None, :]
    a, b, c = tris[:, :, 0], tris[:, :, 1], tris[:, :, 2]
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(-1), (ac * ap).sum(-1)
    bp, cp = p - b, p - c
    d3, d4 = (ab * bp).sum(-1), (ac * bp).sum(-1)
    d5, d6 = (ab * cp).sum(-1), (ac * cp).sum(-1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    denom = np.where(va + vb + vc == 0, 1e-300, va + vb + vc)
    v, w = vb / denom, vc / denom
    q = a + v[..., None] * ab + w[..., None] * ac  # inside the face
    edges = [
        (a, ab, np.clip(d1 / np.maximum((ab * ab).sum(-1), 1e-300), 0, 1)),
        (a, ac, np.clip(d2 / np.maximum((ac * ac).sum(-1), 1e-300), 0, 1)),
        (b, c - b, np.clip(((c - b) * bp).sum(-1) / np.maximum(((c - b) ** 2).sum(-1), 1e-300), 0, 1)),
    ]
    inside = (va >= 0) & (vb >= 0) & (vc >= 0)
    best = np.where(inside, np.linalg.norm(p - q, axis=-1), np.inf)
    for o, e, t in edges:
        best = np.minimum(best, np.linalg.norm(p - (o + t[..., None] * e), axis=-1))
    return best.min(axis=1)


def test_every_unflagged_point_lies_within_1_mm_of_an_element_of_its_class(forest, realistic):
    _, geometry, pose = forest
    geometry = geometry.cropped((pose.x, pose.y), 18.0)
    cloud = realistic.cloud
    clean = np.flatnonzero(cloud.extra["mixed"] == 0)
    assert len(clean) > 0.6 * len(cloud)
    sample = np.random.default_rng(0).choice(clean, 1200, replace=False)
    tris = geometry.triangles()
    lo, hi = tris.min(axis=1) - 1e-3, tris.max(axis=1) + 1e-3
    worst = 0.0
    for label in np.unique(cloud.label[sample]):
        mine = np.flatnonzero(geometry.class_id == label)
        points = cloud.xyz[sample[cloud.label[sample] == label]]
        for chunk in np.array_split(points, max(1, len(points) // 16)):
            # the triangles of the point's class whose box (grown by 1 mm) holds it
            inside = ((lo[mine] <= chunk[:, None]) & (hi[mine] >= chunk[:, None])).all(axis=2)
            for p, near in zip(chunk, inside):
                assert near.any(), f"a {label} point has no triangle of its class within 1 mm"
                worst = max(worst, float(closest_distances(p[None], tris[mine[near]][None])[0]))
    assert worst <= 1e-3


def test_mixed_points_are_flagged_and_their_purity_says_how_mixed(realistic):
    cloud = realistic.cloud
    mixed = cloud.extra["mixed"] == 1
    purity = cloud.extra["label_purity"]
    assert mixed.any() and (purity > 0).all() and (purity <= 1).all()
    impure = purity < 0.999
    assert impure.any() and (mixed & impure).any()
    # an echo with several classes' energy is nearly always off every surface; the few that
    # are not lie on their labeled surface (the test above checks every unflagged point)
    assert mixed[impure].mean() > 0.9


def test_intensity_no_longer_names_the_class(realistic):
    cloud = realistic.cloud
    trunk, crown = class_by_name("trunk").id, class_by_name("treetop").id
    a, b = cloud.intensity[cloud.label == trunk], cloud.intensity[cloud.label == crown]
    assert np.unique(a).size > 100 and np.unique(b).size > 100
    assert max(a.min(), b.min()) < min(a.max(), b.max())  # their ranges overlap


@pytest.fixture(scope="module")
def crowns():
    return crown_gap_fractions(SEED)


@pytest.mark.parametrize("kind", ["conifer", "broadleaf", "birch"])
def test_a_horizontal_beam_passes_3_m_of_crown_20_to_50_percent_of_the_time(kind, crowns):
    rows = [r for r in crowns if r["tree"].rstrip("01") == kind]
    rays = sum(r["rays_3m"] for r in rows)
    gap = sum(r["gap_3m"] * r["rays_3m"] for r in rows) / rays
    assert CROWN_TARGET[0] <= gap <= CROWN_TARGET[1], gap


def test_the_sky_seen_from_under_the_forest_canopy_is_15_to_35_percent(forest):
    plan, geometry, _ = forest
    sky = sky_fraction(plan, geometry)
    assert SKY_TARGET[0] <= sky["sky"] <= SKY_TARGET[1], sky
