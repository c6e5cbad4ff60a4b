"""Scene geometry saved and loaded (raycast/scene_file.py): a user's .blend extracted
once, scanned anywhere without Blender, with the same bytes."""

from __future__ import annotations

import hashlib
import io
import json
import subprocess
import sys
import zipfile

import bpy
import numpy as np
import pytest

from wildscan.app.scan import scan_current_scene
from wildscan.blender.scene_io import empty_scene, open_world
from wildscan.blender.testworld import build_test_world
from wildscan.core.classes import NUM_IDS
from wildscan.core.errors import UserError
from wildscan.core.io.ply import write_scan_files
from wildscan.core.placement import Pose
from wildscan.core.sensor import SensorConfig
from wildscan.raycast import scene_file
from wildscan.raycast.extract import extract_scene
from wildscan.raycast.geometry import from_triangles
from wildscan.raycast.scene_file import geometry_file_bytes, load_geometry, load_geometry_file, save_geometry

from tests.helpers.backend_scenes import add_mesh, box_mesh

POSE = Pose(0.0, 0.0, 20.0)
SENSOR = SensorConfig(rh_deg=2.0)


@pytest.fixture(scope="module")
def users_blend(tmp_path_factory):
    """A user's .blend: the test world plus an untagged object of their own and an
    array-modified fence, saved and opened again as `wildscan scan --world` would."""
    empty_scene()
    build_test_world(7)
    add_mesh("my shed", *box_mesh(2, 2, 2), location=(6.0, 4.0, 1.0))
    fence = add_mesh("my fence", *box_mesh(1, 0.1, 1), "fence", 900, location=(-6.0, -5.0, 0.5))
    fence.modifiers.new("copies", "ARRAY").count = 4
    path = tmp_path_factory.mktemp("blend") / "users.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return path


@pytest.fixture
def extracted(users_blend):
    open_world(str(users_blend))
    return extract_scene()


def ply_of(result, path) -> bytes:
    ply, _ = write_scan_files(path, result.cloud, dict(result.metadata, seed=None))
    return ply.read_bytes()


@pytest.mark.slow
def test_scans_of_the_loaded_geometry_equal_scans_of_the_extracted_one(extracted, tmp_path):
    path = save_geometry(extracted, tmp_path / "users.npz", {"blend": "users.blend"})
    loaded, header = load_geometry_file(path)
    assert header["metadata"] == {"blend": "users.blend"}
    assert loaded.object_names == extracted.object_names
    assert "my shed" in loaded.object_names
    for name in ("vertices", "faces", "class_id", "instance", "object_index", "offset"):
        a, b = getattr(loaded, name), getattr(extracted, name)
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), name
    for backend in ("embree", "bvh"):
        scans = [
            scan_current_scene(POSE, SENSOR, backend=backend, notify=None, geometry=g)
            for g in (extracted, loaded)
        ]
        assert len(scans[0].cloud) > 10_000
        assert scans[0].untagged_objects == scans[1].untagged_objects == {"my shed"}
        assert ply_of(scans[0], tmp_path / "a.ply") == ply_of(scans[1], tmp_path / "b.ply"), backend


def test_a_python_without_blender_loads_and_scans_it_to_the_same_bytes(extracted, tmp_path):
    path = save_geometry(extracted, tmp_path / "users.npz")
    code = (
        "import hashlib, sys\n"
        "for m in ('bpy', 'mathutils', 'bmesh'): sys.modules[m] = None\n"
        "from wildscan.core.placement import Pose\n"
        "from wildscan.core.io.ply import write_scan_files\n"
        "from wildscan.core.sensor import SensorConfig\n"
        "from wildscan.raycast.scene_file import load_geometry\n"
        "from wildscan.app.scan import scan_current_scene\n"
        f"g = load_geometry({str(path)!r})\n"
        f"r = scan_current_scene(Pose({POSE.x!r}, {POSE.y!r}, {POSE.yaw_deg!r}), "
        f"SensorConfig(rh_deg={SENSOR.rh_deg}), backend='auto', geometry=g)\n"
        f"ply, _ = write_scan_files({str(tmp_path / 'free.ply')!r}, r.cloud, dict(r.metadata, seed=None))\n"
        "print(hashlib.sha256(ply.read_bytes()).hexdigest())\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True, timeout=300
    )
    here = scan_current_scene(POSE, SENSOR, backend="embree", notify=None, geometry=extracted)
    assert out.stdout.split()[-1] == hashlib.sha256(ply_of(here, tmp_path / "here.ply")).hexdigest()


