"""Biomes, the ground cover (a sward layer a beam stops in) and deadwood (docs/ground.md)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from wildscan.core.classes import LOG_ID, class_by_name
from wildscan.core.io.ply import header_comments
from wildscan.core.world import plan_hash, plan_world
from wildscan.core.world.cover import BUSH, COVER_INSTANCE_BASE, HIGH_GRASS, LOW_GRASS

from tests.helpers.golden_cases import load

COVER = {LOW_GRASS, HIGH_GRASS, BUSH}


@functools.lru_cache(maxsize=4)
def plan(biome: str):
    return plan_world(1, biome=biome)


@functools.lru_cache(maxsize=2)
def geometry(biome: str):
    from wildscan.raycast.from_plan import plan_geometry

    return plan_geometry(plan(biome))


def scan(biome: str, zone: str, frame: str = "world", noise: float | None = 0.0):
    from wildscan.app.poses import plan_backend, valid_poses
    from wildscan.app.scan import scan_current_scene
    from wildscan.core.placement import Pose
    from wildscan.core.sensors import SensorConfig

    p = valid_poses(plan(biome), plan_backend(plan(biome)), 1)[zone][0]
    sensor = SensorConfig(rh_deg=2.0, noise_sigma=noise)
    pose = Pose(p["x"], p["y"], p["yaw"])
    return scan_current_scene(
        pose, sensor, frame, p.get("z_start"), "embree", geometry=geometry(biome), notify=lambda _: None
    )


def test_the_paper_biome_is_the_world_from_before_biomes_byte_for_byte():
    assert plan_hash(plan("paper")) == load("worlds.json")["1/default"]
    assert plan("paper").cover is None
    assert not plan("paper").elements_of(wildscan_class="log")


def test_the_default_biome_covers_the_ground():
    shares = plan("mixed").cover.shares()
    assert shares["low grass"] > 0.2 and shares["bush"] > 0.05 and shares["high grass"] > 0.05
    assert shares["bare"] < 0.25


def test_the_trail_is_a_two_track_bare_wheel_tracks_and_a_grass_median():
    from wildscan.core.world.stages import cover as stage
    from wildscan.core.world.stages.cover import WHEEL_GAUGE

    p = plan("mixed")
    cover, trail = p.cover, p.layout.trail
    path = trail.path[5:-5]  # (clear of the ends, where the strip stops)
    tangent = np.gradient(path, axis=0)
    tangent /= np.hypot(tangent[:, 0], tangent[:, 1])[:, None]
    normal = np.column_stack([-tangent[:, 1], tangent[:, 0]])

    cls, height = cover.at(path[:, 0], path[:, 1])
    assert (cls == LOW_GRASS).mean() > 0.9 and (height[cls == LOW_GRASS] > 0.05).all()  # the median
    for side in (-1, 1):  # each wheel line runs through bare cells all along (a digital line)
        wheel = path + side * WHEEL_GAUGE / 2 * normal
        bare = np.zeros(len(path), dtype=bool)
        for dx in (-0.25, 0.0, 0.25):
            for dy in (-0.25, 0.0, 0.25):
                bare |= cover.at(wheel[:, 0] + dx, wheel[:, 1] + dy)[0] == 0
        assert bare.all()
    # the tread's cells: its bare share is the two tracks' (0.35-0.5 m each) of its 2.0-2.6 m
    n = cover.shape[0]
    tread = stage._tread(p, n)
    share = (cover.class_id[tread] == 0).mean()
    assert 0.25 < share < 0.55, share


def test_the_cave_roof_and_walls_are_rock_and_its_floor_and_ramp_terrain():
    from wildscan.core.world.stages.cave import ROCK_FACE_TAN

    p = plan("mixed")
    cave = p.layout.cave
    roof = next(e for e in p.elements if e.proto == "cave_roof")
    faces = next(e for e in p.elements if e.proto == "cave_rock_faces")
    assert roof.wildscan_class == faces.wildscan_class == "rock"
    assert roof.instance == next(e for e in plan("paper").elements if e.proto == "cave_roof").instance

    def slopes(el):
        t = p.element_vertices(el)[p.prototypes[el.proto].faces]
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        return np.hypot(n[:, 0], n[:, 1]) / np.abs(n[:, 2]), t.mean(axis=1)

    steep, centre = slopes(faces)
    assert len(steep) > 500 and (steep > ROCK_FACE_TAN).all()
    assert cave.bare(centre[:, 0], centre[:, 1]).all()  # in the cave, nowhere else
    terrain = p.elements_of("terrain", stage="terrain")[0]
    slope, centre = slopes(terrain)
    in_cave = cave.bare(centre[:, 0], centre[:, 1])
    assert in_cave.sum() > 1000 and (slope[in_cave] <= ROCK_FACE_TAN).all()
    # the floor and the ramp's flat part stay terrain
    c = cave.pit
    for u, v in ((0.0, 0.0), (0.3 * c.a, 0.0), (c.a + 0.5 * cave.ramp_length, 0.0)):
        x, y = c.to_world(u, v)
        near = np.hypot(centre[:, 0] - x, centre[:, 1] - y) < 0.5
        assert near.any(), (u, v)
    # together the same triangles as the paper world's one terrain mesh
    whole = plan("paper").prototypes["terrain"].faces
    assert len(whole) == len(p.prototypes["terrain"].faces) + len(p.prototypes["cave_rock_faces"].faces)


def test_the_paper_cave_is_terrain_as_before():
    p = plan("paper")
    assert next(e for e in p.elements if e.proto == "cave_roof").wildscan_class == "terrain"
    assert "cave_rock_faces" not in p.prototypes and not p.elements_of("rock", zone="cave", stage="terrain")


def test_the_cave_is_bare_and_the_plateau_around_it_grows_a_sward():
    p = plan("mixed")
    cave, cover = p.layout.cave, p.cover
    c = cave.pit
    floor = np.array([c.to_world(u, v) for u, v in ((0.0, 0.0), (-0.5 * c.a, 0.0), (c.a + 2.0, 0.0))])
    assert (cover.at(floor[:, 0], floor[:, 1])[0] == 0).all()  # the pit's floor, under the roof, the ramp
    # a ring just outside the pit's edge (inside an element's keep-out margin, off the ramp):
    # plateau, where the sward grows as anywhere
    ring = np.array(
        [c.to_world(-(c.a + 0.5) * np.cos(t), (c.b + 0.5) * np.sin(t)) for t in np.linspace(0.5, 2.6, 12)]
    )
    ring = ring[~cave.bare(ring[:, 0], ring[:, 1])]
    assert len(ring) and (cover.at(ring[:, 0], ring[:, 1])[0] > 0).mean() > 0.5


def test_a_cells_leaf_area_is_its_class_lai_whatever_its_height():
    from wildscan.core.world.cover import LAI, extinction

    heights = np.array([0.12, 0.25, 0.35])  # a lawn, a meadow, a tall patch of it
    k = extinction(np.full(3, LOW_GRASS), heights)
    assert np.allclose(k * heights, 0.5 * LAI[LOW_GRASS])  # G LAI: the soil's chance to show is the same
    assert extinction(np.array([0]), np.array([0.0]))[0] == 0.0


def test_leaf_litter_lies_on_the_forests_floor_only():
    from wildscan.core.world.stages import cover as stage

    p = plan("mixed")
    n = p.cover.shape[0]
    centres = p.cover.x0 + (np.arange(n) + 0.5) * p.cover.cell
    x, y = np.meshgrid(centres, centres)
    ground = 0.25 * sum(
        a for a in (p.cover.node_ground()[i : i + n, j : j + n] for i in (0, 1) for j in (0, 1))
    )
    bare = stage._bare(p, x, y, ground) | stage._tread(p, n)
    shade = stage._shade(p, x, y) & ~bare & ~stage._wet(p, x, y, ground)
    forest = stage._in_cell(p, "forest", x, y)
    litter = shade & (p.cover.class_id == 0)
    assert litter[forest].any() and not litter[~forest].any()


def test_biomes_change_the_mix_not_the_zones():
    a, b = plan("mixed"), plan("scrub")
    assert a.layout.cells == b.layout.cells
    assert np.array_equal(a.grid.z, b.grid.z)
    assert b.cover.shares()["bush"] > a.cover.shares()["bush"]


def test_deadwood_lies_in_the_forest_as_logs():
    logs = plan("mixed").elements_of(wildscan_class="log")
    assert sum(e.zone == "forest" for e in logs) >= 10
    assert all(e.stage == "deadwood" for e in logs)


def test_a_cover_point_lies_inside_its_layer_and_the_scan_is_deterministic():
    result = scan("mixed", "hills")
    cloud = result.cloud
    grass = cloud.instance >= COVER_INSTANCE_BASE  # the sward's returns (elements: their own ids)
    assert grass.mean() > 0.3  # the hills' meadow: most of what the sensor sees
    assert set(np.unique(cloud.label[grass]).tolist()) <= COVER
    cover = plan("mixed").cover
    inside = cover.inside_layer(cloud.xyz[grass])
    assert inside.all(), cloud.xyz[grass][~inside][:5]
    cls, _ = cover.at(cloud.xyz[grass, 0], cloud.xyz[grass, 1])
    assert np.array_equal(cls, cloud.label[grass])  # labelled with the class of its cell
    again = scan("mixed", "hills").cloud
    assert np.array_equal(again.xyz, cloud.xyz) and np.array_equal(again.label, cloud.label)


def test_a_forest_scan_sees_deadwood_and_its_file_lists_the_log_class():
    result = scan("mixed", "forest", frame="leveled", noise=None)
    assert (result.cloud.label == LOG_ID).any() or "log" in str(result.metadata["classes"])
    lines = header_comments(result.cloud, result.metadata)
    assert any(line.startswith("class 14 log") for line in lines)
    paper = scan("paper", "forest", frame="leveled", noise=None)
    assert not any(line.startswith("class 14") for line in header_comments(paper.cloud, paper.metadata))
    assert not np.isin(paper.cloud.label, [LOG_ID]).any()


@pytest.mark.parametrize("biome", ["meadow", "forest", "scrub"])
def test_every_biome_plans_cover_and_keeps_the_paper_elements(biome):
    p = plan_world(2, detail="low", biome=biome)
    assert p.cover is not None and p.biome == biome
    assert {e.wildscan_class for e in p.elements} >= {"trunk", "treetop", "bush", "table", "wire", "pole"}
    assert class_by_name("log").id == LOG_ID


def test_min_scans_with_draws_that_share_of_the_scans_near_the_class():
    from wildscan.core import detmath as dm
    from wildscan.core.posesampler import class_scan_indices, sample_poses

    p = plan("paper")
    poses = sample_poses(p, 20, "zones", {"forest": 1.0}, 2.0, lambda c: True, {"table": 0.2, "wire": 0.25})
    near = {k: [x for x in poses if getattr(x, "kind", "") == f"near {k}"] for k in ("table", "wire")}
    assert len(near["table"]) == 4 and len(near["wire"]) == 5
    tables = np.array([e.location[:2] for e in p.elements_of("table")])
    for pose in near["table"]:
        assert dm.hypot(*(tables - [pose.x, pose.y]).T).min() <= 8.0 + 1e-6
    assert {pose.zone for pose in near["table"]} == {"park"}  # where the tables stand
    assert sorted(class_scan_indices({"table": 0.2}, 20)) == [2, 7, 12, 17]  # spread evenly
    again = sample_poses(p, 20, "zones", {"forest": 1.0}, 2.0, lambda c: True, {"table": 0.2, "wire": 0.25})
    assert again == poses


def test_the_spec_reads_biome_and_min_scans_with_and_refuses_what_is_no_class():
    from wildscan.app.dataset.spec import spec_from_dict, spec_from_json
    from wildscan.core.errors import UserError

    spec = spec_from_dict({"biome": "scrub", "poses": {"min_scans_with": {"table": 0.2, "low grass": 0.5}}})
    assert spec.biome == "scrub" and dict(spec.poses.min_scans_with) == {"table": 0.2, "low grass": 0.5}
    assert spec_from_json(spec.to_dict()) == spec
    paper = spec_from_dict({"layout": "paper"})
    assert "min_scans_with" not in paper.to_dict()["poses"]  # the config hash of before
    with pytest.raises(UserError, match="unknown key 'poses.min_scans_with.boulder'"):
        spec_from_dict({"poses": {"min_scans_with": {"boulder": 0.2}}})
    with pytest.raises(UserError, match="biome"):
        spec_from_dict({"biome": "tundra"})


def test_a_dataset_scan_carries_support_and_the_birds_eye_traversability_fields(tmp_path):
    import plyfile

    from wildscan.app.dataset import worker
    from wildscan.app.dataset.spec import spec_from_dict
    from wildscan.core.truth.traversability import HEIGHT_BINS, SUPPORT_TOLERANCE, TERRAIN_ID

    spec = spec_from_dict(
        {
            "layout": "paper",
            "seeds": [1],
            "detail": "low",
            "scans_per_world": 2,
            "formats": ["ply"],
            "poses": {"zones": {"cave": 1.0}},
        }
    )
    context = worker.build_world(spec, 1)
    rows = [worker.scan_one(spec, context, tmp_path, k) for k in range(2)]
    assert all(r["status"] == "ok" for r in rows)
    files = {f["path"] for r in rows for f in r["files"]}
    ply = next(p for p in sorted(files) if p.endswith(".ply"))
    vertex = plyfile.PlyData.read(str(tmp_path / ply))["vertex"]
    support = np.asarray(vertex["support"]).astype(bool)
    assert support.any() and (~support).any()
    assert (vertex["label"][support] == TERRAIN_ID).all()
    assert (np.abs(vertex["hag"][support]) <= SUPPORT_TOLERANCE).all()
    # the cave's roof and walls are rock: no terrain over the ground, no support up there
    rock_up = (vertex["label"] == class_by_name("rock").id) & (vertex["hag"] > 1.0)
    assert rock_up.any() and not support[rock_up].any()
    assert not ((vertex["label"] == TERRAIN_ID) & (vertex["hag"] > 0.5)).any()
    bev = np.load(tmp_path / next(p for p in sorted(files) if "/bev/" in p))
    assert bev.dtype.names == ("terrain_z", "top_class", "cover_height", "slope", "overhead")
    inside = np.isfinite(bev["terrain_z"])
    assert (bev["cover_height"][inside] >= 0).all() and (bev["slope"][inside] >= 0).all()
    assert np.isfinite(bev["overhead"]).any()  # the cave's roof over the robot
    assert all(len(v) == len(HEIGHT_BINS) for v in rows[0]["class_heights"].values())


def test_a_geometry_file_keeps_the_cover_and_scans_as_the_world_does(tmp_path):
    from wildscan.raycast.scene_file import load_geometry, save_geometry

    path = save_geometry(geometry("mixed"), tmp_path / "world.npz")
    loaded = load_geometry(path)
    assert np.array_equal(loaded.cover.class_id, plan("mixed").cover.class_id)
    assert np.array_equal(loaded.cover.height, plan("mixed").cover.height)


def test_a_biome_that_is_none_is_one_line_and_exit_2(tmp_path):
    from tests.helpers.scene_helpers import WILDSCAN, run

    proc = run([WILDSCAN, "world", "--seed", "1", "--biome", "tundra", "--out", str(tmp_path / "w.blend")])
    assert proc.returncode == 2 and "--biome" in proc.stderr and "mixed" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not any(tmp_path.iterdir())


@pytest.mark.slow
def test_a_world_built_in_blender_scans_with_its_sward_as_the_plan_does():
    from wildscan.app.scan import scan_current_scene
    from wildscan.blender.builder import build_world
    from wildscan.blender.scene_io import empty_scene
    from wildscan.core.placement import Pose
    from wildscan.core.sensors import SensorConfig

    empty_scene()
    build_world(2, "low", biome="meadow")
    pose, sensor = Pose(0.0, 0.0, 0.0), SensorConfig(rh_deg=3.0)
    from wildscan.app.poses import plan_backend, valid_poses

    planned = plan_world(2, "low", biome="meadow")
    p = next(iter(valid_poses(planned, plan_backend(planned), 1).values()))[0]
    pose = Pose(p["x"], p["y"], p["yaw"])
    blender = scan_current_scene(
        pose, sensor, z_start=p.get("z_start"), backend="embree", notify=lambda _: None
    )
    from wildscan.raycast.from_plan import plan_geometry

    plan_scan = scan_current_scene(
        pose,
        sensor,
        z_start=p.get("z_start"),
        backend="embree",
        geometry=plan_geometry(planned),
        notify=lambda _: None,
    )
    assert "cover" in blender.metadata["effects"]
    assert np.array_equal(blender.cloud.xyz, plan_scan.cloud.xyz)
    assert np.array_equal(blender.cloud.label, plan_scan.cloud.label)


def test_the_realistic_model_puts_pure_sward_echoes_inside_the_layer():
    """Not every one: an echo's point lies on the beam's axis at the range its sub-rays stopped
    at, so at the layer's edge a few fall just outside it (the footprint is a few cm wide)."""
    from wildscan.app.scan import scan_current_scene
    from wildscan.core.placement import Pose
    from wildscan.core.sensors import SensorConfig

    p = plan("mixed")
    from wildscan.app.poses import plan_backend, valid_poses

    pose = valid_poses(p, plan_backend(p), 1)["hills"][0]
    sensor = SensorConfig(rh_deg=3.0, model="realistic", noise_sigma=0.0)
    result = scan_current_scene(
        Pose(pose["x"], pose["y"], pose["yaw"]), sensor, "world", None, "embree", geometry=geometry("mixed"),
        notify=lambda _: None,
    )  # fmt: skip
    cloud = result.cloud
    pure = (cloud.instance >= COVER_INSTANCE_BASE) & (cloud.extra["mixed"] == 0)
    assert pure.sum() > 1000
    assert p.cover.inside_layer(cloud.xyz[pure]).mean() > 0.99


