"""Weather (core/effects/weather.py): fog, rain, dust and snow on the effects seam. Clear air and
any effect at zero keep today's bytes; particles are class 15 with a `weather` field; a surface
behind a particle keeps its exact class; far points fall with rain rate and fog density; a
wall's lost returns follow the model's own curve; bad values exit 2 naming the key."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from wildscan.app.scan import scan_effects
from wildscan.core.classes import PARTICLE_ID, class_table_dict, listed_classes
from wildscan.core.effects import CLEAR_AIR, Effects, Rays, Weather
from wildscan.core.effects import particles as P
from wildscan.core.effects.weather import CODES, parse_settings
from wildscan.core.errors import UserError
from wildscan.core.io.ply import header_comments
from wildscan.core.label_schemes import SCHEMES
from wildscan.core.placement import Pose
from wildscan.core.scan import run_scan
from wildscan.core.sensors import SensorConfig

from tests.helpers.analytic import weather_scene as scene
from tests.helpers.scene_helpers import PAPER

TERRAIN, FENCE, ROCK = 1, 6, 9


def scan(weather: str, model: str = "paper", rh: float = 4.0, noise: float = 0.0):
    sensor = SensorConfig(rh_deg=rh, noise_sigma=noise, model=model, max_range=30.0).validate()
    return run_scan(
        scene(), Pose(0.0, 0.0, 0.0), sensor, effects=scan_effects(parse_settings(weather), sensor)
    )


@pytest.mark.parametrize(
    "text, words",
    [
        ("rain=-1", ["rain=", "out of range", "0 to 500 mm/h"]),
        ("fog=2", ["fog=", "5 to 100000 m of visibility"]),
        ("snow=abc", ["snow=", "not a number", "0 to 100"]),
        ("dust=nan", ["dust=", "not a number"]),
        ("hail=3", ["no key 'hail'", "fog, rain, dust, snow"]),
        ("rain", ["not KEY=VALUE"]),
        ("rain=1,rain=2", ["names rain twice"]),
    ],
)
def test_a_bad_value_names_the_key_and_its_range(text, words):
    with pytest.raises(UserError) as caught:
        parse_settings(text)
    assert caught.value.setting == "weather"
    for word in words:
        assert word in str(caught.value)


def test_a_bad_value_on_the_command_line_exits_2_with_one_line(tmp_path):
    run = subprocess.run(
        [sys.executable, "-m", "wildscan.cli", "scan", *PAPER, "--seed", "0", "--pose", "0", "0", "0"]
        + ["--weather", "rain=1000", "--out", str(tmp_path / "s.ply")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 2
    assert run.stderr.strip().count("\n") == 0 and "--weather rain='1000' is out of range" in run.stderr
    assert not list(tmp_path.iterdir())


def test_combined_keys_parse_and_every_zero_is_clear_air():
    assert parse_settings("rain=10, FOG=200") == {"rain": 10.0, "fog": 200.0}
    assert parse_settings("none") == {}
    assert Weather.of({"rain": 0.0, "fog": 0.0, "dust": 0, "snow": 0}) is None
    sensor = SensorConfig()
    assert scan_effects({"rain": 0.0}, sensor) is CLEAR_AIR


@pytest.mark.parametrize("model", ["paper", "realistic"])
def test_rain_0_is_the_clear_scan_byte_for_byte(model):
    clear, dry = scan("none", model, noise=0.015), scan("rain=0,fog=0", model, noise=0.015)
    assert header_comments(dry.cloud, dry.metadata) == header_comments(clear.cloud, clear.metadata)
    assert dry.cloud.to_structured().tobytes() == clear.cloud.to_structured().tobytes()
    assert "particle" not in str(clear.metadata["classes"]) and "effects" not in clear.metadata


def test_a_paper_scan_in_rain_gives_particles_with_their_effect_and_keeps_every_surface_exact():
    clear, wet = scan("none", rh=2.0), scan("rain=100", rh=2.0)
    particle = wet.cloud.label == PARTICLE_ID
    assert particle.sum() > 10
    assert np.all(wet.cloud.extra["weather"][particle] == CODES["rain"])
    assert np.all(wet.cloud.extra["weather"][~particle] == 0) and np.all(wet.cloud.instance[particle] == 0)
    assert wet.cloud.range[particle].max() <= 2.3  # drops are seen within ~2.2 m only
    # every surface point is the clear scan's point of that beam, bit for bit
    key = lambda c: c.ring.astype(np.int64) * 10_000 + c.sweep  # noqa: E731
    where = {k: i for i, k in enumerate(key(clear.cloud))}
    rows = np.array([where[k] for k in key(wet.cloud)[~particle]])
    assert np.array_equal(wet.cloud.xyz[~particle], clear.cloud.xyz[rows])
    assert np.array_equal(wet.cloud.label[~particle], clear.cloud.label[rows])
    assert "particle" in str(wet.metadata["classes"]) and wet.metadata["effects"]["weather"]["rain"] == 100.0
    assert any("15 particle" in line for line in header_comments(wet.cloud, wet.metadata))


def test_a_realistic_beam_gives_a_particle_echo_then_the_surface_behind_with_its_exact_class():
    wet = scan("rain=100", "realistic", rh=2.0)
    cloud = wet.cloud
    key = cloud.ring.astype(np.int64) * 10_000 + cloud.sweep
    particle = cloud.label == PARTICLE_ID
    first = key[particle & (cloud.extra["echo"] == 1)]
    behind = np.isin(key, first) & ~particle & (cloud.extra["echo"] > 1)
    assert behind.sum() > 5
    on_fence = behind & (cloud.label == FENCE) & (cloud.extra["mixed"] == 0)
    assert on_fence.sum() > 0
    # the fence is the plane x = 8: its points lie on it (leveled frame = world here, pose flat)
    assert np.abs(cloud.xyz[on_fence, 0] - 8.0).max() < 1e-3
    assert np.all(cloud.extra["weather"][particle] == CODES["rain"])
    assert np.all(cloud.extra["mixed"][particle & (cloud.extra["label_purity"] == 1)] == 0)


def far_points(weather: str) -> int:
    return int((scan(weather).cloud.range > 10.0).sum())


def test_points_beyond_10m_fall_with_rain_rate_and_fog_density():
    rain = [far_points(w) for w in ("none", "rain=10", "rain=50", "rain=200")]
    fog = [far_points(w) for w in ("none", "fog=2000", "fog=200", "fog=30")]
    assert rain == sorted(rain, reverse=True) and rain[0] > rain[-1]
    assert fog == sorted(fog, reverse=True) and fog[0] > fog[-1]
    assert fog[-1] < fog[0] / 5  # fog=30: a few metres of range left


@pytest.mark.parametrize("text", ["fog=200", "rain=100", "dust=0.5", "snow=20"])
def test_a_walls_lost_returns_follow_the_models_curve(text):
    from wildscan.bench.weather import paper_lost

    weather = Weather.of(parse_settings(text))
    for r in (3.0, 12.0, 25.0):
        assert paper_lost(weather, r, 8000) == pytest.approx(
            float(weather.lost_fraction(np.array([r]))[0]), abs=0.03
        )


def test_draws_are_keyed_on_the_ray_so_a_run_split_in_two_sees_the_same_particles():
    weather = Weather.of({"fog": 60.0, "rain": 50.0}, seed=7)
    n = 4000
    dirs = np.tile([1.0, 0.0, 0.0], (n, 1))
    from wildscan.bench.weather import Wall

    hits = Wall(12.0)(np.zeros(3), dirs, 30.0)
    whole = weather.medium(Rays(np.zeros(3), dirs, 30.0), hits)
    half = n // 2
    first = weather.medium(Rays(np.zeros(3), dirs[:half], 30.0), hits.rows(slice(0, half)))
    second = weather.medium(Rays(np.zeros(3), dirs[half:], 30.0, index0=half), hits.rows(slice(half, n)))
    assert np.array_equal(whole.distance, np.concatenate([first.distance, second.distance]))
    assert np.array_equal(whole.class_id, np.concatenate([first.class_id, second.class_id]))
    other = Weather.of({"fog": 60.0, "rain": 50.0}, seed=8).medium(Rays(np.zeros(3), dirs, 30.0), hits)
    assert not np.array_equal(whole.distance, other.distance)


def test_published_numbers():
    # Koschmieder: 3.912 / V; Kim: fog (V < 500 m) has q = 0, haze at 10 km q = 1.3
    assert P.fog_extinction(100.0) == pytest.approx(0.03912)
    assert P.fog_extinction(10_000.0) == pytest.approx(3.912e-4 * (905 / 550) ** -1.3)
    # Marshall-Palmer at 25 mm/h: extinction 2 * pi N0 / (2 Lambda^3), ~12 dB/km
    lam = 4.1 * 25**-0.21
    assert 2 * P.hit_rate("rain", 25.0) == pytest.approx(np.pi * 8000 / lam**3 * 1e-6)
    # Chepil & Woodruff: 56 mg/m^3 is a visibility of 1 km
    assert P.dust_visibility(0.056) == pytest.approx(1000.0)
    # the range equation's R_max: R e^(alpha R) = 30
    r = P.max_range(0.05, 30.0)
    assert r * np.exp(0.05 * r) == pytest.approx(30.0, rel=1e-9)


def test_every_label_scheme_maps_the_particle_class_and_clear_tables_do_not_list_it():
    assert {s.from_wildscan[PARTICLE_ID] for s in SCHEMES.values()} == {15, 1, 0, 56, 255}  # 255: wildscenes
    assert [c["id"] for c in class_table_dict()][-1] == 12
    assert [c["id"] for c in class_table_dict(listed_classes(declared=Weather.classes))][-1] == PARTICLE_ID


def test_a_scan_in_motion_sees_particles_and_consecutive_2d_scans_see_different_ones():
    from wildscan.core.motion import placements, sweep, trajectory

    backend = scene()
    sensor = SensorConfig(rh_deg=4.0, noise_sigma=0.0, max_range=30.0)
    path = trajectory.straight_path(0.0, 0.0, 0.0, 2.0)
    plan = trajectory.schedule(path, 1.0, sensor.sweeps, 1)
    times, xy, yaw = trajectory.instants(path, 1.0, plan.scans_2d + 1)
    motion = placements.place_all(backend, times, xy, yaw, times)
    noise = np.zeros(plan.scans_2d * sensor.beams_per_column)
    effects = Effects((Weather.of({"snow": 30.0}, seed=1),))
    run = sweep.sweep(backend, motion, 0, plan.scans_2d, sensor, "stepped", noise, "world", None, effects)
    cloud = run.raw
    flakes = cloud.label == PARTICLE_ID
    assert flakes.sum() > 10 and np.all(cloud.extra["weather"][flakes] == CODES["snow"])
    # the head turns between 2D scans, so compare rings: which beams met a flake differs from scan to scan
    by_scan = [set(cloud.ring[flakes & (cloud.sweep == m)]) for m in range(2)]
    assert by_scan[0] != by_scan[1]


def test_a_weather_table_is_checked_drawn_per_scan_and_left_out_of_a_clear_specs_hash():
    from wildscan.app.dataset.draws import draw_weather
    from wildscan.app.dataset.spec import DatasetSpec, spec_from_dict, spec_from_json

    spec = spec_from_dict({"weather": {"rain": [5, 50], "fog": 300}})
    assert spec.weather == (("fog", 300.0), ("rain", (5.0, 50.0)))
    draws = [draw_weather(spec, 1, i)["rain"] for i in range(4)]
    assert all(5 <= d <= 50 for d in draws) and len(set(draws)) == 4
    assert draws == [draw_weather(spec, 1, i)["rain"] for i in range(4)]
    assert spec_from_json(spec.to_dict()) == spec
    assert "weather" not in DatasetSpec().to_dict()  # a clear spec's config hash is unchanged
    assert spec.config_hash() != DatasetSpec().config_hash()
    for bad, words in (
        ({"rain": 900}, "weather.rain: rain=900 is out of range"),
        ({"hail": 1}, "unknown key"),
    ):
        with pytest.raises(UserError, match=words):
            spec_from_dict({"weather": bad})


def test_a_dataset_in_rain_writes_particles_and_its_card_gives_their_share(tmp_path):
    import json

    from tests.helpers.dataset_helpers import wildscan

    spec = tmp_path / "SPEC.toml"
    spec.write_text(
        'layout = "paper"\nseeds = [1]\nscans_per_world = 1\nformats = ["ply"]\n'
        "[poses]\nzones = { park = 1 }\n"
        "[sensor]\nrh = 6.0\n[weather]\nrain = [150, 200]\nfog = 100\n"
    )
    run = wildscan("dataset", str(spec), "--out", str(tmp_path / "out"), "--workers", "1")
    assert run.returncode == 0, run.stderr
    card = json.loads((tmp_path / "out" / "dataset.json").read_text())
    share = card["totals"]["particle_share"]
    assert 0 < share < 1 and card["totals"]["class_points"]["particle"] > 0
    assert "of points are particles" in (tmp_path / "out" / "CARD.md").read_text()
    assert '15: "particle"' in (tmp_path / "out" / "labels.yaml").read_text()  # listed with weather
