"""PLY + sidecar writer: format contract, metadata, determinism, atomicity, and
the readers users already have (plyfile, PCL's pcl_ply2pcd, CloudCompare).

The PCL and CloudCompare tests run the real Debian binaries (apt packages
`pcl-tools` and `cloudcompare`); a missing binary is a failure, not a skip.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import plyfile
import pytest

import wildscan
from wildscan.core.classes import COLOR_BY_ID, class_table_dict, class_table_lines
from wildscan.core.errors import UserError
from wildscan.core.io import ply
from wildscan.core.io.ply import check_output_path, read_ply, sidecar_path, write_scan_files
from wildscan.core.pointcloud import PLY_FIELDS

from tests.helpers.reader_helpers import (
    LONG_WORLD,
    cloudcompare_columns,
    extreme_metadata,
    make_cloud,
    pcl_columns,
)

FIELD_NAMES = [name for name, _ in PLY_FIELDS]
EXPECTED_PROPERTY_LINES = [
    "property float x",
    "property float y",
    "property float z",
    "property float intensity",
    "property uint label",
    "property uint instance",
    "property uchar red",
    "property uchar green",
    "property uchar blue",
    "property ushort ring",
    "property ushort sweep",
    "property float range",
    "property float scalar_label",
]
METADATA = {
    "seed": 42,
    "pose": {"x": 1.5, "y": -2.25, "yaw": 30.0},
    "frame": "leveled",
    "sensor": {"rh": 1.0, "min_range": 0.1, "max_range": 30.0, "noise": {"sigma": 0.01, "seed": 7}},
    "backend": "embree",
}


def header_lines(path: Path) -> list[str]:
    data = path.read_bytes()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    return data[:end].decode("ascii").splitlines()


# --------------------------------------------------------------------------- plyfile + read_ply


@pytest.mark.parametrize("ascii", [False, True])
def test_plyfile_loads_documented_fields_types_and_values(tmp_path, ascii):
    cloud = make_cloud()
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", cloud, METADATA, ascii=ascii)

    data = plyfile.PlyData.read(str(ply_path))
    assert data.text is ascii
    if not ascii:
        assert data.byte_order == "<"
    vertex = data["vertex"]
    assert vertex.count == len(cloud)
    assert [p.name for p in vertex.properties] == FIELD_NAMES
    types = [np.dtype(p.val_dtype).name for p in vertex.properties]
    assert types == ["float32"] * 4 + ["uint32"] * 2 + ["uint8"] * 3 + ["uint16"] * 2 + ["float32"] * 2

    xyz32 = cloud.xyz.astype(np.float32)
    np.testing.assert_array_equal(vertex["x"], xyz32[:, 0])
    np.testing.assert_array_equal(vertex["y"], xyz32[:, 1])
    np.testing.assert_array_equal(vertex["z"], xyz32[:, 2])
    np.testing.assert_array_equal(vertex["intensity"], cloud.intensity)
    np.testing.assert_array_equal(vertex["label"], cloud.label)
    np.testing.assert_array_equal(vertex["scalar_label"], cloud.label.astype(np.float32))
    np.testing.assert_array_equal(vertex["instance"], cloud.instance)
    rgb = np.stack([vertex["red"], vertex["green"], vertex["blue"]], axis=1)
    np.testing.assert_array_equal(rgb, COLOR_BY_ID[cloud.label])
    np.testing.assert_array_equal(vertex["ring"], cloud.ring)
    np.testing.assert_array_equal(vertex["sweep"], cloud.sweep)
    np.testing.assert_array_equal(vertex["range"], cloud.range)


@pytest.mark.parametrize("ascii", [False, True])
def test_header_lists_ply_type_names_in_contract_order(tmp_path, ascii):
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", make_cloud(5), METADATA, ascii=ascii)
    lines = header_lines(ply_path)
    assert lines[:2] == ["ply", "format ascii 1.0" if ascii else "format binary_little_endian 1.0"]
    assert [ln for ln in lines if ln.startswith("property")] == EXPECTED_PROPERTY_LINES
    assert "element vertex 5" in lines
    assert lines[-1] == "end_header"


@pytest.mark.parametrize("ascii", [False, True])
def test_read_ply_round_trips(tmp_path, ascii):
    cloud = make_cloud(300, seed=3)
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", cloud, METADATA, ascii=ascii)
    records, comments = read_ply(ply_path)
    expected = cloud.to_structured()
    assert records.dtype.names == expected.dtype.names
    assert [records.dtype[n].name for n in FIELD_NAMES] == [expected.dtype[n].name for n in FIELD_NAMES]
    for name in FIELD_NAMES:
        np.testing.assert_array_equal(records[name], expected[name], err_msg=name)
    assert comments == ply.header_comments(cloud, METADATA)


def test_binary_file_size_is_header_plus_packed_records(tmp_path):
    cloud = make_cloud(50)
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", cloud, METADATA)
    header_size = len("\n".join(header_lines(ply_path)) + "\n")
    assert ply_path.stat().st_size == header_size + 50 * np.dtype(list(PLY_FIELDS)).itemsize


# --------------------------------------------------------------------------- header comments + sidecar


def test_header_comments_carry_version_metadata_and_class_table(tmp_path):
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", make_cloud(), METADATA)
    comments = plyfile.PlyData.read(str(ply_path)).comments
    assert comments[0] == f"generated by WildScan {wildscan.__version__}"
    assert comments[1:5] == [
        "seed 42",
        "pose x=1.5 y=-2.25 yaw=30.0",
        "frame leveled",
        "sensor max_range=30.0 min_range=0.1 noise.seed=7 noise.sigma=0.01 rh=1.0",
    ]
    assert "backend embree" in comments
    class_comments = [c for c in comments if c.startswith("class ")]
    assert class_comments == [f"class {line}" for line in class_table_lines()]
    assert len(class_comments) == 13


def test_header_frame_defaults_to_the_cloud_frame(tmp_path):
    cloud = make_cloud(4)
    cloud.frame = "world"
    ply_path, json_path = write_scan_files(tmp_path / "scan.ply", cloud, {"seed": 1})
    _, comments = read_ply(ply_path)
    assert "frame world" in comments
    assert json.loads(json_path.read_text())["frame"] == "world"


def test_awkward_metadata_stays_one_ascii_line_per_key(tmp_path):
    meta = {
        "seed": np.int64(9),
        "pose": [np.float32(0.5), 2, -30],
        "world": "my world\nwith a newline\r and ünïcode.blend",
        "odd key\n": {"a b": True, "c": None, "d": Path("/tmp/x y"), "e": np.arange(3)},
    }
    ply_path, json_path = write_scan_files(tmp_path / "scan.ply", make_cloud(3), meta)
    comments = plyfile.PlyData.read(str(ply_path)).comments  # plyfile parses the header as ASCII
    assert all("\n" not in c and "\r" not in c for c in comments)
    assert "seed 9" in comments
    assert "pose 0.5,2,-30" in comments
    (world,) = [c for c in comments if c.startswith("world ")]
    assert json.loads(world[len("world ") :]) == meta["world"]  # quoted text decodes back exactly
    assert 'odd_key_ a_b=true c=null d="/tmp/x y" e=0,1,2' in comments
    # One comment per metadata key (plus `frame`, from the cloud), the version line and the class table.
    assert len(comments) == 1 + len(meta) + 1 + len(class_table_lines())
    sidecar = json.loads(json_path.read_text())
    assert sidecar["seed"] == 9 and sidecar["pose"] == [0.5, 2, -30]
    assert sidecar["odd key\n"]["e"] == [0, 1, 2]


def pairs_of(comments: list[str], key: str) -> dict[str, str]:
    """The `name=value` pairs of a header key, joined over all its lines."""
    pairs = [p for c in comments if c.startswith(key + " ") for p in c[len(key) + 1 :].split(" ")]
    return dict(p.split("=", 1) for p in pairs)


def test_header_lines_stay_short_whatever_the_metadata(tmp_path):
    # Open3D and CloudCompare abort on a header line of 1,032 characters or more.
    meta = extreme_metadata()
    ply_path, json_path = write_scan_files(tmp_path / "scan.ply", make_cloud(50), meta)
    longest = max(header_lines(ply_path), key=len)
    assert len(longest) <= 200, longest[:300]
    comments = plyfile.PlyData.read(str(ply_path)).comments
    assert "untagged_objects_hit count=3000" in comments
    assert "world <sidecar>" in comments and "notes <sidecar>" in comments
    assert "many <sidecar>" in comments
    assert "placement lasers=<sidecar> roll_deg=-17.244513357210916" in comments
    # A key with more pairs than a line holds continues on further lines, losing nothing.
    sensor_lines = [c for c in comments if c.startswith("sensor ")]
    assert len(sensor_lines) > 1
    assert {k: float(v) for k, v in pairs_of(comments, "sensor").items()} == meta["sensor"]
    assert f"{'x' * 64} 1" in comments  # a key is cut, never the line dropped
    # The JSON sidecar keeps every value whole.
    sidecar = json.loads(json_path.read_text(encoding="utf-8"))
    assert sidecar["world"] == LONG_WORLD
    assert sidecar["untagged_objects_hit"] == meta["untagged_objects_hit"]
    assert sidecar["placement"] == meta["placement"] and sidecar["notes"] == meta["notes"]


def test_header_of_a_real_scan_keeps_the_short_facts(tmp_path):
    pose = {"x": 28.863, "y": -58.686, "yaw_deg": 3.4}
    placement = {**extreme_metadata()["placement"], "pitch_deg": -9.608527615557243, "pose": pose}
    meta = {**METADATA, "placement": placement, "untagged_objects_hit": ["Cube", "Suzanne"], "world": None}
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", make_cloud(5), meta)
    comments = plyfile.PlyData.read(str(ply_path)).comments
    assert pairs_of(comments, "placement") == {
        "lasers": "<sidecar>",
        "pitch_deg": "-9.608527615557243",
        "pose.x": "28.863",
        "pose.y": "-58.686",
        "pose.yaw_deg": "3.4",
        "roll_deg": "-17.244513357210916",
    }
    assert "untagged_objects_hit count=2" in comments and "world null" in comments


def test_sidecar_has_metadata_and_file_facts(tmp_path):
    cloud = make_cloud(100, seed=5)
    ply_path, json_path = write_scan_files(tmp_path / "scan.ply", cloud, METADATA)
    assert json_path == tmp_path / "scan.json"
    sidecar = json.loads(json_path.read_text())
    for key, value in METADATA.items():
        assert sidecar[key] == value
    assert sidecar["wildscan_version"] == wildscan.__version__
    assert sidecar["ply_file"] == "scan.ply"
    assert sidecar["ply_format"] == "binary_little_endian"
    assert sidecar["point_count"] == 100
    assert sidecar["classes"] == class_table_dict()
    names = {c["id"]: c["name"] for c in class_table_dict()}
    expected_counts = {names[i]: int((cloud.label == i).sum()) for i in np.unique(cloud.label)}
    assert sidecar["class_counts"] == expected_counts
    assert sum(sidecar["class_counts"].values()) == 100
    text = json_path.read_text()
    assert text == json.dumps(sidecar, indent=2, sort_keys=True) + "\n"


def test_sidecar_lists_the_headers_classes_and_computes_file_facts(tmp_path):
    """A caller's class table declares classes (it cannot drop one the points carry): the
    sidecar lists what the header lists (core/classes.py listed_classes)."""
    declared = [{"id": 15, "name": "particle"}]
    meta = {"seed": 1, "classes": declared, "point_count": -1, "ply_file": "wrong.ply"}
    ply_path, json_path = write_scan_files(tmp_path / "s.ply", make_cloud(7), meta)
    sidecar = json.loads(json_path.read_text())
    _, comments = read_ply(ply_path)
    header = [int(c.split()[1]) for c in comments if c.startswith("class ")]
    assert [c["id"] for c in sidecar["classes"]] == header == [*range(13), 15]
    assert sidecar["point_count"] == 7
    assert sidecar["ply_file"] == "s.ply"


# --------------------------------------------------------------------------- determinism + empty


@pytest.mark.parametrize("ascii", [False, True])
def test_same_inputs_give_identical_bytes(tmp_path, ascii):
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    reordered = dict(reversed(list(METADATA.items())))
    reordered["sensor"] = dict(reversed(list(METADATA["sensor"].items())))
    pa, ja = write_scan_files(tmp_path / "a" / "scan.ply", make_cloud(seed=2), METADATA, ascii=ascii)
    pb, jb = write_scan_files(tmp_path / "b" / "scan.ply", make_cloud(seed=2), reordered, ascii=ascii)
    assert pa.read_bytes() == pb.read_bytes()
    assert ja.read_bytes() == jb.read_bytes()
    # A different cloud must change the bytes (the comparison above can fail).
    pc, _ = write_scan_files(tmp_path / "c.ply", make_cloud(seed=3), METADATA, ascii=ascii)
    assert pc.read_bytes() != pa.read_bytes()


@pytest.mark.parametrize("ascii", [False, True])
def test_empty_cloud(tmp_path, ascii):
    ply_path, json_path = write_scan_files(tmp_path / "empty.ply", make_cloud(0), METADATA, ascii=ascii)
    assert "element vertex 0" in header_lines(ply_path)
    assert plyfile.PlyData.read(str(ply_path))["vertex"].count == 0
    records, _ = read_ply(ply_path)
    assert len(records) == 0 and records.dtype.names == tuple(FIELD_NAMES)
    sidecar = json.loads(json_path.read_text())
    assert sidecar["point_count"] == 0 and sidecar["class_counts"] == {}


def test_overwrites_an_existing_pair(tmp_path):
    write_scan_files(tmp_path / "scan.ply", make_cloud(10), METADATA)
    ply_path, json_path = write_scan_files(tmp_path / "scan.ply", make_cloud(4), {"seed": 2})
    assert len(read_ply(ply_path)[0]) == 4
    assert json.loads(json_path.read_text())["seed"] == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scan.json", "scan.ply"]


# --------------------------------------------------------------------------- atomicity


def test_failure_while_writing_vertices_leaves_nothing(tmp_path, monkeypatch):
    def half_then_fail(f, records, ascii):
        f.write(records[: len(records) // 2].tobytes())
        raise OSError("disk full")

    monkeypatch.setattr(ply, "_write_vertices", half_then_fail)
    with pytest.raises(UserError, match="cannot write .*scan.ply: disk full"):
        write_scan_files(tmp_path / "scan.ply", make_cloud(), METADATA)
    assert list(tmp_path.iterdir()) == []


def test_interrupt_after_ply_rename_removes_the_ply_too(tmp_path, monkeypatch):
    real_replace = os.replace
    calls = []

    def replace_then_interrupt(src, dst):
        calls.append(Path(dst).name)
        if Path(dst).suffix == ".json":
            raise KeyboardInterrupt
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", replace_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        write_scan_files(tmp_path / "scan.ply", make_cloud(), METADATA)
    assert calls == ["scan.ply", "scan.json"]  # the PLY really was in place before the failure
    assert list(tmp_path.iterdir()) == []


def test_interrupt_while_writing_sidecar_leaves_nothing(tmp_path, monkeypatch):
    real_write_durably = ply.write_durably

    def interrupt_on_json(path, write):
        if ".json" in path.name:
            with open(path, "wb") as f:
                f.write(b'{"half": ')
            raise KeyboardInterrupt
        real_write_durably(path, write)

    monkeypatch.setattr(ply, "write_durably", interrupt_on_json)
    with pytest.raises(KeyboardInterrupt):
        write_scan_files(tmp_path / "scan.ply", make_cloud(), METADATA, ascii=True)
    assert list(tmp_path.iterdir()) == []


def test_failed_write_keeps_the_previous_scan_intact(tmp_path, monkeypatch):
    old_ply, old_json = write_scan_files(tmp_path / "scan.ply", make_cloud(8), METADATA)
    old_bytes = old_ply.read_bytes(), old_json.read_bytes()

    def fail(f, records, ascii):
        raise RuntimeError("boom")

    monkeypatch.setattr(ply, "_write_vertices", fail)
    with pytest.raises(RuntimeError):
        write_scan_files(tmp_path / "scan.ply", make_cloud(20), METADATA)
    assert (old_ply.read_bytes(), old_json.read_bytes()) == old_bytes
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scan.json", "scan.ply"]


def test_unserialisable_metadata_fails_before_touching_disk(tmp_path):
    with pytest.raises(TypeError, match="not JSON serialisable"):
        write_scan_files(tmp_path / "scan.ply", make_cloud(), {"seed": 1, "thing": object()})
    assert list(tmp_path.iterdir()) == []


# --------------------------------------------------------------------------- output path checks


def assert_user_error(path, *fragments):
    with pytest.raises(UserError) as info:
        check_output_path(path)
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message
    return message


def test_check_output_path_accepts_good_paths(tmp_path, monkeypatch):
    assert check_output_path(tmp_path / "scan.ply") == (tmp_path / "scan.ply").resolve()
    assert check_output_path(tmp_path / "SCAN.PLY").name == "SCAN.PLY"
    monkeypatch.chdir(tmp_path)
    assert check_output_path("rel.ply") == tmp_path.resolve() / "rel.ply"


def test_check_output_path_rejects_wrong_suffix(tmp_path):
    assert_user_error(tmp_path / "scan.txt", str(tmp_path / "scan.txt"), ".ply")
    assert_user_error(tmp_path / "scan", ".ply")
    assert_user_error(tmp_path / "scan.ply.json", ".ply")


def test_check_output_path_rejects_missing_directory(tmp_path):
    missing = tmp_path / "nope"
    assert_user_error(missing / "scan.ply", str(missing / "scan.ply"), f"directory {missing} does not exist")


def test_check_output_path_rejects_parent_that_is_a_file(tmp_path):
    # Works as root too, where permission bits would not stop a write.
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    assert_user_error(blocker / "scan.ply", f"{blocker} is not a directory")


def test_check_output_path_rejects_unwritable_directory(tmp_path, monkeypatch):
    # os.access is what decides; faking it tests the branch even when running as root.
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if Path(p) == tmp_path else real_access(p, mode))
    assert_user_error(tmp_path / "scan.ply", f"directory {tmp_path} is not writable")


def test_check_output_path_rejects_a_directory(tmp_path):
    (tmp_path / "dir.ply").mkdir()
    assert_user_error(tmp_path / "dir.ply", str(tmp_path / "dir.ply"), "is a directory")
    (tmp_path / "other.json").mkdir()
    assert_user_error(tmp_path / "other.ply", "sidecar", "is a directory")


def test_write_scan_files_checks_the_path_first(tmp_path):
    with pytest.raises(UserError, match="does not exist"):
        write_scan_files(tmp_path / "nope" / "scan.ply", make_cloud(), METADATA)
    assert list(tmp_path.iterdir()) == []


def test_sidecar_path():
    assert sidecar_path("/a/b/scan.ply") == Path("/a/b/scan.json")
    assert sidecar_path("SCAN.PLY") == Path("SCAN.json")


def test_read_ply_rejects_other_files(tmp_path):
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"not a ply\n")
    with pytest.raises(UserError, match="not a PLY"):
        read_ply(bad)
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", make_cloud(10), METADATA)
    truncated = tmp_path / "cut.ply"
    truncated.write_bytes(ply_path.read_bytes()[:-5])
    with pytest.raises(UserError, match="truncated"):
        read_ply(truncated)


# --------------------------------------------------------------------------- PCL (pcl-tools)


@pytest.mark.external
@pytest.mark.parametrize("ascii", [False, True])
def test_pcl_ply2pcd_loads_labels(tmp_path, ascii):
    cloud = make_cloud(150, seed=11)
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", cloud, METADATA, ascii=ascii)
    header, columns = pcl_columns(ply_path, tmp_path)
    fields = header["FIELDS"]
    # PCL keeps every property; red/green/blue are packed into one `rgb` field.
    assert fields == [
        "x",
        "y",
        "z",
        "intensity",
        "label",
        "instance",
        "rgb",
        "ring",
        "sweep",
        "range",
        "scalar_label",
    ]
    kinds = dict(zip(fields, zip(header["TYPE"], header["SIZE"], strict=True), strict=True))
    assert kinds["label"] == ("U", "4")
    assert header["POINTS"] == ["150"]
    np.testing.assert_array_equal(columns["label"], cloud.label)
    np.testing.assert_array_equal(columns["instance"], cloud.instance)
    np.testing.assert_array_equal(columns["ring"], cloud.ring)
    np.testing.assert_array_equal(columns["sweep"], cloud.sweep)
    rgb = COLOR_BY_ID[cloud.label].astype(np.int64)
    np.testing.assert_array_equal(columns["rgb"], (rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2])
    np.testing.assert_allclose(columns["x"], cloud.xyz[:, 0].astype(np.float32), rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(columns["intensity"], cloud.intensity, rtol=1e-6)


# --------------------------------------------------------------------------- CloudCompare


@pytest.mark.external
@pytest.mark.parametrize("ascii", [False, True])
def test_cloudcompare_cli_sees_labels_and_colours(tmp_path, ascii):
    cloud = make_cloud(120, seed=21)
    ply_path, _ = write_scan_files(tmp_path / "scan.ply", cloud, METADATA, ascii=ascii)
    columns = cloudcompare_columns(ply_path, tmp_path)
    assert not isinstance(columns, str), columns
    # Command-line mode keeps x y z, the colours and the `intensity` and `scalar_*`
    # properties (`scalar_label` shows up as the scalar field `label`).
    assert list(columns) == ["X", "Y", "Z", "R", "G", "B", "intensity", "label"]
    assert len(columns["X"]) == len(cloud)
    np.testing.assert_array_equal(columns["label"], cloud.label)
    rgb = np.stack([columns["R"], columns["G"], columns["B"]], axis=1)
    np.testing.assert_array_equal(rgb, COLOR_BY_ID[cloud.label])
    np.testing.assert_allclose(columns["X"], cloud.xyz[:, 0].astype(np.float32), rtol=1e-6, atol=1e-5)
    np.testing.assert_allclose(columns["intensity"], cloud.intensity, rtol=1e-6, atol=1e-6)
