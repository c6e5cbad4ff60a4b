"""Helpers of the dataset tests: running `wildscan dataset`, an independent SemanticKITTI
reader written from the published layout, and comparing two dataset folders."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from tests.helpers.processes import started

RUN_TIMEOUT_S = 300
# Files whose content records time (how long scans took): compared without those fields.
TIMED = ("manifest.jsonl", "dataset.json", "CARD.md")

SMALL_SPEC = """\
layout = "paper"
seeds = [1, 2]
scans_per_world = 3
formats = ["semantickitti", "las", "ply"]
label_scheme = "semantickitti"
split = { train = 0.5, val = 0.5, test = 0.0 }

[poses]
strategy = "zones"
zones = { forest = 1, park = 1, hills = 1 }

[sensor]
rh = 4.0
noise = [0.01, 0.02]
"""


def wildscan(*args: str, timeout: float = RUN_TIMEOUT_S, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "wildscan.cli", *args], capture_output=True, text=True, timeout=timeout, **kw
    )


def written_dataset(root: Path, spec_text: str, out: str = "out") -> tuple[Path, subprocess.CompletedProcess]:
    """`wildscan dataset` of spec_text (written to root/spec.toml) into root/out with one
    worker, asserted to succeed: the folder and the run."""
    (root / "spec.toml").write_text(spec_text)
    result = wildscan("dataset", str(root / "spec.toml"), "--out", str(root / out), "--workers", "1")
    assert result.returncode == 0, result.stderr
    return root / out, result


def start_wildscan(*args: str, **kw) -> subprocess.Popen:
    """`wildscan ...` in its own process group, so a test can kill the whole job (and the
    watchdog does, at its deadline)."""
    return started(
        [sys.executable, "-m", "wildscan.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
        **kw,
    )


# --------------------------------------------------------------------------- SemanticKITTI reader


def read_kitti_scan(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """velodyne/NNNNNN.bin: float32 (N, 4) x y z remission (the KITTI odometry layout)."""
    scan = np.fromfile(path, dtype=np.float32).reshape(-1, 4)
    return scan[:, :3], scan[:, 3]


def read_kitti_labels(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """labels/NNNNNN.label: uint32, semantic class in the lower 16 bits, instance in the upper 16."""
    label = np.fromfile(path, dtype=np.uint32)
    return label & 0xFFFF, label >> 16


def read_kitti_poses(path: Path) -> list[np.ndarray]:
    """poses.txt: 12 numbers a line, the first three rows of a 4x4 pose, row-major."""
    poses = []
    for line in path.read_text().splitlines():
        m = np.eye(4)
        m[:3, :4] = np.array([float(v) for v in line.split()]).reshape(3, 4)
        poses.append(m)
    return poses


def read_kitti_calib(path: Path) -> dict[str, np.ndarray]:
    """calib.txt: `KEY: 12 numbers` per line (semantic-kitti-api's parse_calibration)."""
    calib = {}
    for line in path.read_text().splitlines():
        key, values = line.split(":", 1)
        m = np.eye(4)
        m[:3, :4] = np.array([float(v) for v in values.split()]).reshape(3, 4)
        calib[key] = m
    return calib


# --------------------------------------------------------------------------- comparing datasets


def manifest_rows(root: Path) -> list[dict]:
    return [json.loads(line) for line in (root / "manifest.jsonl").read_text().splitlines()]


def untimed_rows(root: Path) -> list[dict]:
    return [{k: v for k, v in row.items() if k != "seconds"} for row in manifest_rows(root)]


def data_files(root: Path) -> dict[str, bytes]:
    """Every file of a dataset but the timed ones and the card's pictures, by relative path."""
    out = {}
    for folder, _, names in os.walk(root):
        for name in names:
            path = Path(folder) / name
            rel = path.relative_to(root).as_posix()
            if rel in TIMED or rel.startswith("card/"):
                continue
            out[rel] = path.read_bytes()
    return out


def assert_same_dataset(a: Path, b: Path) -> None:
    fa, fb = data_files(a), data_files(b)
    assert sorted(fa) == sorted(fb)
    different = [rel for rel in fa if fa[rel] != fb[rel]]
    assert not different, different[:5]
    assert untimed_rows(a) == untimed_rows(b)
    ja, jb = (json.loads((p / "dataset.json").read_text()) for p in (a, b))
    for key in ("spec", "config_hash", "sequences", "complete", "files"):
        assert ja[key] == jb[key], key
    ta, tb = ({k: v for k, v in j["totals"].items() if k != "scan_seconds"} for j in (ja, jb))
    assert ta == tb, {k: (ta.get(k), tb.get(k)) for k in set(ta) | set(tb) if ta.get(k) != tb.get(k)}
