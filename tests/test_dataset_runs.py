"""`wildscan dataset` runs that stop part-way and resume, on a local cluster and on a real
Dask scheduler and worker started as separate processes: every way gives the bytes of one
uninterrupted run, nothing partial is ever visible, and --verify catches a changed file."""

from __future__ import annotations

import http.server
import json
import os
import shutil
import signal
import socket
import socketserver
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest

from wildscan.app.dataset.layout import TEMP_NAME

from tests.helpers.dataset_helpers import assert_same_dataset, manifest_rows, start_wildscan, wildscan
from tests.helpers.processes import started

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

# Solid crowns: these runs test stopping and resuming, not vegetation, and a porous world
# takes about five times longer to build (tests/test_dataset.py writes porous ones).
SPEC = """\
layout = "paper"
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


def wait_until(condition, what: str, job: subprocess.Popen | None = None, timeout: float = 120.0):
    """Poll `condition()` until it returns something true (an event: a file, a line, a
    process), failing after `timeout` or when `job` ends first."""
    t0 = time.monotonic()
    while True:
        found = condition()
        if found:
            return found
        if job is not None:
            assert job.poll() is None, f"the job ended before {what}: {job.communicate()}"
        assert time.monotonic() - t0 < timeout, f"no {what} in {timeout:g} s"
        time.sleep(0.005)


def worker_processes(job: subprocess.Popen) -> list[psutil.Process]:
    """The local cluster's worker processes (multiprocessing's spawn children) of `job`."""
    try:
        children = psutil.Process(job.pid).children(recursive=True)
    except psutil.NoSuchProcess:
        return []
    out = []
    for p in children:
        try:
            if "spawn_main" in " ".join(p.cmdline()):
                out.append(p)
        except psutil.Error:  # gone between the listing and the look
            pass
    return out


def at_least(n: int, found: list) -> list | None:
    return found if len(found) >= n else None


def scan_files_on_disk(out: Path) -> list[str]:
    """Files under sequences/ (temporary or renamed): a worker is writing a scan."""
    return [name for _, _, names in os.walk(out / "sequences") for name in names]


def one_line(stderr: str) -> str:
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    return lines[0]


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
    assert "5 were there from before, re-checked" in second.stdout  # the final line says it all
    assert_same_dataset(clean, out)
    assert (out / "revisits.json").read_bytes() == (clean / "revisits.json").read_bytes()  # from the rows
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


def test_verify_checks_the_folder_against_the_spec_not_only_against_the_manifest(clean, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(clean, copy)
    manifest = copy / "manifest.jsonl"
    lines = manifest.read_text().splitlines(keepends=True)
    manifest.write_text("".join(lines[:-1]))  # the last scan's row gone, its files still there
    (copy / "sequences/00/velodyne/000099.bin").write_bytes(bytes(16))  # a stray scan
    (copy / "CARD.md").unlink()
    bad = wildscan("dataset", "--verify", str(copy))
    assert bad.returncode == 1
    assert (
        f"dataset.json says complete but manifest.jsonl has no row for 1 of the {TOTAL} planned scans "
        "(scan 3 of sequence 02)" in bad.stderr
    )
    assert (
        "sequences/02/velodyne/000003.bin: a file neither manifest.jsonl nor dataset.json lists" in bad.stderr
    )
    assert "sequences/00/velodyne/000099.bin: a file neither" in bad.stderr
    assert "CARD.md: missing" in bad.stderr
    assert f"incomplete ({TOTAL - 1} of {TOTAL} scans)" in bad.stdout
    # a temporary file a stopped run left is named as such
    shutil.rmtree(copy)
    shutil.copytree(clean, copy)
    (copy / "sequences/01/labels/.000001.tmp-4242.label").write_bytes(b"x")
    temp = wildscan("dataset", "--verify", str(copy))
    assert temp.returncode == 1 and "a temporary file a stopped run left" in temp.stderr


def test_another_spec_into_the_same_folder_is_refused(clean, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(clean, copy)
    other = tmp_path / "other.toml"
    other.write_text(SPEC.replace("rh = 2.0", "rh = 4.0"))
    result = wildscan("dataset", str(other), "--out", str(copy))
    assert result.returncode == 2 and "another spec" in result.stderr
    assert wildscan("dataset", "--verify", str(tmp_path)).returncode == 2


def dask_process(*args: str, stderr=subprocess.DEVNULL, env=None) -> subprocess.Popen:
    exe = str(Path(sys.executable).with_name("dask"))
    return started([exe, *args], stdout=subprocess.DEVNULL, stderr=stderr, env=env, start_new_session=True)


def stop_processes(*processes) -> None:
    for p in processes:
        if p is not None and p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=30)


def dask_scheduler(folder: Path, *options: str) -> tuple[subprocess.Popen, str]:
    """`dask scheduler` on a free loopback port, and its address once it is up."""
    scheduler_file = folder / "scheduler.json"
    scheduler = dask_process(
        "scheduler", "--host", "127.0.0.1", "--port", "0", "--scheduler-file", str(scheduler_file), *options
    )
    try:
        info = wait_until(lambda: scheduler_info(scheduler_file), "scheduler file", scheduler, timeout=60)
        return scheduler, info["address"]
    except BaseException:
        stop_processes(scheduler)
        raise


def scheduler_info(path: Path) -> dict | None:
    """The scheduler file's contents once it is whole: Dask writes it in place, so it can
    exist, empty or part-written, before it parses."""
    try:
        return json.loads(path.read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def dask_worker(address: str, **kw) -> subprocess.Popen:
    return dask_process(
        "worker", address, "--nthreads", "1", "--nworkers", "1", "--no-dashboard", "--host", "127.0.0.1", **kw
    )


def test_an_existing_dask_scheduler_and_worker_give_the_local_result(spec, clean, tmp_path):
    scheduler, address = dask_scheduler(tmp_path, "--no-dashboard")
    worker = None
    try:
        worker = dask_worker(address)
        out = tmp_path / "out"
        result = wildscan("dataset", str(spec), "--out", str(out), "--scheduler", address)
        assert result.returncode == 0, result.stderr
        assert_same_dataset(clean, out)
        assert (
            "scheduler tcp://127.0.0.1"
            in json.loads((out / "dataset.json").read_text())["runs"][-1]["engine"]
        )
    finally:
        stop_processes(worker, scheduler)


def test_a_scheduler_that_dies_mid_run_ends_it_in_one_line_without_temporary_files(spec, tmp_path):
    scheduler, address = dask_scheduler(tmp_path, "--no-dashboard")
    log = tmp_path / "worker.log"
    job = worker = None
    try:
        # the worker stops with a scan's temporary files written, not yet renamed
        with open(log, "w") as stderr:
            worker = dask_worker(
                address, stderr=stderr, env=dict(os.environ, WILDSCAN_TEST_PAUSE_AT="writing")
            )
        out = tmp_path / "out"
        job = start_wildscan("dataset", str(spec), "--out", str(out), "--scheduler", address, "--quiet")
        wait_until(lambda: "wildscan-test-pause writing" in log.read_text(), "worker pause", job)
        assert temp_files(out)
        os.killpg(scheduler.pid, signal.SIGKILL)
        _, stderr = job.communicate(timeout=120)
    finally:
        stop_processes(job, worker, scheduler)
    assert job.returncode == 1
    assert one_line(stderr).startswith(
        f"wildscan dataset: error: lost the connection to the Dask scheduler at {address}"
    )
    assert f"0 of {TOTAL} scans in the manifest" in stderr
    assert temp_files(out) == []


class _Silent(socketserver.BaseRequestHandler):
    def handle(self):  # accepts and says nothing until the client gives up
        self.request.recv(1 << 16)
        self.request.recv(1 << 16)


class _Http(http.server.BaseHTTPRequestHandler):
    def do_GET(self):
        self.send_response(200)
        self.end_headers()

    def log_message(self, *args):  # not on the test's stderr
        pass


class _Talker(socketserver.BaseRequestHandler):
    def handle(self):  # speaks first, in HTTP: Dask reads "HTTP/1.1" as a frame count
        self.request.sendall(b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 3)
        self.request.recv(1 << 16)


def dashboard_port(scheduler: subprocess.Popen, address: str) -> int:
    """The scheduler's other listening port: its HTTP dashboard (health routes without bokeh)."""
    own = int(address.rsplit(":", 1)[1])

    def other():
        ports = {
            c.laddr.port for c in psutil.Process(scheduler.pid).net_connections("tcp") if c.status == "LISTEN"
        }
        return sorted(ports - {own})

    return wait_until(other, "dashboard port", scheduler, timeout=60)[0]


