import math

import numpy as np
import pytest

from wildscan.core import sensors as S
from wildscan.core.classes import CLASSES, WATER, label_from_reflectivity, reflectivity_of
from wildscan.core.errors import UserError


def test_full_scan_at_1_degree_has_194400_beams_as_eq1():
    dirs, ring, sweep = S.beam_directions(1.0)
    assert dirs.shape == (194_400, 3)
    assert ring.max() == 1079 and sweep.max() == 179
    assert np.allclose(np.linalg.norm(dirs, axis=1), 1.0)
    # Eq. (1) written out beam by beam for a sample of (n, m).
    rng = np.random.default_rng(0)
    for i in rng.integers(0, len(dirs), 500):
        n, m = int(ring[i]), int(sweep[i])
        t = math.radians(n * 0.25 - 135.0)
        phi = math.radians(m * 1.0)
        expected = (math.cos(phi) * math.sin(t), math.sin(phi) * math.sin(t), math.cos(t))
        assert np.allclose(dirs[i], expected, atol=1e-12)


def test_no_beam_within_45_degrees_of_straight_down():
    dirs, _, _ = S.beam_directions(1.0)
    from_down = np.degrees(np.arccos(np.clip(-dirs[:, 2], -1, 1)))
    assert from_down.min() >= S.DEFAULT_DEVICE.beams.blind_cone_half_angle_deg - 1e-9
    # …and the blind cone is exactly that wide: beam n = 0 sits on its edge.
    assert from_down.min() == pytest.approx(45.0, abs=1e-9)


@pytest.mark.parametrize(
    "rh, sweeps", [(0.25, 720), (0.5, 360), (1, 180), (2, 90), (4, 45), (0.3, 600), (180, 1)]
)
def test_rh_that_divides_180(rh, sweeps):
    assert S.sweep_count(rh) == sweeps
    assert S.SensorConfig(rh_deg=rh).beam_count == 1080 * sweeps


@pytest.mark.parametrize("rh", [7, 0.7, 0, -1, float("nan"), float("inf"), 181, 1.0001])
def test_rh_that_does_not_divide_180_is_a_clear_error(rh):
    with pytest.raises(UserError) as info:
        S.sweep_count(rh)
    assert info.value.setting == "rh"


@pytest.mark.parametrize(
    "kw, setting",
    [
        ({"max_range": 31}, "max_range"),
        ({"max_range": -1}, "max_range"),
        ({"min_range": -0.1}, "min_range"),
        ({"min_range": float("nan")}, "min_range"),
        ({"min_range": 5, "max_range": 4}, "min_range"),
        ({"noise_sigma": -0.01}, "noise"),
        ({"noise_sigma": float("inf")}, "noise"),
    ],
)
def test_bad_sensor_settings_name_the_setting(kw, setting):
    with pytest.raises(UserError) as info:
        S.SensorConfig(**kw).validate()
    assert info.value.setting == setting and str(info.value).startswith(f"{setting} ")


def test_an_error_is_phrased_by_each_front_end_from_one_table():
    from wildscan.app.settings import command_line_message, panel_message

    with pytest.raises(UserError) as info:
        S.SensorConfig(min_range=5, max_range=4).validate()
    e = info.value
    assert e.setting == "min_range" and e.related == ("max_range",)
    assert str(e) == "min_range (5 m) must be below max_range (4 m)"
    assert command_line_message(e) == "--min-range (5 m) must be below --max-range (4 m)"
    assert panel_message(e) == "Min range (5 m) must be below Max range (4 m)"
    with pytest.raises(UserError) as info:
        S.SensorConfig(max_range=31).validate()
    assert info.value.allowed == (0, S.DEFAULT_DEVICE.ranges.max_dark_m)
    assert command_line_message(info.value).startswith("--max-range must be in (0, 30] m")
    assert panel_message(info.value).startswith("Max range must be in (0, 30] m")


def test_user_errors_keep_their_setting_across_pickling():
    import pickle

    e = pickle.loads(pickle.dumps(UserError("must be x", setting="rh", allowed=(1, 2), related=("frame",))))
    assert (e.message, e.setting, e.allowed, e.related) == ("must be x", "rh", (1, 2), ("frame",))


def test_max_range_settable_up_to_30_m():
    assert S.SensorConfig(max_range=30).validate().max_range == 30


def test_noise_is_seeded_per_beam():
    a = S.range_noise(S.SensorConfig(noise_seed=1), 1000)
    b = S.range_noise(S.SensorConfig(noise_seed=1), 1000)
    c = S.range_noise(S.SensorConfig(noise_seed=2), 1000)
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    assert not S.range_noise(S.SensorConfig(noise_sigma=0), 10).any()


def test_labels_come_from_reflectivity():
    ids = np.array([c.id for c in CLASSES] + [WATER.id, 0])
    assert np.array_equal(label_from_reflectivity(reflectivity_of(ids)), ids)
    with pytest.raises(ValueError):
        label_from_reflectivity(np.array([99.0]))
