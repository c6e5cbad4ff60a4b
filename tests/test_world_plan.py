"""The world planner without Blender: heightfield, grid error, layout, stages, shapes, map."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wildscan.core.errors import UserError
from wildscan.core.rng import stage_rng
from wildscan.core.world import (
    DETAILS,
    ELEMENT_STAGES,
    EXTENT,
    MAX_RELIEF,
    STAGE_INSTANCE_BASE,
    STAGE_INSTANCE_BLOCK,
    STAGES,
    ZONES,
    Clearance,
    WorldParams,
    check_seed,
    check_zone,
    detail_level,
    footprint_ok,
    model_errors,
    plan_hash,
    plan_world,
)
from wildscan.core.world import heightfield as hf
from wildscan.core.world import terrain_grid as tg
from wildscan.core.world.shapes import plants, powerline, primitives, rocks, trees

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

ALL_TAGS = {
    "terrain",
    "trunk",
    "treetop",
    "table",
    "bush",
    "fence",
    "bench",
    "low grass",
    "rock",
    "high grass",
    "wire",
    "pole",
    "water",
    "log",  # the default biome's deadwood (core/world/stages/deadwood.py)
}


@pytest.fixture(scope="module")
def plan():
    return plan_world(1)


@pytest.fixture(scope="module")
def plans():
    return {s: plan_world(s) for s in (0, 2, 3)}


# --- heightfield ------------------------------------------------------------------------


def test_noise_is_seeded_smooth_and_bounded():
    a = hf.FractalNoise(stage_rng(5, "t"), 50.0, 4)
    b = hf.FractalNoise(stage_rng(5, "t"), 50.0, 4)
    c = hf.FractalNoise(stage_rng(6, "t"), 50.0, 4)
    x, y = np.meshgrid(np.linspace(-75, 75, 121), np.linspace(-75, 75, 121))
    assert np.array_equal(a(x, y), b(x, y))
    assert not np.allclose(a(x, y), c(x, y))
    assert np.abs(a(x, y)).max() <= 1.0
    # continuity: a millimetre step changes the value by far less than a millimetre's worth of slope allows
    assert np.abs(a(x + 1e-3, y) - a(x, y)).max() < 1e-3


def test_field_evaluates_anywhere_the_same(plan):
    f = plan.heightfield
    pts = np.array([[0.0, 0.0], [12.3, -45.6], [-74.9, 74.9]])
    together = f(pts[:, 0], pts[:, 1])
    one_by_one = [float(f(x, y)) for x, y in pts]
    assert np.allclose(together, one_by_one, atol=0, rtol=0)


def test_relief_within_twenty_metres(plan, plans):
    for p in [plan, *plans.values()]:
        z = p.grid.z
        assert 0.0 <= z.max() - z.min() <= MAX_RELIEF
        assert z.max() - z.min() > 8.0  # hills, not a flat plate


@pytest.mark.parametrize("detail", list(DETAILS))
def test_terrain_grid_error_within_detail_tolerance(detail):
    p = plan_world(4, detail)
    tol = DETAILS[detail].terrain_tolerance
    # measured by the planner on 100,000 points ...
    assert p.grid_fit.error.max <= tol
    # ... and again on fresh points, cell midpoints included (the worst case of linear interpolation)
    g = p.grid
    mx, my = np.meshgrid(0.5 * (g.xs[1:] + g.xs[:-1]), 0.5 * (g.ys[1:] + g.ys[:-1]))
    err = np.abs(g.height_at(mx, my) - p.heightfield(mx, my))
    assert err.max() <= 1.5 * tol
    assert np.sqrt(np.mean(err**2)) < tol / 3


def test_finer_detail_means_finer_terrain():
    tri = {d: plan_world(4, d).grid.triangle_count for d in DETAILS}
    assert tri["low"] < tri["default"] < tri["high"]


def test_adaptive_grid_beats_a_uniform_grid_of_the_same_error(plan):
    fit = plan.grid_fit
    uniform = tg.uniform_grid(plan.heightfield, EXTENT, fit.spacing_min)
    assert fit.grid.triangle_count < uniform.triangle_count / 3
    coarse = tg.uniform_grid(plan.heightfield, EXTENT, fit.spacing_max)
    pts = tg.error_sample_points(EXTENT, 20_000, stage_rng(0, "test"))
    assert tg.grid_error(plan.heightfield, coarse, pts).max > fit.tolerance


def test_height_at_matches_the_triangles():
    """height_at interpolates exactly what the terrain mesh's triangles are."""
    xs, ys = np.array([0.0, 1.0, 3.0]), np.array([0.0, 2.0, 2.5])
    z = np.arange(9.0).reshape(3, 3) ** 1.3
    grid = tg.TerrainGrid(xs, ys, z)
    v, f = grid.mesh()
    rng = stage_rng(0, "bary")
    for tri in f:
        w = rng.dirichlet([1, 1, 1])
        p = w @ v[tri]
        assert grid.height_at(p[0], p[1]) == pytest.approx(p[2], abs=1e-9)


