"""Golden guards (tests/helpers/golden_cases.py): a refactor keeps every world and scan byte for byte."""

import pytest

from tests.helpers.golden_cases import all_scans, load, world_hashes

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not


def test_world_content_hashes_of_seeds_0_to_3_at_every_detail_are_unchanged():
    assert world_hashes() == load("worlds.json")


def test_scan_checksums_of_every_zone_and_backend_are_unchanged():
    expected = load("scans.json")
    measured = all_scans()
    assert measured.keys() == expected.keys()
    for key, want in expected.items():
        assert measured[key] == want, key
