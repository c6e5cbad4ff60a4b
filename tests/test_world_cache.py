"""The world cache (app/cache/): keys that change with every input and with the code, entries
written atomically by concurrent writers, verified on read (a damaged entry is rebuilt with
one warning, never used), a size cap that drops the least recently used entries, and a
dataset scanned from a warm cache byte for byte the one scanned cold or without a cache."""

from __future__ import annotations

import json
import multiprocessing
import os
from pathlib import Path

import numpy as np
import pytest

from wildscan import __version__
from wildscan.app.cache import key as cache_key
from wildscan.app.cache.config import cache_config, cache_from_options, default_cache_dir
from wildscan.app.cache.store import TEMP_PREFIX, DiskCache
from wildscan.app.cache.worlds import prepared_world, world_inputs
from wildscan.core.errors import UserError
from wildscan.core.truth.open_sky import open_sky
from wildscan.core.truth.traversability import ROBOT_HEIGHT
from wildscan.core.world import EXTENT

from tests.helpers.dataset_helpers import assert_same_dataset, wildscan

KEY = "ab" * 32
OTHER = "cd" * 32
SMALL_WORLD = (1, "low", "solid", "mixed")  # the smallest world with ground cover: ~20 MB


def arrays(n: int = 1000, seed: int = 0) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    return {
        "vertices": rng.random((n, 3)),
        "faces": rng.integers(0, n, (n, 3)).astype(np.int32),
        "flags": rng.random(n) > 0.5,
        "empty": np.zeros((0, 3)),
        "scalar": np.float32(2.5) * np.ones(()),
    }


def assert_same_arrays(a: dict, b: dict) -> None:
    assert sorted(a) == sorted(b)
    for name in a:
        assert a[name].dtype == b[name].dtype and a[name].shape == b[name].shape, name
        assert np.array_equal(a[name], b[name]), name


# --------------------------------------------------------------------------- keys


def test_the_key_changes_with_every_input_and_with_the_code(monkeypatch):
    base = world_inputs(*SMALL_WORLD)
    changed = [dict(base, seed=2), dict(base, detail="default"), dict(base, vegetation="porous"),
               dict(base, biome="meadow")]  # fmt: skip
    keys = [cache_key.entry_key("world", inputs) for inputs in [base, *changed]]
    keys.append(cache_key.entry_key("poses", base))
    monkeypatch.setattr(cache_key, "FORMAT", cache_key.FORMAT + 1)
    keys.append(cache_key.entry_key("world", base))
    monkeypatch.undo()
    monkeypatch.setattr(cache_key, "source_hash", lambda: "0" * 64)  # any edit of the code
    keys.append(cache_key.entry_key("world", base))
    assert len(set(keys)) == len(keys)
    monkeypatch.undo()
    assert cache_key.entry_key("world", dict(base)) == keys[0]  # and nothing else moves it


def test_the_source_hash_follows_every_file_of_the_hashed_folders_but_bytecode(tmp_path, monkeypatch):
    for folder in cache_key.SOURCES:
        (tmp_path / folder).mkdir(parents=True)
        (tmp_path / folder / "a.py").write_text("x = 1\n")
    monkeypatch.setattr(cache_key, "PACKAGE", tmp_path)
    try:
        hashes = []
        for change in (None, "core/a.py", "raycast/a.py", "app/cache/a.py", "core/presets/s.toml"):
            if change:
                (tmp_path / change).parent.mkdir(exist_ok=True)
                (tmp_path / change).write_text("x = 2\n")
            cache_key.source_hash.cache_clear()
            hashes.append(cache_key.source_hash())
        (tmp_path / "core" / "__pycache__").mkdir()
        (tmp_path / "core" / "__pycache__" / "a.cpython-311.pyc").write_bytes(b"\0")
        (tmp_path / "app" / "other.py").write_text("y = 1\n")  # not a folder worlds are made in
        cache_key.source_hash.cache_clear()
        assert cache_key.source_hash() == hashes[-1]
    finally:
        monkeypatch.undo()
        cache_key.source_hash.cache_clear()
    assert len(set(hashes)) == len(hashes)


def test_the_real_source_hash_covers_the_world_code():
    files = {p.relative_to(cache_key.PACKAGE).as_posix() for f in cache_key.SOURCES
             for p in (cache_key.PACKAGE / f).rglob("*.py")}  # fmt: skip
    for module in (
        "core/world/pipeline.py",
        "raycast/from_plan.py",
        "raycast/settle.py",
        "app/cache/worlds.py",
    ):
        assert module in files


