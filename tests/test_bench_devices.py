"""`wildscan bench --suite devices`: every device preset's full-frame scan time beside
Embree's own cast of the same rays (bench/devices.py). No timing is judged here (the
machine is shared): the rows, the arithmetic and the options are."""

from __future__ import annotations

import io

import pytest

from wildscan.core.sensors import SensorConfig, device_named, preset_names

pytest.importorskip("embreex")


@pytest.fixture(scope="module")
def bench():
    from wildscan.bench.devices import bench_devices

    printed = io.StringIO()
    rows = bench_devices(seed=0, quick=True, stream=printed)
    return rows, printed.getvalue()


@pytest.mark.slow
def test_every_preset_has_a_row_with_its_beams_and_both_times(bench):
    rows, printed = bench
    assert [r["device"] for r in rows] == list(preset_names())
    for r in rows:
        assert r["beams"] == SensorConfig.for_device(device_named(r["device"])).beam_count
        assert r["points"] > 1000 and r["scan_s"] > 0 and r["backend_s"] > 0 and r["cast_s"] > 0
        assert r["ratio"] == pytest.approx(r["scan_s"] / r["cast_s"])
        assert r["one_thread_ratio"] == pytest.approx(r["one_thread_s"] / r["cast_s"])
        line = next(ln for ln in printed.splitlines() if ln.startswith(r["device"] + " "))
        assert f"{r['beams']:,}" in line and f"{r['ratio']:.2f}x" in line
        assert line.rstrip().endswith(f"{r['one_thread_ratio']:.2f}x")  # the like-for-like column last


def test_the_devices_suite_is_dispatched_with_seed_and_quick(monkeypatch):
    from wildscan import cli
    from wildscan.bench import devices

    calls = []
    monkeypatch.setattr(devices, "bench_devices", lambda seed, quick: calls.append((seed, quick)))
    assert cli.main(["bench", "--suite", "devices", "--seed", "3", "--quick"]) == 0
    assert calls == [(3, True)]


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--backends", "embree"], "--backends applies to --suite backends only"),
        (["--details", "low"], "--details applies to --suite backends only"),
    ],
)
def test_backend_options_are_refused_for_the_devices_suite(argv, message, capsys):
    from wildscan import cli

    assert cli.main(["bench", "--suite", "devices", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
