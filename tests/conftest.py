import sys
from pathlib import Path

# Test helpers (analytic.py, …) live beside the tests.
sys.path.insert(0, str(Path(__file__).parent))

# `make test` runs two pytest-xdist processes, each taking a whole test file at a time in
# collection order. The longest files (measured: tens of seconds to minutes each) go first,
# so the two processes finish close together instead of one starting a long file last.
LONGEST_FIRST = (
    "test_determinism.py",
    "test_dataset_runs.py",
    "test_readers.py",
    "test_interrupts.py",
    "test_addon.py",
    "test_drive_outputs.py",
    "test_from_plan.py",
    "test_scan_scene.py",
    "test_bench.py",
    "test_world_cli.py",
    "test_golden.py",
    "test_gui.py",
)


def pytest_collection_modifyitems(items):
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: order kept within a file
