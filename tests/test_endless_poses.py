"""`wildscan poses` on the endless layout: its table on stdout, its progress on stderr."""

from __future__ import annotations

import io

from wildscan.app.tile_memory import TileCounts
from wildscan.cli import main
from wildscan.cli.poses import PosesProgress


def test_poses_says_on_stderr_how_the_search_goes(capsys):
    argv = ["poses", "--seed", "1", "--region", "1000", "1000", "1060", "1060", "--count", "2", "--no-cache"]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert len([ln for ln in out.splitlines() if not ln.startswith("#")]) == 2
    lines = err.splitlines()
    assert lines and all(ln.startswith("poses: ") for ln in lines), err
    assert lines[-1].startswith("poses: 2 of 2 found, ")
    assert " tiles (" in lines[-1] and " built, " in lines[-1]


def test_a_log_gets_a_line_per_pose_found_and_per_few_tiles_made():
    stream = io.StringIO()
    progress = PosesProgress(stream)
    tiles = TileCounts()
    progress(0, 3, 1, tiles)  # the first candidate: always said
    progress(0, 3, 2, tiles)  # nothing new
    tiles.built = PosesProgress.TILES_A_LINE
    progress(0, 3, 3, tiles)  # more tiles
    progress(1, 3, 4, tiles)  # a pose
    progress.end()
    lines = stream.getvalue().splitlines()
    assert [ln.split(",")[0] for ln in lines] == ["poses: 0 of 3 found"] * 2 + ["poses: 1 of 3 found"]
    assert "4 tiles (4 built, 0 from the cache)" in lines[1]
