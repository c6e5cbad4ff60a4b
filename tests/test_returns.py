"""Return modes (core/sensors/returns.py): strongest, last and dual as the Velodyne and Ouster
manuals define them, the UTM-30LX-EW's multi-echo as before, and a mode a device does not have
refused with one clear line."""

import subprocess

import numpy as np
import pytest

from wildscan.core.errors import UserError
from wildscan.core.sensors import SensorConfig, device_named, preset_names
from wildscan.core.sensors.load import PRESETS_DIR, device_from_text
from wildscan.core.sensors.returns import (
    LAST,
    SECOND_STRONGEST,
    STRONGEST,
    STRONGEST_AND_LAST,
    select_returns,
)

from tests.helpers.scene_helpers import WILDSCAN, user_error_line
from tests.test_realistic import AXIS, E_U, E_V, FENCE, TABLE, beam_points, edge_scene

# four beams: (near strong, far weak); (near weak, far strong: its strongest is its last); one
# echo; three echoes whose strongest is its last
BEAM = np.array([0, 0, 1, 1, 2, 3, 3, 3])
STRENGTH = np.array([9.0, 2.0, 1.0, 8.0, 5.0, 3.0, 4.0, 7.0])


def test_strongest_and_last_keep_one_return_a_beam():
    keep, kind = select_returns(BEAM, STRENGTH, "strongest")
    assert keep.tolist() == [0, 3, 4, 7] and (kind == STRONGEST).all()
    keep, kind = select_returns(BEAM, STRENGTH, "last")
    assert keep.tolist() == [1, 3, 4, 7] and (kind == LAST).all()


def test_velodyne_dual_is_the_strongest_and_the_last_or_the_second_strongest_when_they_are_one():
    keep, kind = select_returns(BEAM, STRENGTH, "dual", "strongest-last")
    assert keep.tolist() == [0, 1, 2, 3, 4, 6, 7]
    assert kind.tolist() == [
        STRONGEST,
        LAST,
        SECOND_STRONGEST,  # beam 1: its strongest is its last, so the second-strongest comes with it
        STRONGEST_AND_LAST,
        STRONGEST_AND_LAST,  # a single return, reported once
        SECOND_STRONGEST,  # beam 3 as beam 1
        STRONGEST_AND_LAST,
    ]


def test_ouster_dual_is_the_two_strongest_returns():
    keep, kind = select_returns(BEAM, STRENGTH, "dual", "two-strongest")
    assert keep.tolist() == [0, 1, 2, 3, 4, 6, 7]
    assert kind.tolist() == [
        STRONGEST,
        SECOND_STRONGEST,
        SECOND_STRONGEST,
        STRONGEST,
        STRONGEST,
        SECOND_STRONGEST,
        STRONGEST,
    ]


def test_equal_strengths_go_to_the_nearer_return():
    keep, _ = select_returns(np.array([0, 0]), np.array([3.0, 3.0]), "strongest")
    assert keep.tolist() == [0]


@pytest.mark.parametrize(
    "mode, ranges, labels, kinds",
    [
        ("strongest", [5.0], [TABLE], None),
        ("last", [5.5], [FENCE], None),
        ("dual", [5.0, 5.5], [TABLE, FENCE], [STRONGEST, LAST]),
    ],
)
def test_a_vlp16_beam_over_an_edge_reports_what_its_mode_asks(mode, ranges, labels, kinds):
    """The table's edge takes most of the footprint at 5 m, the wall behind it the rest at 5.5 m:
    strongest is the table, last the wall, dual both, flagged."""
    sensor = SensorConfig.for_device(device_named("vlp16"), model="realistic", noise_sigma=0.0, returns=mode)
    sensor = sensor.validate()
    pts = beam_points(edge_scene(5.5, 0.2), AXIS, E_U, E_V, sensor)
    assert pts.range == pytest.approx(ranges, abs=1e-9)
    assert pts.label.tolist() == labels
    assert pts.echo.tolist() == list(range(1, len(ranges) + 1))
    if kinds is not None:
        assert pts.return_type.tolist() == kinds


def test_the_utm30lx_ew_keeps_its_multi_echo():
    device = device_named("utm30lx-ew")
    assert device.optics.returns == ("multi",) and device.optics.echoes == 3
    sensor = SensorConfig(model="realistic", noise_sigma=0.0)
    assert sensor.return_mode == "multi" and "returns" not in sensor.to_dict()
    pts = beam_points(edge_scene(5.5, 0.2), AXIS, E_U, E_V, sensor)
    assert pts.range == pytest.approx([5.0, 5.5], abs=1e-9) and not pts.return_type.any()


