"""`wildscan bench --suite drive`'s last row: a drive of kilometres over the endless world's
trail network, run as a user runs it: `wildscan drive --seed 1 --trail --distance 2000
--bag ros2 --out DIR`, a process of its own on an empty world cache (every tile built), its
wall time, CPU time and peak resident memory (the drive's own, from the operating system:
os.wait4 in a small starter process, measured_run), beside the targets.

Targets (on this 2-core machine, quiet): at most 120 s, at most 2 GB peak.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LONG_SEED = 1
LONG_M = 2000.0
QUICK_M = 100.0  # --quick: the same drive, a short stretch
TARGET_SECONDS = 120.0
TARGET_PEAK_BYTES = 2e9


# Linux keeps a process's high-water resident size across execve, and Python starts a child by
# vfork: a child's ru_maxrss (os.wait4) starts at its parent's peak, so from a bench that has
# scanned for minutes a 20 m drive read 3.2 GB. A small Python in between starts the measured
# command (its fresh memory is what the command inherits) and reports the command's own figures.
STARTER = """
import os, subprocess, sys
child = subprocess.Popen(sys.argv[1:])
_, status, usage = os.wait4(child.pid, 0)
code = os.waitstatus_to_exitcode(status)
print(PEAK_MARK, usage.ru_maxrss, usage.ru_utime + usage.ru_stime, code, flush=True)
sys.exit(code & 0xFF)
"""
PEAK_MARK = "wildscan-measured"


def measured_run(command: list[str], env: dict | None = None) -> tuple[list[str], float, float, int, int]:
    """Run `command` (its output read line by line): (its lines, wall seconds, CPU seconds,
    peak resident bytes of its own, exit code)."""
    starter = [sys.executable, "-c", STARTER.replace("PEAK_MARK", repr(PEAK_MARK)), *command]
    t0 = time.perf_counter()
    child = subprocess.Popen(
        starter, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1
    )
    said = [line.rstrip("\n") for line in child.stdout]
    child.wait()
    seconds = time.perf_counter() - t0
    figures = next((line.split()[1:] for line in said if line.startswith(PEAK_MARK)), None)
    if figures is None:
        return said, seconds, 0.0, 0, child.returncode or 1
    said = [line for line in said if not line.startswith(PEAK_MARK)]
    return said, seconds, float(figures[1]), int(figures[0]) * 1024, int(figures[2])  # Linux: kilobytes


def long_drive(distance: float = LONG_M, seed: int = LONG_SEED) -> dict:
    """Run the drive in a child process and measure it."""
    with tempfile.TemporaryDirectory(prefix="wildscan-bench-drive-long-") as tmp:
        out = Path(tmp) / "drive"
        command = [sys.executable, "-m", "wildscan.cli", "drive", "--seed", str(seed), "--trail"]
        command += ["--distance", f"{distance:g}", "--bag", "ros2", "--out", str(out)]
        env = dict(os.environ, XDG_CACHE_HOME=str(Path(tmp) / "cache"))
        said, seconds, cpu, peak, code = measured_run(command, env)
        said = [line for line in said if not line.startswith("driving:")]
        size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file()) if out.exists() else 0
    if code != 0:
        raise RuntimeError(f"the long drive failed ({code}): " + " / ".join(said[-3:]))
    return {
        "command": " ".join(["wildscan", *command[3:-1], "DIR"]),
        "seconds": seconds,
        "cpu": cpu,
        "peak": peak,
        "bytes": size,
        "said": [line for line in said if line.startswith(("drove", "  time:"))],
    }


def print_long(row: dict, load: tuple[float, float] | None = None) -> None:
    """The long drive's row beside its targets (`load`: the load average before and after)."""
    print(f"\nwildscan drive of kilometres: `{row['command']}`, an empty world cache, its own process")
    for line in row["said"]:
        print(f"  {line.strip()}")
    time_ok = "met" if row["seconds"] <= TARGET_SECONDS else "MISSED"
    peak_ok = "met" if row["peak"] <= TARGET_PEAK_BYTES else "MISSED"
    print(
        f"  wall {row['seconds']:.1f} s (<= {TARGET_SECONDS:g} {time_ok}), CPU {row['cpu']:.1f} s, "
        f"peak {row['peak'] / 1e9:.2f} GB (<= {TARGET_PEAK_BYTES / 1e9:g} {peak_ok}), "
        f"{row['bytes'] / 1e9:.2f} GB written"
    )
    if load is not None:
        print(f"  load average {load[0]:.2f} before, {load[1]:.2f} after (2 cores: above 2, others ran too)")


def bench_long_drive(quick: bool = False) -> dict:
    before = os.getloadavg()[0]
    row = long_drive(QUICK_M if quick else LONG_M)
    print_long(row, (before, os.getloadavg()[0]))
    return row
