"""Ctrl-C and SIGTERM at any moment: every command that writes, in the
bpy wheel and in a real Blender, ends with exit 130 / 143, one true line saying what it
completed, and no temporary or partial file.

The moments are hit exactly with the test hook of core/runtime/pause.py (WILDSCAN_TEST_PAUSE_AT):
the process prints a marker and waits there, and the signal is sent when the marker is read.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers.processes import finished, how_it_ended, started
from tests.helpers.scene_helpers import BLENDER, PAPER, REPO, WILDSCAN, save_seed_2_low

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

CODES = {signal.SIGINT: (130, "interrupted"), signal.SIGTERM: (143, "terminated")}
SCAN = ["--pose", "0", "0", "0", "--rh", "4", "--quiet"]  # seed 2, low detail: a valid pose
COMPLETED = re.compile(r"completed (\d+) files? in (\S+) \((.*)\), nothing else$")


def stop_at(cmd: list[str], moment: str, sig: signal.Signals, cwd: Path) -> tuple[int, list[str]]:
    """Run `cmd`, send `sig` when it reaches `moment`; (exit code, stderr lines after the marker)."""
    env = dict(os.environ, WILDSCAN_TEST_PAUSE_AT=moment, PYTHONUNBUFFERED="1")
    # the deadline ends a process that hangs before its marker: the loop below then reads the end
    proc = started(cmd, 300, cwd=cwd, env=env, text=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    before = []
    for line in proc.stderr:
        if line.startswith(f"wildscan-test-pause {moment.split(':')[0]}"):
            proc.send_signal(sig)
            break
        before.append(line)
    else:
        proc.wait(timeout=60)
        pytest.fail(f"{moment} never reached ({how_it_ended(proc)}): {''.join(before)}")
    rest = proc.stderr.read()
    proc.wait(timeout=60)
    return proc.returncode, [ln for ln in rest.splitlines() if ln.strip()]


def files_in(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


def assert_stopped_truly(code, lines, sig, where, folder: Path, before: set[str]) -> None:
    exit_code, word = CODES[sig]
    assert code == exit_code, lines
    assert len(lines) == 1 and "Traceback" not in lines[0], lines
    assert lines[0].startswith(f"{where}: {word}; "), lines
    now = files_in(folder)
    debris = [n for n in now if Path(n).name.startswith(".") or n.endswith("@") or ".tmp-" in n]
    assert not debris, debris
    new = now - before
    said = lines[0].split("; ", 1)[1]
    if said == "nothing written":
        assert not new, new
    else:
        m = COMPLETED.search(said)
        assert m, said
        names = m.group(3).split(", ")
        assert int(m.group(1)) == len(names) and Path(m.group(2)) == folder
        assert set(names) == new, (names, new)


@pytest.fixture(scope="module")
def worlds(tmp_path_factory):
    """Seed 2 at low detail, saved by the wheel (a .blend and a geometry file)."""
    return save_seed_2_low(tmp_path_factory.mktemp("worlds"))


WHEEL_CASES = [
    ("scan-world", "starting", signal.SIGINT),  # the first thing the `wildscan` script does
    ("world", "bpy-import", signal.SIGINT),
    ("world", "writing", signal.SIGTERM),
    ("world", "writing", signal.SIGINT),
    ("scan-world", "bpy-import", signal.SIGTERM),
    ("scan-world", "casting", signal.SIGINT),
    ("scan-world", "writing", signal.SIGTERM),
    ("scan-geometry", "casting", signal.SIGTERM),
    ("scan-geometry", "writing", signal.SIGINT),
    ("demo", "bpy-import", signal.SIGTERM),
    ("demo", "casting", signal.SIGINT),
    ("demo", "writing:3", signal.SIGINT),  # the world, its map and one scan are complete
    ("demo", "writing:4", signal.SIGTERM),  # ... and the scan's preview
]


def wheel_command(case: str, worlds: Path) -> tuple[list[str], str]:
    return {
        "world": (
            ["world", *PAPER, "--seed", "2", "--detail", "low", "--map", "m.png", "--out", "w.blend"],
            "world",
        ),
        "scan-world": (["scan", "--world", str(worlds / "w.blend"), *SCAN, "--out", "s.ply"], "scan"),
        "scan-geometry": (["scan", "--geometry", str(worlds / "w.npz"), *SCAN, "--out", "s.ply"], "scan"),
        "demo": (["demo", "--seed", "2", "--rh", "6", "--out", "demo"], "demo"),
    }[case]


@pytest.mark.parametrize("case, moment, sig", WHEEL_CASES, ids=lambda v: getattr(v, "name", v))
def test_a_signal_at_any_moment_leaves_no_debris_and_says_truly_what_was_completed(
    tmp_path, worlds, case, moment, sig
):
    args, command = wheel_command(case, worlds)
    code, lines = stop_at([WILDSCAN, *args], moment, sig, tmp_path)
    folder = tmp_path / "demo" if case == "demo" else tmp_path
    assert_stopped_truly(code, lines, sig, f"wildscan {command}", folder, set())
    if moment.startswith("writing:"):  # the demo had completed files, and says so
        assert "completed" in lines[0]


@pytest.fixture(scope="module")
def blender_world(tmp_path_factory):
    """Seed 2 at low detail saved by Blender 3.4 (it cannot read the wheel's newer .blend)."""
    d = tmp_path_factory.mktemp("blender_world")
    script = [BLENDER, "-b", "--factory-startup", "-P", "blender_scripts/world.py", "--"]
    what = "Blender 3.4's world.py building seed 2 (low detail) for the signal tests"
    args = [*PAPER, "--seed", "2", "--detail", "low", "--quiet", "--out", str(d / "w.blend")]
    finished([*script, *args], what, 300, cwd=REPO)
    return d / "w.blend"


@pytest.mark.blender_binary
@pytest.mark.parametrize(
    "script, moment, sig",
    [
        ("scan", "starting", signal.SIGINT),  # Blender's own handler would ignore it
        ("world", "writing", signal.SIGINT),
        ("world", "writing", signal.SIGTERM),
        ("scan", "casting", signal.SIGINT),
        ("scan", "writing", signal.SIGTERM),
    ],
    ids=lambda v: getattr(v, "name", v),
)
def test_a_signal_stops_a_real_blender_with_130_or_143_and_no_debris(
    tmp_path, blender_world, script, moment, sig
):
    """Blender's own SIGINT handler ignores the first Ctrl-C and exits 2 on the second."""
    if script == "world":
        args = [*PAPER, "--seed", "2", "--detail", "low", "--out", str(tmp_path / "w.blend")]
        cmd = [BLENDER, "-b", "--factory-startup", "-P", "blender_scripts/world.py", "--", *args]
    else:
        args = [*SCAN, "--backend", "bvh", "--out", str(tmp_path / "s.ply")]
        cmd = [BLENDER, "-b", str(blender_world), "--factory-startup", "-P", "blender_scripts/scan.py"]
        cmd += ["--", *args]
    code, lines = stop_at(cmd, moment, sig, REPO)
    assert_stopped_truly(code, lines, sig, f"blender_scripts/{script}.py", tmp_path, set())


def test_a_signal_while_signals_are_deferred_is_raised_when_the_moment_is_over():
    from wildscan.app.interrupts import Terminated, deferred, stopping_on_signals

    reached = []
    with stopping_on_signals():
        with pytest.raises(Terminated):
            with deferred():
                os.kill(os.getpid(), signal.SIGTERM)
                reached.append("end of the deferred block")
    assert reached == ["end of the deferred block"]


@pytest.mark.parametrize("name", ["KeyboardInterrupt", "Terminated"])
def test_a_signal_that_lands_in_a_finaliser_is_not_dropped(name):
    """A signal handled while a weakref callback or a __del__ runs raises there, where Python
    prints "Exception ignored" and drops it (a dataset once finished after its Ctrl-C this
    way): the next check (a dataset's poll, a file about to be placed) raises it."""
    from wildscan.app.interrupts import Terminated, stopping_on_signals
    from wildscan.core.runtime.signals import check_host_break, check_lost_signal

    kind = Terminated if name == "Terminated" else KeyboardInterrupt

    class Dropped:
        def __del__(self):
            raise kind()  # what on_signal raises when the signal lands here

    with stopping_on_signals():
        Dropped()  # freed at once: its exception is unraisable
        with pytest.raises(kind):
            check_lost_signal()
        check_host_break()  # noted once: raised once
        Dropped()
        with pytest.raises(kind):
            check_host_break()


# Without the test hook: the process signals itself from inside the work, the way a user's
# Ctrl-C or a scheduler's SIGTERM lands mid-write or mid-cast.
SELF_SIGNAL = """
import os, runpy, signal, sys
sys.path.insert(0, {addon!r})
from wildscan.core import scan
from wildscan.core.io import ply

def write_then_signal(path, write, _real=ply.write_durably):
    _real(path, write)
    os.kill(os.getpid(), signal.{sig})

def cast_then_signal(*args, _real=scan.cast_in_chunks):
    os.kill(os.getpid(), signal.{sig})
    return _real(*args)

ply.write_durably = write_then_signal
scan.cast_in_chunks = cast_then_signal
{run}
"""


def test_sigterm_after_the_ply_is_written_removes_it_and_exits_143(tmp_path, worlds):
    args = ["scan", "--geometry", str(worlds / "w.npz"), *SCAN, "--out", "s.ply"]
    code = SELF_SIGNAL.format(
        addon=str(REPO / "addon"),
        sig="SIGTERM",
        run=f"from wildscan.cli import main; sys.exit(main({args!r}))",
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert (done.returncode, done.stderr) == (143, "wildscan scan: terminated; nothing written\n")
    assert not any(tmp_path.iterdir())


@pytest.mark.blender_binary
def test_one_ctrl_c_in_a_real_blender_stops_the_scan_with_130(tmp_path, blender_world):
    """Blender's own handler ignores the first Ctrl-C: the scan would finish and exit 0."""
    script = str(REPO / "blender_scripts" / "scan.py")
    wrapper = tmp_path / "wrapper.py"
    wrapper.write_text(
        SELF_SIGNAL.format(addon=str(REPO / "addon"), sig="SIGINT", run=f"runpy.run_path({script!r})")
    )
    args = [*SCAN, "--backend", "bvh", "--out", str(tmp_path / "s.ply")]
    cmd = [BLENDER, "-b", str(blender_world), "--factory-startup", "-P", str(wrapper), "--", *args]
    done = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert (done.returncode, done.stderr) == (130, "blender_scripts/scan.py: interrupted; nothing written\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["wrapper.py"]


# Blender runs Python handlers while it opens a file, and prints and swallows whatever they
# raise: a Ctrl-C landing in one would be lost and the scan written. The handler below is
# that moment, made certain: it signals the process from inside Blender's file read.
IN_LOAD_HANDLER = """
import os, runpy, signal, sys
sys.path.insert(0, {addon!r})
import bpy

@bpy.app.handlers.persistent
def signal_while_loading(*_):
    os.kill(os.getpid(), signal.SIGINT)

bpy.app.handlers.load_post.append(signal_while_loading)
{run}
"""


def test_a_ctrl_c_while_the_wheel_reads_the_blend_is_not_swallowed(tmp_path, worlds):
    args = ["scan", "--world", str(worlds / "w.blend"), *SCAN, "--out", "s.ply"]
    code = IN_LOAD_HANDLER.format(
        addon=str(REPO / "addon"), run=f"from wildscan.cli import main; sys.exit(main({args!r}))"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert (done.returncode, done.stderr) == (130, "wildscan scan: interrupted; nothing written\n")
    assert not any(tmp_path.iterdir())


@pytest.mark.blender_binary
def test_a_ctrl_c_while_blender_reads_the_world_is_not_swallowed(tmp_path, blender_world):
    """`blender -b -P scan.py -- --world W`: the .blend is read by the script, in Blender 3.4."""
    script = str(REPO / "blender_scripts" / "scan.py")
    wrapper = tmp_path / "wrapper.py"
    wrapper.write_text(IN_LOAD_HANDLER.format(addon=str(REPO / "addon"), run=f"runpy.run_path({script!r})"))
    args = ["--world", str(blender_world), *SCAN, "--backend", "bvh", "--out", str(tmp_path / "s.ply")]
    cmd = [BLENDER, "-b", "--factory-startup", "-P", str(wrapper), "--", *args]
    done = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert (done.returncode, done.stderr) == (130, "blender_scripts/scan.py: interrupted; nothing written\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["wrapper.py"]


# The `wildscan` script's first second is spent importing; a Ctrl-C there used to end in a
# traceback from inside an import. The finder below signals the process while the world
# planner (imported by the command line's modules) is being imported.
DURING_IMPORT = """
import os, signal, sys
sys.path.insert(0, {addon!r})
sys.argv[0] = os.path.join(os.path.dirname(sys.executable), "wildscan")

class SignalOnImport:
    def find_spec(self, name, path, target=None):
        if name == "wildscan.core.world":
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None

sys.meta_path.insert(0, SignalOnImport())
from wildscan.cli import main
sys.exit(main({args!r}))
"""


def test_a_ctrl_c_while_the_command_line_imports_exits_130_in_one_line(tmp_path, worlds):
    args = ["scan", "--geometry", str(worlds / "w.npz"), *SCAN, "--out", "s.ply"]
    code = DURING_IMPORT.format(addon=str(REPO / "addon"), args=args)
    done = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300
    )
    assert (done.returncode, done.stderr) == (130, "wildscan scan: interrupted; nothing written\n")
    assert not any(tmp_path.iterdir())


# Debian's Blender takes a Ctrl-C that comes while it starts (before the script's handler is
# installed) with its own handler, which only sets G.is_break: the run used to go on and
# write its files, exit 0. The --python-expr before -P is that moment, made certain: it runs
# under Blender's handler, and signals the process.
CTRL_C_WHILE_BLENDER_STARTS = "import os, signal; os.kill(os.getpid(), signal.SIGINT)"


@pytest.mark.blender_binary
@pytest.mark.parametrize(
    "script, args",
    [
        ("extract", ["--out", "x.npz"]),  # the factory scene's cube: seconds
        ("scan", ["--seed", "2", *SCAN, "--backend", "bvh", "--out", "s.ply"]),
        ("world", ["--seed", "2", "--detail", "low", "--quiet", "--out", "w.blend"]),
    ],
)
def test_a_ctrl_c_while_blender_starts_stops_the_script_with_130(tmp_path, script, args):
    cmd = [BLENDER, "-b", "--factory-startup", "--python-expr", CTRL_C_WHILE_BLENDER_STARTS]
    cmd += ["-P", str(REPO / "blender_scripts" / f"{script}.py"), "--", *args]
    done = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert "Sent an internal break event" in done.stdout  # Blender's own handler took it
    assert (done.returncode, done.stderr) == (
        130,
        f"blender_scripts/{script}.py: interrupted; nothing written\n",
    )
    assert not any(tmp_path.iterdir())


def test_blenders_break_flag_is_found_from_its_handlers_first_instructions():
    from wildscan.app.host_break import _flag_address

    # Debian's Blender 3.4.1, sig_handle_blender_esc: lea rax,[rip+0x4af5bc9]; mov byte [rax+0x818],1
    code = bytes.fromhex("488d05c95baf04c6801808000001")
    assert _flag_address(0x1000, code) == 0x1000 + 7 + 0x04AF5BC9 + 0x818
    assert _flag_address(0x1000, bytes(14)) is None  # another build's code: nothing read
    assert _flag_address(0x1000, code[:10]) is None


def test_a_host_break_found_set_is_one_ctrl_c():
    from wildscan.core.runtime import signals

    flag = [True]
    with pytest.raises(KeyboardInterrupt):
        signals.watch_host_break(lambda: flag[0])
        signals.check_host_break()
    signals.check_host_break()  # read once: it does not stop the run again
