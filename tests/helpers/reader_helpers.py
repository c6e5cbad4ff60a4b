"""Run the readers users open our PLY files with -- PCL's pcl_ply2pcd and CloudCompare
(Debian's binaries), Open3D (both of its readers) -- and return what they loaded.

Both abort the whole process on a header they cannot take (RPly's fixed line buffer:
"buffer overflow detected"), so each runs in a child process: a crash fails the test
that asked, never pytest itself.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from wildscan.core.pointcloud import PointCloud

TOOL_TIMEOUT_S = 60
OPEN3D_PROBE = Path(__file__).with_name("open3d_probe.py")


def require_tool(name: str, apt_package: str) -> str:
    exe = shutil.which(name)
    assert exe, f"{name} not found: install the Debian package {apt_package}"
    return exe


def run_tool(args: list[str], cwd: Path, env: dict | None = None) -> subprocess.CompletedProcess:
    proc = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=TOOL_TIMEOUT_S)
    assert proc.returncode == 0, f"{args[0]} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    return proc


# --------------------------------------------------------------------------- clouds to read


def make_cloud(n: int = 200, seed: int = 0) -> PointCloud:
    """A random cloud with every PLY label (0..12) in it."""
    rng = np.random.default_rng(seed)
    label = rng.integers(0, 13, n).astype(np.uint16)  # 0..12: every PLY label, never water
    if n >= 13:
        label[:13] = np.arange(13)
    return PointCloud(
        xyz=rng.normal(scale=20.0, size=(n, 3)),
        intensity=rng.uniform(0, 120, n).astype(np.float32),
        label=label,
        instance=rng.integers(0, 5000, n).astype(np.uint32),
        ring=rng.integers(0, 1080, n).astype(np.uint16),
        sweep=rng.integers(0, 180, n).astype(np.uint16),
        range=rng.uniform(0.1, 30, n).astype(np.float32),
    )


# A world path as users have them, long and not ASCII (each character JSON-escapes to 6).
LONG_WORLD = "/home/ana/" + "/".join(["Wälder und Hügel – 森林と丘の世界 ⛰"] * 12) + "/my world.blend"


def extreme_metadata() -> dict:
    """Metadata whose naive header lines run to thousands of characters."""
    laser = {"name": "front (+X)", "class": "terrain", "origin": [29.1974103, -58.66613236, 19.86786016]}
    return {
        "seed": 2147483647,
        "pose": {"x": -51.293, "y": -59.568, "yaw_deg": 73.5},
        "sensor": {f"setting_{i:02d}": i / 7 for i in range(40)},  # too many pairs for one line
        "world": LONG_WORLD,
        "untagged_objects_hit": [f"Objekt ünïcödé {i:04d}" for i in range(3000)],
        "placement": {"roll_deg": -17.244513357210916, "lasers": [laser] * 4},
        "notes": "ü" * 5000,
        "x" * 500: 1,
        "many": list(range(2000)),
    }


# --------------------------------------------------------------------------- PCL


def parse_ascii_pcd(path: Path) -> tuple[dict[str, list[str]], dict[str, np.ndarray]]:
    lines = path.read_text().splitlines()
    header: dict[str, list[str]] = {}
    for i, line in enumerate(lines):
        if line.startswith("#"):
            continue
        key, *values = line.split()
        header[key] = values
        if key == "DATA":
            body = lines[i + 1 :]
            break
    assert header["DATA"] == ["ascii"], header
    table = np.array([row.split() for row in body], dtype=np.float64).reshape(-1, len(header["FIELDS"]))
    return header, {name: table[:, j] for j, name in enumerate(header["FIELDS"])}


def pcl_columns(ply: Path, work: Path) -> tuple[dict[str, list[str]], dict[str, np.ndarray]]:
    """The header and columns of the PCD that PCL's `pcl_ply2pcd` makes of `ply`."""
    exe = require_tool("pcl_ply2pcd", "pcl-tools")
    pcd = work / (ply.stem + ".pcd")
    run_tool([exe, "-format", "0", str(ply), str(pcd)], cwd=work)
    return parse_ascii_pcd(pcd)


# --------------------------------------------------------------------------- CloudCompare


def cloudcompare_env(work: Path) -> dict[str, str]:
    # Qt's offscreen platform needs no X server (CI has no display); a private
    # HOME keeps CloudCompare's settings out of the user's home.
    home = work / "cc_home"
    home.mkdir(exist_ok=True)
    runtime = home / "runtime"
    runtime.mkdir(mode=0o700, exist_ok=True)
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env.update(QT_QPA_PLATFORM="offscreen", HOME=str(home), XDG_RUNTIME_DIR=str(runtime))
    return env


def parse_cloudcompare_asc(path: Path) -> dict[str, np.ndarray]:
    lines = path.read_text().splitlines()
    assert lines[0].startswith("//"), lines[0]
    names = lines[0][2:].split()
    table = np.array([row.split() for row in lines[1:]], dtype=np.float64).reshape(-1, len(names))
    return {name: table[:, j] for j, name in enumerate(names)}


def cloudcompare_export(ply: Path, work: Path) -> subprocess.CompletedProcess:
    """Open `ply` in CloudCompare's command-line mode and save what it loaded as
    `work/<name>.asc` (a header line naming the columns); the finished process."""
    exe = require_tool("CloudCompare", "cloudcompare")
    out = work / (ply.stem + ".asc")
    args = [exe, "-SILENT", "-O", str(ply), "-C_EXPORT_FMT", "ASC", "-ADD_HEADER", "-SEP", "SPACE"]
    args += ["-NO_TIMESTAMP", "-SAVE_CLOUDS", "FILE", str(out)]
    env = cloudcompare_env(work)
    return subprocess.run(args, cwd=work, env=env, capture_output=True, text=True, timeout=TOOL_TIMEOUT_S)


def cloudcompare_columns(ply: Path, work: Path) -> dict[str, np.ndarray] | str:
    """The columns CloudCompare loaded from `ply`, or why it loaded nothing."""
    proc = cloudcompare_export(ply, work)
    out = work / (ply.stem + ".asc")
    if proc.returncode != 0 or not out.exists():
        tail = (proc.stdout + proc.stderr).strip().splitlines()[-3:]
        return f"CloudCompare exit {proc.returncode}, wrote {'a' if out.exists() else 'no'} file: {tail}"
    return parse_cloudcompare_asc(out)


# --------------------------------------------------------------------------- Open3D


def open3d_read(plys: list[Path], work: Path) -> dict[Path, dict[str, np.ndarray] | str]:
    """What Open3D's tensor and legacy readers load from each file (open3d_probe.py's
    arrays), or why they loaded nothing. One child process reads the files in turn; when
    one kills it, that file is reported and the next child goes on after it."""
    results: dict[Path, dict[str, np.ndarray] | str] = {}
    pending = list(enumerate(plys))
    while pending:
        args = [sys.executable, str(OPEN3D_PROBE), str(work)]
        for i, ply in pending:
            args += [str(i), str(ply)]
        proc = subprocess.run(args, capture_output=True, text=True, timeout=TOOL_TIMEOUT_S * len(pending))
        done = {int(line.split()[1]) for line in proc.stdout.splitlines() if line.startswith("read ")}
        for i, ply in pending:
            if i in done:
                with np.load(work / f"open3d-{i}.npz") as arrays:
                    results[ply] = dict(arrays)
        left = [(i, ply) for i, ply in pending if i not in done]
        if left:
            tail = proc.stderr.strip().splitlines()[-2:]
            results[left[0][1]] = f"Open3D's process died reading it (exit {proc.returncode}): {tail}"
        pending = left[1:]
    return results
