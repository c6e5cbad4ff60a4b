"""The endless landscape (core/world/endless): tiles that depend only on their own coordinates,
seams without cracks, land cover with its shares, every class, the new ground materials in
every label scheme, and a region planned whole equal to its tiles planned one by one."""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest

from wildscan.core.classes import ALL_ELEMENTS, BY_ID, GROUND_IDS, class_by_name
from wildscan.core.world.endless import (
    LAND_COVERS,
    TILE_M,
    build_tile,
    land_cover_at,
    landscape,
    plan_region,
    tile_distance,
    tile_levels,
    tiles_in_disc,
    tiles_in_region,
)
from wildscan.core.world.endless import anchors as A
from wildscan.core.world.endless import fields as F
from wildscan.core.world.endless import library as L
from wildscan.core.world.endless.build import SKIRT_DEPTH
from wildscan.core.world.endless.tiles import LEVEL_FACTORS, TERRAIN_SPACING, level_at

SEED = 1


def _forget_everything():
    """Drop every per-process cache, as a fresh process would start."""
    F.landscape.cache_clear()
    L.forget_libraries()
    from wildscan.core.world.endless import clearing

    clearing.furniture.cache_clear()


def tile_digest(tile) -> str:
    """SHA-256 over everything a tile holds: terrain, cover, its own meshes, its elements."""
    h = hashlib.sha256()
    for a in (tile.grid.xs, tile.grid.ys, tile.grid.z, tile.cover_class, tile.cover_height):
        h.update(np.ascontiguousarray(a).tobytes())
    for key in sorted(tile.prototypes):
        p = tile.prototypes[key]
        h.update(key.encode() + p.vertices.tobytes() + p.faces.tobytes())
    for el in tile.elements:
        h.update(f"{el.name}|{el.wildscan_class}|{el.instance}|{el.proto}|{el.zone}".encode())
        h.update(np.array([*el.location, el.yaw, *el.scale, el.radius], dtype=np.float64).tobytes())
    return h.hexdigest()


def test_a_tiles_bytes_do_not_depend_on_which_tiles_were_built_before():
    _forget_everything()
    first = {t: tile_digest(build_tile(SEED, "mixed", "default", "porous", *t)) for t in ((0, 0), (1, 0))}
    _forget_everything()
    second = {t: tile_digest(build_tile(SEED, "mixed", "default", "porous", *t)) for t in ((1, 0), (0, 0))}
    assert first == second
    assert first[(0, 0)] != first[(1, 0)]


def test_another_seed_or_biome_is_another_tile():
    a = tile_digest(build_tile(SEED, "mixed", "default", "porous", 0, 0))
    assert a != tile_digest(build_tile(SEED + 1, "mixed", "default", "porous", 0, 0))
    assert a != tile_digest(build_tile(SEED, "forest", "default", "porous", 0, 0))


def test_neighbouring_tiles_share_their_edge_heights_exactly():
    left = build_tile(SEED, "mixed", "default", "porous", 3, -2)
    right = build_tile(SEED, "mixed", "default", "porous", 4, -2)
    above = build_tile(SEED, "mixed", "default", "porous", 3, -1)
    assert left.grid.xs[-1] == right.grid.xs[0]
    np.testing.assert_array_equal(left.grid.z[:, -1], right.grid.z[:, 0])
    np.testing.assert_array_equal(left.grid.z[-1, :], above.grid.z[0, :])


def test_the_skirt_closes_the_gap_between_levels():
    """A full-detail tile beside the coarsest: their edges share every coarse node exactly, and
    between nodes differ by less than the skirt's depth (which hangs from both edges)."""
    coarse_level = len(LEVEL_FACTORS) - 1
    fine = build_tile(SEED, "mixed", "default", "porous", 0, 5, 0)
    coarse = build_tile(SEED, "mixed", "default", "porous", 1, 5, coarse_level)
    shared = np.isin(fine.grid.ys, coarse.grid.ys)
    np.testing.assert_array_equal(fine.grid.z[shared, -1], coarse.grid.z[:, 0])
    edge = coarse.grid.height_at(np.full(len(fine.grid.ys), TILE_M), fine.grid.ys)
    gap = np.abs(edge - fine.grid.z[:, -1])
    assert gap.max() < SKIRT_DEPTH
    ground = [el for el in coarse.elements if el.zone == "ground"]
    v = np.concatenate([coarse.prototypes[el.proto].vertices for el in ground])
    west = v[v[:, 0] == TILE_M]
    for y, z in zip(coarse.grid.ys, coarse.grid.z[:, 0]):  # the skirt hangs from every edge node
        assert np.any((west[:, 1] == y) & (west[:, 2] == z - SKIRT_DEPTH))


