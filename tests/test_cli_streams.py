"""The command line as a Unix tool: a reader that closes the pipe, a full standard output, a
Ctrl-C before the command has even imported its parser, numbers typed in any option, and
user values quoted in one-line errors. Every case here once gave a traceback or accepted
what it should refuse (issue 31, held-out defects 3, 8, 9 and 10)."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

import pytest

from wildscan.cli.options import finite_float
from wildscan.core.checks import decimal
from wildscan.core.effects.dust_cloud import parse_region
from wildscan.core.effects.weather import parse_settings
from wildscan.core.errors import UserError, shortened
from wildscan.core.io.waypoints import read_waypoints
from wildscan.core.sensors import device_from_dict
from wildscan.core.sensors.load import PRESETS_DIR, toml_reader

from tests.helpers.scene_helpers import REPO, WILDSCAN

TIMEOUT_S = 120


def run_into(stdout, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [WILDSCAN, *args], stdout=stdout, stderr=subprocess.PIPE, text=True, timeout=TIMEOUT_S
    )


def closed_pipe() -> int:
    """The write end of a pipe whose reader has already gone (`| head -1` after its line):
    every write into it fails, whenever the command writes."""
    read, write = os.pipe()
    os.close(read)
    return write


@pytest.mark.parametrize(
    "args",
    [
        ["sensors"],
        pytest.param(["poses", "--seed", "1", "--count", "50"], marks=pytest.mark.slow),  # builds a world
    ],
    ids=["sensors", "poses"],
)
def test_a_closed_pipe_ends_the_command_quietly(args):
    write = closed_pipe()
    try:
        done = run_into(write, *args)
    finally:
        os.close(write)
    assert "Traceback" not in done.stderr and "Exception ignored" not in done.stderr, done.stderr
    progress = [ln for ln in done.stderr.splitlines() if not ln.startswith(("world:", "poses:"))]
    assert progress == [], done.stderr
    assert done.returncode == 141  # 128 + SIGPIPE, as a shell reports a tool the pipe stopped


def test_a_full_standard_output_is_one_line_and_a_failure():
    with open("/dev/full", "w") as full:
        done = run_into(full, "sensors")
    assert done.returncode == 1
    said = "wildscan sensors: error: cannot write to standard output: No space left on device\n"
    assert done.stderr == said


# Python raises a Ctrl-C inside whatever import is running. The finder below signals the
# process the moment the command line asks for argparse, its first import of the standard
# library: before the fix the handler that defers a signal was installed after it.
SIGNAL_ON_IMPORT = """
import os, signal, sys
sys.path.insert(0, {addon!r})
sys.argv[0] = os.path.join(os.path.dirname(sys.executable), "wildscan")
assert {module!r} not in sys.modules

class SignalOnImport:
    def find_spec(self, name, path, target=None):
        if name == {module!r}:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, SignalOnImport())
from wildscan.cli import main
sys.exit(main(["sensors"]))
"""


@pytest.mark.parametrize("module", ["argparse", "shlex", "wildscan.cli.options"])
def test_a_ctrl_c_during_the_first_imports_is_a_quiet_130(module):
    code = SIGNAL_ON_IMPORT.format(addon=str(REPO / "addon"), module=module)
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=TIMEOUT_S
    )
    assert (done.returncode, done.stderr) == (130, "wildscan sensors: interrupted; nothing written\n")
    assert done.stdout == ""


# --------------------------------------------------------------------------- numbers typed


@pytest.mark.parametrize("text", ["٣", "１０", "1_0", "²", "3,5", "0x10", ""])
def test_one_parser_refuses_every_number_that_is_not_ascii_digits(text):
    with pytest.raises(ValueError):
        decimal(text)
    with pytest.raises(argparse.ArgumentTypeError):
        finite_float(text)
    with pytest.raises(UserError, match="weather"):
        parse_settings(f"rain={text}")
    if "," not in text:  # "3,5" is two of a region's numbers
        with pytest.raises(UserError, match="dust region"):
            parse_region(f"{text},1,2")


def test_a_waypoints_file_takes_ascii_digits_only(tmp_path):
    path = tmp_path / "w.txt"
    path.write_text("0,0\n1_0,２\n")
    with pytest.raises(UserError, match="line 2"):
        read_waypoints(path)


@pytest.mark.parametrize("text, value", [("3", 3.0), (" 2.5 ", 2.5), ("-1e3", -1000.0), (".5", 0.5)])
def test_ascii_numbers_still_parse(text, value):
    assert decimal(text) == value
    assert parse_settings(f"rain={text.strip()}")["rain"] == value if value >= 0 else True


def test_the_weather_option_refuses_arabic_digits_in_one_line(tmp_path):
    pose = ["--seed", "0", "--pose", "0", "0", "0"]
    done = run_into(subprocess.PIPE, "scan", *pose, "--weather", "rain=٣", "--out", str(tmp_path / "s.ply"))
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "rain='٣' is not a number (digits 0-9" in done.stderr and not any(tmp_path.iterdir())


# --------------------------------------------------------------------------- user values quoted short


def test_a_device_file_of_100000_beams_is_refused_in_a_short_line():
    data = toml_reader().loads((PRESETS_DIR / "vlp16.toml").read_text())
    n = 100_000
    data["beams"]["elevation_deg"] = [-15 + 30 * i / n for i in range(n)]
    with pytest.raises(UserError) as e:
        device_from_dict(data, "big.toml")
    message = str(e.value)
    assert len(message) < 300 and "\n" not in message, message[:400]
    assert "beams.elevation_deg must be a list of 1 to" in message and "(100,000 values)" in message


def test_shortened_keeps_short_values_whole_and_says_the_size_of_long_ones():
    assert shortened("abc") == "abc"
    long = "x" * 1000
    assert shortened(long).endswith("(1,000 characters)") and len(shortened(long)) < 110
    assert "(500 values)" in shortened(list(range(500)))


# --------------------------------------------------------------------------- output paths


@pytest.mark.parametrize("typed", ["x.npz/", "x.npz/.", "sub/x.npz//"])
def test_an_output_path_ending_in_a_slash_is_refused_not_written_as_a_file(tmp_path, monkeypatch, typed):
    from wildscan.core.io.files import check_output_path

    monkeypatch.chdir(tmp_path)
    (tmp_path / "sub").mkdir()
    with pytest.raises(UserError, match="ends in a slash, which names a directory"):
        check_output_path(typed, ".npz", "range_image")
    assert check_output_path("x.npz", ".npz", "range_image") == tmp_path / "x.npz"


def test_range_image_with_a_trailing_slash_writes_nothing(tmp_path):
    pose = ["--seed", "0", "--pose", "0", "0", "0"]
    image, out = f"{tmp_path}/x.npz/", str(tmp_path / "s.ply")
    done = run_into(subprocess.PIPE, "scan", *pose, "--range-image", image, "--out", out)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert not any(tmp_path.iterdir())


def test_an_error_quoting_a_huge_value_stays_one_short_line(tmp_path):
    pose = ["--seed", "0", "--pose", "0", "0", "0"]
    huge = "rain=" + "1" * 100_000 + "x"
    done = run_into(subprocess.PIPE, "scan", *pose, "--weather", huge, "--out", str(tmp_path / "s.ply"))
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert len(done.stderr) < 2100 and "characters)" in done.stderr, len(done.stderr)
