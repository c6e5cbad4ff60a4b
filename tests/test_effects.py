"""Effects (core/effects): clear air changes nothing, and the medium hook is called in each of
the three scan paths (paper, realistic, in motion) with what it needs, its hits used."""

from __future__ import annotations

import numpy as np
import pytest

from wildscan.core.effects import CLEAR_AIR, Effect, Effects, Rays, Wind
from wildscan.core.errors import UserError
from wildscan.core.hits import RayHits
from wildscan.core.motion import placements, sweep, trajectory
from wildscan.core.placement import Pose
from wildscan.core.scan import run_scan
from wildscan.core.sensors import SensorConfig

from tests.helpers.analytic import AnalyticBackend, Patch

TERRAIN, FENCE = 1, 6
LIMIT = 5.0  # m


class DropBeyond(Effect):
    """A medium that swallows every ray whose first hit lies beyond `limit` (a test effect)."""

    name = "drop_beyond"
    changes_medium = True

    def __init__(self, limit: float):
        self.limit = limit
        self.calls: list[Rays] = []

    def describe(self) -> dict:
        return {"limit": self.limit}

    def medium(self, rays: Rays, hits: RayHits) -> RayHits:
        self.calls.append(rays)
        far = hits.distance > self.limit
        return RayHits(
            distance=np.where(far, np.inf, hits.distance),
            class_id=np.where(far, -1, hits.class_id).astype(np.int16),
            instance=np.where(far, -1, hits.instance).astype(np.int32),
            untagged_objects=hits.untagged_objects,
            normal=None if hits.normal is None else np.where(far[:, None], 0.0, hits.normal),
            reflectivity=hits.reflectivity,
        )


def scene() -> AnalyticBackend:
    return AnalyticBackend(
        [
            Patch((0, 0, 0), (0, 0, 1), TERRAIN),
            Patch((8, 0, 0), (-1, 0, 0), FENCE, instance=3, xy_box=(7, 9, -6, 6)),
        ]
    )


def test_clear_air_is_the_very_hits_it_was_given():
    hits = RayHits.empty(4)
    rays = Rays(np.zeros(3), np.tile([1.0, 0.0, 0.0], (4, 1)), 10.0)
    assert not CLEAR_AIR and CLEAR_AIR.medium(rays, hits) is hits
    # an effect without a medium (the wind moves the scene) leaves the medium clear too
    windy = Effects((Wind(4.0, 1),))
    assert not windy.changes_medium and windy.medium(rays, hits) is hits
    assert windy.scene_mover is windy.items[0]


def test_two_effects_that_move_the_scene_are_refused():
    with pytest.raises(UserError, match="wind, wind both move the scene"):
        Effects((Wind(4.0, 1), Wind(2.0, 2)))


@pytest.mark.parametrize("model", ["paper", "realistic"])
def test_a_static_scan_sees_through_the_medium(model):
    sensor = SensorConfig(rh_deg=4.0, noise_sigma=0.0, model=model, max_range=15.0)
    pose = Pose(0.0, 0.0, 0.0)
    clear = run_scan(scene(), pose, sensor)
    drop = DropBeyond(LIMIT)
    hazy = run_scan(scene(), pose, sensor, effects=Effects((drop,)))
    assert len(drop.calls) == 1
    rays = drop.calls[0]
    subrays = 1 if model == "paper" else 5
    assert len(rays.directions) == subrays * sensor.beam_count and rays.times is None
    assert clear.cloud.range.max() > LIMIT + 1 and hazy.cloud.range.max() <= LIMIT
    assert hazy.metadata["effects"] == {"drop_beyond": {"limit": LIMIT}} and "effects" not in clear.metadata
    if model == "paper":  # every beam it kept is the clear scan's, bit for bit
        near = clear.cloud.range <= LIMIT
        assert np.array_equal(hazy.cloud.xyz, clear.cloud.xyz[near])
        assert np.array_equal(hazy.cloud.label, clear.cloud.label[near])


def test_a_scan_in_motion_sees_through_the_medium():
    backend = scene()
    sensor = SensorConfig(rh_deg=4.0, noise_sigma=0.0)
    path = trajectory.straight_path(0.0, 0.0, 0.0, 2.0)
    plan = trajectory.schedule(path, 1.0, sensor.sweeps, 1)
    times, xy, yaw = trajectory.instants(path, 1.0, plan.scans_2d + 1)
    motion = placements.place_all(backend, times, xy, yaw, times)
    noise = np.zeros(plan.scans_2d * sensor.beams_per_column)
    clear = sweep.sweep(backend, motion, 0, plan.scans_2d, sensor, "stepped", noise, "world")
    drop = DropBeyond(LIMIT)
    hazy = sweep.sweep(
        backend, motion, 0, plan.scans_2d, sensor, "stepped", noise, "world", None, Effects((drop,))
    )
    rays = np.concatenate([r.directions for r in drop.calls])
    assert len(rays) == plan.scans_2d * 1080
    # each ray knows its time: beam n of 2D scan k at k * 25 ms + n * 25/1440 ms
    t = np.concatenate([r.times for r in drop.calls])
    assert t[1080 + 2] == pytest.approx(0.025 + 2 * 0.025 / 1440, abs=1e-15)
    assert clear.raw.range.max() > LIMIT + 1 and hazy.raw.range.max() <= LIMIT
    near = clear.returns.keep & (clear.returns.range <= LIMIT)
    assert np.array_equal(hazy.returns.keep, near)
