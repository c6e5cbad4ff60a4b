"""Sensor devices as data (core/sensors): the UTM-30LX-EW preset file, its beams as Eq. 1,
and the mistakes a device file can hold."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from wildscan.core import detmath as dm
from wildscan.core.errors import UserError
from wildscan.core.sensors import (
    DEFAULT_DEVICE,
    SensorConfig,
    beam_directions,
    device_from_dict,
    device_named,
    directions_at,
    preset_names,
    rotated_beam_directions,
)
from wildscan.core.sensors.load import PRESETS_DIR, device_from_text, toml_reader

PRESET = PRESETS_DIR / "utm30lx-ew.toml"


def test_the_utm30lx_ew_file_loads_with_the_datasheet_numbers():
    d = device_named("utm30lx-ew")
    assert "utm30lx-ew" in preset_names() and d is DEFAULT_DEVICE
    assert d.name == "Hokuyo UTM-30LX-EW"
    assert d.beams.count == 1080 and d.beams.fan == (-135.0, 0.25)
    assert d.timing.column_period_s == 0.025 and d.timing.steps_per_column == 1440
    assert d.timing.column_period_ns == 25_000_000
    assert d.timing.field_time_s == pytest.approx(0.01875, abs=1e-15)
    assert (d.ranges.min_m, d.ranges.max_m, d.ranges.max_dark_m) == (0.1, 15.0, 30.0)
    assert d.noise.sigma_m == 0.015 and d.noise.accuracy == ((10.0, 0.030), (30.0, 0.050))
    assert (d.optics.divergence_mrad, d.optics.echoes, d.optics.echo_separation_m) == (4.4, 3, 0.3)
    m = d.mount
    assert (m.kind, m.axis, m.tilt_deg, m.step_deg, m.sweep_deg) == (
        "rotating",
        (0.0, 0.0, 1.0),
        0.0,
        1.0,
        180.0,
    )
    assert d.beams.blind_cone_half_angle_deg == 45.0


def test_the_utm30lx_ew_beam_table_is_eq_1():
    beams = DEFAULT_DEVICE.beams
    # θn = n·r_v − 135° from the column, in one plane, ring n = beam n, beam n at step n
    assert beams.from_axis_deg == tuple(n * 0.25 - 135.0 for n in range(1080))
    assert beams.planar and not any(beams.azimuth_offset_deg)
    assert beams.ring == tuple(range(1080)) and DEFAULT_DEVICE.timing.beam_step == tuple(range(1080))
    # and the directions are Eq. 1's, bit for bit, from detmath's sines in the fixed order
    dirs, ring, column = beam_directions(2.0)
    sin_t, cos_t = dm.sincos(dm.deg2rad(np.arange(1080, dtype=np.float64) * 0.25 - 135.0))
    sin_p, cos_p = dm.sincos(dm.deg2rad(np.arange(90, dtype=np.float64) * 2.0))
    want = np.stack(
        np.broadcast_arrays(cos_p[:, None] * sin_t[None, :], sin_p[:, None] * sin_t[None, :], cos_t[None, :]),
        axis=-1,
    ).reshape(-1, 3)
    assert dirs.tobytes() == want.tobytes()
    assert np.array_equal(ring, np.tile(np.arange(1080), 90)) and np.array_equal(
        column, np.repeat(np.arange(90), 1080)
    )


def preset_text() -> str:
    return PRESET.read_text(encoding="utf-8")


@pytest.mark.parametrize(
    "old, new, says",
    [
        ("count = 1080", "count = 0", "beams.count must be a whole number from 1 to 4096, got 0"),
        ('kind = "fan"', 'kind = "cone"', 'beams.kind must be one of "fan", "table", got "cone"'),
        ("step_deg = 0.25", "step_deg = -0.25", "beams.step_deg must be a number above 0"),
        ("column_period_s = 0.025", "column_period_s = 0", "timing.column_period_s must be a number above 0"),
        ("max_m = 15.0", "max_m = 45.0", "range.max_m must be a number above 0.1 and at most 30, got 45.0"),
        ("echoes = 3", "echoes = 4", "optics.echoes must be a whole number from 1 to 3, got 4"),
        (
            'kind = "rotating"',
            'kind = "hovering"',
            'mount.kind must be one of "rotating", "spinning", "fixed"',
        ),
        (
            "axis = [0.0, 0.0, 1.0]",
            "axis = [0.0, 0.0, 2.0]",
            "mount.axis must be a list of 3 numbers from -1 to 1",
        ),
        ("accuracy = [[10.0, 0.030], [30.0, 0.050]]", "accuracy = [[10.0, 0.030]]", "noise.accuracy must be"),
        (
            "sigma_m = 0.015",
            "sigma_m = 0.015\nsigma = 1",
            "unknown key 'noise.sigma'; allowed in [noise]: sigma_m",
        ),
    ],
)
def test_a_bad_device_value_names_the_key_the_value_and_what_is_allowed(old, new, says):
    text = preset_text()
    assert old in text
    with pytest.raises(UserError) as info:
        device_from_text(text.replace(old, new, 1), "mine.toml")
    assert str(info.value).startswith("mine.toml: ") and says in str(info.value)


def test_not_toml_and_an_unknown_preset_are_user_errors():
    with pytest.raises(UserError, match="mine.toml: not valid TOML"):
        device_from_text("id = ", "mine.toml")
    with pytest.raises(UserError) as info:
        device_named("vlp99")
    assert info.value.setting == "device" and "utm30lx-ew" in info.value.allowed


def table_device(mount_kind: str = "rotating"):
    """A toy multi-beam device: four beams with elevations and azimuth offsets."""
    data = toml_reader().loads(preset_text())
    data["id"] = "toy4"
    data["beams"] = {
        "kind": "table",
        "elevation_deg": [5.0, -15.0, 0.0, -2.0],
        "azimuth_offset_deg": [0, 3, 0, -3],
    }
    data["timing"] = {"column_period_s": 0.001, "steps_per_column": 8, "beam_step": [0, 1, 2, 3]}
    data["mount"]["kind"] = mount_kind
    return device_from_dict(data, "toy4.toml")


def test_a_beam_table_numbers_rings_from_the_lowest_elevation_and_offsets_each_beam():
    device = table_device()
    assert device.beams.ring == (3, 0, 2, 1) and not device.beams.planar
    assert device.beams.fan is None
    sensor = SensorConfig.for_device(device, rh_deg=90.0).validate()
    dirs, ring, column = beam_directions(90.0, device)
    assert sensor.beam_count == len(dirs) == 8
    for row, (r, m) in enumerate(zip(ring, column)):
        i = device.beams.ring.index(int(r))
        e = math.radians(device.beams.elevation_deg[i])
        psi = math.radians(90.0 * m + device.beams.azimuth_offset_deg[i])
        want = (math.cos(e) * math.cos(psi), math.cos(e) * math.sin(psi), math.sin(e))
        assert np.allclose(dirs[row], want, atol=1e-12)
    # the turned beams and the per-column directions agree with them
    assert np.allclose(rotated_beam_directions(np.eye(3), 90.0, device), dirs, atol=1e-15)
    assert np.allclose(directions_at(np.radians([0.0, 90.0]), device).reshape(-1, 3), dirs, atol=1e-12)
    assert sensor.to_dict()["device"] == "toy4" and "rv_deg" not in sensor.to_dict()


def test_the_scan_limits_come_from_the_device():
    device = replace(DEFAULT_DEVICE, id="dim", ranges=replace(DEFAULT_DEVICE.ranges, max_dark_m=20.0))
    with pytest.raises(UserError) as info:
        SensorConfig(max_range=25.0, device=device).validate()
    assert info.value.setting == "max_range" and info.value.allowed == (0, 20.0)
    assert SensorConfig(max_range=25.0).validate().max_range == 25.0
    assert "device" not in SensorConfig().to_dict()


def test_a_tilted_mount_is_refused_by_name_and_points_to_a_head():
    device = table_device("spinning")
    SensorConfig.for_device(device).validate()  # a spinning mount about Z scans
    tilted = replace(device, mount=replace(device.mount, tilt_deg=10.0))
    with pytest.raises(UserError, match=r"toy4: a spinning mount turns about \[0, 0, 1\] with tilt 0 .*head"):
        SensorConfig.for_device(tilted).validate()


def test_the_fallback_reader_reads_the_presets_as_tomllib_does():
    """Blender 3.4-4.0's Python 3.10 has neither tomllib nor tomli: the add-on reads its
    presets with simple_toml, which must agree with the real parser."""
    from wildscan.core.sensors import simple_toml

    for path in PRESETS_DIR.glob("*.toml"):
        text = path.read_text(encoding="utf-8")
        assert simple_toml.loads(text) == toml_reader().loads(text), path.name
    with pytest.raises(simple_toml.TOMLDecodeError, match="line 2: .*install tomli"):
        simple_toml.loads("[a]\nx = true\n")


@pytest.mark.parametrize("name", ["vlp16", "hdl64e", "utm30lx-ew"])
def test_the_directions_of_some_beams_are_the_rows_of_all_beams(name):
    """rotated_beams makes the beams asked for from their gathered angles: the same bits as
    rotated_beam_directions' rows, and with ranges the same bits as its rows times the ranges."""
    from wildscan.core.sensors.beams import rotated_beams
    from wildscan.core.spatial.leveling import leveling_matrix

    device = device_named(name)
    rh = SensorConfig.for_device(device).rh_deg
    rotation = leveling_matrix(0.03, -0.02)
    every = rotated_beam_directions(rotation, rh, device)
    rng = np.random.default_rng(0)
    for share in (0.05, 0.5, 0.9, 1.0):
        beams = np.flatnonzero(rng.random(len(every)) < share)
        ranges = rng.uniform(0.5, 80.0, len(beams))
        assert rotated_beams(rotation, rh, device, beams).tobytes() == every[beams].tobytes()
        points = rotated_beams(rotation, rh, device, beams, ranges)
        assert points.tobytes() == (every[beams] * ranges[:, None]).tobytes()


def test_eq_2_kept_for_a_pose_is_a_copy_with_the_bits_made_afresh():
    from wildscan.core.spatial.leveling import _leveling, leveling_matrix

    first = leveling_matrix(0.02, 0.1)
    first[0, 0] = 7.0  # a caller changing its copy changes nothing kept
    for roll, pitch in ((0.02, 0.1), (-0.0, 0.1), (0.0, 0.1), (np.float64(0.3), -0.2)):
        assert leveling_matrix(roll, pitch).tobytes() == _leveling(roll, pitch).tobytes()
