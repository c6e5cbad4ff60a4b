"""The realistic sensor model on primitives of known geometry (no Blender): the thin beam is the
paper's, a beam over an edge gives two echoes or one flagged mixed point at the right ranges,
intensity follows its documented model, noise follows the datasheet."""

import math

import numpy as np
import pytest

from wildscan.core import sensor as S
from wildscan.core.classes import BY_ID, REFLECTIVITY_BY_ID
from wildscan.core.placement import Pose
from wildscan.core.realism.echoes import R_REF
from wildscan.core.realism.footprint import SUBRAYS, ring_radius_fraction, subray_directions, subrays_around
from wildscan.core.realism.realistic import echo_points
from wildscan.core.scan import run_scan
from wildscan.core.world.shapes.primitives import box, merge
from wildscan.raycast.embree_backend import EmbreeBackend
from wildscan.raycast.geometry import SceneGeometry, local_origin

from tests.helpers.analytic import AnalyticBackend, Patch

TERRAIN, TABLE, FENCE, ROCK = 1, 4, 6, 9
REALISTIC = S.SensorConfig(model="realistic")


def geometry_of(*parts):
    """One SceneGeometry of (mesh, class id, instance) parts."""
    meshes = [m for m, _, _ in parts]
    v, f = merge(meshes)
    cls = np.concatenate([np.full(len(m[1]), c) for m, c, _ in parts])
    inst = np.concatenate([np.full(len(m[1]), i) for m, _, i in parts])
    g = SceneGeometry(v, f, cls, inst, np.zeros(len(f)), ("scene",))
    g.offset = local_origin(g.vertices, g.faces)
    return g


def beam_points(backend, direction, e_u, e_v, sensor, origin=(0.0, 0.0, 0.0), cast_range=40.0):
    """The realistic points of beams along `direction` (N,3) with footprint axes e_u, e_v."""
    sub = subrays_around(
        np.atleast_2d(direction), np.atleast_2d(e_u), np.atleast_2d(e_v), sensor.divergence_mrad
    )

    def cast(o, d, r, normals):
        return backend.cast(o, d, r, normals=normals)

    return echo_points(cast, np.asarray(origin, dtype=float), sub, sensor, cast_range)


def test_the_footprint_pattern_is_the_documented_one():
    dirs = S.beam_directions(1.0)[0]
    sub = subray_directions(1.0, 4.4)
    assert sub.shape == (SUBRAYS, len(dirs), 3)
    assert np.array_equal(sub[0], dirs)  # the axis is the paper's ray, bit for bit
    assert np.allclose(np.linalg.norm(sub, axis=2), 1.0)
    off_axis = np.arccos(np.clip(np.einsum("nk,snk->sn", dirs, sub[1:]), -1, 1))
    assert np.allclose(off_axis, 0.5 * 4.4e-3 * ring_radius_fraction(), rtol=1e-6)
    # the ring's sub-rays lie along +u, +v, -u, -v: opposite pairs straddle the axis
    assert np.allclose(sub[1] + sub[3], 2 * np.cos(off_axis[0])[:, None] * dirs)
    assert subray_directions(1.0, 0.0).shape == (1, len(dirs), 3)


def test_realistic_with_a_thin_beam_and_one_echo_gives_the_papers_points_and_labels():
    scene = AnalyticBackend(
        [
            Patch((0, 0, 0), (0, 0, 1), TERRAIN),
            Patch((4, 0, 0), (-1, 0, 0.2), ROCK, instance=7, xy_box=(3, 5, -2, 2)),
            Patch((0, 6, 0), (0, -1, 0), FENCE, instance=3, xy_box=(-4, 4, 5, 7)),
        ]
    )
    paper = run_scan(scene, Pose(0.3, -0.2, 20), S.SensorConfig(rh_deg=2.0, noise_sigma=0.0))
    thin = run_scan(
        scene,
        Pose(0.3, -0.2, 20),
        # the detection step off: the paper model returns every surface to its range limit
        S.SensorConfig(
            rh_deg=2.0, noise_sigma=0.0, model="realistic", divergence_mrad=0.0, echoes=1, detection=False
        ),
    )
    a, b = paper.cloud, thin.cloud
    assert len(a) > 10_000 and len(a) == len(b)
    for field in ("xyz", "label", "instance", "ring", "sweep", "range"):
        assert np.array_equal(getattr(a, field), getattr(b, field)), field
    assert set(b.extra) == {"echo", "echoes", "label_purity", "mixed"}
    assert (b.extra["echo"] == 1).all() and (b.extra["echoes"] == 1).all()
    assert (b.extra["label_purity"] == 1).all() and not b.extra["mixed"].any()


