"""Every process a test starts has a deadline, so none can hang a run (issue 31: a module
fixture ran Blender 3.4's world.py with no timeout, and CI waited 48 minutes).

- `subprocess.run`, `check_output`, `check_call` and `call` take `timeout=`
  (tests/test_process_deadlines.py reads every test file and holds each call to it);
  `finished` runs one for a fixture and, when it fails or times out, fails the test saying
  which command, how, and the end of its output.
- A process that runs beside the test (`subprocess.Popen`) is started by `started`: a
  watchdog kills it (its whole group, when it leads one) at its deadline, so a test reading
  its output reaches the end instead of waiting for ever; `how_it_ended` says whether the
  deadline did it.
"""

from __future__ import annotations

import os
import signal
import subprocess
import threading

import pytest

DEADLINE_S = 600  # a process beside a test: the longest any test needs one for


def started(cmd: list[str], deadline: float = DEADLINE_S, **kw) -> subprocess.Popen:
    """`subprocess.Popen(cmd, **kw)` with a watchdog that kills it after `deadline` seconds."""
    proc = subprocess.Popen(cmd, **kw)
    proc.deadline_s = deadline
    proc.killed_at_deadline = False
    group = bool(kw.get("start_new_session"))

    def kill() -> None:
        if proc.poll() is None:
            proc.killed_at_deadline = True
            try:
                os.killpg(proc.pid, signal.SIGKILL) if group else proc.kill()
            except ProcessLookupError:  # it ended meanwhile
                pass

    watchdog = threading.Timer(deadline, kill)
    watchdog.daemon = True
    watchdog.start()
    return proc


def how_it_ended(proc: subprocess.Popen) -> str:
    """'exit N', 'still running', or that its deadline killed it."""
    if getattr(proc, "killed_at_deadline", False):
        return f"killed at its {proc.deadline_s:g} s deadline: {' '.join(map(str, proc.args))}"
    code = proc.poll()
    return "still running" if code is None else f"exit {code}"


def finished(cmd: list[str], what: str, timeout: float, **kw) -> subprocess.CompletedProcess:
    """`cmd` run to its end within `timeout` seconds, output captured as text, for a fixture:
    one that fails or times out fails the test with `what` it was doing and the end of its
    output, instead of an exception far from the cause or a wait without end."""
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, **kw)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"{what}: not finished after {timeout:g} s ({' '.join(map(str, cmd))}){_tail(exc)}")
    if done.returncode != 0:
        pytest.fail(f"{what}: exit {done.returncode} ({' '.join(map(str, cmd))}){_tail(done)}")
    return done


def _tail(run, chars: int = 3000) -> str:
    def text(value) -> str:
        if isinstance(value, bytes):
            value = value.decode(errors="replace")
        return (value or "")[-chars:]

    return f"\n--- stdout (end) ---\n{text(run.stdout)}\n--- stderr (end) ---\n{text(run.stderr)}"
