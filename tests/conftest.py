"""The order tests run in.

`make test` runs two pytest-xdist processes, each taking a whole test file at a time in
collection order. Files with a test marked `slow` (marked in the test file itself, e.g.
`pytestmark = pytest.mark.slow`: tens of seconds to minutes each) go first, so the two
processes finish close together instead of one starting a long file last. `make test-fast`
leaves them out.
"""


def pytest_collection_modifyitems(items):
    slow_files = {item.path for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: item.path not in slow_files)  # stable: order kept within a file