# --------------------------------------------------------------------------- the store


def test_an_entry_reads_back_bit_for_bit_and_numpy_opens_it(tmp_path):
    cache = DiskCache(tmp_path, 1 << 30)
    cache.put("world", KEY, {"names": ["a", "b"], "z": [0.1, 1e-300]}, arrays())
    entry = cache.get("world", KEY)
    assert entry.meta == {"names": ["a", "b"], "z": [0.1, 1e-300]} and not cache.warnings
    assert_same_arrays(entry.arrays, arrays())
    for a in entry.arrays.values():
        assert a.flags.writeable and a.flags.c_contiguous and a.ctypes.data % 64 == 0
    with np.load(cache.path("world", KEY), allow_pickle=False) as npz:  # a plain .npz for numpy
        assert_same_arrays({n: npz[n] for n in npz.files if n != "entry.json"}, arrays())
    assert cache.get("world", OTHER) is None and not cache.warnings  # a miss says nothing


def _flip(data: bytes) -> bytes:
    middle = bytearray(data)
    middle[len(data) // 2] ^= 0x01
    return bytes(middle)


@pytest.mark.parametrize(
    "damage",
    [_flip, lambda d: d[: len(d) // 2], lambda d: d[:10], lambda d: b"", lambda d: d + b"\0",
     lambda d: d[:-64] + b"0" * 64],
    ids=["a-flipped-bit", "truncated", "cut-to-10-bytes", "empty", "a-byte-more", "no-digest"],
)  # fmt: skip
def test_a_damaged_entry_is_never_used_and_says_so_once(tmp_path, damage):
    cache = DiskCache(tmp_path, 1 << 30)
    cache.put("world", KEY, {"n": 1}, arrays())
    path = cache.path("world", KEY)
    path.write_bytes(damage(path.read_bytes()))
    assert cache.get("world", KEY) is None
    assert len(cache.warnings) == 1 and path.name in cache.warnings[0] and "damaged" in cache.warnings[0]
    assert not path.exists()  # removed: the next writer puts a whole one
    cache.put("world", KEY, {"n": 1}, arrays())
    assert_same_arrays(cache.get("world", KEY).arrays, arrays())
    assert len(cache.warnings) == 1


def test_a_whole_entry_under_another_key_is_not_taken_for_it(tmp_path):
    cache = DiskCache(tmp_path, 1 << 30)
    cache.put("world", KEY, {"n": 1}, arrays())
    os.replace(cache.path("world", KEY), cache.path("world", OTHER))
    assert cache.get("world", OTHER) is None and "not the entry its name says" in cache.warnings[0]


def _write_when_told(root: str, ready, go) -> None:
    """A writer that stops with its whole temporary file written, before the rename, until
    the test says go (a spawned process: the patch is its own)."""
    from wildscan.app.cache import store

    rename = os.replace

    def replace(src, dst):
        ready.wait(timeout=120)
        go.wait(timeout=120)
        rename(src, dst)

    store.os.replace = replace
    DiskCache(Path(root), 1 << 30).put("world", KEY, {"n": 1}, arrays(200_000))


def test_two_processes_writing_the_same_entry_at_once_leave_one_whole_entry(tmp_path):
    spawn = multiprocessing.get_context("spawn")
    ready, go = spawn.Barrier(3), spawn.Event()
    # daemonic: a writer that never ends is ended with the test run, not waited for at its exit
    writers = [
        spawn.Process(target=_write_when_told, args=(str(tmp_path), ready, go), daemon=True) for _ in range(2)
    ]
    for w in writers:
        w.start()
    ready.wait(timeout=120)  # both have written every byte, neither has renamed
    cache = DiskCache(tmp_path, 1 << 30)
    assert cache.get("world", KEY) is None and not cache.warnings  # nothing half-written is visible
    assert [p.name.startswith(TEMP_PREFIX) for p in tmp_path.iterdir()] == [True, True]
    go.set()
    for w in writers:
        w.join(timeout=120)
        assert w.exitcode == 0
    assert_same_arrays(cache.get("world", KEY).arrays, arrays(200_000))
    assert not cache.warnings and [p.name for p in tmp_path.iterdir()] == [cache.path("world", KEY).name]


def test_the_cap_drops_the_least_recently_used_entries_and_nothing_else(tmp_path):
    big = DiskCache(tmp_path, 1 << 30)
    names = ["a" * 64, "b" * 64, "c" * 64]
    for t, name in enumerate(names):
        big.put("world", name, {}, arrays(20_000, t))
        os.utime(big.path("world", name), (1000.0 * (t + 1),) * 2)  # a oldest, c newest
    size = big.path("world", names[0]).stat().st_size
    (tmp_path / "notes.txt").write_bytes(b"x" * 3 * size)  # not an entry: never counted, never removed
    stale = tmp_path / f"{TEMP_PREFIX}killed.npz"
    stale.write_bytes(b"half")
    os.utime(stale, (0.0, 0.0))
    fresh = tmp_path / f"{TEMP_PREFIX}writing.npz"
    fresh.write_bytes(b"half")
    assert big.get("world", names[0]) is not None  # a is used again: now the most recent
    capped = DiskCache(tmp_path, int(2.5 * size))
    capped.put("world", "d" * 64, {}, arrays(20_000, 3))
    left = sorted(p.name for p in tmp_path.iterdir())
    assert left == sorted([f"world-{'a' * 64}.npz", f"world-{'d' * 64}.npz", "notes.txt", fresh.name])
    tiny = DiskCache(tmp_path, 1)  # holds nothing, not even what it was just given
    tiny.put("world", "e" * 64, {}, arrays(10))
    assert tiny.entries_bytes() == 0 and (tmp_path / "notes.txt").exists()


def test_a_cache_that_cannot_be_written_warns_once_and_the_work_goes_on(tmp_path):
    (tmp_path / "file").write_text("")
    cache = DiskCache(tmp_path / "file" / "cache", 1 << 30)
    for _ in range(2):
        cache.put("world", KEY, {}, arrays())
        assert cache.get("world", KEY) is None
    assert len(cache.warnings) == 1 and "cannot write the world cache" in cache.warnings[0]


# --------------------------------------------------------------------------- worlds


def test_a_world_read_back_is_the_world_built_and_a_damaged_one_is_built_again(tmp_path):
    cache = DiskCache(tmp_path, 1 << 30)
    inputs = world_inputs(*SMALL_WORLD)
    built = prepared_world(inputs, cache)
    read = prepared_world(inputs, cache)
    assert (built.from_cache, read.from_cache) == (False, True) and read.plan is None
    for name in ("vertices", "faces", "class_id", "instance", "object_index", "reflectivity", "offset"):
        assert np.array_equal(getattr(built.geometry, name), getattr(read.geometry, name), equal_nan=True)
    assert built.geometry.object_names == read.geometry.object_names
    for name in ("padded", "normal", "d", "corners", "band"):
        assert np.array_equal(getattr(built.settler, name), getattr(read.settler, name)), name
    assert all(np.array_equal(a, b) for a, b in zip(built.settler.neighbours, read.settler.neighbours))
    assert np.array_equal(built.open_ground.is_open, read.open_ground.is_open)
    # the open sky stored is the one the worker would make of the triangles (core/truth/open_sky.py)
    g, terrain = built.geometry, built.ground.terrain
    made = open_sky(g.vertices, g.faces, terrain, ROBOT_HEIGHT, EXTENT)
    for sky in (built.open_sky, read.open_sky):
        assert (sky.x0, sky.y0, sky.cell) == (made.x0, made.y0, made.cell)
        assert np.array_equal(sky.is_open, made.is_open) and made.is_open.any()
    assert built.z_range == read.z_range and np.array_equal(built.instances, read.instances)
    x, y = np.meshgrid(np.linspace(-70, 70, 50), np.linspace(-70, 70, 50))
    assert np.array_equal(built.ground(x, y), read.ground(x, y), equal_nan=True)
    assert np.array_equal(built.cover.node_ground(), read.cover.node_ground())
    assert np.array_equal(built.cover.at(x, y)[1], read.cover.at(x, y)[1])

    path = next(tmp_path.glob("world-*.npz"))
    path.write_bytes(_flip(path.read_bytes()))
    again = prepared_world(inputs, cache)
    assert not again.from_cache and len(cache.warnings) == 1 and path.name in cache.warnings[0]
    assert prepared_world(inputs, cache).from_cache and len(cache.warnings) == 1


def test_a_dataset_scanned_from_a_warm_cache_is_the_one_scanned_cold_or_without(tmp_path):
    from wildscan.app.dataset import worker
    from wildscan.app.dataset.spec import spec_from_dict

    spec = spec_from_dict(
        {"layout": "paper", "seeds": [1], "detail": "low", "vegetation": "solid", "scans_per_world": 2,
         "formats": ["semantickitti", "ply"], "sensor": {"rh": 10.0}}
    )  # fmt: skip
    config = cache_config(tmp_path / "cache")
    files, sources = {}, []
    for label, cache in (("cold", config), ("warm", config), ("none", None)):
        worker._last_world.clear()
        (tmp_path / label).mkdir()
        result = worker.scan_batch(spec.to_dict(), str(tmp_path / label), 1, [0, 1], __version__, cache=cache)
        files[label] = {f["path"]: f["sha256"] for row in result["rows"] for f in row["files"]}
        sources.append(result["worker"]["world_source"])
        assert result["worker"]["cache_warnings"] == []
    worker._last_world.clear()
    assert sources == ["built", "cache", "built"]
    assert files["cold"] == files["warm"] == files["none"] and len(files["cold"]) >= 6


# --------------------------------------------------------------------------- the command line


def test_the_default_cache_is_the_users_cache_directory(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_cache_dir() == tmp_path / "xdg" / "wildscan"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/is/ignored")  # as the XDG specification says
    monkeypatch.setenv("HOME", str(tmp_path))
    assert default_cache_dir() == tmp_path / ".cache" / "wildscan"
    assert cache_from_options(None, True, None, None, print) is None
    assert cache_from_options(str(tmp_path / "c"), False, 2.5, None, print) == {
        "dir": str(tmp_path / "c"),
        "max_bytes": 2_500_000_000,
    }
    with pytest.raises(UserError, match="--no-cache takes no --cache-size"):
        cache_from_options(None, True, 2.0, None, print)


@pytest.mark.parametrize(
    "args, says",
    [
        (["--cache", "{d}/file/cache"], "--cache {d}/file/cache: cannot create the directory"),
        (["--cache", "{d}/file"], "--cache {d}/file: it is a file"),
        (["--cache-size", "0"], "--cache-size: must be a number of gigabytes above 0, got '0'"),
        (["--no-cache", "--cache", "{d}/c"], "not allowed with argument"),
    ],
    ids=["under-a-file", "a-file", "size-0", "both"],
)
def test_a_cache_the_run_cannot_use_is_one_line_and_exit_2_before_any_work(tmp_path, args, says):
    (tmp_path / "file").write_text("")
    text = 'layout = "paper"\nseeds = [1]\ndetail = "low"\nscans_per_world = 1\n'
    (tmp_path / "spec.toml").write_text(text)
    out = tmp_path / "out"
    done = wildscan("dataset", str(tmp_path / "spec.toml"), "--out", str(out),
                    *[a.format(d=tmp_path) for a in args])  # fmt: skip
    assert done.returncode == 2 and says.format(d=tmp_path) in done.stderr, done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and not out.exists()


TWO_WORLDS = """\
layout = "paper"
seeds = [1, 2]
detail = "low"
vegetation = "solid"
scans_per_world = 2
formats = ["semantickitti", "ply"]
split = { train = 1.0, val = 0.0, test = 0.0 }

[sensor]
rh = 10.0
"""


@pytest.mark.slow
def test_a_run_on_a_warm_cache_builds_no_world_says_so_and_writes_the_same_dataset(tmp_path):
    (tmp_path / "spec.toml").write_text(TWO_WORLDS)
    cache = str(tmp_path / "cache")
    said = {}
    for name, flags in (("cold", ["--cache", cache]), ("warm", ["--cache", cache]), ("none", ["--no-cache"])):
        done = wildscan("dataset", str(tmp_path / "spec.toml"), "--out", str(tmp_path / name),
                        "--workers", "1", "--quiet", *flags)  # fmt: skip
        assert done.returncode == 0 and done.stderr == "", done.stderr
        said[name] = done.stdout
    assert "worlds: 0 from cache, 2 built" in said["cold"] and "worlds: 0 from cache, 2 built" in said["none"]
    assert "worlds: 2 from cache, 0 built" in said["warm"]
    run = json.loads((tmp_path / "warm" / "dataset.json").read_text())["runs"][-1]
    assert (run["worlds_from_cache"], run["worlds_built"]) == (2, 0)
    assert_same_dataset(tmp_path / "cold", tmp_path / "warm")  # every file, every manifest SHA-256
    assert_same_dataset(tmp_path / "cold", tmp_path / "none")
