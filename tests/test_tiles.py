"""The endless world's tiles through the world cache (app/tiles.py) and the commands that build
them: tiles kept and bounded in memory, one cache entry per tile read back bit for bit,
regions that share tiles giving the same triangles whatever was built first, terrain
everywhere in a region, and a scan anywhere."""

from __future__ import annotations

import json

import numpy as np
import pytest

from wildscan.app.cache.store import DiskCache
from wildscan.app.tile_memory import TileMemory
from wildscan.app.tiles import (
    TilePart,
    join,
    merge_covers,
    object_bounds,
    part_from_entry,
    part_to_entry,
)
from wildscan.cli import main
from wildscan.core.world.cover import CoverGrid
from wildscan.raycast.geometry import from_triangles

from tests.helpers.scene_helpers import WILDSCAN, run


def cover_of_tile(i: int, j: int, size: float = 10.0, cell: float = 0.5, step: float = 1.0) -> CoverGrid:
    """A synthetic tile's cover: class and height by position, terrain z = x + 2 y."""
    x0, y0 = i * size, j * size
    n = int(size / cell)
    cx = x0 + cell * (np.arange(n) + 0.5)
    cy = y0 + cell * (np.arange(n) + 0.5)
    gx, gy = np.meshgrid(cx, cy)
    cls = np.where((np.floor(gx) + np.floor(gy)) % 3 == 0, 8, 10).astype(np.uint8)
    height = (0.1 + 0.01 * (gx % 7)).astype(np.float32)
    xs = x0 + step * np.arange(int(size / step) + 1)
    ys = y0 + step * np.arange(int(size / step) + 1)
    tx, ty = np.meshgrid(xs, ys)
    return CoverGrid(x0, y0, cell, cls, height, xs, ys, tx + 2 * ty)


def test_merged_covers_answer_as_each_tile_does_and_nothing_where_no_tile_is():
    tiles = [cover_of_tile(0, 0), cover_of_tile(1, 0), cover_of_tile(1, 1)]  # an L: (0, 1) missing
    merged = merge_covers(tiles)
    rng = np.random.default_rng(3)
    for tile in tiles:
        x = tile.x0 + rng.uniform(0, 10, 500)
        y = tile.y0 + rng.uniform(0, 10, 500)
        for got, want in zip(merged.at(x, y), tile.at(x, y)):
            np.testing.assert_array_equal(got, want)
        np.testing.assert_allclose(merged.ground(x, y), tile.ground(x, y), atol=1e-12)
    cls, height = merged.at(rng.uniform(0, 10, 100), rng.uniform(10, 20, 100))  # the missing tile
    assert not cls.any() and not height.any()


def part(offset: float, names=("a", "b")) -> TilePart:
    tris = offset + np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 1, 0], [2, 1, 0], [1, 2, 1]]], float)
    geometry = from_triangles(tris, class_id=[1, 3], instance=[7, 8], object_index=[0, 1], object_names=names)
    return TilePart(geometry, cover_of_tile(int(offset), 0))


def test_a_tile_entry_is_read_back_bit_for_bit(tmp_path):
    cache = DiskCache(tmp_path, 10**9)
    original = part(5.0)
    cache.put("tile", "k" * 64, *part_to_entry(original))
    entry = cache.get("tile", "k" * 64)
    back = part_from_entry(entry.meta, entry.arrays)
    for name in ("vertices", "faces", "class_id", "instance", "object_index"):
        np.testing.assert_array_equal(getattr(back.geometry, name), getattr(original.geometry, name))
    assert back.geometry.object_names == original.geometry.object_names
    np.testing.assert_array_equal(back.cover.class_id, original.cover.class_id)
    np.testing.assert_array_equal(back.cover.terrain_z, original.cover.terrain_z)
    np.testing.assert_array_equal(back.geometry.offset, original.geometry.offset)
    for got, want in zip(back.bounds(), object_bounds(original.geometry)):
        np.testing.assert_array_equal(got, want)


def test_an_objects_box_holds_each_of_its_triangles():
    g = part(3.0).geometry
    lo, hi = object_bounds(g)
    tris = g.triangles()[:, :, :2]
    assert (tris.min(axis=1) >= lo[g.object_index]).all() and (tris.max(axis=1) <= hi[g.object_index]).all()
    assert lo[0].tolist() == [3.0, 3.0] and hi[1].tolist() == [5.0, 5.0]