# A table top edge at 5 m, its face towards the sensor, and a fence wall behind it.
EDGE_Y = 0.003  # the box ends 3 mm beside the axis: the +u sub-ray (7.4 mm off at 5 m) misses it
AXIS, E_U, E_V = np.array([1.0, 0, 0]), np.array([0.0, 1, 0]), np.array([0.0, 0, 1])


def edge_scene(wall_x: float, box_depth: float):
    table = box(center=(5.0 + box_depth / 2, EDGE_Y - 1.0, 0.0), size=(box_depth, 2.0, 2.0))
    wall = box(center=(wall_x + 0.05, 0.0, 0.0), size=(0.1, 4.0, 4.0))
    return EmbreeBackend(geometry_of((table, TABLE, 11), (wall, FENCE, 22)))


def test_a_beam_over_a_box_edge_with_a_wall_behind_returns_two_echoes_at_their_ranges():
    sensor = S.SensorConfig(model="realistic", noise_sigma=0.0)
    pts = beam_points(edge_scene(5.5, 0.2), AXIS, E_U, E_V, sensor)
    assert list(pts.echo) == [1, 2] and list(pts.echoes) == [2, 2]
    assert list(pts.label) == [TABLE, FENCE] and list(pts.instance) == [11, 22]
    assert pts.range == pytest.approx([5.0, 5.5], abs=1e-9)
    assert not pts.mixed.any()  # each point lies on its surface along the beam axis
    assert pts.purity == pytest.approx([1.0, 1.0])
    # the table took 4 of the 5 sub-rays' energy, the wall 1 (at its range and reflectivity)
    table_i = 4 / SUBRAYS * REFLECTIVITY_BY_ID[TABLE] * (R_REF / 5.0) ** 2
    wall_i = 1 / SUBRAYS * REFLECTIVITY_BY_ID[FENCE] * (R_REF / 5.5) ** 2
    assert pts.intensity == pytest.approx([table_i, wall_i], rel=1e-5)  # off-axis: cos, range


def test_a_beam_over_a_box_edge_with_a_wall_close_behind_returns_one_flagged_mixed_point():
    sensor = S.SensorConfig(model="realistic", noise_sigma=0.0)
    pts = beam_points(edge_scene(5.1, 0.05), AXIS, E_U, E_V, sensor)
    assert len(pts.range) == 1 and pts.echoes[0] == 1
    # one range between the two surfaces, weighted by their energy
    e_table = 4 * REFLECTIVITY_BY_ID[TABLE] / 5.0**2
    e_wall = 1 * REFLECTIVITY_BY_ID[FENCE] / 5.1**2
    assert 5.0 < pts.range[0] < 5.1
    assert pts.range[0] == pytest.approx((5.0 * e_table + 5.1 * e_wall) / (e_table + e_wall), abs=1e-6)
    assert pts.mixed[0]  # not on any surface: flagged, never silently labeled
    assert pts.label[0] == TABLE and pts.purity[0] == pytest.approx(e_table / (e_table + e_wall))


def test_with_a_thin_beam_the_same_edge_gives_one_clean_point():
    sensor = S.SensorConfig(model="realistic", noise_sigma=0.0, divergence_mrad=0.0)
    pts = beam_points(edge_scene(5.1, 0.05), AXIS, E_U, E_V, sensor)
    assert pts.range == pytest.approx([5.0]) and not pts.mixed.any() and pts.label[0] == TABLE


def tilted_wall(distance: float, tilt_deg: float, class_id: int = ROCK):
    """An unbounded plane through (distance, 0, 0) whose normal is turned tilt_deg from -X."""
    t = math.radians(tilt_deg)
    return AnalyticBackend([Patch((distance, 0, 0), (-math.cos(t), math.sin(t), 0), class_id)])