# --- layout, zones, stages --------------------------------------------------------------


def test_all_six_zones_tile_the_world(plan, plans):
    for p in [plan, *plans.values()]:
        cells = p.layout.cells
        assert set(cells) == set(ZONES)
        area = sum((c[1] - c[0]) * (c[3] - c[2]) for c in cells.values())
        assert area == pytest.approx(150.0 * 150.0)
        for c in cells.values():
            assert -75 <= c[0] < c[1] <= 75 and -75 <= c[2] < c[3] <= 75
    layouts = {tuple(sorted(p.layout.cells.items())) for p in [plan, *plans.values()]}
    assert len(layouts) > 1  # where zones lie depends on the seed


def test_every_class_of_table_one_is_planned(plan):
    assert {e.wildscan_class for e in plan.elements} == ALL_TAGS
    kinds = {e.proto.split("_")[1].rstrip("0123456789") for e in plan.elements_of("trunk")}
    assert kinds == {"conifer", "broadleaf", "birch"}
    assert len(plan.elements_of("trunk")) == len(plan.elements_of("treetop"))
    park = {e.wildscan_class for e in plan.elements if e.zone == "park"}
    assert {"table", "bench", "fence"} <= park
    assert {e.zone for e in plan.elements_of("pole")} == {"hills"}
    sizes = [e.scale[0] for e in plan.elements_of("rock")]
    assert max(sizes) / min(sizes) > 3  # rocks of varied size


def test_instances_unique_and_in_stage_blocks(plan):
    ids = [e.instance for e in plan.elements]
    assert len(ids) == len(set(ids)) and min(ids) >= 1
    for e in plan.elements:
        base = STAGE_INSTANCE_BASE[e.stage]
        assert base < e.instance < base + STAGE_INSTANCE_BLOCK
    names = [e.name for e in plan.elements]
    assert len(names) == len(set(names))


def test_repeated_elements_share_meshes(plan):
    c = plan.counts()
    assert c["objects"] > 20 * c["meshes"]
    assert c["objects"] < 3000  # Scene.ray_cast cost grows with objects
    assert len(plan.prototypes[plan.elements_of("low grass")[0].proto].faces) <= 16  # few-polygon tufts


def test_same_seed_same_world_other_seed_other_world(plan):
    again = plan_world(1)
    assert plan_hash(again) == plan_hash(plan)
    assert plan_hash(plan_world(2)) != plan_hash(plan)


@pytest.mark.parametrize(
    "stage,changes",
    [("rocks", {"size": (0.5, 3.0)}), ("grass", {"min_spacing": 1.1}), ("trees", {"variants": 3})],
)
def test_one_stage_changed_leaves_the_others(plan, stage, changes):
    changed = plan_world(1, params=WorldParams().with_stage(stage, **changes))
    assert plan_hash(changed, stage) != plan_hash(plan, stage)
    for other in ELEMENT_STAGES:
        if other != stage:
            assert plan_hash(changed, other) == plan_hash(plan, other), other


def test_sites_stand_on_clear_terrain(plan):
    assert {s.zone for s in plan.sites} == set(ZONES)
    for s in plan.sites:
        assert footprint_ok(plan, s.x, s.y, s.yaw_deg, allow_pit=s.zone == "cave")
        for e in plan.elements:
            if e.stage in ("terrain", "trail", "lake", "cave", "powerline") or e.wildscan_class == "treetop":
                continue
            assert math.hypot(e.location[0] - s.x, e.location[1] - s.y) >= e.radius + 0.5, (s, e.name)
    inside = [s for s in plan.sites if s.z_start is not None]
    assert inside and all(s.zone == "cave" and s.z_start < plan.cave_level for s in inside)


