"""The order tests run in.

`make test` runs two pytest-xdist processes, each taking a whole test file at a time in
collection order. Files with a test marked `slow` (marked in the test file itself, e.g.
`pytestmark = pytest.mark.slow`: tens of seconds to minutes each) go first, so the two
processes finish close together instead of one starting a long file last. `make test-fast`
leaves them out.

`wildscan dataset` keeps the worlds it builds in the user's cache directory (app/cache/): the
tests' runs keep theirs in a temporary folder of each pytest process, removed when it ends.
"""

import atexit
import os
import shutil
import tempfile

_WORLD_CACHE = tempfile.mkdtemp(prefix="wildscan-test-cache-")
os.environ["XDG_CACHE_HOME"] = _WORLD_CACHE
atexit.register(shutil.rmtree, _WORLD_CACHE, ignore_errors=True)


def pytest_collection_modifyitems(items):
    slow_files = {item.path for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: item.path not in slow_files)  # stable: order kept within a file