@pytest.mark.parametrize("distance", [2.0, 5.0, 10.0, 20.0])
@pytest.mark.parametrize("tilt", [0.0, 30.0, 60.0, 80.0])
def test_intensity_falls_with_incidence_and_range_as_documented(distance, tilt):
    """I = rho * cos(incidence) * (R_REF / R)^2 for a surface filling the beam."""
    thin = S.SensorConfig(model="realistic", noise_sigma=0.0, divergence_mrad=0.0, max_range=30.0)
    pts = beam_points(tilted_wall(distance, tilt), AXIS, E_U, E_V, thin, cast_range=80.0)
    expected = BY_ID[ROCK].reflectivity * math.cos(math.radians(tilt)) * (R_REF / distance) ** 2
    assert pts.intensity == pytest.approx([expected], rel=1e-9)
    # the footprint (all its sub-rays on the plane) changes it by its own geometry only
    wide = S.SensorConfig(model="realistic", noise_sigma=0.0, max_range=30.0)
    pts = beam_points(tilted_wall(distance, tilt), AXIS, E_U, E_V, wide, cast_range=80.0)
    assert pts.intensity == pytest.approx([expected], rel=0.01)
    if tilt <= 72:  # the footprint's returns are moved to the axis along the plane: exact
        assert pts.range == pytest.approx([distance], abs=1e-9) and not pts.mixed.any()
    else:  # grazing: their own ranges' mean, flagged unless within 1 mm of the axis's
        assert pts.range == pytest.approx([distance], abs=0.01)
        assert pts.mixed[0] == (abs(pts.range[0] - distance) > 1e-3)


def test_intensity_halves_from_head_on_to_60_degrees_and_quarters_from_10_to_20_m():
    thin = S.SensorConfig(model="realistic", noise_sigma=0.0, divergence_mrad=0.0, max_range=30.0)

    def intensity(distance, tilt):
        return beam_points(tilted_wall(distance, tilt), AXIS, E_U, E_V, thin).intensity[0]

    assert intensity(10.0, 60.0) / intensity(10.0, 0.0) == pytest.approx(0.5)
    assert intensity(20.0, 0.0) / intensity(10.0, 0.0) == pytest.approx(0.25)
    assert intensity(10.0, 0.0) == pytest.approx(BY_ID[ROCK].reflectivity)  # the documented reference


def fan(count: int, spread_deg: float = 20.0):
    """`count` beams fanned in the XY plane around +X, with their footprint axes."""
    a = np.radians(np.linspace(-spread_deg / 2, spread_deg / 2, count))
    d = np.stack([np.cos(a), np.sin(a), np.zeros(count)], -1)
    e_u = np.stack([-np.sin(a), np.cos(a), np.zeros(count)], -1)
    return d, e_u, np.tile([0.0, 0.0, 1.0], (count, 1))


@pytest.mark.parametrize("distance, sigma", [(5.0, 0.015), (9.0, 0.015), (14.0, 0.025), (25.0, 0.025)])
def test_range_noise_by_range_matches_the_datasheet_within_5_percent(distance, sigma):
    """±30 mm up to 10 m and ±50 mm beyond, read as 2 sigma (95 % of ranges within them)."""
    sensor = S.SensorConfig(model="realistic", max_range=30.0, noise_seed=3)
    d, e_u, e_v = fan(20_000)
    wall = AnalyticBackend([Patch((distance, 0, 0), (-1, 0, 0), ROCK)])
    pts = beam_points(wall, d, e_u, e_v, sensor)
    true = distance / d[pts.beam, 0]
    error = pts.range - true
    assert len(error) == 20_000
    assert abs(error.mean()) < 3 * sigma / math.sqrt(len(error))
    assert error.std() == pytest.approx(sigma, rel=0.05)
    bound = 0.030 if distance <= 10 else 0.050
    assert (np.abs(error) <= bound).mean() == pytest.approx(0.9545, abs=0.01)


def test_a_given_noise_overrides_the_datasheet():
    sensor = S.SensorConfig(model="realistic", noise_sigma=0.04, noise_seed=1)
    d, e_u, e_v = fan(20_000)
    pts = beam_points(AnalyticBackend([Patch((5.0, 0, 0), (-1, 0, 0), ROCK)]), d, e_u, e_v, sensor)
    assert (pts.range - 5.0 / d[pts.beam, 0]).std() == pytest.approx(0.04, rel=0.05)


def test_datasheet_sigma_is_documented_2_sigma_of_the_accuracy():
    assert S.datasheet_sigma(np.array([0.1, 10.0, 10.01, 30.0])) == pytest.approx(
        [0.015, 0.015, 0.025, 0.025]
    )
    assert S.SensorConfig(model="realistic").fixed_noise is None
    assert S.SensorConfig().fixed_noise == S.DEFAULT_NOISE_SIGMA


def test_paper_sensor_metadata_is_what_it_always_was():
    """A paper scan's files must not change: its sensor block has exactly the old keys."""
    assert S.SensorConfig().to_dict() == {
        "rh_deg": 1.0,
        "min_range": 0.1,
        "max_range": 15.0,
        "noise_sigma": 0.015,
        "noise_seed": 0,
        "model": "Hokuyo UTM-30LX-EW",
        "rv_deg": 0.25,
        "beams_per_2d_scan": 1080,
        "sweeps": 180,
    }
    d = REALISTIC.to_dict()
    assert d["scan_model"] == "realistic" and d["noise_model"] == "datasheet" and d["divergence_mrad"] == 4.4