def test_the_sward_medium_gives_the_same_bytes_on_one_thread_or_two(monkeypatch):
    """Its parts are fixed (effects/cover.py PART) and each draws from its own stream, so the
    threads that share them do not change a ray's stop; a grazing stop that goes on stays in
    the layer (every held stop is checked against the grid)."""
    from wildscan.core.effects import cover as medium

    monkeypatch.setattr(medium, "PART", 4096)  # several parts in one scan
    clouds = []
    for threads in ("1", "2"):
        monkeypatch.setenv("WILDSCAN_CAST_THREADS", threads)
        clouds.append(scan("mixed", "hills").cloud)
    one, two = clouds
    assert np.array_equal(one.xyz, two.xyz) and np.array_equal(one.label, two.label)
    grass = one.instance >= COVER_INSTANCE_BASE
    assert grass.any() and plan("mixed").cover.inside_layer(one.xyz[grass]).all()


def test_the_biomes_bench_counts_the_caves_rock_in_the_cave_and_none_on_the_hills():
    from wildscan.bench.biomes import _cave_rock
    from wildscan.core.spatial.frames import to_world

    cave = scan("mixed", "cave", frame="leveled")
    rock = _cave_rock(plan("mixed"), cave)
    assert rock > 100 and (cave.cloud.label == class_by_name("rock").id).sum() >= rock
    assert _cave_rock(plan("mixed"), scan("mixed", "hills", frame="leveled")) == 0
    # the roof is rock: no terrain point lies over the ground
    terrain = cave.cloud.label == class_by_name("terrain").id
    xyz = to_world(np.asarray(cave.cloud.xyz[terrain], dtype=np.float64), "leveled", cave.placement)
    assert (xyz[:, 2] - plan("mixed").ground(xyz[:, 0], xyz[:, 1]) < 0.5).all()