def test_a_region_is_its_tiles_whatever_the_order():
    """The triangles of a tile in a 2x2 region's plan are those of the tile's own plan, and
    the region's cover is its tiles' covers merged (the front caches tiles one by one)."""
    from wildscan.core.world.endless import merge_covers

    tiles = tiles_in_region(0, 0, 200, 200)
    whole = plan_region(SEED, "mixed", "default", "porous", tiles)
    alone = [plan_region(SEED, "mixed", "default", "porous", [t]) for t in reversed(tiles)]
    assert len({el.instance for el in whole.elements}) == len(whole.elements)
    assert sorted(el.name for el in whole.elements) == sorted(el.name for p in alone for el in p.elements)
    one = alone[0]
    mine = {el.name: el for el in whole.elements}
    for el in one.elements:
        np.testing.assert_array_equal(whole.element_vertices(mine[el.name]), one.element_vertices(el))
    merged = merge_covers([p.cover for p in alone])
    np.testing.assert_array_equal(merged.class_id, whole.cover.class_id)
    np.testing.assert_array_equal(merged.terrain_z, whole.cover.terrain_z)


def test_terrain_is_everywhere_in_a_region():
    plan = plan_region(SEED, "mixed", "default", "porous", tiles_in_region(-200, -200, 0, 0))
    ground = [el for el in plan.elements if class_by_name(el.wildscan_class).id in GROUND_IDS]
    xy = np.concatenate([plan.element_vertices(el)[:, :2] for el in ground])
    cells = np.unique(np.floor(xy / 10.0).astype(int), axis=0)
    assert len(cells) >= 20 * 20
    assert plan.extent == (-200.0, 0.0, -200.0, 0.0)


def _feature_tiles(seed: int) -> list[tuple[int, int]]:
    """Tiles holding a clearing, a lake, a cave and a power line of the seed's landscape."""
    land = landscape(seed, "mixed")
    found, out = set(), []
    for ci in range(-3, 4):
        for cj in range(-3, 4):
            c = land.anchors.cell(ci, cj)
            for name, point, reach in (
                ("clearing", c.node if c.clearing else None, c.clearing),
                ("lake", (c.lake.basin.cx, c.lake.basin.cy) if c.lake else None, 0.0),
                ("cave", (c.cave.pit.cx, c.cave.pit.cy) if c.cave else None, 0.0),
            ):
                if point is not None and name not in found:
                    found.add(name)
                    out += tiles_in_disc(point[0], point[1], reach)
        line = land.anchors.row_line(ci)
        if line is not None and "powerline" not in found:
            found.add("powerline")
            out.append((0, math.floor(line / TILE_M)))
    assert found == {"clearing", "lake", "cave", "powerline"}
    return out


def test_every_class_occurs():
    """Every element class of the paper's worlds (terrain apart: the ground is its materials)
    and every ground material, in a few tiles holding each kind of feature."""
    classes = set()
    for t in _feature_tiles(SEED):
        plan = plan_region(SEED, "mixed", "default", "porous", [t])
        classes |= {el.wildscan_class for el in plan.elements}
    wanted = {c.name for c in ALL_ELEMENTS} - {"particle", "unlabeled", "terrain"}
    assert wanted <= classes, sorted(wanted - classes)