def test_joined_tiles_keep_each_triangle_with_its_own_object():
    joined = join([part(0.0, ("a", "b")), part(10.0, ("c", "d"))], centre=(5, 5))
    assert joined.object_names == ("a", "b", "c", "d")
    assert [joined.object_names[k] for k in joined.object_index] == ["a", "b", "c", "d"]
    assert joined.triangle_count == 4 and list(joined.offset[:2]) == [5.0, 5.0]
    np.testing.assert_array_equal(joined.triangles()[2:], part(10.0).geometry.triangles())


def test_the_tile_memory_stays_under_its_bound_dropping_the_least_recently_used():
    one = part(0.0).nbytes()
    memory = TileMemory(max_bytes=3 * one)
    for k in range(3):
        memory.put(f"t{k}", part(float(k)))
    assert memory.get("t0") is not None  # t0 now the most recently used
    memory.put("t3", part(3.0))
    assert memory.held <= 3 * one and set(memory.parts) == {"t2", "t0", "t3"}


# --- the endless world itself (core/world/endless): slow, tiles are built ----------------


def triangles_inside(path, box) -> np.ndarray:
    """The extracted triangles (float64 corners) lying wholly inside box, sorted, as bytes rows."""
    with np.load(path) as f:
        tris = f["vertices"][f["faces"]]
    x, y = tris[:, :, 0], tris[:, :, 1]
    inside = (x.min(1) >= box[0]) & (y.min(1) >= box[1]) & (x.max(1) <= box[2]) & (y.max(1) <= box[3])
    rows = np.ascontiguousarray(tris[inside]).reshape(-1, 9).view(np.dtype((np.void, 72))).ravel()
    return np.sort(rows)


LIGHT = ["--detail", "low", "--vegetation", "solid", "--quiet"]


@pytest.mark.slow
def test_regions_that_share_tiles_give_the_same_triangles_whichever_is_built_first(tmp_path):
    a, b = ["--region", "10", "10", "90", "90"], ["--region", "50", "10", "150", "90"]
    overlap = (50.0, 10.0, 90.0, 90.0)
    got = {}
    for order, first, second in (("ab", a, b), ("ba", b, a)):
        cache = tmp_path / f"cache-{order}"
        for name, region in ((f"{order}-1", first), (f"{order}-2", second)):
            out = tmp_path / f"{name}.npz"
            done = run(
                [
                    WILDSCAN,
                    "extract",
                    "--seed",
                    "1",
                    *region,
                    *LIGHT,
                    "--cache",
                    str(cache),
                    "--out",
                    str(out),
                ]
            )
            assert done.returncode == 0, done.stderr
            got[name] = triangles_inside(out, overlap)
    assert len(got["ab-1"]) > 1000
    assert got["ab-1"].tobytes() == got["ab-2"].tobytes() == got["ba-1"].tobytes() == got["ba-2"].tobytes()


@pytest.mark.slow
def test_a_region_has_terrain_in_every_10_m_cell(tmp_path):
    from wildscan.core.classes import class_by_name

    out = tmp_path / "r.npz"
    done = run(
        [
            WILDSCAN,
            "extract",
            "--seed",
            "1",
            "--region",
            "-60",
            "-40",
            "60",
            "40",
            *LIGHT,
            "--out",
            str(out),
            "--no-cache",
        ]
    )
    assert done.returncode == 0, done.stderr
    with np.load(out) as f:
        tris, cls = f["vertices"][f["faces"]], f["class_id"]
    ground = {class_by_name("terrain").id} | {c for c in range(16, 22)}  # terrain and the ground materials
    centre = tris[np.isin(cls, list(ground))][:, :, :2].mean(axis=1)
    cells = {
        (int(np.floor(x / 10)), int(np.floor(y / 10))) for x, y in centre if -60 <= x < 60 and -40 <= y < 40
    }
    assert cells == {(i, j) for i in range(-6, 6) for j in range(-4, 4)}


@pytest.mark.slow
def test_a_scan_far_from_the_origin_builds_its_tiles_and_equals_itself_from_the_cache(tmp_path, capsys):
    pose = ["--pose", "1520", "-730", "40"]
    args = ["scan", "--seed", "2", *pose, "--rh", "6", "--cache", str(tmp_path / "c"), "--quiet"]
    assert main([*args, "--out", str(tmp_path / "a.ply")]) == 0
    assert main([*args, "--out", str(tmp_path / "b.ply")]) == 0
    assert (tmp_path / "a.ply").read_bytes() == (tmp_path / "b.ply").read_bytes()
    meta = json.loads((tmp_path / "a.json").read_text())
    assert meta["layout"] == "endless" and meta["lod"] == "on" and meta["seed"] == 2
    assert any(p.name.startswith("tile-") for p in (tmp_path / "c").iterdir())
    capsys.readouterr()
    assert (
        main(
            [
                "scan",
                "--seed",
                "2",
                *pose,
                "--rh",
                "6",
                "--lod",
                "off",
                "--no-cache",
                "--quiet",
                "--out",
                str(tmp_path / "off.ply"),
            ]
        )
        == 0
    )


