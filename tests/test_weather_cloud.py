"""A dust cloud (core/effects/dust_cloud.py): dust in a vertical cylinder, clear air outside.
A beam that never enters the cloud keeps its clear-air hit byte for byte; a beam through it
meets dust only inside; the same seed gives the same particles."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.app.scan import scan_effects
from wildscan.core.classes import PARTICLE_ID
from wildscan.core.effects import CLEAR_AIR, Rays, Weather
from wildscan.core.effects.dust_cloud import Cylinder
from wildscan.core.effects.weather import parse_settings
from wildscan.core.errors import UserError
from wildscan.core.hits import RayHits
from wildscan.core.placement import Pose
from wildscan.core.scan import run_scan
from wildscan.core.sensors import SensorConfig

from tests.helpers.analytic import weather_scene as scene

ORIGIN = np.array([0.0, 0.0, 1.0])
WALL = 20.0  # m: every beam of the fan hits a wall this far


def fan(count: int = 4000) -> tuple[Rays, RayHits]:
    """Level beams all round from ORIGIN, each hitting a wall at WALL m."""
    angle = np.linspace(-np.pi, np.pi, count, endpoint=False)
    directions = np.stack([np.cos(angle), np.sin(angle), np.zeros(count)], axis=1)
    hits = RayHits(np.full(count, WALL), np.full(count, 1, np.int16), np.arange(count, dtype=np.int32))
    return Rays(ORIGIN, directions, 30.0), hits


def test_a_region_parses_with_the_other_keys_and_bad_ones_name_the_form():
    assert parse_settings("rain=10,dust=0.5@12,-3,8,4,fog=300") == {
        "rain": 10.0,
        "dust": 0.5,
        "dust_at": [12.0, -3.0, 8.0, 4.0],
        "fog": 300.0,
    }
    assert parse_settings("dust=0.5@12,-3,8") == {"dust": 0.5, "dust_at": [12.0, -3.0, 8.0]}
    for bad, words in (
        ("dust=0.5@1,2", r"is not X,Y,RADIUS\[,TOP\]"),
        ("dust=0.5@1,2,0", "radius 0; it must be above 0"),
        ("dust=0.5@1,2,x", "is not X,Y,RADIUS"),
        ("rain=5@1,2,3", "only dust takes a region"),
        ("dust=20@1,2,3", "dust='20' is out of range"),
    ):
        with pytest.raises(UserError, match=words):
            parse_settings(bad)


def test_segments_are_the_exact_intersection_with_the_cylinder_and_its_top():
    cyl = Cylinder(10.0, 0.0, 2.0, top=3.0)
    directions = np.array([[1.0, 0, 0], [0, 1.0, 0], [0.6, 0, 0.8], [0, 0, 1.0]])
    t0, t1 = cyl.segments(np.array([[0.0, 0, 0], [0, 0, 0], [0, 0, 0], [10.5, 0, -1]]), directions)
    assert (t0[0], t1[0]) == (8.0, 12.0)  # along the axis' line: through the diameter
    assert t0[1] >= t1[1]  # beside it: never inside
    assert t0[2] >= t1[2]  # rising at 0.6/0.8: above the top (z 6) before reaching x 8
    assert t0[3] == 0.0 and t1[3] == pytest.approx(4.0)  # a vertical ray inside, up to the top


def test_a_beam_that_never_enters_the_cloud_keeps_its_clear_air_hit_byte_for_byte():
    rays, hits = fan()
    weather = Weather.of(parse_settings("dust=10@3,0,2"), seed=3)
    seen = weather.medium(rays, hits)
    clear = CLEAR_AIR.medium(rays, hits)
    t0, t1 = weather.cloud.region.segments(rays.origins, rays.directions)
    outside = ~(t0 < t1)
    assert 0 < outside.sum() < len(outside)
    for name in ("distance", "class_id", "instance"):
        got, want = getattr(seen, name)[outside], getattr(clear, name)[outside]
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes(), name
    assert seen.overrides()[outside].tobytes() == clear.overrides()[outside].tobytes()


def test_a_beam_through_the_cloud_meets_dust_only_inside_it_and_the_same_seed_the_same_dust():
    rays, hits = fan()
    weather = Weather.of(parse_settings("dust=10@3,0,2"), seed=3)
    seen = weather.medium(rays, hits)
    particle = seen.class_id == PARTICLE_ID
    assert particle.sum() > 100
    where = ORIGIN + rays.directions[particle] * seen.distance[particle][:, None]
    assert np.hypot(where[:, 0] - 3.0, where[:, 1]).max() <= 2.0 + 1e-9
    assert np.all(seen.instance[particle] == 3)  # the dust's code, the scan's `weather` field
    again = Weather.of(parse_settings("dust=10@3,0,2"), seed=3).medium(rays, hits)
    assert again.distance.tobytes() == seen.distance.tobytes()
    other = Weather.of(parse_settings("dust=10@3,0,2"), seed=4).medium(rays, hits)
    assert other.distance.tobytes() != seen.distance.tobytes()


def test_a_thick_cloud_loses_the_surfaces_behind_it_and_no_other():
    rays, hits = fan()
    weather = Weather.of(parse_settings("dust=10@8,0,5"), seed=1)
    seen = weather.medium(rays, hits)
    t0, t1 = weather.cloud.region.segments(rays.origins, rays.directions)
    deep = t1 - t0 > 8.0  # 20 e^(0.25 * 8) > 30 m: past the budget
    lost = np.isinf(seen.distance)
    assert deep.sum() > 100 and not np.any(seen.distance[deep] == WALL)  # lost, or a dust echo
    assert lost[deep].any() and (seen.class_id[deep] == PARTICLE_ID).any()
    assert not lost[~(t0 < t1)].any()


def test_a_scan_beside_a_cloud_it_never_reaches_is_the_clear_scan_plus_a_zero_weather_field():
    sensor = SensorConfig(rh_deg=4.0, noise_sigma=0.0, max_range=30.0).validate()
    clear = run_scan(scene(), Pose(0.0, 0.0, 0.0), sensor).cloud
    effects = scan_effects(parse_settings("dust=5@200,200,10"), sensor)
    cloudy = run_scan(scene(), Pose(0.0, 0.0, 0.0), sensor, effects=effects).cloud
    fields = list(clear.to_structured().dtype.names)
    assert np.array_equal(cloudy.to_structured()[fields], clear.to_structured())
    assert not cloudy.extra["weather"].any()