def test_land_cover_shares_follow_the_biome():
    """Over 4 km x 4 km, forest, scrub and rock hold their biome's shares within 5 points;
    wetland a bit more (lake shores come on top); trails and clearings a few percent."""
    t = np.arange(-2000.0, 2000.0, 25.0) + 3.0
    x, y = np.meshgrid(t, t)
    cover = land_cover_at(SEED, "mixed", x, y)
    share = {name: float((cover == k).mean()) for k, name in enumerate(LAND_COVERS)}
    want = F.BIOME_SHARES["mixed"]
    assert abs(share["forest"] - want.forest) < 0.06
    assert abs(share["scrub"] - want.scrub) < 0.05
    assert abs(share["rock"] - want.rock) < 0.03
    assert want.wetland - 0.02 < share["wetland"] < want.wetland + 0.05
    assert 0.0 < share["trail"] < 0.05 and 0.0 < share["clearing"] < 0.03
    assert share["meadow"] > 0.15
    for biome in ("meadow", "forest", "scrub"):
        cover = land_cover_at(SEED, biome, x, y)
        want = F.BIOME_SHARES[biome]
        for code, target in ((F.FOREST, want.forest), (F.SCRUB, want.scrub), (F.ROCK, want.rock)):
            assert abs(float((cover == code).mean()) - target) < 0.06, (biome, LAND_COVERS[code])


def test_land_cover_is_a_pure_function_of_position():
    x = np.array([10.0, 250.5, -1234.25, 1999.0])
    y = np.array([-5.0, 777.0, 42.0, -1999.0])
    one = land_cover_at(SEED, "mixed", x, y)
    each = [int(land_cover_at(SEED, "mixed", x[k : k + 1], y[k : k + 1])[0]) for k in range(len(x))]
    assert one.tolist() == each


def test_features_come_from_their_anchor_cell_alone():
    flat = lambda x, y: np.zeros(np.shape(x))  # noqa: E731
    a, b = A.Anchors(SEED, flat), A.Anchors(SEED, flat)
    b.cell(5, 5)  # another order of asking
    b.trails_of(1, -1)
    assert a.cell(2, -1) == b.cell(2, -1)
    mine, theirs = a.trails_of(2, -1), b.trails_of(2, -1)
    assert len(mine) == len(theirs)
    assert all(np.array_equal(p.path, q.path) and p.kind == q.kind for p, q in zip(mine, theirs))


def test_every_ground_material_is_mapped_in_every_scheme_and_has_a_reflectance():
    from wildscan.core.io.las import ASPRS_CODES
    from wildscan.core.label_schemes import SCHEMES
    from wildscan.core.realism.intensity import MATERIALS

    for gid in GROUND_IDS:
        for s in SCHEMES.values():
            assert gid in s.from_wildscan
            assert not s.is_other(gid), (s.name, BY_ID[gid].name)
        assert ASPRS_CODES[gid] == 2
        lo, hi = MATERIALS[BY_ID[gid].name]
        assert 0.0 < lo < hi <= 1.0
    wildscan = SCHEMES["wildscan"]
    assert not set(GROUND_IDS) & set(wildscan.config_tables(particles=False)["labels"])
    assert set(GROUND_IDS) <= set(wildscan.config_tables(particles=False, grounds=True)["labels"])


def test_class_tables_list_ground_materials_only_when_points_carry_them():
    from wildscan.core.classes import carries_ground_materials, class_table_lines

    assert not carries_ground_materials(np.array([1, 2, 3]))
    assert carries_ground_materials(np.array([1, 17]))
    assert len(class_table_lines(grounds=True)) == len(class_table_lines()) + len(GROUND_IDS)


