"""`wildscan extract` and `scan --geometry`: a world's scan geometry saved once, scanned
anywhere without Blender, with the points of a scan of the world itself."""

from __future__ import annotations

import json
import sys

import pytest

from wildscan.core.io.ply import read_ply

from tests.helpers.scene_helpers import BLENDER, PAPER, WILDSCAN, run, user_error_line

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

PARK_POSE_SEED_2_LOW = ("61.908", "-58.594", "126.6")  # `wildscan poses --seed 2 --detail low --zone park`
# Runs a wildscan command in a Python where bpy cannot be imported at all.
NO_BPY = (
    "import sys; sys.modules['bpy'] = None; sys.modules['mathutils'] = None\n"
    "from wildscan.cli import main; sys.exit(main(sys.argv[1:]))"
)


def without_bpy(*args: str):
    return run([sys.executable, "-c", NO_BPY, *args])


def points(path) -> bytes:
    return read_ply(path)[0].tobytes()


def test_a_seeds_geometry_is_extracted_and_scanned_without_blender_as_the_seed_itself(tmp_path):
    scene = tmp_path / "seed2.npz"
    extracted = without_bpy("extract", *PAPER, "--seed", "2", "--detail", "low", "--out", str(scene))
    assert extracted.returncode == 0, extracted.stderr
    assert f"wrote {scene}" in extracted.stdout
    pose = ["--pose", *PARK_POSE_SEED_2_LOW, "--rh", "4", "--noise", "0"]
    from_file = without_bpy("scan", "--geometry", str(scene), *pose, "--out", str(tmp_path / "file.ply"))
    assert from_file.returncode == 0, from_file.stderr
    # the same world built in Blender (the bpy wheel) and scanned there
    low = run(
        [WILDSCAN, "world", *PAPER, "--seed", "2", "--detail", "low", "--out", str(tmp_path / "w.blend")]
    )
    assert low.returncode == 0, low.stderr
    in_blender = run(
        [WILDSCAN, "scan", "--world", str(tmp_path / "w.blend"), *pose, "--out", str(tmp_path / "b.ply")]
    )
    assert in_blender.returncode == 0, in_blender.stderr
    assert points(tmp_path / "file.ply") == points(tmp_path / "b.ply")
    sidecar = json.loads((tmp_path / "file.json").read_text())
    assert sidecar["seed"] == 2 and sidecar["geometry"] == str(scene)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--backend", "blender"], "--backend blender needs a Blender scene"),
        (["--geometry", "missing.npz"], "--geometry"),
    ],
)
def test_geometry_mistakes_exit_2_in_one_line(tmp_path, args, message):
    scene = tmp_path / "s.npz"
    assert (
        without_bpy("extract", *PAPER, "--seed", "0", "--detail", "low", "--out", str(scene)).returncode == 0
    )
    argv = ["scan", "--geometry", str(scene), "--pose", "0", "0", "0", "--out", str(tmp_path / "x.ply")]
    if args[0] == "--geometry":
        argv[2] = str(tmp_path / args[1])
    else:
        argv += args
    proc = without_bpy(*argv)
    assert proc.returncode == 2
    assert message in user_error_line(proc)
    assert not (tmp_path / "x.ply").exists()


def test_extract_builds_the_vegetation_asked_for_and_records_it(tmp_path):
    from wildscan.raycast.from_plan import world_geometry
    from wildscan.raycast.scene_file import load_geometry_file

    scene = tmp_path / "solid.npz"
    proc = without_bpy(
        "extract", *PAPER, "--seed", "2", "--detail", "low", "--vegetation", "solid", "--out", str(scene)
    )
    assert proc.returncode == 0, proc.stderr
    geometry, header = load_geometry_file(scene)
    assert header["metadata"]["vegetation"] == "solid"
    solid = world_geometry(2, "low", "solid")
    assert geometry.triangle_count == solid.triangle_count != world_geometry(2, "low").triangle_count
    saved = tmp_path / "x.blend"  # exists: the path check comes first and must pass
    saved.write_bytes(b"")
    blend = without_bpy(
        "extract", "--world", str(saved), "--vegetation", "solid", "--out", str(tmp_path / "b.npz")
    )
    assert blend.returncode == 2
    assert "--vegetation applies to a world built from --seed only" in user_error_line(blend)


