"""`wildscan dataset` cases a new user hit (issue 31, held-out defects 1, 2, 4, 5 and 11):
a list of devices of two kinds, a device file edited between runs, two Ctrl-Cs, a dataset
read while it is written or before it is finished, and --verify's summary beside problems.

Signals are sent when the run says it reached a moment (core/pause.py's test hook), never
after a fixed sleep; every process has a timeout."""

from __future__ import annotations

import json
import os
import shutil
import signal
from pathlib import Path

import pytest
import yaml

from wildscan.app.dataset.projection import dataset_projection
from wildscan.app.dataset.spec import spec_from_dict
from wildscan.core.io.projection import kept_share
from wildscan.core.sensors import beam_directions, device_named

from tests.helpers.dataset_helpers import manifest_rows, start_wildscan, wildscan
from tests.helpers.semantic_kitti_laserscan import LaserScan

# one low, solid world, two scans: these runs test the sensor's setting, not the world
ONE_WORLD = """\
layout = "paper"
seeds = [0]
detail = "low"
vegetation = "solid"
scans_per_world = 2
formats = ["semantickitti"]
"""
MIXED = ONE_WORLD + '\n[sensor]\ndevice = ["vlp16", "utm30lx-ew"]\n'
PAUSE_TIMEOUT_S = 120


def run_spec(folder: Path, spec_text: str, *args: str):
    """`wildscan dataset` of `spec_text` (written to folder/spec.toml) into folder/out, one
    worker: the folder, and the run."""
    (folder / "spec.toml").write_text(spec_text)
    out = folder / "out"
    return out, wildscan(
        "dataset", str(folder / "spec.toml"), "--out", str(out), "--workers", "1", "--quiet", *args
    )


def test_a_list_of_the_hokuyo_and_a_spinning_preset_has_one_truthful_projection():
    """Without rh each device scans at its own step (the Hokuyo 1 deg); the projection covers
    both devices' fields of view at the finer pixels, and says what it keeps of each."""
    spec = spec_from_dict({"sensor": {"device": ["vlp16", "utm30lx-ew"]}})
    p = dataset_projection(spec)  # was: rh_choices(None) -> TypeError after the last scan
    hokuyo, vlp = device_named("utm30lx-ew"), device_named("vlp16")
    assert p.fov_up > 89.9 and p.fov_down < -45  # the Hokuyo's zenith and below the horizon
    assert p.W >= 360 / 0.2 * 2  # VLP-16 columns 0.2 deg apart, two pixels each
    shares = [
        kept_share(beam_directions(rh, d)[0].astype("float32"), p) for d, rh in ((hokuyo, 1.0), (vlp, 0.2))
    ]
    assert p.kept == round(min(shares), 4) and p.kept > 0.99


@pytest.mark.slow
def test_a_dataset_mixing_the_hokuyo_and_a_spinning_preset_finishes(tmp_path):
    out, done = run_spec(tmp_path, MIXED)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    for name in ("labels.yaml", "weights.json", "CARD.md"):
        assert (out / name).is_file(), name
    assert json.loads((out / "dataset.json").read_text())["complete"] is True
    # the projection labels.yaml ships, used as semantic-kitti-api uses it, keeps each scan
    projection = yaml.safe_load((out / "labels.yaml").read_text())["projection"]
    for row in manifest_rows(out):
        if row["status"] != "ok":
            continue
        velodyne = next(f["path"] for f in row["files"] if "/velodyne/" in f["path"])
        scan = LaserScan(project=True, **projection)
        scan.open_scan(str(out / velodyne))
        kept = len(set(scan.proj_idx[scan.proj_idx >= 0].tolist())) / len(scan.points)
        assert kept > 0.95, (row["sensor"], kept)


DEVICE_FILE_SPEC = ONE_WORLD + '\n[sensor]\ndevice = "{device}"\n'