def closed_port() -> int:
    """A loopback port nothing listens on (bound, then let go)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


LOADED = "cannot reach a Dask scheduler there (no connection within 10 s)"


def test_a_scheduler_address_where_no_dask_scheduler_answers_is_refused_in_one_line(spec, tmp_path):
    servers = {
        "silent": socketserver.ThreadingTCPServer(("127.0.0.1", 0), _Silent),
        "talker": socketserver.ThreadingTCPServer(("127.0.0.1", 0), _Talker),
        "http": http.server.ThreadingHTTPServer(("127.0.0.1", 0), _Http),
    }
    for server in servers.values():
        server.daemon_threads = True
        threading.Thread(target=server.serve_forever, daemon=True).start()
    not_dask = (
        "what answers there is not a Dask scheduler",
        "did not answer as a Dask scheduler within 10 s",
    )
    scheduler, address = dask_scheduler(tmp_path, "--dashboard-address", "127.0.0.1:0")
    jobs = []
    try:
        cases = [
            (servers["silent"].server_address[1], ("did not answer as a Dask scheduler within 10 s",)),
            (servers["talker"].server_address[1], ("what answers there is not a Dask scheduler",)),
            (servers["http"].server_address[1], not_dask),
            (dashboard_port(scheduler, address), not_dask),
            (closed_port(), ("cannot reach a Dask scheduler there ([Errno 111] Connection refused)",)),
        ]
        for port, _ in cases:  # side by side: each waits up to its 10 s bound
            out = tmp_path / f"out-{port}"
            where = f"tcp://127.0.0.1:{port}"
            jobs.append(
                (start_wildscan("dataset", str(spec), "--out", str(out), "--scheduler", where), where, out)
            )
        for (job, where, out), (_, expected) in zip(jobs, cases, strict=True):
            _, stderr = job.communicate(timeout=60)
            assert job.returncode == 2, stderr
            line = one_line(stderr)
            assert line.startswith(f"wildscan dataset: error: --scheduler {where}: "), line
            # the reason on a quiet machine; on a loaded one Dask's handshake may outlast the
            # bound, and the line says that instead (still one line, exit 2, nothing written)
            assert any(words in line for words in (*expected, LOADED)), line
            assert not out.exists()  # refused before anything was written
    finally:
        stop_processes(*(job for job, _, _ in jobs), scheduler)
        for server in servers.values():
            server.shutdown()
            server.server_close()


def test_a_worker_killed_mid_run_is_replaced_and_the_result_is_the_same(spec, clean, tmp_path):
    out = tmp_path / "out"
    job = start_wildscan("dataset", str(spec), "--out", str(out), "--workers", "2", "--quiet")
    try:
        workers = wait_until(lambda: at_least(2, worker_processes(job)), "2 workers", job)
        # a scan file (temporary or renamed) on disk: the first batches are under way
        wait_until(lambda: scan_files_on_disk(out), "scan file", job)
        workers[0].kill()
        _, stderr = job.communicate(timeout=240)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    assert job.returncode == 0, stderr
    assert "Traceback" not in stderr
    assert_same_dataset(clean, out)


def test_a_worker_killed_as_the_local_cluster_starts_is_replaced_and_the_result_is_the_same(
    spec, clean, tmp_path
):
    out = tmp_path / "out"
    job = start_wildscan("dataset", str(spec), "--out", str(out), "--workers", "2", "--quiet")
    try:
        # the first worker process, as soon as it exists: long before it has imported Dask
        # and its nanny could report it started
        first = wait_until(lambda: worker_processes(job), "worker process", job)[0]
        first.kill()
        stdout, stderr = job.communicate(timeout=240)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    assert job.returncode == 0, stderr
    assert stderr == "" and f"complete: {TOTAL} of {TOTAL} scans" in stdout
    assert_same_dataset(clean, out)


def test_no_worker_that_can_start_ends_the_run_in_one_line_saying_why(spec, tmp_path):
    out = tmp_path / "out"
    env = dict(os.environ, DASK_DISTRIBUTED__WORKER__PRELOAD='["wildscan_test_no_such_module"]')
    result = wildscan("dataset", str(spec), "--out", str(out), "--workers", "1", env=env)
    assert result.returncode == 1
    line = one_line(result.stderr)
    assert line.startswith("wildscan dataset: error: no local Dask worker could start")
    assert "ModuleNotFoundError: No module named 'wildscan_test_no_such_module'" in line
    assert f"0 of {TOTAL} scans in the manifest" in line
    assert temp_files(out) == []


def test_ctrl_c_while_the_local_cluster_starts_says_one_line_and_leaves_no_worker(spec, tmp_path):
    out = tmp_path / "out"
    job = start_wildscan("dataset", str(spec), "--out", str(out), "--workers", "2", "--quiet")
    try:
        workers = wait_until(lambda: worker_processes(job), "worker process", job)
        os.killpg(job.pid, signal.SIGINT)  # a terminal's Ctrl-C reaches the whole group
        _, stderr = job.communicate(timeout=120)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    assert job.returncode == 130
    assert one_line(stderr) == (
        f"wildscan dataset: interrupted: 0 of {TOTAL} scans in the manifest (0 written by this run); "
        "the same command finishes the job"
    )
    _, alive = psutil.wait_procs(workers, timeout=30)
    assert alive == []


def blocked_signals(pid: int) -> set[int]:
    """The signals a process has blocked (its SigBlk mask in /proc)."""
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("SigBlk:"):
            mask = int(line.split()[1], 16)
            return {n for n in range(1, 65) if mask >> (n - 1) & 1}
    raise AssertionError(f"no SigBlk line for process {pid}")


def test_worker_processes_are_born_with_ctrl_c_blocked(spec, tmp_path):
    """A terminal's Ctrl-C reaches the whole process group: a worker interpreter that got it
    while importing `site` printed a 'Fatal Python error' traceback (seen on a loaded
    machine). Workers are born with SIGINT blocked; the parent alone answers it."""
    out = tmp_path / "out"
    job = start_wildscan("dataset", str(spec), "--out", str(out), "--workers", "2", "--quiet")
    try:
        workers = wait_until(lambda: worker_processes(job), "worker process", job)
        masks = {w.pid: blocked_signals(w.pid) for w in workers}
        assert signal.SIGTERM not in blocked_signals(job.pid)
        os.killpg(job.pid, signal.SIGINT)
        _, stderr = job.communicate(timeout=120)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    assert all(signal.SIGINT in blocked for blocked in masks.values()), masks
    assert job.returncode == 130, stderr


def test_ctrl_c_after_the_last_scan_leaves_the_dataset_incomplete_until_its_card_is_written(
    spec, clean, tmp_path
):
    out = tmp_path / "out"
    env = dict(os.environ, WILDSCAN_TEST_PAUSE_AT="card")  # every scan recorded, the card next
    job = start_wildscan("dataset", str(spec), "--out", str(out), "--workers", "2", "--quiet", env=env)
    try:
        assert job.stderr.readline() == "wildscan-test-pause card\n"
        os.kill(job.pid, signal.SIGINT)
        _, stderr = job.communicate(timeout=60)
    finally:
        if job.poll() is None:
            os.killpg(job.pid, signal.SIGKILL)
    assert job.returncode == 130
    assert one_line(stderr).startswith(
        f"wildscan dataset: interrupted: {TOTAL} of {TOTAL} scans in the manifest"
    )
    assert json.loads((out / "dataset.json").read_text())["complete"] is False
    assert not (out / "CARD.md").exists()
    verify = wildscan("dataset", "--verify", str(out))
    assert verify.returncode == 0 and f"incomplete ({TOTAL} of {TOTAL} scans)" in verify.stdout
    rerun = wildscan("dataset", str(spec), "--out", str(out), "--quiet")
    assert rerun.returncode == 0 and "wrote 0 scans" in rerun.stdout and (out / "CARD.md").exists()
    assert f"{TOTAL} were there from before" in rerun.stdout
    assert_same_dataset(clean, out)


def test_bench_dataset_times_each_worker_count_side_by_side_cold_and_warm():
    result = wildscan(
        "bench-dataset", "--layout", "paper", "--worlds", "2", "--scans", "2", "--rh", "10",
        "--workers", "1", "--workers", "2", "--vegetation", "solid",
    )  # fmt: skip
    assert result.returncode == 0 and result.stderr == "", result.stderr
    said = "2 scans at r_h = 10 deg from 2 worlds (paper layout; default detail, solid vegetation)"
    assert said in result.stdout
    lines = result.stdout.splitlines()
    steps = lines[lines.index(next(line for line in lines if line.startswith("| step |"))) :]
    assert any(line.startswith("| read and verify the entry |") for line in steps)
    table = lines[lines.index(next(line for line in lines if line.startswith("| workers |"))) + 2 :]
    rows = [line.split("|")[1:-1] for line in table if line.startswith("| ")]
    assert [tuple(c.strip() for c in r[:3]) for r in rows] == [
        ("1", "cold", "2"),
        ("2", "cold", "2"),
        ("2", "warm", "2"),
    ]
    assert [r[8].strip() for r in rows] == ["0 / 2", "0 / 2", "2 / 0"]  # worlds read / built
    assert float(rows[1][7].strip().rstrip("x")) > 0 and rows[1][10].count("GB") == 2  # a worker each
    assert "speed-up >= 1.85x" in result.stdout and "warm cache, at most 30 s" in result.stdout
    # each run's line says how much of its scans' time the caster took (core/runtime/cast_clock.py)
    assert sum("s in scans (" in line and "scan/cast" in line for line in result.stdout.splitlines()) == 3
    # and where its workers waited (app/dataset/timeline.py): two workers, two tasks
    idle = [line for line in lines if "workers idle" in line]
    assert len(idle) == 3 and "(summed over 1: " in idle[0] and "(summed over 2: " in idle[1]
    wrong = wildscan("bench-dataset", "--vegetation", "leafy")
    assert wrong.returncode == 2 and "--vegetation must be one of porous, solid" in wrong.stderr