def test_extract_refuses_a_wrong_suffix_before_any_work(tmp_path):
    proc = without_bpy("extract", *PAPER, "--seed", "1", "--out", str(tmp_path / "scene.txt"))
    assert proc.returncode == 2
    assert "must end in .npz" in user_error_line(proc)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.blender_binary
def test_blender_34_extracts_the_open_file_and_the_wheel_scans_it_as_blender_does(tmp_path):
    blend, scene = tmp_path / "w.blend", tmp_path / "w.npz"
    script = [BLENDER, "-b", "--factory-startup", "-P"]
    built = run(
        [
            *script,
            "blender_scripts/world.py",
            "--",
            *PAPER,
            "--seed",
            "2",
            "--detail",
            "low",
            "--out",
            str(blend),
        ]
    )
    assert built.returncode == 0, built.stderr
    extracted = run(
        [
            BLENDER,
            "-b",
            str(blend),
            "--factory-startup",
            "-P",
            "blender_scripts/extract.py",
            "--",
            "--out",
            str(scene),
        ]
    )
    assert extracted.returncode == 0, extracted.stderr
    pose = ["--pose", *PARK_POSE_SEED_2_LOW, "--rh", "4", "--backend", "bvh"]
    scanned = run(
        [
            BLENDER,
            "-b",
            str(blend),
            "--factory-startup",
            "-P",
            "blender_scripts/scan.py",
            "--",
            *pose,
            "--out",
            str(tmp_path / "b.ply"),
        ]
    )
    assert scanned.returncode == 0, scanned.stderr
    from_file = run([WILDSCAN, "scan", "--geometry", str(scene), *pose, "--out", str(tmp_path / "g.ply")])
    assert from_file.returncode == 0, from_file.stderr
    assert points(tmp_path / "g.ply") == points(tmp_path / "b.ply")


def test_a_blends_header_names_the_blender_that_wrote_it(tmp_path):
    import gzip

    from wildscan.blender.blend_header import _unzstd_with_libzstd, blend_version, header_version

    assert header_version(b"BLENDER-v304REND") == (3, 4)  # 3.4, 64-bit, little-endian
    assert header_version(b"BLENDER_V279REND") == (2, 79)  # 32-bit, big-endian
    assert header_version(b"BLENDER17-01v0500") == (5, 0)  # the header bpy 5.0.1 writes
    assert header_version(b"PK\x03\x04") is None
    (tmp_path / "old.blend").write_bytes(gzip.compress(b"BLENDER-v279REND" + bytes(64)))
    assert blend_version(tmp_path / "old.blend") == (2, 79)
    new = tmp_path / "new.blend"
    saved = run(
        [
            sys.executable,
            "-c",
            f"import bpy; bpy.ops.wm.save_as_mainfile(filepath={str(new)!r}, compress=True)",
        ]
    )
    assert saved.returncode == 0, saved.stderr
    assert blend_version(tmp_path / "new.blend") == (5, 0)
    # a Blender's own Python may have no zstandard module: libzstd through ctypes reads it too
    data = (tmp_path / "new.blend").read_bytes()
    assert data[:4] == b"\x28\xb5\x2f\xfd" and _unzstd_with_libzstd(data, 17) == b"BLENDER17-01v0500"


@pytest.mark.blender_binary
def test_blender_34_given_a_newer_blend_says_which_blender_wrote_it_and_what_to_do(tmp_path):
    blend = tmp_path / "new.blend"
    saved = run([sys.executable, "-c", f"import bpy; bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})"])
    assert saved.returncode == 0, saved.stderr
    cmd = [BLENDER, "-b", "--factory-startup", "-P", "blender_scripts/scan.py", "--", "--world", str(blend)]
    done = run([*cmd, "--pose", "0", "0", "0", "--out", str(tmp_path / "s.ply")])
    assert done.returncode == 2
    line = user_error_line(done)
    assert "written by Blender 5.0, which this Blender 3.4" in line, line
    assert "blender -b -P blender_scripts/world.py" in line and "not a blend file" not in line
    assert not (tmp_path / "s.ply").exists()