def test_lod_levels_grow_with_distance_and_off_is_full_detail():
    from wildscan.core.sensors.load import device_named

    os1 = device_named("os1-64")
    levels = tile_levels(os1, 1050.0, 1050.0, lod=True)
    assert set(levels) == set(tiles_in_disc(1050.0, 1050.0, os1.ranges.max_m + 5.0))
    assert levels[(21, 21)] == 0
    far = max(levels, key=lambda t: tile_distance(*t, 1050.0, 1050.0))
    assert levels[far] == 2  # beams 0.44 deg apart (0.7 deg rings, 0.35 deg columns): 0.6 m from 79 m
    assert sorted(set(levels.values())) == [0, 1, 2]
    vlp16 = tile_levels(device_named("vlp16"), 1050.0, 1050.0, lod=True)  # 0.63 deg: 0.6 m from 54 m
    assert vlp16[(21, 21)] == 0 and max(vlp16.values()) == 2
    assert set(tile_levels(os1, 1050.0, 1050.0, lod=False).values()) == {0}
    assert set(tile_levels(os1, 1050.0, 1050.0, lod="off").values()) == {0}
    assert level_at(10.0, math.radians(5.0)) == 0  # full detail near the sensor, whatever the device
    assert [level_at(d, 0.01) for d in (30.0, 70.0, 200.0)] == [1, 2, 3]
    spacing = [TERRAIN_SPACING["default"] * f for f in LEVEL_FACTORS]
    assert spacing == sorted(spacing)


def test_coarse_tiles_leave_small_elements_out():
    full = build_tile(SEED, "mixed", "default", "porous", 2, 2, 0)
    coarse = build_tile(SEED, "mixed", "default", "porous", 2, 2, 2)
    count = lambda t, c: sum(el.wildscan_class == c for el in t.elements)  # noqa: E731
    assert count(coarse, "low grass") == 0 < count(full, "low grass")
    assert count(coarse, "treetop") == count(full, "treetop")
    assert len(coarse.grid.xs) < len(full.grid.xs)


def test_a_tile_beyond_reach_is_refused():
    from wildscan.core.errors import UserError

    with pytest.raises(UserError, match="beyond"):
        build_tile(SEED, "mixed", "default", "porous", 500, 0)


def test_a_library_from_a_cache_builds_the_same_tile(tmp_path):
    """A front stores the shared meshes once (np.savez) and a later process builds with them."""
    path = tmp_path / "library.npz"
    np.savez(path, **L.library_arrays(L.library(SEED, "default", "porous")))
    want = tile_digest(build_tile(SEED, "mixed", "default", "porous", -1, 2))
    L.forget_libraries()
    with np.load(path) as arrays:
        L.provide_library(SEED, "default", "porous", arrays)
    assert tile_digest(build_tile(SEED, "mixed", "default", "porous", -1, 2)) == want


def test_trails_form_a_network_of_nodes():
    """Trails run node to node: every trail's ends are anchor nodes, and most nodes join two
    trails or more (a network a drive can follow)."""
    from wildscan.core.world.endless import trail_network

    trails = trail_network(SEED, "mixed", -1000.0, -1000.0, 1000.0, 1000.0)
    assert len(trails) > 20 and {kind for _, kind in trails} == {k[0] for k in A.TRAIL_KINDS}
    ends = [tuple(np.round(p[k], 6)) for p, _ in trails for k in (0, -1)]
    degree = {e: ends.count(e) for e in ends}
    assert sum(d >= 2 for d in degree.values()) > len(degree) / 2


def test_no_pose_stands_in_a_thicket_or_a_reed_bed():
    """footprint_ok refuses a pose whose laser tips fall where the sward is taller than
    STAND_COVER_MAX (reeds, undergrowth, shrubs), and accepts one on a low sward."""
    from wildscan.core.world import footprint_ok
    from wildscan.core.world.endless.region import STAND_COVER_MAX

    plan = plan_region(SEED, "mixed", "default", "porous", tiles_in_region(0, 0, 100, 100))
    cover = plan.cover
    ys, xs = np.nonzero(cover.height > 1.2)
    tall = [(cover.x0 + (i + 0.5) * cover.cell, cover.y0 + (j + 0.5) * cover.cell) for j, i in zip(ys, xs)]
    assert tall, "the test region holds reeds or shrubs"
    assert sum(footprint_ok(plan, x, y, 0.0) for x, y in tall[::50]) == 0
    ok = [
        footprint_ok(plan, x, y, 0.0)
        for x in np.arange(2.0, 98.0, 3.0)
        for y in np.arange(2.0, 98.0, 3.0)
        if np.all(
            cover.at(np.array([x - 0.8, x + 0.8, x, x]), np.array([y, y, y - 0.8, y + 0.8]))[1]
            < STAND_COVER_MAX
        )
    ]
    assert any(ok)