def test_nothing_stands_in_water_or_on_the_trail(plan):
    for e in plan.elements:
        if e.stage in ("terrain", "trail", "lake", "cave", "powerline"):
            continue
        x, y = e.location[:2]
        assert not plan.in_water(x, y), e.name
        assert plan.trail_distance(np.array([x]), np.array([y]))[0] > plan.layout.trail.width / 2, e.name


def test_each_stage_is_a_module_of_its_own():
    from wildscan.core.world import pipeline

    assert STAGES == (
        "layout",
        "terrain",
        "poses",
        "trail",
        "lake",
        "cave",
        "trees",
        "bushes",
        "rocks",
        "grass",
        "park",
        "powerline",
        "deadwood",
        "cover",
    )
    for module in pipeline.STAGE_MODULES:
        assert module.__name__ == f"wildscan.core.world.stages.{module.STAGE}" and callable(module.run)


def test_every_zone_keeps_elements_off_what_it_holds(plan):
    lay, need = plan.layout, Clearance(0.3)
    cave, (x0, x1, y0, y1) = lay.cave, lay.park.rect
    roof_middle = ((cave.roof_u[0] + cave.roof_u[1]) / 2, (cave.roof_v[0] + cave.roof_v[1]) / 2)
    held = {
        "the trail": lay.trail.path,
        "the lake": [[lay.lake.basin.cx, lay.lake.basin.cy]],
        "the cave's pit and roof": np.column_stack(
            cave.pit.to_world([0.0, roof_middle[0]], [0.0, roof_middle[1]])
        ),
        "the park's fence": [
            [x0, (y0 + y1) / 2],
            [x1, (y0 + y1) / 2],
            [(x0 + x1) / 2, y0],
            [(x0 + x1) / 2, y1],
        ],
        "the power-line poles": lay.powerline.poles,
        "the scan sites": [[s.x, s.y] for s in plan.sites],
    }
    for what, pts in held.items():
        pts = np.asarray(pts, dtype=np.float64)
        assert plan.blocked(pts[:, 0], pts[:, 1], need).all(), what
    # the lawn is for grass (and the picnic tables), not for trees, bushes or rocks
    lawn = np.array([(x0 + x1) / 2]), np.array([(y0 + y1) / 2])
    assert plan.blocked(*lawn, need).all()
    assert not plan.blocked(*lawn, Clearance(0.3, park_interior=True)).any()


def test_water_fills_the_basin(plan):
    water = plan.elements_of("water")[0]
    v = plan.element_vertices(water)
    assert np.allclose(v[:, 2], plan.water_z)
    centre = plan.layout.lake.basin
    assert plan.ground(centre.cx, centre.cy) < plan.water_z - 1.0  # deep in the middle
    # every cell of water has terrain below the surface somewhere in it: no water on dry land
    quads = v.reshape(-1, 4, 3)
    mid = quads[:, :, :2].mean(axis=1)
    low = np.min(
        [
            plan.ground(*(mid + d).T)
            for d in np.array([[0, 0], [0.9, 0.9], [-0.9, 0.9], [0.9, -0.9], [-0.9, -0.9]])
        ],
        axis=0,
    )
    assert (low < plan.water_z + 0.05).all()


def test_trail_follows_the_terrain(plan):
    trail = plan.elements_of("terrain", zone="trail")[0]
    v = plan.element_vertices(trail)
    top = v[v[:, 2] > plan.ground(v[:, 0], v[:, 1])]
    gap = top[:, 2] - plan.ground(top[:, 0], top[:, 1])
    assert 0.0 < gap.min() and gap.max() < 0.2


def test_wires_hang_as_catenaries(plan):
    for wire in plan.elements_of("wire"):
        v = plan.element_vertices(wire)
        poles = plan.elements_of("pole")
        tops = max(p.location[2] for p in poles) + powerline.POLE_HEIGHT
        assert v[:, 2].max() <= tops + 0.1
        # lowest point well above the ground below it
        low = v[np.argmin(v[:, 2])]
        assert low[2] - plan.ground(low[0], low[1]) > 3.0


