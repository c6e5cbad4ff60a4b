"""Paths and names as users type them: every path option is read by one
function (core/io/files.user_path) and checked before any work; a legal long name is
written; a failed write names the file that failed and why."""

from __future__ import annotations

import errno
import os
import subprocess
from pathlib import Path

import pytest

from wildscan.core.errors import UserError
from wildscan.core.io import files

from tests.helpers.processes import started
from tests.helpers.scene_helpers import PAPER, WILDSCAN, run, save_seed_2_low, user_error_line

SCAN = ["--pose", "0", "0", "0", "--rh", "4", "--quiet"]  # seed 2, low detail: a valid pose
TOO_LONG = "n" * 300  # over NAME_MAX (255 bytes) on every file system we write to


@pytest.fixture(scope="module")
def worlds(tmp_path_factory):
    return save_seed_2_low(tmp_path_factory.mktemp("worlds"))


@pytest.mark.slow
def test_a_legal_long_name_is_written_though_its_temporary_name_would_be_too_long(tmp_path, worlds):
    limit = os.pathconf(tmp_path, "PC_NAME_MAX")
    out = tmp_path / ("s" * (limit - len(".json")) + ".ply")  # the sidecar's name is the longest legal
    done = run([WILDSCAN, "scan", "--geometry", str(worlds / "w.npz"), *SCAN, "--out", str(out)])
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([out.name, out.with_suffix(".json").name])


@pytest.mark.slow
@pytest.mark.parametrize(
    "args, flag",
    [
        (["scan", "--geometry", "{w}/w.npz", *SCAN, "--out", "{d}/" + TOO_LONG + ".ply"], "--out"),
        (["scan", "--world", "{d}/" + TOO_LONG + ".blend", *SCAN, "--out", "{d}/s.ply"], "--world"),
        (["scan", "--geometry", "{d}/" + TOO_LONG + "/g.npz", *SCAN, "--out", "{d}/s.ply"], "--geometry"),
        (["world", *PAPER, "--seed", "2", "--out", "{d}/" + TOO_LONG + ".blend"], "--out"),
        (
            ["world", *PAPER, "--seed", "2", "--out", "{d}/w.blend", "--map", "{d}/" + TOO_LONG + ".png"],
            "--map",
        ),
        (["extract", *PAPER, "--seed", "2", "--out", "{d}/" + TOO_LONG + ".npz"], "--out"),
        (["demo", "--out", "{d}/" + TOO_LONG], "--out"),
    ],
    ids=["scan-out", "scan-world", "scan-geometry", "world-out", "world-map", "extract-out", "demo-out"],
)
def test_a_name_over_the_limit_is_a_user_mistake_found_before_any_work(tmp_path, worlds, args, flag):
    cmd = [a.format(w=worlds, d=tmp_path) for a in args]
    done = run([WILDSCAN, *cmd])
    assert done.returncode == 2, done.stderr
    line = user_error_line(done)
    assert f"error: {flag} " in line and "longer than the 255 the file system allows" in line, line
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_every_path_option_takes_a_tilde_the_same_way(tmp_path, worlds):
    home = tmp_path / "home"
    home.mkdir()
    for name in ("w.blend", "w.npz"):
        (home / name).write_bytes((worlds / name).read_bytes())
    env = dict(os.environ, HOME=str(home), PYTHONUNBUFFERED="1")

    def wildscan(*args):
        done = subprocess.run(
            [WILDSCAN, *args], capture_output=True, text=True, env=env, cwd=tmp_path, timeout=300
        )
        assert done.returncode == 0, done.stderr

    # `--opt=~/x` reaches us unexpanded (the shell only expands a word-initial ~)
    wildscan("scan", "--world=~/w.blend", *SCAN, "--out=~/a.ply")
    wildscan("scan", "--geometry=~/w.npz", *SCAN, "--out=~/b.ply")
    wildscan("extract", "--world=~/w.blend", "--out=~/c.npz", "--quiet")
    wildscan("world", "--seed=2", "--detail=low", "--out=~/d.blend", "--map=~/m.png", "--quiet")
    assert {"a.ply", "b.ply", "c.npz", "d.blend", "d.json", "m.png"} <= {p.name for p in home.iterdir()}
    assert not (tmp_path / "~").exists()


