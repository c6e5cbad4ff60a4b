"""The format table (core/io/formats.py): `wildscan scan --format`, read back by readers users
already have (laspy for LAS, numpy by SemanticKITTI's published layout for .bin/.label)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from wildscan.app.dataset.layout import SCAN_FILES
from wildscan.app.dataset.spec import FORMATS as DATASET_FORMATS
from wildscan.core.errors import UserError
from wildscan.core.io import files, formats
from wildscan.core.io.las import asprs_codes
from wildscan.core.io.ply import read_ply, write_scan_files
from wildscan.core.label_schemes import scheme
from wildscan.core.pointcloud import PointCloud

from tests.helpers.scene_helpers import PAPER, WILDSCAN, user_error_line

PARK_POSE_SEED_2_LOW = ("61.908", "-58.594", "126.6")  # `wildscan poses --seed 2 --detail low --zone park`
TIMEOUT_S = 300


def wildscan(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([WILDSCAN, *args], capture_output=True, text=True, timeout=TIMEOUT_S, cwd=cwd)


@pytest.fixture(scope="module")
def geometry(tmp_path_factory):
    """Seed 2 at low detail as a geometry file (planned without Blender)."""
    out = tmp_path_factory.mktemp("geometry") / "seed2.npz"
    done = wildscan("extract", *PAPER, "--seed", "2", "--detail", "low", "--out", str(out), "--quiet")
    assert done.returncode == 0, done.stderr
    return out


def scan(geometry, out, *extra: str) -> subprocess.CompletedProcess:
    args = ("--pose", *PARK_POSE_SEED_2_LOW, "--rh", "4", "--frame", "world", "--quiet")
    done = wildscan("scan", "--geometry", str(geometry), *args, *extra, "--out", str(out))
    assert done.returncode == 0, done.stderr
    return done


@pytest.fixture(scope="module")
def reference(geometry, tmp_path_factory):
    """The PLY of the scan the other formats are compared with (world frame: LAS offsets)."""
    out = tmp_path_factory.mktemp("ply") / "scan.ply"
    scan(geometry, out)
    records, _ = read_ply(out)
    assert len(records) > 1000
    return records


# --------------------------------------------------------------------------- PLY: today's bytes


def test_format_ply_is_the_default_and_writes_the_same_bytes(geometry, tmp_path):
    scan(geometry, tmp_path / "a.ply")
    scan(geometry, tmp_path / "b.ply", "--format", "ply")
    for suffix in (".ply", ".json"):
        a, b = (tmp_path / f"{n}{suffix}" for n in "ab")
        assert a.read_bytes() == b.read_bytes().replace(b"b.ply", b"a.ply")


def a_cloud(n: int = 500, seed: int = 3) -> PointCloud:
    rng = np.random.default_rng(seed)
    return PointCloud(
        xyz=rng.uniform(-20, 20, (n, 3)),
        intensity=rng.choice([15.0, 40.0, 90.0, 100.0], n).astype(np.float32),
        label=rng.integers(0, 13, n).astype(np.uint16),
        instance=rng.integers(0, 50, n).astype(np.uint32),
        ring=rng.integers(0, 1080, n).astype(np.uint16),
        sweep=rng.integers(0, 180, n).astype(np.uint16),
        range=rng.uniform(0.1, 15, n).astype(np.float32),
    )


@pytest.mark.parametrize("ascii", [False, True])
def test_the_ply_writer_of_the_table_writes_what_write_scan_files_writes(tmp_path, ascii):
    """write_scan_files is what tests/golden_cases.py checksums: the table's PLY is those bytes."""
    cloud, meta = a_cloud(), {"seed": 4, "pose": {"x": 1.0, "y": 2.0, "yaw_deg": 3.0}}
    write_scan_files(tmp_path / "old.ply", cloud, meta, ascii=ascii)
    w = formats.writer("ply")
    written = formats.write_scan(w, formats.single_scan(w, cloud, meta, ascii), tmp_path / "old2.ply")
    assert written == [tmp_path / "old2.ply", tmp_path / "old2.json"]
    assert (tmp_path / "old.ply").read_bytes() == (tmp_path / "old2.ply").read_bytes()
    old_json, new_json = ((tmp_path / n).read_text() for n in ("old.json", "old2.json"))
    assert old_json == new_json.replace("old2.ply", "old.ply")


# --------------------------------------------------------------------------- LAS


