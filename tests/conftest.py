"""The order tests run in.

`make test` runs two pytest-xdist processes, each taking a whole test file at a time in
collection order. Files with a test marked `slow` (marked in the test file itself, e.g.
`pytestmark = pytest.mark.slow`: tens of seconds to minutes each) go first, so the two
processes finish close together instead of one starting a long file last. `make test-fast`
leaves them out.

`wildscan dataset` keeps the worlds it builds in the user's cache directory (app/cache/): the
tests' runs keep theirs in a temporary folder of each pytest process, removed when it ends.

Dask's nanny writes its workers' malloc settings (app/dataset/heap.py: GLIBC_TUNABLES with
mmap_max=0 and no trim, MALLOC_TRIM_THRESHOLD_) into the environment of the process that
starts them, so after a test that runs a local cluster every process a later test starts
would inherit a worker's heap (seen: a 20 m drive's peak 3.3 GB, glibc's default mapping of
a large array gone). Each test starts from the environment the session began with.
"""

import atexit
import os
import shutil
import tempfile

import pytest

_WORLD_CACHE = tempfile.mkdtemp(prefix="wildscan-test-cache-")
os.environ["XDG_CACHE_HOME"] = _WORLD_CACHE
atexit.register(shutil.rmtree, _WORLD_CACHE, ignore_errors=True)


_MALLOC_ENVIRON = ("GLIBC_TUNABLES", "MALLOC_TRIM_THRESHOLD_", "MALLOC_ARENA_MAX")
_SESSION_MALLOC = {name: os.environ.get(name) for name in _MALLOC_ENVIRON}


@pytest.fixture(autouse=True)
def _malloc_environ_as_the_session_began():
    yield
    for name, value in _SESSION_MALLOC.items():
        if value is None:
            os.environ.pop(name, None)
        else:
            os.environ[name] = value


def pytest_collection_modifyitems(items):
    slow_files = {item.path for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: item.path not in slow_files)  # stable: order kept within a file