@pytest.mark.parametrize("name", preset_names())
def test_every_preset_has_its_manuals_return_modes(name):
    optics = device_named(name).optics
    vendor = device_named(name).vendor
    expected = {
        "Velodyne": (("strongest", "last", "dual"), "strongest-last", 2),
        "Ouster": (("strongest", "dual"), "two-strongest", 2),
        "Hokuyo": (("multi",), None, 3),
    }[vendor]
    assert (optics.returns, optics.dual, optics.echoes) == expected
    default = SensorConfig.for_device(device_named(name), model="realistic").validate()
    assert default.return_mode == optics.return_mode
    assert default.echoes == (1 if optics.return_mode in ("strongest", "last") else optics.echoes)


def test_a_mode_the_device_does_not_have_is_a_user_error():
    with pytest.raises(UserError) as e:
        SensorConfig.for_device(device_named("os1-64"), model="realistic", returns="last").validate()
    assert e.value.setting == "returns" and "strongest, dual" in str(e.value)
    with pytest.raises(UserError) as e:
        SensorConfig(model="realistic", returns="dual").validate()
    assert "multi" in str(e.value)
    with pytest.raises(UserError) as e:  # echoes contradicting the mode: the mode decides
        SensorConfig.for_device(device_named("vlp16"), model="realistic", echoes=2).validate()
    assert e.value.setting == "echoes" and "strongest" in str(e.value)


def test_the_command_line_refuses_a_mode_in_one_line(tmp_path):
    out = tmp_path / "scan.ply"
    args = ["scan", "--seed", "0", "--pose", "5", "5", "0", "--sensor", "os1-64", "--model", "realistic"]
    proc = subprocess.run(
        [WILDSCAN, *args, "--returns", "last", "--out", str(out)], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 2
    assert "--returns must be one of strongest, dual" in user_error_line(proc)
    assert not out.exists()


@pytest.mark.parametrize(
    "optics, wrong",
    [
        ('returns = ["strongest", "bright"]', "returns"),
        ('returns = ["multi", "dual"]\ndual = "strongest-last"', "returns"),
        ('returns = ["strongest", "dual"]', "dual"),  # what the dual mode pairs is required
        ('returns = ["strongest"]\ndual = "two-strongest"', "dual"),
        ('returns = ["strongest", "dual"]\ndual = "two-strongest"\nreturn_mode = "last"', "return_mode"),
    ],
)
def test_a_wrong_return_mode_in_a_device_file_names_the_key(optics, wrong):
    text = (PRESETS_DIR / "vlp16.toml").read_text()
    start = text.index('returns = ["strongest"')
    end = text.index("[mount]")
    text = text[:start] + optics + "\n\n" + text[end:]
    with pytest.raises(UserError) as e:
        device_from_text(text, "mine.toml")
    assert "mine.toml" in str(e.value) and f"optics.{wrong}" in str(e.value)


def test_a_dataset_spec_sets_the_return_mode_and_refuses_one_its_device_lacks(tmp_path):
    from wildscan.app.dataset.draws import draw_sensor
    from wildscan.app.dataset.spec import load_spec

    spec = tmp_path / "spec.toml"
    spec.write_text('seeds = [0]\nscans_per_world = 1\n[sensor]\nmodel = "realistic"\nreturns = "dual"\n')
    with pytest.raises(UserError) as e:  # the default device, the UTM-30LX-EW: multi-echo only
        load_spec(spec)
    assert "sensor.returns must be one of multi" in str(e.value)
    spec.write_text(spec.read_text() + 'device = "vlp16"\n')
    sensor = draw_sensor(load_spec(spec).sensor, 0, 0)
    assert (sensor.return_mode, sensor.echoes) == ("dual", 2)
    assert sensor.to_dict()["returns"] == "dual"


def test_a_beams_strongest_is_the_highest_and_the_nearest_of_equals_on_random_echoes():
    """select_returns' strongest (per-beam maxima, no sort) against the definition: the echo
    of highest intensity, the nearest (first in range order) of equals."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        per_beam = rng.integers(1, 5, rng.integers(1, 40))
        beam = np.repeat(np.arange(len(per_beam)) * 3, per_beam)  # beams numbered with gaps
        intensity = rng.integers(0, 4, len(beam)).astype(np.float32)  # many ties
        expected = [int(np.flatnonzero(beam == b)[np.argmax(intensity[beam == b])]) for b in np.unique(beam)]
        kept, kinds = select_returns(beam, intensity, "strongest")
        assert kept.tolist() == expected and set(kinds.tolist()) == {STRONGEST}