def test_las_holds_the_points_of_the_ply_of_the_same_scan(geometry, reference, tmp_path):
    import laspy

    done = scan(geometry, tmp_path / "scan.las", "--format", "las")
    assert done.stdout.splitlines()[0].startswith(f"wrote {tmp_path / 'scan.las'} (")
    las = laspy.read(tmp_path / "scan.las")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scan.las"]
    assert len(las.points) == len(reference)
    # the PLY's float32 coordinates and LAS's 0.1 mm steps (offsets: the optical centre, rounded)
    step = las.header.scales
    for axis, name in enumerate("xyz"):
        assert np.max(np.abs(np.asarray(las[name]) - reference[name])) <= step[axis]
    assert np.all(las.header.offsets != 0)  # world frame: the scan's own origin, not 0
    assert np.array_equal(np.asarray(las.wildscan_label), reference["label"])
    assert np.array_equal(np.asarray(las.label), reference["label"])  # a single scan: WildScan's ids
    assert np.array_equal(np.asarray(las.classification), asprs_codes(reference["label"]))
    assert np.array_equal(np.asarray(las.intensity), np.rint(reference["intensity"]).astype(np.uint16))
    for name in ("instance", "ring", "sweep"):
        assert np.array_equal(np.asarray(las[name]), reference[name]), name
    assert "hag" not in las.point_format.extra_dimension_names  # no terrain known: no made-up heights


# --------------------------------------------------------------------------- SemanticKITTI


def test_semantickitti_writes_a_bin_and_label_pair_beside_out(geometry, reference, tmp_path):
    done = scan(geometry, tmp_path / "000000.bin", "--format", "semantickitti")
    assert f"wrote {tmp_path / '000000.label'}" in done.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["000000.bin", "000000.label"]
    # SemanticKITTI's published layout: float32 x y z remission; uint32 class | instance << 16
    velodyne = np.fromfile(tmp_path / "000000.bin", dtype="<f4").reshape(-1, 4)
    raw = np.fromfile(tmp_path / "000000.label", dtype="<u4")
    assert len(velodyne) == len(raw) == len(reference)
    for axis, name in enumerate("xyz"):
        assert np.array_equal(velodyne[:, axis], reference[name])
    assert np.allclose(velodyne[:, 3], reference["intensity"] / 100.0)
    assert np.array_equal(raw & 0xFFFF, scheme("semantickitti").map(reference["label"]))
    ranks = raw >> 16
    assert np.array_equal(ranks == 0, reference["instance"] == 0)
    # one rank per instance: the same element keeps its rank, two elements never share one
    pairs = np.unique(np.stack([reference["instance"], ranks]), axis=1)
    assert len(np.unique(pairs[0])) == len(np.unique(pairs[1])) == pairs.shape[1]


def test_a_failed_write_of_the_label_leaves_neither_file(tmp_path, monkeypatch):
    real = files.write_durably

    def refuse_labels(path, write):
        if str(path).endswith(".label"):
            raise OSError(28, "No space left on device", str(path))
        real(path, write)

    monkeypatch.setattr(formats, "write_durably", refuse_labels)
    w = formats.writer("semantickitti")
    with pytest.raises(UserError, match=r"cannot write .*k\.label: No space left"):
        formats.write_scan(w, formats.single_scan(w, a_cloud(), {}), tmp_path / "k.bin")
    assert not any(tmp_path.iterdir())


# --------------------------------------------------------------------------- mistakes


@pytest.mark.parametrize(
    "args, words",
    [
        (["--format", "xyz", "--out", "s.ply"], ["--format", "'xyz'", "semantickitti", "las", "ply"]),
        (["--format", "las", "--out", "s.ply"], ["--out", "must end in .las"]),
        (["--format", "semantickitti", "--out", "s.label"], ["--out", "must end in .bin"]),
        (["--format", "las", "--ascii", "--out", "s.las"], ["--ascii", "--format ply only", "las"]),
    ],
)
def test_a_format_mistake_exits_2_with_one_line_and_writes_nothing(geometry, tmp_path, args, words):
    pose = ["--pose", *PARK_POSE_SEED_2_LOW]
    done = wildscan("scan", "--geometry", str(geometry), *pose, *args, cwd=tmp_path)
    assert done.returncode == 2
    line = user_error_line(done)
    assert all(word in line for word in words), line
    assert not any(tmp_path.iterdir())


# --------------------------------------------------------------------------- the table


def test_every_front_end_reads_its_formats_from_the_table():
    names = tuple(formats.WRITERS)
    assert DATASET_FORMATS == names
    assert set(SCAN_FILES) == {*names, "bev"}
    for name, w in formats.WRITERS.items():
        assert SCAN_FILES[name] == tuple((f.kind, f.folder, f.suffix) for f in w.files)
    help_text = subprocess.run(
        [sys.executable, "-m", "wildscan.cli", "scan", "--help"], capture_output=True, text=True, timeout=60
    ).stdout
    assert "{" + ",".join(names) + "}" in help_text


def test_the_writers_of_a_single_scan_name_distinct_files(tmp_path):
    for w in formats.WRITERS.values():
        paths = formats.scan_paths(w, formats.check_scan_output(w, tmp_path / f"scan{w.suffix}"))
        assert len(set(paths.values())) == len(w.scan_files)
