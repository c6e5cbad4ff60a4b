"""`wildscan dataset` runs that stop part-way and resume, on a local cluster and on a real
Dask scheduler and worker started as separate processes: every way gives the bytes of one
uninterrupted run, nothing partial is ever visible, and --verify catches a changed file."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from wildscan.app.dataset.layout import TEMP_NAME

from tests.helpers.dataset_helpers import assert_same_dataset, manifest_rows, start_wildscan, wildscan

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

# Solid crowns: these runs test stopping and resuming, not vegetation, and a porous world
# takes about five times longer to build (tests/test_dataset.py writes porous ones).
SPEC = """\
seeds = [1, 2, 3]
scans_per_world = 4
vegetation = "solid"
label_scheme = "rellis3d"
split = { train = 0.34, val = 0.33, test = 0.33 }

[poses]
zones = { forest = 1, lake = 1, trail = 1 }

[sensor]
rh = 2.0
"""
TOTAL = 12


@pytest.fixture(scope="module")
def spec(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("spec") / "spec.toml"
    path.write_text(SPEC)
    return path


@pytest.fixture(scope="module")
def clean(spec, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("clean") / "out"
    result = wildscan("dataset", str(spec), "--out", str(out), "--workers", "2")
    assert result.returncode == 0, result.stderr
    return out


def temp_files(root: Path) -> list[str]:
    return [name for _, _, names in os.walk(root) for name in names if TEMP_NAME.match(name)]


def wait_for_rows(out: Path, job: subprocess.Popen, timeout: float = 120.0) -> None:
    """Until the manifest holds some rows (the job is part-way)."""
    t0 = time.monotonic()
    while not (out / "manifest.jsonl").exists():
        assert job.poll() is None, job.communicate()
        assert time.monotonic() - t0 < timeout, "no manifest row in time"
        time.sleep(0.02)


def assert_nothing_partial(out: Path, clean: Path) -> None:
    """Every visible file is complete: listed in the manifest with its checksum, or (written
    by a batch the kill cut short) equal to the clean run's file."""
    listed = {f["path"]: f for r in manifest_rows(out) for f in r["files"]}
    for folder, _, names in os.walk(out / "sequences"):
        for name in names:
            if TEMP_NAME.match(name):
                continue
            rel = (Path(folder) / name).relative_to(out).as_posix()
            data = (out / rel).read_bytes()
            if rel in listed:
                assert len(data) == listed[rel]["bytes"], rel
            assert data == (clean / rel).read_bytes(), rel


def test_a_sigkilled_run_resumes_to_the_same_bytes(spec, clean, tmp_path):
    out = tmp_path / "out"
    job = start_wildscan("dataset", str(spec), "--out", str(out), "--workers", "1", "--quiet")
    wait_for_rows(out, job)
    os.killpg(job.pid, signal.SIGKILL)  # the whole job: client, nannies, workers
    job.wait(timeout=30)
    rows = manifest_rows(out)
    assert 0 < len(rows) < TOTAL
    assert_nothing_partial(out, clean)
    result = wildscan("dataset", str(spec), "--out", str(out), "--workers", "2")
    assert result.returncode == 0, result.stderr
    assert f"complete: {TOTAL} of {TOTAL} scans" in result.stdout
    assert temp_files(out) == [] and not (out / ".wildscan-dataset.lock").exists()
    assert_same_dataset(clean, out)


@pytest.mark.parametrize(
    "sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")]
)
def test_ctrl_c_or_sigterm_stops_with_a_true_message_and_no_debris(spec, clean, tmp_path, sig, code, word):
    out = tmp_path / "out"
    job = start_wildscan("dataset", str(spec), "--out", str(out), "--workers", "1")
    wait_for_rows(out, job)
    os.kill(job.pid, sig)  # the client only, as a terminal's Ctrl-C reaches it
    _, stderr = job.communicate(timeout=60)
    assert job.returncode == code, stderr
    rows = len(manifest_rows(out))
    assert f"{word}: {rows} of {TOTAL} scans in the manifest" in stderr.splitlines()[-1]
    assert temp_files(out) == []
    assert_nothing_partial(out, clean)
    assert wildscan("dataset", str(spec), "--out", str(out), "--quiet").returncode == 0
    assert_same_dataset(clean, out)


def test_limit_runs_part_of_the_job_and_the_next_run_finishes_it(spec, clean, tmp_path):
    out = tmp_path / "out"
    first = wildscan("dataset", str(spec), "--out", str(out), "--limit", "5", "--quiet")
    assert first.returncode == 0 and "incomplete" in first.stdout and len(manifest_rows(out)) == 5
    assert json.loads((out / "dataset.json").read_text())["complete"] is False
    second = wildscan("dataset", str(spec), "--out", str(out), "--quiet")
    assert second.returncode == 0 and "wrote 7 scans" in second.stdout
    assert_same_dataset(clean, out)
    third = wildscan("dataset", str(spec), "--out", str(out), "--quiet")
    assert "wrote 0 scans" in third.stdout  # nothing left: every scan verified and skipped