def test_catenary_meets_both_ends_and_sags():
    p0, p1 = np.array([0.0, 0.0, 9.0]), np.array([20.0, 0.0, 9.0])
    path = powerline.catenary(p0, p1, 0.6, 41)
    assert np.allclose(path[0], p0) and np.allclose(path[-1], p1)
    assert path[20, 2] == pytest.approx(9.0 - 0.6, abs=1e-6)
    a = powerline.catenary_parameter(20.0, 0.6)
    assert np.allclose(path[:, 2], a * np.cosh((path[:, 0] - 10.0) / a) + 9.0 - a * np.cosh(10.0 / a))
    uneven = powerline.catenary(p0, p1 + [0, 0, 2.0], 0.6, 41)
    assert np.allclose(uneven[-1], p1 + [0, 0, 2.0])


# --- shapes -----------------------------------------------------------------------------


def _closed(faces) -> bool:
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    return bool((counts == 2).all())


def test_icosphere_and_lathe_are_closed():
    for s in range(3):
        v, f = primitives.icosphere(s)
        assert len(f) == 20 * 4**s and _closed(f)
        assert np.allclose(np.linalg.norm(v, axis=1), 1.0)
    v, f = primitives.lathe([0.0, 1.0, 0.5, 0.0], [0.0, 1.0, 2.0, 3.0], 8)
    assert _closed(f)


def test_tuft_polygon_budget():
    for d in DETAILS.values():
        v, f = plants.tuft(stage_rng(0, "t"), 0.3, 0.3, d.tuft_planes, d.tuft_blades)
        assert len(f) == d.tuft_planes * d.tuft_blades


def test_trees_hide_nothing_inside_their_crowns():
    for name, make in trees.TREE_KINDS.items():
        t = make(stage_rng(0, name), DETAILS["default"])
        trunk_top = t.trunk[0][:, 2].max()
        crown_v = t.crown[0]
        assert _closed(t.crown[1])
        # the trunk stops less than a metre into the crown, not up at its top
        assert (
            crown_v[:, 2].min()
            < trunk_top
            < crown_v[:, 2].min() + 1.0 + 0.5 * (crown_v[:, 2].max() - crown_v[:, 2].min())
        )
        assert trunk_top < crown_v[:, 2].max() - 1.0


def test_buried_faces_are_dropped():
    for d in DETAILS.values():
        for make in (rocks.rock, plants.bush):
            (v, f), _ = make(stage_rng(1, "r"), d)
            assert (v[f][:, :, 2].max(axis=1) >= -0.05).all()


# --- inputs -----------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [-1, "-3", "1.5", "abc", "", True, 2.5])
def test_bad_seed_is_a_user_error(bad):
    with pytest.raises(UserError, match="seed must be a whole number from 0 to 2147483647"):
        check_seed(bad)


def test_good_seeds():
    assert check_seed(0) == 0 and check_seed("42") == 42 and check_seed(2**31 - 1) == 2**31 - 1
    with pytest.raises(UserError, match="from 0 to 2147483647"):
        check_seed(2**31)  # stored on the world as a 32-bit Blender property


def test_unknown_detail_and_zone():
    with pytest.raises(UserError, match="detail must be one of low, default, high"):
        detail_level("ultra")
    with pytest.raises(UserError, match="zone must be one of"):
        check_zone("desert")


# --- aerial map -------------------------------------------------------------------------


def test_aerial_map_shows_classes_zones_and_poses(plan, tmp_path):
    from matplotlib.image import imread

    from wildscan.viz.aerial_map import render_map

    out = render_map(plan, str(tmp_path / "map.png"), poses=plan.sites)
    img = (imread(out)[..., :3] * 255).round().astype(int)
    assert img.shape[0] > 800 and img.shape[1] > 800

    def has(rgb, tol=8):
        return bool((np.abs(img - np.array(rgb)).max(axis=-1) <= tol).sum() > 20)

    for rgb in [(128, 128, 0), (0, 160, 0), (255, 165, 0), (255, 0, 0), (0, 255, 255), (255, 255, 0)]:
        assert has(rgb), rgb


def test_model_errors_shrink_with_detail():
    low, default, high = (model_errors(DETAILS[d]) for d in ("low", "default", "high"))
    for key in low:
        assert low[key] > default[key] > high[key], key
    assert default["crown_3m"] < 0.06 and default["wire_chord"] < 0.01