@pytest.mark.slow
def test_a_device_file_edited_between_runs_is_refused_on_resume(tmp_path):
    device = tmp_path / "mine.toml"
    device.write_text(device_named_text("vlp16"))
    spec = tmp_path / "spec.toml"
    spec.write_text(DEVICE_FILE_SPEC.format(device=device))
    out = tmp_path / "out"
    first = wildscan("dataset", str(spec), "--out", str(out), "--workers", "1", "--limit", "1", "--quiet")
    assert first.returncode == 0, first.stderr
    # a row written under other contents (a file edited while a run was writing) is named
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    manifest = copy / "manifest.jsonl"
    manifest.write_text(manifest.read_text().replace('"config_hash":"', '"config_hash":"0', 1))
    mixed = wildscan("dataset", "--verify", str(copy))
    assert mixed.returncode == 1
    assert "1 scans (the first: scan 0 of sequence 00) were made under another config" in mixed.stderr
    device.write_text(device_named_text("vlp16").replace("max_m = 100.0", "max_m = 50.0"))
    again = wildscan("dataset", str(spec), "--out", str(out), "--workers", "1", "--quiet")
    assert again.returncode == 2 and again.stderr.count("\n") == 1, again.stderr
    assert f"other contents of the device file {device}" in again.stderr
    assert len(manifest_rows(out)) == 1  # nothing scanned with the edited file
    device.write_text(device_named_text("vlp16"))  # put back: the run finishes
    last = wildscan("dataset", str(spec), "--out", str(out), "--workers", "1", "--quiet")
    assert last.returncode == 0, last.stderr
    assert len({r["config_hash"] for r in manifest_rows(out)}) == 1


def device_named_text(name: str) -> str:
    from wildscan.core.sensors.load import PRESETS_DIR

    return (PRESETS_DIR / f"{name}.toml").read_text().replace(f'id = "{name}"', 'id = "mine"')


SIX = """\
layout = "paper"
seeds = [1, 2]
detail = "low"
vegetation = "solid"
scans_per_world = 3
formats = ["semantickitti"]
split = { train = 0.5, test = 0.5 }

[sensor]
rh = 10.0
"""


def read_until_pause(job, moment: str) -> list[str]:
    """stderr lines up to the hook's marker for `moment` (the run waits there)."""
    before = []
    for line in job.stderr:
        if line.startswith(f"wildscan-test-pause {moment}"):
            return before
        before.append(line)
    job.wait(timeout=PAUSE_TIMEOUT_S)
    pytest.fail(f"{moment} never reached (exit {job.returncode}): {''.join(before)}")


def stop_job(job) -> None:
    if job.poll() is None:
        os.killpg(job.pid, signal.SIGKILL)
        job.wait(timeout=60)


@pytest.mark.slow
def test_two_ctrl_cs_count_and_name_the_scans_completed(tmp_path):
    out, first = run_spec(tmp_path, SIX, "--limit", "4")
    assert first.returncode == 0, first.stderr
    # The run pauses as it closes its cluster (its scans done); a user pressing Ctrl-C twice
    # then: both land in the closing, which used to let them escape as a list of rewritten
    # bookkeeping files.
    env = dict(os.environ, WILDSCAN_TEST_PAUSE_AT="stopping")
    job = start_wildscan("dataset", str(tmp_path / "spec.toml"), "--out", str(out), "--workers", "1",
                         "--quiet", env=env)  # fmt: skip
    try:
        read_until_pause(job, "stopping")
        os.kill(job.pid, signal.SIGINT)
        os.kill(job.pid, signal.SIGINT)
        _, stderr = job.communicate(timeout=PAUSE_TIMEOUT_S)
    finally:
        stop_job(job)
    assert job.returncode == 130, stderr
    lines = stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    assert lines[0].startswith("wildscan dataset: interrupted: 6 of 6 scans in the manifest (2 written by "
                               "this run: sequence 01 scans 1-2, 4 from before)"), lines  # fmt: skip
    assert "dataset.json" not in lines[0] and "manifest.jsonl" not in lines[0] and "files" not in lines[0]


def test_a_run_names_the_scans_it_wrote():
    from wildscan.app.dataset.scan_names import scan_names

    keys = [("00", 0), ("00", 1), ("00", 2), ("00", 5), ("01", 2)]
    assert scan_names(keys) == "sequence 00 scans 0-2 and 5, sequence 01 scan 2"
    many = [(f"{s:02d}", 0) for s in range(5)]
    assert scan_names(many).endswith("sequence 02 scan 0, 2 more in 2 more sequences")