def test_the_same_geometry_always_gives_the_same_bytes(extracted, tmp_path):
    first = save_geometry(extracted, tmp_path / "one.npz", {"b": 1, "a": [1, 2]}).read_bytes()
    second = save_geometry(extracted, tmp_path / "two.npz", {"a": [1, 2], "b": 1}).read_bytes()
    assert first == second
    again = geometry_file_bytes(load_geometry(tmp_path / "one.npz"), {"a": [1, 2], "b": 1})
    assert again == first
    # numpy reads it as it is
    with np.load(tmp_path / "one.npz") as npz:
        assert npz["faces"].tobytes() == extracted.faces.tobytes()
    with zipfile.ZipFile(tmp_path / "one.npz") as zf:
        assert [i.filename for i in zf.infolist()][0] == "header.json"
        assert {i.date_time for i in zf.infolist()} == {(1980, 1, 1, 0, 0, 0)}


def test_an_empty_geometry_round_trips(tmp_path):
    empty = from_triangles(np.zeros((0, 3, 3)), object_names=())
    loaded = load_geometry(save_geometry(empty, tmp_path / "empty.npz"))
    assert loaded.triangle_count == 0 and loaded.object_names == ()


def test_an_objects_own_reflectance_is_saved_and_read_back_only_where_one_is_given(tmp_path):
    g = from_triangles(np.stack([np.eye(3), 2 * np.eye(3)]), class_id=1, instance=2, object_names=("a",))
    plain = geometry_file_bytes(g)
    assert json.loads(zipfile.ZipFile(io.BytesIO(plain)).read("header.json"))["version"] == 1
    g.reflectance = np.array([0.05, np.nan], dtype=np.float32)
    loaded, header = load_geometry_file(save_geometry(g, tmp_path / "own.npz"))
    assert header["version"] == 4
    np.testing.assert_array_equal(loaded.reflectance, g.reflectance)
    assert np.isnan(loaded.reflectivity).all()


def test_a_failed_save_leaves_no_file(tmp_path, monkeypatch):
    g = from_triangles(np.eye(3)[None], class_id=1, instance=2)

    def disk_full(path, write):
        path.write_bytes(b"half a file")
        raise OSError(28, "No space left on device", str(path))

    monkeypatch.setattr(scene_file, "write_durably", disk_full)
    with pytest.raises(UserError, match="No space left"):
        save_geometry(g, tmp_path / "g.npz")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "name, why",
    [("g.ply", "must end in .npz"), ("missing/g.npz", "does not exist")],
)
def test_bad_output_paths_are_user_errors(tmp_path, name, why):
    with pytest.raises(UserError, match=why):
        save_geometry(from_triangles(np.eye(3)[None]), tmp_path / name)


def rewrite(path, out, header_changes=None, drop=None, replace=None):
    """A copy of a geometry file with its header or entries changed."""
    with zipfile.ZipFile(path) as src, zipfile.ZipFile(out, "w") as dst:
        for info in src.infolist():
            data = src.read(info.filename)
            if info.filename == drop:
                continue
            if info.filename == "header.json" and header_changes:
                data = json.dumps({**json.loads(data), **header_changes}).encode()
            if replace and info.filename in replace:
                data = replace[info.filename]
            dst.writestr(info, data)
    return out


def npy(array) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


