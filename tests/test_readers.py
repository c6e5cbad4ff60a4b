"""Real scans from every zone of two seeds, made by `wildscan scan` and by Debian's Blender
(`blender -b -P blender_scripts/scan.py`), opened with the readers users have:
CloudCompare's command line, Open3D's tensor and legacy readers, and PCL's pcl_ply2pcd.
Each must load every point with its class visible -- CloudCompare as the `label` scalar
field (our `scalar_label`), Open3D's tensor reader as `scalar_label`, PCL as `label`
(uint32, PointXYZL's), and all but PCL as the class colours.

CloudCompare and Open3D kept a 1,024-byte line buffer and aborted on the placement comment of most
real scans; a scan of a small synthetic cloud never showed it. A coarse r_h keeps this
quick: the header, which broke them, does not depend on it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from wildscan.core.classes import COLOR_BY_ID
from wildscan.core.io.ply import MAX_HEADER_LINE, read_ply, write_scan_files
from wildscan.core.world.plan import ZONES

from tests.helpers.reader_helpers import (
    cloudcompare_columns,
    extreme_metadata,
    make_cloud,
    open3d_read,
    pcl_columns,
)
from tests.helpers.scene_helpers import BLENDER, PAPER, WILDSCAN, blender_scan, run

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

SEEDS = (1, 2)
RH_DEG = "6"
# A user's folder: long, and not ASCII; JSON-escaped (as a header would quote it) the
# path of a world in it runs past the 1,031 characters that break the readers.
USER_FOLDER = ("Wälder und Hügel – 森林と丘 ⛰",) * 16
# What Open3D's tensor reader keeps of our fields (measured, 0.20): it takes uchar, uint16,
# int, float and double properties, and drops uint (`label`, `instance`) and ushort
# (`ring`, `sweep`); x y z become `positions`, red green blue `colors`.
OPEN3D_TENSOR_KEEPS = {"positions", "colors", "intensity", "range", "scalar_label"}


def zone_poses(seed: int) -> dict[str, dict]:
    """The first valid pose of every zone of a seed (`wildscan poses`, no Blender)."""
    proc = run([WILDSCAN, "poses", *PAPER, "--seed", str(seed), "--count", "1", "--json"])
    assert proc.returncode == 0, proc.stderr
    poses = {zone: found[0] for zone, found in json.loads(proc.stdout)["poses"].items() if found}
    assert sorted(poses) == sorted(ZONES), poses
    return poses


def pose_args(pose: dict) -> list[str]:
    args = ["--pose", str(pose["x"]), str(pose["y"]), str(pose["yaw"]), "--rh", RH_DEG]
    return args + (["--z-start", str(pose["z_start"])] if "z_start" in pose else [])


@pytest.fixture(scope="module")
def poses() -> dict[int, dict[str, dict]]:
    return {seed: zone_poses(seed) for seed in SEEDS}


def wildscan_scans(poses: dict, out: Path) -> list[Path]:
    """`wildscan scan` of every zone of every seed (Blender-free): the first zone with
    `--seed S`, the others from the seed's geometry extracted once into a user's long
    non-ASCII folder (`--geometry`, the same points; its path goes into the header)."""
    plys = []
    for seed, zones in poses.items():
        scene = out.joinpath(*USER_FOLDER) / f"world {seed}.npz"
        scene.parent.mkdir(parents=True, exist_ok=True)
        extract = run([WILDSCAN, "extract", *PAPER, "--seed", str(seed), "--out", str(scene), "--quiet"])
        assert extract.returncode == 0, extract.stderr
        for k, (zone, pose) in enumerate(zones.items()):
            ply = out / f"wildscan-{seed}-{zone}.ply"
            world = [*PAPER, "--seed", str(seed)] if k == 0 else ["--geometry", str(scene)]
            proc = run([WILDSCAN, "scan", *world, *pose_args(pose), "--out", str(ply), "--quiet"])
            assert proc.returncode == 0, proc.stderr
            plys.append(ply)
    return plys


def blender_scans(poses: dict, out: Path) -> list[Path]:
    """Each seed's world saved once by Blender 3.4 in a user's long non-ASCII folder, then
    every zone scanned by `blender -b -P blender_scripts/scan.py -- --world ...`."""
    plys = []
    for seed, zones in poses.items():
        blend = out.joinpath(*USER_FOLDER) / f"world {seed}.blend"
        blend.parent.mkdir(parents=True, exist_ok=True)
        build = run([BLENDER, "-b", "--factory-startup", "-P", "blender_scripts/world.py", "--"] + [
            *PAPER, "--seed", str(seed), "--out", str(blend), "--poses", "1", "--quiet",
        ])  # fmt: skip
        assert build.returncode == 0, build.stdout[-2000:] + build.stderr
        for zone, pose in zones.items():
            ply = out / f"blender-{seed}-{zone}.ply"
            proc = blender_scan(["--world", str(blend), *pose_args(pose), "--out", str(ply), "--quiet"])
            assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr
            plys.append(ply)
    return plys


@pytest.fixture(
    scope="module", params=["wildscan", pytest.param("blender", marks=pytest.mark.blender_binary)]
)
def real_scans(request, poses, tmp_path_factory) -> list[Path]:
    """Every zone of both seeds, made by one of the two ways users scan."""
    out = tmp_path_factory.mktemp(f"scans-{request.param}")
    plys = wildscan_scans(poses, out) if request.param == "wildscan" else blender_scans(poses, out)
    for ply in plys:
        longest = max(header_text(ply).splitlines(), key=len)
        assert len(longest) <= MAX_HEADER_LINE, f"{ply.name}: {longest[:300]}"
    return plys


def header_text(ply: Path) -> str:
    data = ply.read_bytes()
    return data[: data.index(b"end_header\n")].decode("ascii")


def truth(ply: Path) -> np.ndarray:
    """The records we wrote, read back by our own reader; the sidecar must agree."""
    records, _ = read_ply(ply)
    sidecar = json.loads(ply.with_suffix(".json").read_text(encoding="utf-8"))
    assert sidecar["point_count"] == len(records) > 1000, ply.name
    return records


def check_all(plys: list[Path], check) -> None:
    """Run `check(ply, records)` on every file; fail once, naming every file that failed."""
    failures = []
    for ply in plys:
        try:
            check(ply, truth(ply))
        except AssertionError as e:
            failures.append(f"{ply.name}: {str(e).strip()[:400]}")
    assert not failures, f"{len(failures)} of {len(plys)} files:\n" + "\n".join(failures)


def check_cloudcompare(ply: Path, records: np.ndarray, work: Path) -> None:
    columns = cloudcompare_columns(ply, work)
    assert not isinstance(columns, str), columns
    # Command-line mode keeps x y z, the colours, `intensity` and `scalar_*` properties
    # (`scalar_label` shows up as the scalar field `label`).
    assert list(columns) == ["X", "Y", "Z", "R", "G", "B", "intensity", "label"]
    assert len(columns["X"]) == len(records)
    np.testing.assert_array_equal(columns["label"], records["label"])
    rgb = np.stack([columns["R"], columns["G"], columns["B"]], axis=1)
    np.testing.assert_array_equal(rgb, COLOR_BY_ID[records["label"]])
    np.testing.assert_allclose(columns["Z"], records["z"], rtol=1e-6, atol=1e-5)


def check_pcl(ply: Path, records: np.ndarray, work: Path) -> None:
    header, columns = pcl_columns(ply, work)
    fields = dict(zip(header["FIELDS"], zip(header["TYPE"], header["SIZE"], strict=True), strict=True))
    assert fields["label"] == ("U", "4")  # PointXYZL's uint32 label
    assert header["POINTS"] == [str(len(records))]
    np.testing.assert_array_equal(columns["label"], records["label"])
    np.testing.assert_array_equal(columns["instance"], records["instance"])


def check_open3d(loaded: dict[str, np.ndarray] | str, records: np.ndarray) -> None:
    assert not isinstance(loaded, str), loaded
    kept = {name.removeprefix("tensor.") for name in loaded if name.startswith("tensor.")}
    assert kept == OPEN3D_TENSOR_KEEPS
    assert loaded["tensor.positions"].shape == (len(records), 3)
    label = loaded["tensor.scalar_label"].ravel()
    assert label.dtype == np.float32
    np.testing.assert_array_equal(label, records["label"])
    np.testing.assert_array_equal(loaded["tensor.colors"], COLOR_BY_ID[records["label"]])
    np.testing.assert_array_equal(loaded["tensor.positions"][:, 2], records["z"])
    # The legacy reader keeps points and colours (scaled to 0..1): the class as its colour.
    assert loaded["legacy.points"].shape == (len(records), 3)
    np.testing.assert_array_equal(np.round(loaded["legacy.colors"] * 255), COLOR_BY_ID[records["label"]])


@pytest.mark.external
def test_cloudcompare_loads_every_zone_with_its_classes(real_scans, tmp_path):
    check_all(real_scans, lambda ply, records: check_cloudcompare(ply, records, tmp_path))


@pytest.mark.external
def test_pcl_loads_every_zone_with_its_labels(real_scans, tmp_path):
    check_all(real_scans, lambda ply, records: check_pcl(ply, records, tmp_path))


def test_open3d_loads_every_zone_with_its_classes(real_scans, tmp_path):
    loaded = open3d_read(real_scans, tmp_path)
    check_all(real_scans, lambda ply, records: check_open3d(loaded[ply], records))


# --------------------------------------------------------------------------- whatever the metadata


@pytest.fixture(scope="module")
def extreme_scan(tmp_path_factory) -> Path:
    """A cloud written with metadata whose naive header lines run to kilobytes."""
    ply, _ = write_scan_files(
        tmp_path_factory.mktemp("extreme") / "scan.ply", make_cloud(2000), extreme_metadata()
    )
    return ply


@pytest.mark.external
def test_cloudcompare_loads_a_scan_with_extreme_metadata(extreme_scan, tmp_path):
    check_cloudcompare(extreme_scan, read_ply(extreme_scan)[0], tmp_path)


def test_open3d_loads_a_scan_with_extreme_metadata(extreme_scan, tmp_path):
    check_open3d(open3d_read([extreme_scan], tmp_path)[extreme_scan], read_ply(extreme_scan)[0])