@pytest.mark.slow
def test_a_full_disk_while_writing_the_map_names_the_map(tmp_path, monkeypatch):
    """matplotlib's write error names no file: the world's files must not take the blame."""
    from wildscan.app.world import make_world
    from wildscan.viz import aerial_map

    from tests.helpers.scene_helpers import fresh_scene

    def full_disk(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    fresh_scene()
    monkeypatch.setattr(aerial_map, "render_map", full_disk)
    with pytest.raises(UserError) as caught:
        make_world(2, "low", tmp_path / "w.blend", tmp_path / "m.png")
    assert str(caught.value) == f"cannot write {tmp_path / 'm.png'}: No space left on device"
    assert not any(tmp_path.iterdir())


def test_a_full_disk_while_renaming_names_the_file_and_leaves_nothing(tmp_path, monkeypatch):
    finals = [tmp_path / "a.ply", tmp_path / "a.json"]
    real_replace = os.replace

    def replace(src, dst):
        if str(dst).endswith(".json"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(src))
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(UserError, match=r"cannot write .*a\.json: No space left on device"):
        with files.atomic_outputs(*finals) as temps:
            for t in temps:
                t.write_text("x")
    assert not any(tmp_path.iterdir())


def test_blenders_save_message_is_reworded_to_name_the_users_file():
    from wildscan.blender.scene_io import blender_save_reason

    tmp = Path("/d/.w.tmp-12.blend")
    said = RuntimeError(f"Error: Cannot open file {tmp}@ for writing: No space left on device\n")
    assert blender_save_reason(said, tmp) == "No space left on device"
    assert blender_save_reason(RuntimeError(""), tmp) == "Blender could not save it"


def test_user_path_reads_what_users_type(tmp_path, monkeypatch):
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.chdir(tmp_path)
    assert files.user_path("~/a.ply", "out") == tmp_path / "a.ply"
    assert files.user_path("sub/../a.ply", "out") == tmp_path / "a.ply"
    with pytest.raises(UserError, match="needs a file name, got an empty one"):
        files.user_path("  ", "out")
    with pytest.raises(UserError, match="longer than"):
        files.user_path(tmp_path / TOO_LONG / "a.ply", "out")
    long_final = tmp_path / ("x" * 250 + ".ply")
    assert len(files.temp_path(long_final).name.encode()) < files.name_max(tmp_path)


def deep_folder(root: Path, at_least: int) -> Path:
    """A folder under `root` whose absolute path is at least `at_least` bytes long."""
    folder = root
    while len(os.fsencode(str(folder))) < at_least:
        folder = folder / ("d" * 100)
    folder.mkdir(parents=True)
    return folder


def test_an_existing_world_by_a_path_longer_than_blender_reads_is_called_too_long(tmp_path, worlds):
    world = deep_folder(tmp_path, 1024) / "w.blend"
    world.write_bytes((worlds / "w.blend").read_bytes())
    done = run([WILDSCAN, "scan", "--world", str(world), *SCAN, "--out", str(tmp_path / "s.ply")])
    assert done.returncode == 2
    line = user_error_line(done)
    assert (
        "too long for Blender" in line and "at most 1023 bytes" in line and "no such file" not in line.lower()
    )
    assert not (tmp_path / "s.ply").exists()


def test_a_world_out_path_blender_cannot_write_is_refused_before_any_work(tmp_path):
    out = deep_folder(tmp_path, 1010) / "w.blend"
    done = run([WILDSCAN, "world", *PAPER, "--seed", "2", "--detail", "low", "--quiet", "--out", str(out)])
    assert done.returncode == 2
    assert "too long for Blender" in user_error_line(done)
    assert not any(out.parent.iterdir())


def blocked_on_a_lock(pid: int) -> bool:
    """Whether process `pid` waits for a lock another holds (/proc/locks lists it with ->)."""
    return any(
        line.split()[1] == "->" and line.split()[6] == str(pid)
        for line in Path("/proc/locks").read_text().splitlines()
        if len(line.split()) > 6
    )


def test_two_scans_to_the_same_out_at_once_leave_one_scans_ply_and_sidecar_together(tmp_path, worlds):
    """A stops after renaming its PLY, before its sidecar; B writes the same --out meanwhile.
    B must wait for A's group (else B's PLY and then A's sidecar would be left side by side)."""
    import json
    import time

    from wildscan.core.io.ply import read_ply

    resume = tmp_path / "resume"
    scan = [WILDSCAN, "scan", "--geometry", str(worlds / "w.npz"), "--rh", "4", "--quiet", "--out", "s.ply"]
    env = dict(os.environ, WILDSCAN_TEST_PAUSE_AT="renamed", WILDSCAN_TEST_RESUME=str(resume))
    first = started(
        [*scan, "--pose", "0", "0", "0"], cwd=tmp_path, env=env, stderr=subprocess.PIPE, text=True
    )
    assert first.stderr.readline().startswith("wildscan-test-pause renamed")
    second = started([*scan, "--pose", "0", "0", "90"], cwd=tmp_path, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while second.poll() is None and not blocked_on_a_lock(second.pid):  # an event: B done, or B waiting
        assert time.monotonic() < deadline, "the second scan neither finished nor waited"
        time.sleep(0.01)  # the poll's interval, not a guess at how long anything takes
    resume.touch()
    assert first.wait(timeout=120) == 0 and second.wait(timeout=120) == 0, (
        first.stderr.read(),
        second.stderr.read(),
    )
    sidecar = json.loads((tmp_path / "s.json").read_text())
    cloud, _ = read_ply(tmp_path / "s.ply")
    assert sidecar["point_count"] == len(cloud)
    assert sidecar["pose"]["yaw_deg"] == 90.0  # B's group, written whole after A's
    assert sorted(p.name for p in tmp_path.iterdir()) == ["resume", "s.json", "s.ply"]