@pytest.mark.parametrize(
    "change, message",
    [
        (dict(header_changes={"version": 5, "wildscan_version": "9.0.0"}), "written by a newer WildScan"),
        (dict(header_changes={"format": "something else"}), "not a WildScan scene geometry file"),
        (dict(drop="header.json"), r"no header\.json"),
        (dict(drop="faces.npy"), r"faces\.npy is missing"),
        (dict(replace={"faces.npy": npy(np.zeros((1, 3), dtype=np.float32))}), r"faces\.npy holds float32"),
        (dict(replace={"faces.npy": npy(np.full((1, 3), 7, dtype=np.int32))}), "do not fit together"),
        (dict(replace={"object_index.npy": npy(np.array([5], dtype=np.int32))}), "not listed"),
        (dict(header_changes={"object_names": "x"}), "object names are damaged"),
    ],
)
def test_wrong_or_damaged_files_are_refused_clearly(tmp_path, change, message):
    good = save_geometry(from_triangles(np.eye(3)[None], class_id=1, object_names=("a",)), tmp_path / "g.npz")
    bad = rewrite(good, tmp_path / "bad.npz", **change)
    with pytest.raises(UserError, match=message) as error:
        load_geometry(bad)
    assert str(error.value).startswith(f"geometry {bad}")


def test_files_that_are_not_geometry_are_refused(tmp_path):
    (tmp_path / "notes.npz").write_text("hello")
    with pytest.raises(UserError, match="not a WildScan scene geometry file"):
        load_geometry(tmp_path / "notes.npz")
    with pytest.raises(UserError, match="no such file"):
        load_geometry(tmp_path / "absent.npz", setting="scene")


def one_triangle_file(tmp_path):
    g = from_triangles(np.eye(3)[None], class_id=1, instance=2, object_names=("a",))
    return save_geometry(g, tmp_path / "g.npz")


@pytest.mark.parametrize("cut", [0.3, 0.6, 0.99])
def test_a_truncated_file_is_called_damaged_not_foreign(tmp_path, cut):
    data = one_triangle_file(tmp_path).read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: int(len(data) * cut)])
    with pytest.raises(UserError, match="damaged or truncated.*save it again") as error:
        load_geometry(tmp_path / "cut.npz")
    assert "not a WildScan" not in str(error.value)


def test_a_flipped_bit_in_an_array_is_called_damaged(tmp_path):
    data = bytearray(one_triangle_file(tmp_path).read_bytes())
    at = (
        data.index(b"\x93NUMPY", data.index(b"vertices.npy")) + 130
    )  # past the 128-byte .npy header: a vertex value
    data[at] ^= 0x10
    (tmp_path / "flipped.npz").write_bytes(bytes(data))
    with pytest.raises(UserError, match=r"damaged or truncated \(Bad CRC-32"):
        load_geometry(tmp_path / "flipped.npz")


@pytest.mark.parametrize(
    "entry, value, message",
    [
        (
            "class_id.npy",
            np.array([NUM_IDS], dtype="<i2"),
            rf"class_id\.npy holds {NUM_IDS} at triangle 0; allowed 0 to {NUM_IDS - 1}",
        ),
        (
            "class_id.npy",
            np.array([-1], dtype="<i2"),
            rf"class_id\.npy holds -1 .*allowed 0 to {NUM_IDS - 1}",
        ),
        ("instance.npy", np.array([-5], dtype="<i4"), r"instance\.npy holds -5 .*allowed 0 to 2147483647"),
    ],
)
def test_class_ids_and_instances_out_of_range_are_refused_naming_the_array(tmp_path, entry, value, message):
    bad = rewrite(one_triangle_file(tmp_path), tmp_path / "bad.npz", replace={entry: npy(value)})
    with pytest.raises(UserError, match=message):
        load_geometry(bad)


def test_scanning_a_file_with_a_class_id_out_of_range_exits_2_in_one_line(tmp_path):
    from tests.helpers.scene_helpers import WILDSCAN

    bad = rewrite(
        one_triangle_file(tmp_path),
        tmp_path / "bad.npz",
        replace={"class_id.npy": npy(np.array([99], dtype="<i2"))},
    )
    cmd = [
        WILDSCAN,
        "scan",
        "--geometry",
        str(bad),
        "--pose",
        "0",
        "0",
        "0",
        "--out",
        str(tmp_path / "s.ply"),
    ]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 2, done.stderr
    assert done.stderr.count("\n") == 1 and "class_id.npy holds 99" in done.stderr, done.stderr
    assert not (tmp_path / "s.ply").exists()