@pytest.mark.parametrize(
    "kw, setting",
    [
        ({"model": "lidar"}, "model"),
        ({"model": "realistic", "divergence_mrad": -1.0}, "divergence"),
        ({"model": "realistic", "divergence_mrad": 51.0}, "divergence"),
        ({"model": "realistic", "echoes": 4}, "echoes"),
        ({"model": "realistic", "echoes": 0}, "echoes"),
        ({"model": "realistic", "echo_separation": 0.0}, "echo_separation"),
        ({"model": "realistic", "echo_separation": float("nan")}, "echo_separation"),
    ],
)
def test_bad_realistic_settings_name_their_setting(kw, setting):
    from wildscan.core.errors import UserError

    with pytest.raises(UserError) as info:
        S.SensorConfig(**kw).validate()
    assert info.value.setting == setting


def test_water_deflects_the_sub_rays_that_meet_it():
    water = AnalyticBackend([Patch((5.0, 0, 0), (-1, 0, 0), 13)])
    pts = beam_points(water, AXIS, E_U, E_V, S.SensorConfig(model="realistic", noise_sigma=0.0))
    assert len(pts.range) == 0 and pts.stats["water_subrays"] == SUBRAYS


def test_a_backend_without_normals_is_refused_for_the_realistic_model():
    from wildscan.core.errors import UserError

    class NoNormals:
        name = "blender"
        capabilities = frozenset()

        def cast(self, origins, directions, max_range):
            raise AssertionError("must not be reached")

    with pytest.raises(UserError) as info:
        run_scan(NoNormals(), Pose(0, 0, 0), REALISTIC)
    assert info.value.setting == "backend"


def test_echoes_formed_block_by_block_on_threads_are_those_of_one_pass(monkeypatch):
    """echo_points forms a scan's points a block of beams at a time on the cast's threads:
    every beam's echoes, noise and axis are its own, so the blocks joined are one pass's bytes
    (two- and three-echo beams, mixed pixels and beams that hit nothing included)."""
    from wildscan.core.realism import realistic
    from wildscan.core.realism.echoes import form_echoes
    from wildscan.core.realism.footprint import subray_weights
    from wildscan.core.runtime import threads
    from wildscan.raycast.geometry import from_triangles

    rng = np.random.default_rng(11)
    centres = rng.normal(size=(3000, 3))
    centres *= (1.0 + 3.0 * rng.random(3000))[:, None] / np.linalg.norm(centres, axis=1)[:, None]
    leaves = centres[:, None, :] + 0.05 * rng.normal(size=(3000, 3, 3))
    classes = rng.choice([2, 3, 8], size=3000)  # two leaves of other classes in one echo: a mixed pixel
    backend = EmbreeBackend(from_triangles(leaves, class_id=classes, instance=np.arange(3000)))
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    e_u = np.cross(d, [0.0, 0.0, 1.0])
    e_u /= np.linalg.norm(e_u, axis=1)[:, None]
    sensor = S.SensorConfig(model="realistic", divergence_mrad=40.0)
    sub = subrays_around(d, e_u, np.cross(d, e_u), sensor.divergence_mrad)
    hits = backend.cast(np.zeros(3), sub.reshape(-1, 3), 10.0, normals=True)
    one_pass = form_echoes(
        realistic.subray_returns(hits, sub), subray_weights(len(sub)), sensor.echo_separation, sensor.echoes
    )
    per_beam = np.bincount(one_pass.beam, minlength=len(d))
    assert (per_beam == 0).any() and (per_beam == 1).any() and (per_beam >= 2).any()
    assert (one_pass.purity < 1).any()

    def cast(origins, directions, max_range, normals):
        return backend.cast(origins, directions, max_range, normals=normals)

    whole = realistic.echo_points(cast, np.zeros(3), sub, sensor, 10.0, threads=1)
    monkeypatch.setattr(realistic, "BEAM_BLOCK", 77)
    monkeypatch.setenv(threads.THREADS_ENV, "2")
    blocks = realistic.echo_points(cast, np.zeros(3), sub, sensor, 10.0, threads=2)
    assert len(whole.beam) >= len(one_pass.beam) // 2  # most echoes kept within the range limits
    for field in ("beam", "range", "intensity", "label", "purity", "instance", "echo", "echoes", "mixed"):
        assert getattr(blocks, field).tobytes() == getattr(whole, field).tobytes(), field