@pytest.mark.slow
def test_learn_and_verify_recognise_a_dataset_being_written_or_unfinished(tmp_path):
    out, part = run_spec(tmp_path, SIX, "--limit", "4")
    assert part.returncode == 0, part.stderr
    learn = wildscan("bench", "--suite", "learn", str(out))
    assert learn.returncode == 2 and learn.stderr.count("\n") == 1, learn.stderr
    assert "the dataset is incomplete (4 of 6 scans)" in learn.stderr
    env = dict(os.environ, WILDSCAN_TEST_PAUSE_AT="card")  # every scan recorded, the card next
    job = start_wildscan("dataset", str(tmp_path / "spec.toml"), "--out", str(out), "--workers", "1",
                         "--quiet", env=env)  # fmt: skip
    try:
        read_until_pause(job, "card")
        for args in (["dataset", "--verify", str(out)], ["bench", "--suite", "learn", str(out)]):
            during = wildscan(*args)
            assert during.returncode == 2 and during.stderr.count("\n") == 1, during.stderr
            assert (
                f"the dataset is being written by a wildscan dataset run (process {job.pid})" in during.stderr
            )
        os.kill(job.pid, signal.SIGINT)
        job.communicate(timeout=PAUSE_TIMEOUT_S)
    finally:
        stop_job(job)
    after = wildscan("dataset", "--verify", str(out))  # the run is gone: its lock file no longer counts
    assert after.returncode == 0 and "incomplete (6 of 6 scans)" in after.stdout, after.stderr


@pytest.mark.slow
def test_verify_never_calls_a_dataset_with_problems_complete(tmp_path):
    out, done = run_spec(tmp_path, SIX)
    assert done.returncode == 0, done.stderr
    copy = tmp_path / "copy"
    shutil.copytree(out, copy)
    label = next(Path(copy).glob("sequences/*/labels/*.label"))
    label.write_bytes(label.read_bytes()[:-4])
    bad = wildscan("dataset", "--verify", str(copy))
    assert bad.returncode == 1
    assert (
        "is complete" not in bad.stdout and "incomplete (6 of 6 scans) until they are repaired" in bad.stdout
    )


# --------------------------------------------------------------------------- a full disk


def test_a_full_disk_names_the_scan_group_in_a_few_words(tmp_path, monkeypatch):
    import errno

    from wildscan.core.errors import UserError
    from wildscan.core.io import files

    kinds = ["velodyne/000003.bin", "labels/000003.label", "bev/000003.npy", "rangeimage/000003.npz"]
    finals = [tmp_path / "sequences/00" / k for k in kinds]
    for p in finals:
        p.parent.mkdir(parents=True, exist_ok=True)

    def full(self, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))  # a write names no file

    monkeypatch.setattr(Path, "write_bytes", full)
    with pytest.raises(UserError) as e:
        with files.atomic_outputs(*finals) as temps:
            for t in temps:
                t.write_bytes(b"x")
    said = str(e.value)
    assert " or " not in said, said
    assert said == (
        f"cannot write one of the 4 files of 000003 in {tmp_path / 'sequences/00'} (velodyne/000003.bin, "
        "labels/000003.label, ...): No space left on device"
    )


@pytest.mark.slow
def test_a_batch_the_disk_fills_mid_way_returns_its_whole_scans(tmp_path, monkeypatch):
    """The scans a worker wrote before the disk filled are whole: they are recorded (were
    left on disk, listed nowhere), and the failure comes back with them."""
    from wildscan import __version__
    from wildscan.app.dataset import worker
    from wildscan.core.errors import UserError

    spec = spec_from_dict({"layout": "paper", "seeds": [1], "detail": "low", "vegetation": "solid",
                           "scans_per_world": 3, "formats": ["semantickitti"],
                           "sensor": {"rh": 10.0}})  # fmt: skip
    real, calls = worker.write_scan, []

    def fills_on_the_second(root, files):
        calls.append(len(files))
        if len(calls) == 2:
            raise UserError("cannot write one of the files: No space left on device")
        return real(root, files)

    monkeypatch.setattr(worker, "write_scan", fills_on_the_second)
    result = worker.scan_batch(spec.to_dict(), str(tmp_path), 1, [0, 1, 2], __version__)
    assert [r["scan"] for r in result["rows"]] == [0]
    assert result["failure"].endswith("No space left on device")
    for record in result["rows"][0]["files"]:
        assert (tmp_path / record["path"]).stat().st_size == record["bytes"]
