"""The endless pose search places each candidate on a caster over only the triangles near it
(app/poses.py TileBackends.caster, app/tiles.py placement_caster): it accepts and rejects the
candidates the whole full-detail tiles do, and an accepted pose stands where the dataset
worker's scan stands on its own world (LandWorld.for_scan): the same x, y, z, roll and pitch."""

from __future__ import annotations

import numpy as np

from wildscan.app.dataset.spec import spec_from_dict


def _placed(backend, pose, height):
    from wildscan.core.errors import PoseRejected
    from wildscan.core.placement import place

    try:
        p = place(backend, pose, None, height)
    except PoseRejected as e:
        return ("rejected", str(e))
    return (
        "placed",
        p.optical_centre.tobytes(),
        p.ground_centre.tobytes(),
        float(p.roll_rad),
        float(p.pitch_rad),
    )


def _element_centres(geometry, name: str, count: int) -> list[tuple[float, float]]:
    """The xy middles of the first `count` elements of a class: poses on a trunk, a rock or a
    log, which the placement rejects or accepts tilted, besides the plain ground's poses."""
    from wildscan.core.classes import class_by_name

    mine = geometry.class_id == class_by_name(name).id
    out = []
    for o in np.unique(geometry.object_index[mine])[:count]:
        v = geometry.vertices[np.unique(geometry.faces[geometry.object_index == o])]
        out.append((round(float(v[:, 0].mean()), 3), round(float(v[:, 1].mean()), 3)))
    return out


def test_a_pose_placed_near_stands_as_on_the_whole_tiles_and_where_the_scan_places_itself(tmp_path):
    from wildscan.app.cache.config import cache_config, open_cache
    from wildscan.app.dataset.draws import draw_sensor
    from wildscan.app.dataset.land import LandWorld
    from wildscan.app.poses import TileBackends
    from wildscan.app.tile_memory import TileMemory
    from wildscan.app.tiles import TiledWorld, full_detail, tiles_geometry
    from wildscan.core.placement import Pose
    from wildscan.core.posesampler import ScanPose
    from wildscan.raycast.select import make_backend

    cache, memory = open_cache(cache_config(tmp_path / "cache")), TileMemory()
    spec = spec_from_dict({"detail": "low", "sensor": {"rh": 4.0, "max_range": 10.0}})
    world = TiledWorld(1, spec.biome, "low", spec.vegetation)
    sensor = draw_sensor(spec.sensor, 1, 0)
    backends = TileBackends(world, cache, memory)
    land = LandWorld(1, world, [], cache, 0.0, False)
    rng = np.random.default_rng(7)
    # plain ground round four tiles' corner (the caster then takes four tiles), and elements' middles
    tile = backends.parts(backends.key(0.0, 0.0))[0].geometry
    xy = [tuple(p) for p in np.round(rng.uniform(-12.0, 12.0, (6, 2)), 3)]
    xy += (
        _element_centres(tile, "rock", 3)
        + _element_centres(tile, "log", 3)
        + _element_centres(tile, "trunk", 2)
    )
    outcomes = []
    for x, y in xy:
        pose = Pose(float(x), float(y), float(round(rng.uniform(0.0, 360.0), 1)))
        caster = backends.caster(pose.x, pose.y)
        near = _placed(caster, pose, sensor.mount_height)
        # the scan's own world, placed on as the dataset worker's scan places itself: the same bits
        scan = land.for_scan(ScanPose("forest", pose.x, pose.y, pose.yaw_deg, "random"), sensor).backend
        assert _placed(scan, pose, sensor.mount_height) == near
        # the whole full-detail tiles (the search before): the same answer, to float64 rounding
        # (that caster's local origin is the tiles' middle, not the pose's)
        whole, _ = tiles_geometry(world, full_detail(backends.key(pose.x, pose.y)), cache, memory)
        before = _placed(make_backend("auto", geometry=whole, notify=None), pose, sensor.mount_height)
        assert before[0] == near[0]
        if near[0] == "placed":
            for a, b in zip(before[1:], near[1:]):
                a, b = (np.frombuffer(v) if isinstance(v, bytes) else v for v in (a, b))
                assert np.allclose(a, b, rtol=0, atol=1e-12)
        assert caster.geometry.triangle_count < whole.triangle_count / 20
        outcomes.append(near[0])
    assert outcomes.count("placed") >= 8 and outcomes.count("rejected") >= 3, outcomes  # both compared
