"""Every process a test starts has a deadline (tests/helpers/processes.py; issue 31: a fixture
that ran Blender 3.4 without one held CI for 48 minutes). Read from the test files themselves,
so a new call without one fails here, not by hanging a run."""

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent
RUNS = {"run", "check_output", "check_call", "call"}  # subprocess functions that wait for the end
WATCHDOG = TESTS / "helpers" / "processes.py"  # the one place a Popen is made


def subprocess_calls(path: Path):
    """(line, function name, keyword names) of each `subprocess.NAME(...)` call in `path`."""
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if not isinstance(node, ast.Call) or not isinstance(node.func, ast.Attribute):
            continue
        owner = node.func.value
        if isinstance(owner, ast.Name) and owner.id == "subprocess":
            yield node.lineno, node.func.attr, {k.arg for k in node.keywords}


def test_every_process_a_test_waits_for_has_a_timeout():
    missing = [
        f"{path.relative_to(TESTS.parent)}:{line} subprocess.{name}"
        for path in sorted(TESTS.rglob("*.py"))
        for line, name, keywords in subprocess_calls(path)
        if name in RUNS and "timeout" not in keywords
    ]
    assert not missing, "give these a timeout= (tests/helpers/processes.py):\n" + "\n".join(missing)


def test_every_process_beside_a_test_is_started_with_a_watchdog():
    direct = [
        f"{path.relative_to(TESTS.parent)}:{line}"
        for path in sorted(TESTS.rglob("*.py"))
        if path != WATCHDOG
        for line, name, _ in subprocess_calls(path)
        if name == "Popen"
    ]
    assert not direct, "start these with tests/helpers/processes.started (a deadline):\n" + "\n".join(direct)


def test_the_checks_above_see_the_calls_they_look_for(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text(
        "import subprocess\n"
        "subprocess.run(['true'])\n"
        "subprocess.run(['true'], timeout=5)\n"
        "p = subprocess.Popen(['sleep', '1'])\n"
    )
    assert list(subprocess_calls(sample)) == [(2, "run", set()), (3, "run", {"timeout"}), (4, "Popen", set())]


def test_a_watchdog_kills_a_process_at_its_deadline_and_says_so():
    import subprocess
    import sys

    from tests.helpers.processes import how_it_ended, started

    proc = started([sys.executable, "-c", "import time; time.sleep(600)"], deadline=0.5)
    proc.wait(timeout=60)  # the watchdog, not this wait, ends it
    assert proc.killed_at_deadline and "killed at its 0.5 s deadline" in how_it_ended(proc)
    quick = started([sys.executable, "-c", "pass"], deadline=60, stdout=subprocess.DEVNULL)
    assert quick.wait(timeout=60) == 0 and how_it_ended(quick) == "exit 0"
