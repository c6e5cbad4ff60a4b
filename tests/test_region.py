"""Layouts and regions (core/world/region.py) and their command-line options: what a region may be,
and the one line a wrong one gets."""

from __future__ import annotations

import pytest

from wildscan.cli import main
from wildscan.core.errors import UserError
from wildscan.core.world.region import (
    DEFAULT_REGION,
    MAX_REGION_SIDE,
    Region,
    check_region,
    extended_region,
    reach_beyond,
    region_around,
)


def test_the_default_region_is_the_paper_islands_square():
    assert DEFAULT_REGION == Region(-75.0, -75.0, 75.0, 75.0)
    assert check_region((-75, -75, 75, 75), "paper") == DEFAULT_REGION


@pytest.mark.parametrize(
    "values, words",
    [
        ((10, 0, 5, 20), "XMIN < XMAX"),
        ((0, 20, 10, 20), "YMIN < YMAX"),
        ((0, 0, MAX_REGION_SIDE + 1, 10), f"at most {MAX_REGION_SIDE:g} m"),
        ((0, 0, float("nan"), 10), "finite"),
    ],
)
def test_a_wrong_region_is_refused_saying_what_is_allowed(values, words):
    with pytest.raises(UserError, match="region") as caught:
        check_region(values)
    assert words in str(caught.value)


def test_the_paper_layout_has_nothing_beyond_its_island():
    check_region((1000, 1000, 1300, 1300), "endless")
    with pytest.raises(UserError, match="leaves the paper layout's island"):
        check_region((1000, 1000, 1300, 1300), "paper")


def test_reach_beyond_measures_how_far_a_disc_leaves_the_region():
    region = Region(0, 0, 100, 100)
    assert reach_beyond(region, 50, 50, 30) == 0.0
    assert reach_beyond(region, 90, 50, 30) == pytest.approx(20.0)
    assert reach_beyond(region, 50, 5, 30) == pytest.approx(25.0)


def test_an_extended_region_holds_the_reach_and_keeps_under_the_limit():
    region = Region(0, 0, 100, 100)
    grown = extended_region(region, 90, 50, 30)
    assert grown.contains(region) and reach_beyond(grown, 90, 50, 30) == 0.0
    far = extended_region(region, 2000, 0, 120)
    assert far == region_around(2000, 0, 240) and max(far.size) <= MAX_REGION_SIDE


@pytest.mark.parametrize(
    "argv, line",
    [
        (
            ["extract", "--seed", "1", "--region", "5", "0", "1", "1", "--out", "s.npz"],
            "--region must have XMIN < XMAX",
        ),
        (
            ["poses", "--seed", "1", "--region", "0", "0", "900", "10"],
            f"a side may span at most {MAX_REGION_SIDE:g} m",
        ),
        (["poses", "--layout", "paper", "--seed", "1", "--region", "0", "0", "100", "10"], "island"),
        (
            [
                "world",
                "--layout",
                "paper",
                "--seed",
                "1",
                "--region",
                "0",
                "0",
                "10",
                "10",
                "--out",
                "w.blend",
            ],
            "--layout endless",
        ),
        (["poses", "--layout", "flat", "--seed", "1"], "--layout must be one of endless, paper"),
        (
            ["scan", "--world", "w.blend", "--lod", "off", "--pose", "0", "0", "0", "--out", "s.ply"],
            "no such file",
        ),
        (
            [
                "scan",
                "--layout",
                "paper",
                "--seed",
                "1",
                "--lod",
                "off",
                "--pose",
                "0",
                "0",
                "0",
                "--out",
                "s.ply",
            ],
            "--lod applies to --layout endless only",
        ),
        (  # a 245 m device's full-detail tiles would take tens of GB
            "scan --seed 1 --sensor vls128 --lod off --pose 0 0 0 --out s.ply".split(),
            "--lod off builds every tile within the scan's reach at full detail: 247 m",
        ),
    ],
)
def test_the_command_line_says_in_one_line_what_is_wrong_with_a_region(argv, line, capsys, tmp_path):
    argv = [str(tmp_path / a) if a in ("s.ply", "s.npz", "w.blend") else a for a in argv]
    try:
        code = main(argv)
    except SystemExit as e:  # argparse's own refusals exit from inside the parser
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and line in err[0], err