def test_tiles_cropped_before_the_join_equal_the_joined_whole_cropped():
    parts = [part(0.0, ("a", "b")), part(1.5, ("c", "d")), part(10.0, ("e", "f"))]
    whole = join(parts, centre=(1.0, 1.0)).cropped((1.0, 1.0), 1.2)
    joined = join(parts, centre=(1.0, 1.0), radius=1.2)
    early = joined.cropped((1.0, 1.0), 1.2)
    assert 0 < early.triangle_count <= joined.triangle_count < 6  # the far tile's objects left out
    for name in ("vertices", "faces", "class_id", "instance", "object_index", "offset"):
        np.testing.assert_array_equal(getattr(early, name), getattr(whole, name))
    assert early.object_names == whole.object_names


@pytest.mark.slow
def test_a_fresh_process_builds_the_same_tiles_from_the_cached_library(tmp_path):
    cache = tmp_path / "cache"
    region = ["--region", "10", "10", "40", "40"]
    for name in ("a", "b"):
        done = run(
            [
                WILDSCAN,
                "extract",
                "--seed",
                "3",
                *region,
                *LIGHT,
                "--cache",
                str(cache),
                "--out",
                str(tmp_path / f"{name}.npz"),
            ]
        )
        assert done.returncode == 0, done.stderr
        libraries = [p for p in cache.iterdir() if p.name.startswith("library-")]
        assert len(libraries) == 1
        for tile in cache.glob("tile-*"):
            tile.unlink()  # the next run builds its tiles again, from the library it reads back
    assert (tmp_path / "a.npz").read_bytes() == (tmp_path / "b.npz").read_bytes()


@pytest.mark.slow
def test_world_builds_a_region_of_the_endless_world_with_its_poses_and_map(tmp_path, capsys):
    from matplotlib.image import imread

    from wildscan.core.world.endless import LAND_COVERS

    out = tmp_path / "w.blend"
    region = ["--region", "10", "10", "60", "50"]
    argv = [
        "world",
        "--seed",
        "4",
        *region,
        *LIGHT,
        "--poses",
        "1",
        "--out",
        str(out),
        "--map",
        str(tmp_path / "m.png"),
    ]
    assert main(argv) == 0, capsys.readouterr().err
    sidecar = json.loads((tmp_path / "w.json").read_text())
    assert sidecar["layout"] == "endless" and sidecar["region"] == {
        "xmin": 10,
        "ymin": 10,
        "xmax": 60,
        "ymax": 50,
    }
    assert set(sidecar["poses"]) == set(LAND_COVERS) and sum(map(len, sidecar["poses"].values())) >= 1
    for cover, poses in sidecar["poses"].items():
        assert all(p["cover"] == cover and 10 <= p["x"] <= 60 and 10 <= p["y"] <= 50 for p in poses)
    assert imread(str(tmp_path / "m.png")).shape[0] > 400
    assert out.stat().st_size > 0


def test_the_process_counts_the_tiles_it_built_and_read_and_their_seconds(tmp_path):
    """TILE_WORK: what a dataset worker reports of its tiles (bench-dataset's floor)."""
    from wildscan.app.tile_memory import TILE_WORK
    from wildscan.app.tiles import TiledWorld, tile_part

    world = TiledWorld(3, "mixed", "low", "solid")
    cache = DiskCache(tmp_path, 10**10)
    before = TILE_WORK.copy()
    built = tile_part(world, (0, 0), 0, cache)
    after_build = TILE_WORK.since(before)
    assert (after_build.built, after_build.read) == (1, 0) and after_build.build_seconds > 0
    read = tile_part(world, (0, 0), 0, cache)  # no memory given: from the cache
    work = TILE_WORK.since(before)
    assert (work.built, work.read) == (1, 1) and work.read_seconds > 0
    assert work.build_seconds == after_build.build_seconds
    np.testing.assert_array_equal(read.geometry.vertices, built.geometry.vertices)
