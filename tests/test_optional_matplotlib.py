"""Only viz/ needs matplotlib: every other module imports without it, and asking for a
picture without it says what is missing. (Import cycles: tests/test_architecture.py.)"""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.helpers.scene_helpers import PAPER

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not


def test_only_the_pictures_need_matplotlib(tmp_path):
    """Every module imports without matplotlib; asking for a map says what is missing."""
    code = (
        "import sys, pkgutil, importlib\n"
        "sys.modules['matplotlib'] = None  # as if it were not installed\n"
        "import wildscan\n"
        "for m in pkgutil.walk_packages(wildscan.__path__, 'wildscan.'):\n"
        "    if not m.name.endswith('__main__'):\n"
        "        importlib.import_module(m.name)\n"
        "from wildscan.cli import main\n"
        "sys.exit(main(sys.argv[1:]))\n"
    )
    argv = [
        "world",
        *PAPER,
        "--seed",
        "1",
        "--out",
        str(tmp_path / "w.blend"),
        "--map",
        str(tmp_path / "m.png"),
    ]
    proc = subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and list(tmp_path.iterdir()) == [], proc.stderr
    assert proc.stderr.strip() == (
        "wildscan world: error: --map needs matplotlib (pip install matplotlib); it is not installed here"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, "poses", *PAPER, "--seed", "1", "--zone", "park", "--count", "1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0 and proc.stdout.count("park") == 1, proc.stderr
