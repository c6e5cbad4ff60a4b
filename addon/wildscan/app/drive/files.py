"""The files of a drive, staged in a hidden folder inside DIR and moved into place together.

    DIR/drive.json                       what was asked, what came out (every file listed)
    DIR/trajectory.tum                   the sensor's true pose at the start of every 2D scan
    DIR/imu.csv                          the IMU's samples (EuRoC columns; with an IMU)
    DIR/revisits.json                    pairs of 3D scans within 3 m, and the rule for negatives
    DIR/raw/NNNNNN.ply, .json            per 3D scan: the raw cloud and its sidecar
    DIR/deskewed/NNNNNN.ply, .json       per 3D scan: the deskewed cloud and its sidecar
    DIR/sequences/00/velodyne/NNNNNN.bin SemanticKITTI: the deskewed scans, their labels,
                    labels/NNNNNN.label   poses.txt (points -> world), calib.txt, times.txt
    DIR/labels.yaml                      SemanticKITTI's label config
    DIR/drive.bag, DIR/drive_ros2/       the ROS bags (bags.py)

Nothing appears in DIR until the drive is complete: every file is written (and synced)
under DIR/.wildscan-drive.tmp-PID/, then each is renamed into place. An error, Ctrl-C or
SIGTERM removes the staging folder; a staging folder a killed run left is removed by the
next drive into DIR. Files a previous drive into DIR listed in its drive.json that this
one does not write are removed (and the folders they leave empty), so DIR holds one drive.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ...core.errors import UserError
from ...core.io import semantickitti as sk
from ...core.io.files import fsync_dir, user_path
from ...core.io.formats import WRITERS
from ...core.io.writer import ScanOutput

DRIVE_JSON = "drive.json"
TRAJECTORY = "trajectory.tum"
REVISITS_JSON = "revisits.json"
SEQUENCE = "sequences/00"
STAGING = re.compile(r"^\.wildscan-drive\.tmp-(\d+)$")


def scan_files(index: int) -> dict[str, str]:
    """kind -> path in DIR of the files of 3D scan `index`."""
    name = f"{index:06d}"
    return {
        "raw": f"raw/{name}.ply",
        "raw_sidecar": f"raw/{name}.json",
        "deskewed": f"deskewed/{name}.ply",
        "deskewed_sidecar": f"deskewed/{name}.json",
        "velodyne": f"{SEQUENCE}/velodyne/{name}.bin",
        "labels": f"{SEQUENCE}/labels/{name}.label",
    }


class Staging:
    """A hidden folder in `root` holding this run's files until `commit` moves them in."""

    def __init__(self, root: Path):
        self.root = root
        remove_stale_staging(root)
        self.dir = root / f".wildscan-drive.tmp-{os.getpid()}"
        shutil.rmtree(self.dir, ignore_errors=True)
        self.dir.mkdir()
        self._syncer = ThreadPoolExecutor(max_workers=1, thread_name_prefix="wildscan-fsync")
        self._syncs: list[Future] = []
        self._synced: set[str] = set()  # relative paths whose fsync `write` queued

    def path(self, relative: str) -> Path:
        """Where to write `relative` now (its folders made)."""
        target = self.dir / relative
        target.parent.mkdir(parents=True, exist_ok=True)
        return target

    def write(self, relative: str, data: bytes) -> None:
        """Write `relative`; its fsync runs on a thread of its own while the drive goes on
        (the disk's wait overlaps the sweeps), and `commit` waits for every one."""
        path = self.path(relative)
        path.write_bytes(data)
        self._syncs.append(self._syncer.submit(_fsync, path))
        self._synced.add(relative)

    def files(self) -> list[str]:
        """Every file staged so far, relative to the root, sorted."""
        return sorted(str(p.relative_to(self.dir)) for p in self.dir.rglob("*") if p.is_file())

    def commit(self) -> list[str]:
        """Move every staged file into place; remove what the previous drive wrote and this one
        did not. Returns the files in place."""
        written = self.files()
        # files written through `path` by their own writers (the ROS bags) are synced here
        unsynced = [f for f in written if f not in self._synced]
        self._syncs.extend(self._syncer.submit(_fsync, self.dir / f) for f in unsynced)
        for sync in self._syncs:
            sync.result()  # every staged file is on disk before any is renamed into place
        previous = previous_files(self.root)
        folders = set()
        for relative in written:
            final = self.root / relative
            final.parent.mkdir(parents=True, exist_ok=True)
            os.replace(self.dir / relative, final)
            folders.add(final.parent)
        for relative in sorted(set(previous) - set(written)):
            try:
                os.unlink(self.root / relative)
            except OSError:
                pass
            remove_emptied_folders(self.root, relative)
        for folder in folders:
            fsync_dir(folder)
        shutil.rmtree(self.dir, ignore_errors=True)
        return written

    def discard(self) -> None:
        self._syncer.shutdown(wait=True, cancel_futures=True)
        shutil.rmtree(self.dir, ignore_errors=True)


def _fsync(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def remove_emptied_folders(root: Path, relative: str) -> None:
    """The folders inside `root` that held `relative` (a previous drive's file, now removed),
    from the innermost out, while they are empty: a re-drive with `--bag none` leaves no empty
    drive_ros2/. A folder holding anything else (a user's file) stays, as does `root`."""
    folder = (root / relative).parent
    while folder != root and root in folder.parents:
        try:
            folder.rmdir()  # only ever removes an empty folder
        except OSError:
            return
        folder = folder.parent


def remove_stale_staging(root: Path) -> None:
    """Staging folders of drives into `root` that were killed (their process is gone)."""
    for entry in root.iterdir():
        match = STAGING.match(entry.name)
        if match and entry.is_dir() and not _alive(int(match.group(1))):
            shutil.rmtree(entry, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def previous_files(root: Path) -> list[str]:
    """The files the drive last written into `root` listed (none when there was none);
    only plain paths inside `root` are trusted."""
    try:
        listed = json.loads((root / DRIVE_JSON).read_text()).get("files", [])
    except (OSError, ValueError, AttributeError):
        return []
    safe = []
    for name in listed if isinstance(listed, list) else []:
        if isinstance(name, str) and name and not Path(name).is_absolute() and ".." not in Path(name).parts:
            safe.append(name)
    return safe


def check_out_dir(text) -> Path:
    """The output folder as given, refused early if it names a file (it is made later)."""
    out = user_path(text, "out", "a directory name")
    if out.exists() and not out.is_dir():
        raise UserError(f"{out}: it is a file; give a directory", setting="out")
    return out


# ------------------------------------------------------------------------------------------
# SemanticKITTI


def stage_format(stage: Staging, name: str, scan: ScanOutput, paths: dict[str, str]) -> None:
    """Stage the files of `scan` in format `name` (core/io/formats.py); `paths`: the format's
    kinds of file -> where each goes in DIR."""
    encoded = WRITERS[name].encode(scan, {kind: stage.dir / path for kind, path in paths.items()})
    for kind, data in encoded.items():
        stage.write(paths[kind], data)


def kitti_sequence(
    stage: Staging, pose_matrices: list[np.ndarray], start_times: list[float], imu_to_velo=None
) -> None:
    stage.write(f"{SEQUENCE}/poses.txt", sk.poses_text(pose_matrices).encode())
    stage.write(f"{SEQUENCE}/calib.txt", sk.calib_text(imu_to_velo).encode())
    stage.write(f"{SEQUENCE}/times.txt", "".join(f"{t:.6e}\n" for t in start_times).encode())


def json_bytes(data: dict) -> bytes:
    return (json.dumps(data, indent=2, sort_keys=True) + "\n").encode()
