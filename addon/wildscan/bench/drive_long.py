"""`wildscan bench --suite drive`'s last row: a drive of kilometres over the endless world's
trail network, run as a user runs it: `wildscan drive --seed 1 --trail --distance 2000
--bag ros2 --out DIR`, a process of its own on an empty world cache (every tile built), its
wall time, CPU time and peak resident memory (the child's own, from the operating system:
os.wait4), beside the targets.

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


def long_drive(distance: float = LONG_M, seed: int = LONG_SEED) -> dict:
    """Run the drive in a child process and measure it."""
    with tempfile.TemporaryDirectory(prefix="wildscan-bench-drive-long-") as tmp:
        out = Path(tmp) / "drive"
        command = [sys.executable, "-m", "wildscan.cli", "drive", "--seed", str(seed), "--trail"]
        command += ["--distance", f"{distance:g}", "--bag", "ros2", "--out", str(out)]
        env = dict(os.environ, XDG_CACHE_HOME=str(Path(tmp) / "cache"))
        t0 = time.perf_counter()
        child = subprocess.Popen(
            command, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1
        )
        said = [line.rstrip("\n") for line in child.stdout if not line.startswith("driving:")]
        _, status, usage = os.wait4(child.pid, 0)
        seconds = time.perf_counter() - t0
        child.returncode = os.waitstatus_to_exitcode(status)
        size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file()) if out.exists() else 0
    if child.returncode != 0:
        raise RuntimeError(f"the long drive failed ({child.returncode}): " + " / ".join(said[-3:]))
    return {
        "command": " ".join(["wildscan", *command[3:-1], "DIR"]),
        "seconds": seconds,
        "cpu": usage.ru_utime + usage.ru_stime,
        "peak": usage.ru_maxrss * 1024,  # Linux: kilobytes
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
