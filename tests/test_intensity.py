"""A dataset's intensity (core/realism/intensity.py, app/dataset/intensity.py): `physical` follows the
lidar equation with a reflectance per surface that varies within a class, stays in [0, 100]
(remission [0, 1]) and does not identify the class; `class` is the paper's tag, which a
lookup reads back for every point."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.core.classes import class_by_name
from wildscan.core.io.semantickitti import scan_bytes
from wildscan.core.realism import intensity as I

TERRAIN = class_by_name("terrain").id
TRUNK = class_by_name("trunk").id
TREETOP = class_by_name("treetop").id
ROCK = class_by_name("rock").id


def test_head_on_within_r_near_reads_the_surface_reflectance_and_falls_as_1_over_r2_beyond():
    rho = np.array([0.4, 0.4, 0.4, 0.4])
    value = I.physical_percent(rho, [1.0, 1.0, 0.5, 1.0], [2.0, I.R_NEAR, 3.0, 2 * I.R_NEAR], 1.0)
    np.testing.assert_allclose(value, [40.0, 40.0, 20.0, 10.0])


def test_physical_intensity_stays_in_0_to_100_whatever_the_inputs():
    rng = np.random.default_rng(0)
    n = 10_000
    value = I.physical_percent(
        rng.uniform(0, 1, n), rng.uniform(-1, 1, n), rng.uniform(0, 40, n), I.speckle(3, 4, n)
    )
    assert value.min() >= 0.0 and value.max() <= 100.0
    remission = np.frombuffer(scan_bytes(np.zeros((n, 3)), value), dtype="<f4").reshape(-1, 4)[:, 3]
    assert remission.min() >= 0.0 and remission.max() <= 1.0


def test_a_realistic_scans_bright_near_energy_saturates_remission_at_1():
    # the realistic model's echo energy (core/realism/echoes.py) reads 400 for terrain head-on at 5 m
    remission = np.frombuffer(scan_bytes(np.zeros((2, 3)), np.array([400.0, 40.0])), dtype="<f4")[3::4]
    np.testing.assert_allclose(remission, [1.0, 0.4])


def test_surfaces_of_one_class_differ_and_the_same_surface_keeps_its_value():
    instances = np.arange(1, 201)
    labels = np.full(200, TRUNK)
    xy = np.zeros((200, 2))
    rho = I.surface_reflectance(7, labels, instances, xy)
    low, high = I.MATERIALS["trunk"]
    assert rho.min() >= low and rho.max() <= high
    assert rho.std() > 0.25 * (high - low) / np.sqrt(12)  # spread over the range, not one number
    np.testing.assert_array_equal(rho, I.surface_reflectance(7, labels, instances, xy))
    assert not np.array_equal(rho, I.surface_reflectance(8, labels, instances, xy))  # seeded by the world


def test_the_terrain_varies_over_metres_and_is_smooth_within_a_patch():
    x = np.linspace(0, 100, 2001)
    xy = np.stack([x, np.zeros_like(x)], axis=1)
    rho = I.surface_reflectance(1, np.full(len(x), TERRAIN), np.ones(len(x), dtype=np.int64), xy)
    assert rho.max() - rho.min() > 0.15  # soil patches, not one number
    assert np.abs(np.diff(rho)).max() < 0.02  # 5 cm apart: nearly the same soil


def test_class_ranges_overlap_so_a_lookup_cannot_name_the_class():
    labels = np.repeat([TRUNK, TREETOP, ROCK], 3000)
    instances = np.tile(np.arange(3000), 3)
    rho = I.surface_reflectance(2, labels, instances, np.zeros((len(labels), 2)))
    hist = I.remission_histogram(rho, labels)
    assert I.balanced_lookup_accuracy(hist) < 0.6
    tagged = I.remission_histogram(I.class_percent(labels) / 100, labels)
    assert I.lookup_accuracy(tagged) == 1.0 and I.balanced_lookup_accuracy(tagged) == 1.0


def test_lookup_accuracy_counts_each_bins_commonest_class():
    hist = {"1": [8, 0] + [0] * 98, "2": [2, 5] + [0] * 98}
    assert I.lookup_accuracy(hist) == pytest.approx(13 / 15)
    assert I.majority_share(hist) == pytest.approx(8 / 15)
    assert I.balanced_lookup_accuracy(hist) == pytest.approx((8 / 8 + 5 / 7) / 2)


def test_speckle_is_seeded_per_scan_and_bounded():
    a = I.speckle(1, 2, 1000)
    np.testing.assert_array_equal(a, I.speckle(1, 2, 1000))
    assert not np.array_equal(a, I.speckle(1, 3, 1000))
    assert a.min() >= 1 - I.SPECKLE and a.max() <= 1 + I.SPECKLE


# --------------------------------------------------------------------------- class weights


def test_class_weights_follow_their_formulas_over_the_learning_map():
    import math

    from wildscan.core.class_weights import class_weights, learning_counts
    from wildscan.core.classes import listed_classes
    from wildscan.core.label_schemes import SCHEMES

    sk = SCHEMES["semantickitti"]
    # WildScan trunk (71) and treetop + bush (both 70 vegetation) and unlabeled (0, ignored)
    counts = learning_counts(sk, {71: 100, 70: 300, 0: 50}, listed_classes())
    trunk, vegetation = sk.learning_map[71], sk.learning_map[70]
    assert counts[trunk] == 100 and counts[vegetation] == 300 and counts[sk.learning_map[0]] == 0
    w = class_weights(counts)
    assert w["inverse_frequency"][trunk] == pytest.approx(400 / (2 * 100))
    assert w["inverse_frequency"][vegetation] == pytest.approx(400 / (2 * 300))
    assert w["enet"][trunk] == pytest.approx(1 / math.log(1.02 + 0.25))
    assert w["enet"][sk.learning_map[0]] == 0.0  # ignored: nothing to learn
    assert max(w["enet"].values()) <= 1 / math.log(1.02)


# --------------------------------------------------------------------------- the dataset card


def test_the_card_warns_when_remission_alone_labels_over_90_percent():
    from types import SimpleNamespace

    from wildscan.app.dataset.intensity import intensity_lines, remission_totals

    labels = np.repeat([TERRAIN, TRUNK, ROCK], [700, 200, 100])
    tagged = [{"remission_histogram": I.remission_histogram(I.class_percent(labels) / 100, labels)}]
    totals = remission_totals(tagged)
    assert totals["remission_lookup_accuracy"] == 1.0 and totals["majority_class_share"] == 0.7
    (line,) = intensity_lines(SimpleNamespace(intensity="class"), totals)
    assert "labels 100.0 % of points" in line and "Warning" in line
    xy = np.random.default_rng(0).uniform(-100, 100, (len(labels), 2))  # terrain over many patches
    rho = I.surface_reflectance(3, labels, np.arange(len(labels)), xy)
    physical = remission_totals([{"remission_histogram": I.remission_histogram(rho, labels)}])
    (line,) = intensity_lines(SimpleNamespace(intensity="physical"), physical)
    assert physical["remission_lookup_accuracy"] < 0.9 and "Warning" not in line
    assert intensity_lines(SimpleNamespace(intensity="physical"), {}) == []  # rows from before: no line


def test_the_lookup_figures_do_not_depend_on_the_order_scans_were_added():
    """A resumed dataset run adds the scans' histograms in another order than a clean run:
    its card must carry the same figures (the mean of the recalls summed in another order
    differed in its last bit)."""
    rng = np.random.default_rng(3)
    scans = [
        {str(c): [int(v) for v in rng.integers(0, 50, I.REMISSION_BINS)] for c in rng.permutation(12)[:5]}
        for _ in range(30)
    ]
    scans.append({"1": [7] * I.REMISSION_BINS, "2": [7] * I.REMISSION_BINS})  # ties in every bin
    totals = []
    for order in (scans, scans[::-1], [scans[i] for i in rng.permutation(len(scans))]):
        total: dict = {}
        for h in order:
            I.add_histograms(total, h)
        totals.append((I.lookup_accuracy(total), I.balanced_lookup_accuracy(total), I.majority_share(total)))
    assert totals[0] == totals[1] == totals[2]


def _second_cast_incidence(backend, result, reach: float) -> np.ndarray:
    """|cos θ| of the surface along each point's beam, cast again through the point as far as
    `reach` (how the physical intensity found it before the sweep's own normals), 1 where none."""
    world = result.cloud.xyz.astype(np.float64)
    origin = result.placement.optical_centre
    offset = world - origin
    length = np.linalg.norm(offset, axis=1)
    dirs = offset / length[:, None]
    hits = backend.cast(origin, dirs, reach, True)
    cos = np.abs(np.einsum("ij,ij->i", hits.normal, dirs))
    return np.where(np.isfinite(hits.distance), cos, 1.0)


@pytest.mark.parametrize("weather", [None, {"snow": 30.0}])
def test_a_paper_scans_incidence_is_the_surface_along_each_beam_without_a_second_cast(weather):
    """run_scan(..., incidence=True): each point's |cos θ| from the sweep's own hits, what a
    second cast along its beam within the sweep's reach finds; a snowflake's point takes the
    surface behind it (1 where none is within reach)."""
    from wildscan.core.classes import PARTICLE_ID
    from wildscan.core.effects import CLEAR_AIR, Effects, Weather
    from wildscan.core.placement import Pose
    from wildscan.core.scan import NOISE_MARGIN_SIGMAS, run_scan
    from wildscan.core.sensors import SensorConfig

    from tests.helpers.analytic import weather_scene

    backend = weather_scene()
    effects = CLEAR_AIR if weather is None else Effects((Weather.of(weather, seed=1),))
    sensor = SensorConfig(rh_deg=4.0, noise_sigma=0.0)
    result = run_scan(backend, Pose(0.0, 0.0, 0.0), sensor, "world", effects=effects, incidence=True)
    assert result.incidence.shape == (len(result.cloud),)
    reach = sensor.max_range + NOISE_MARGIN_SIGMAS * sensor.max_noise_sigma  # the sweep's
    expected = _second_cast_incidence(backend, result, reach)
    np.testing.assert_allclose(result.incidence, expected, rtol=0, atol=1e-9)
    assert 0.05 < result.incidence.min() < 0.5 and result.incidence.max() > 0.99  # ground and walls
    if weather is not None:
        assert (result.cloud.label == PARTICLE_ID).sum() > 100
    assert run_scan(backend, Pose(0.0, 0.0, 0.0), sensor, "world").incidence is None  # not asked


def test_the_terrain_fields_corner_draws_are_the_same_from_a_table_or_point_by_point():
    """Many points over a few cells (a scan: one hash a corner, in a table) and a few points far
    apart (one hash a point) give each point the same number as it gets alone."""
    rng = np.random.default_rng(5)
    compact = rng.uniform(-30, 30, (5000, 2))
    sparse = rng.uniform(-5000, 5000, (20, 2))
    for xy in (compact, sparse, np.concatenate([compact, sparse])):
        alone = np.array([I._terrain_field(3, p[None, :])[0] for p in xy[:50]])
        assert np.array_equal(I._terrain_field(3, xy)[:50], alone)
    assert I.hash_unit(np.int64(1), np.arange(4)).shape == (4,) and I.hash_unit(np.int64(1)).shape == ()