def test_verify_passes_on_a_clean_dataset_and_names_a_corrupted_file(clean, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(clean, copy)
    ok = wildscan("dataset", "--verify", str(copy))
    assert ok.returncode == 0 and "match the manifest" in ok.stdout and "complete" in ok.stdout
    bin_file = copy / "sequences/01/velodyne/000002.bin"
    data = bytearray(bin_file.read_bytes())
    data[1234] ^= 0x01  # one bit, same size
    bin_file.write_bytes(bytes(data))
    (copy / "sequences/00/poses.txt").write_text("truncated")
    bad = wildscan("dataset", "--verify", str(copy))
    assert bad.returncode == 1
    assert "sequences/01/velodyne/000002.bin: SHA-256 differs" in bad.stderr
    assert "sequences/00/poses.txt" in bad.stderr and "2 of" in bad.stdout
    # a rerun writes the changed scan again and the dataset verifies
    spec = copy / "spec.toml"
    spec.write_text(SPEC)
    spec.replace(tmp_path / "spec.toml")
    rerun = wildscan("dataset", str(tmp_path / "spec.toml"), "--out", str(copy), "--quiet")
    assert rerun.returncode == 0 and "wrote 1 scans" in rerun.stdout
    assert wildscan("dataset", "--verify", str(copy)).returncode == 0
    assert_same_dataset(clean, copy)


def test_another_spec_into_the_same_folder_is_refused(clean, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(clean, copy)
    other = tmp_path / "other.toml"
    other.write_text(SPEC.replace("rh = 2.0", "rh = 4.0"))
    result = wildscan("dataset", str(other), "--out", str(copy))
    assert result.returncode == 2 and "another spec" in result.stderr
    assert wildscan("dataset", "--verify", str(tmp_path)).returncode == 2


def dask_process(*args: str) -> subprocess.Popen:
    exe = str(Path(sys.executable).with_name("dask"))
    return subprocess.Popen(
        [exe, *args], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True
    )


def test_an_existing_dask_scheduler_and_worker_give_the_local_result(spec, clean, tmp_path):
    scheduler_file = tmp_path / "scheduler.json"
    scheduler = dask_process(
        "scheduler", "--host", "127.0.0.1", "--no-dashboard", "--scheduler-file", str(scheduler_file)
    )
    worker = None
    try:
        t0 = time.monotonic()
        while not scheduler_file.exists():
            assert time.monotonic() - t0 < 60 and scheduler.poll() is None, "dask scheduler did not start"
            time.sleep(0.1)
        address = json.loads(scheduler_file.read_text())["address"]
        worker = dask_process(
            "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard", "--host", "127.0.0.1"
        )
        out = tmp_path / "out"
        result = wildscan("dataset", str(spec), "--out", str(out), "--scheduler", address)
        assert result.returncode == 0, result.stderr
        assert_same_dataset(clean, out)
        assert (
            "scheduler tcp://127.0.0.1"
            in json.loads((out / "dataset.json").read_text())["runs"][-1]["engine"]
        )
    finally:
        for p in (worker, scheduler):
            if p is not None:
                os.killpg(p.pid, signal.SIGTERM)
                p.wait(timeout=30)


def test_a_worker_killed_mid_run_is_replaced_and_the_result_is_the_same(spec, clean, tmp_path):
    out = tmp_path / "out"
    job = start_wildscan("dataset", str(spec), "--out", str(out), "--workers", "2", "--quiet")
    try:
        t0 = time.monotonic()
        workers = []
        while len(workers) < 2:
            assert time.monotonic() - t0 < 60 and job.poll() is None
            workers = [
                p
                for p in psutil.Process(job.pid).children(recursive=True)
                if "spawn" in " ".join(p.cmdline())
            ]
            time.sleep(0.05)
        time.sleep(1.5)  # both are planning or scanning their first world
        workers[0].kill()
        _, stderr = job.communicate(timeout=240)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    assert job.returncode == 0, stderr
    assert_same_dataset(clean, out)


def test_bench_dataset_times_each_worker_count_side_by_side():
    result = wildscan(
        "bench-dataset", "--worlds", "2", "--scans", "2", "--rh", "10",
        "--workers", "1", "--workers", "2", "--vegetation", "solid",
    )  # fmt: skip
    assert result.returncode == 0 and result.stderr == "", result.stderr
    assert "2 scans at r_h = 10 deg from 2 worlds (default detail, solid vegetation)" in result.stdout
    rows = [line.split("|")[1:-1] for line in result.stdout.splitlines() if line.startswith("| ")][1:]
    assert [(r[0].strip(), r[1].strip()) for r in rows] == [("1", "2"), ("2", "2")]
    assert float(rows[1][4].strip().rstrip("x")) > 0 and rows[1][6].count("GB") == 2  # a worker each
    assert "speed-up >= 1.8x" in result.stdout
    wrong = wildscan("bench-dataset", "--vegetation", "leafy")
    assert wrong.returncode == 2 and "--vegetation must be one of porous, solid" in wrong.stderr