def test_on_the_two_track_support_points_lie_on_the_wheel_tracks_and_grass_points_in_the_median():
    from wildscan.core.truth.traversability import SUPPORT_TOLERANCE, support_flags
    from wildscan.core.world.stages import cover as stage

    p = plan("mixed")
    cloud = scan("mixed", "trail").cloud  # world frame: a pose on the trail's centre line
    hag = cloud.xyz[:, 2] - p.standing_ground()(cloud.xyz[:, 0], cloud.xyz[:, 1])
    support = support_flags(cloud.label, hag).astype(bool)
    assert (cloud.label[support] == class_by_name("terrain").id).all()
    assert (np.abs(hag[support]) <= SUPPORT_TOLERANCE).all()  # at the ground the robot stands on
    n = p.cover.shape[0]
    on_tread = stage._tread(p, n).reshape(-1)[p.cover.cells(cloud.xyz[:, 0], cloud.xyz[:, 1])[0]]
    cls, _ = p.cover.at(cloud.xyz[:, 0], cloud.xyz[:, 1])
    assert (support & on_tread & (cls == 0)).sum() > 100  # the wheel tracks' soil
    median = on_tread & (cloud.label == LOW_GRASS)
    assert median.sum() > 100 and not support[median].any()  # the median's grass, above the soil
    assert (cls[median] == LOW_GRASS).all()  # in the median's cells, as their layer


@pytest.mark.parametrize("biome", ["paper", "mixed"])
def test_the_placement_probe_stands_on_a_terrain_roof_and_passes_a_rock_one(biome):
    from wildscan.app.poses import plan_backend, valid_poses
    from wildscan.core.placement import Pose, place

    backend = plan_backend(plan(biome))
    inside = next(p for p in valid_poses(plan(biome), backend, 3)["cave"] if p.get("z_start"))
    pose = Pose(inside["x"], inside["y"], inside["yaw"])
    floor = place(backend, pose, inside["z_start"]).optical_centre[2]
    probed = place(backend, pose).optical_centre[2]  # the probe from above, no z_start
    if biome == "paper":
        assert probed > inside["z_start"] + 0.5  # on the roof: what --z-start avoids
    else:
        assert probed == pytest.approx(floor, abs=1e-6)  # the rock roof is no ground: the floor under it
