"""`wildscan bench --suite drive` prints each drive beside its own target (with wind or
without), met or not. No timing here: the rows are made up."""

from __future__ import annotations

from wildscan.bench.drive import TARGET_SECONDS, WIND_TARGET_SECONDS, print_rows


def row(wind: float, seconds: float) -> dict:
    stages = {"world": 1.0, "crop": 0.1, "placement": 0.2, "sweep": seconds - 1.5, "write": 0.2}
    return {
        "case": f"stepped, wind {wind:g}, bags both",
        "wind": wind,
        "seconds": seconds,
        "stages": stages,
        "scans_2d": 2400,
        "scans_3d": 13,
        "points": 870_000,
        "files": 90,
        "bytes": 259e6,
    }


def test_each_row_is_printed_beside_its_target(capsys):
    print_rows(
        0, [row(0.0, TARGET_SECONDS - 0.5), row(0.0, TARGET_SECONDS + 0.5), row(3.0, 9.0), row(3.0, 11.0)]
    )
    lines = capsys.readouterr().out.splitlines()
    assert f"at most {TARGET_SECONDS:g} s without wind, {WIND_TARGET_SECONDS:g} s with wind" in lines[0]
    verdicts = [line.split()[-2:] for line in lines[2:]]
    assert verdicts == [
        [f"{TARGET_SECONDS:g}", "met"],
        [f"{TARGET_SECONDS:g}", "MISSED"],
        [f"{WIND_TARGET_SECONDS:g}", "met"],
        [f"{WIND_TARGET_SECONDS:g}", "MISSED"],
    ]


def test_the_long_drive_runs_as_a_user_runs_it_and_is_printed_beside_its_targets(capsys):
    """bench/drive_long.py: the drive in a process of its own (its own peak memory and CPU)."""
    from wildscan.bench.drive_long import TARGET_PEAK_BYTES, TARGET_SECONDS, long_drive, print_long

    row = long_drive(20.0)
    assert row["command"] == "wildscan drive --seed 1 --trail --distance 20 --bag ros2 --out DIR"
    assert row["seconds"] > 0 and row["cpu"] > 0 and 50e6 < row["peak"] < TARGET_PEAK_BYTES
    assert row["bytes"] > 0 and row["said"][0].startswith("drove 20.00 m")
    print_long(row, (0.5, 0.7))
    out = capsys.readouterr().out
    assert f"(<= {TARGET_SECONDS:g} " in out and "load average 0.50 before, 0.70 after" in out


def test_a_measured_childs_peak_is_its_own_not_its_parents():
    """Linux keeps the high-water resident size across execve and Python starts children by
    vfork: measured directly, a tiny child of a big process reads the parent's peak."""
    import sys

    from wildscan.bench.drive_long import measured_run

    ballast = bytearray(600 * 2**20)  # this process: 600 MB resident
    ballast[::4096] = b"x" * len(ballast[::4096])
    said, seconds, cpu, peak, code = measured_run([sys.executable, "-c", "print('small')"])
    assert code == 0 and said == ["small"] and seconds > 0 and cpu > 0
    assert 1e6 < peak < 200e6, peak
    del ballast


def test_a_workers_own_peak_is_not_its_starters():
    """core/runtime/peak.py (a dataset worker's reported peak): VmHWM, not ru_maxrss, which a
    child of a big process starts at."""
    import subprocess
    import sys

    ballast = bytearray(600 * 2**20)
    ballast[::4096] = b"x" * len(ballast[::4096])
    code = "from wildscan.core.runtime.peak import peak_resident_bytes as p; import resource; "
    code += "print(p(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)"
    own, inherited = map(int, subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                             check=True, timeout=120).stdout.split())  # fmt: skip
    assert own < 200e6 < 600e6 < inherited
    del ballast
