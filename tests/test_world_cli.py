"""`wildscan world` / `wildscan poses` / the world benchmark, through cli.main (what the
`wildscan` script runs): files written, sidecar contents, bad input -> exit 2."""

from __future__ import annotations

import io
import json
import subprocess
import sys

import pytest

from wildscan.bench.world_build import bench_world
from wildscan.blender.scene_io import BLEND_MAGICS
from wildscan.cli import main
from wildscan.core.world import ZONES

from tests.helpers.scene_helpers import PAPER

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_world_writes_blend_sidecar_and_map(tmp_path, capsys):
    out = tmp_path / "w.blend"
    code, stdout, err = run(
        capsys,
        "world",
        *PAPER,
        "--seed",
        "3",
        "--out",
        str(out),
        "--map",
        str(tmp_path / "m.png"),
        "--detail",
        "low",
    )
    assert code == 0, err
    assert out.read_bytes().startswith(BLEND_MAGICS)
    assert (tmp_path / "m.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    side = json.loads((tmp_path / "w.json").read_text())
    assert [z["name"] for z in side["zones"]] == list(ZONES)
    for z in side["zones"]:
        e = z["extent"]
        assert -75 <= e["xmin"] < e["xmax"] <= 75 and -75 <= e["ymin"] < e["ymax"] <= 75
        assert len(z["poses"]) >= 3, z["name"]
        for p in z["poses"]:
            assert e["xmin"] <= p["x"] <= e["xmax"] and e["ymin"] <= p["y"] <= e["ymax"]
    assert side["seed"] == 3 and side["detail"] == "low"
    assert side["terrain"]["error"]["max"] <= side["terrain"]["tolerance"]
    # progress by stage, then the files written
    for stage in ("terrain", "trees", "grass", "powerline", "blender.objects", "save .blend"):
        assert f"world: {stage}" in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.png", "w.blend", "w.json"]  # no temporaries left


def test_poses_prints_valid_poses_per_zone(capsys):
    code, out, err = run(capsys, "poses", *PAPER, "--seed", "1", "--zone", "cave", "--count", "4")
    assert code == 0, err
    rows = [line.split() for line in out.splitlines() if not line.startswith("#")]
    assert len(rows) == 4 and all(r[0] == "cave" for r in rows)
    assert rows[0][4] != "-"  # the first cave pose stands inside: it needs --z-start
    code, out, _ = run(capsys, "poses", *PAPER, "--seed", "1", "--count", "2", "--json")
    data = json.loads(out)
    assert set(data["poses"]) == set(ZONES) and all(len(v) == 2 for v in data["poses"].values())


@pytest.mark.parametrize(
    "argv,message",
    [
        (["world", "--seed", "-1"], "--seed must be a whole number from 0 to 2147483647"),
        (["world", "--seed", "1.5"], "--seed must be a whole number from 0 to 2147483647"),
        (["world", "--seed", "x7"], "--seed must be a whole number from 0 to 2147483647"),
        (["world", "--seed", "1", "--detail", "ultra"], "--detail must be one of low, default, high"),
        (["world", "--seed", "1", "--out", "{tmp}/missing/w.blend"], "does not exist"),
        (["world", "--seed", "1", "--out", "{tmp}"], "must end in .blend"),
        (["world", "--seed", "1", "--out", "{tmp}/w.txt"], "must end in .blend"),
        (["world", "--seed", "1", "--map", "{tmp}/nowhere/m.png"], "does not exist"),
        (["world", "--seed", "2147483648"], "from 0 to 2147483647"),
        (
            ["world", "--seed", "1", "--detail", "low", "--quiet", "--out", "/proc/wildscan-world.blend"],
            "cannot write",
        ),
        (["poses", "--seed", "1", "--zone", "desert"], "--zone must be one of"),
        (["poses", "--seed", "1", "--count", "0"], "--count must be a whole number from 1"),
        (["poses", "--seed", "-4"], "--seed must be a whole number from 0 to 2147483647"),
    ],
)
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, capsys, argv, message):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    if argv[0] == "world" and "--out" not in argv:
        argv += ["--out", str(tmp_path / "w.blend")]
    code, out, err = run(capsys, *argv)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], err
    assert list(tmp_path.iterdir()) == []


def test_unwritable_output_in_a_subprocess(tmp_path):
    """The real process: exit code 2, one line on stderr, nothing written."""
    target = tmp_path / "sub" / "w.blend"
    proc = subprocess.run(
        [sys.executable, "-m", "wildscan.cli", "world", "--seed", "2", "--out", str(target)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "does not exist" in proc.stderr
    assert not target.parent.exists()


def test_bench_reports_every_stage(capsys):
    stream = io.StringIO()
    rows = bench_world(0, ("low",), stream=stream)
    text = stream.getvalue()
    for stage in ("layout", "terrain", "poses", "trees", "grass", "park", "powerline", "blender.objects"):
        assert stage in rows[0]["stages_s"] and stage in text
    assert rows[0]["objects"] > 1000 and rows[0]["triangles"] > rows[0]["terrain_triangles"]
    assert "uniform 1 m" in text and "adaptive" in text


def test_a_scan_and_a_world_of_the_same_name_do_not_replace_each_others_sidecar(tmp_path, capsys):
    code, _, _ = run(
        capsys, "world", "--seed", "3", "--detail", "low", "--quiet", "--out", str(tmp_path / "w.blend")
    )
    assert code == 0
    before = (tmp_path / "w.json").read_bytes()
    code, _, err = run(
        capsys,
        "scan",
        "--world",
        str(tmp_path / "w.blend"),
        "--pose",
        "0",
        "0",
        "0",
        "--out",
        str(tmp_path / "w.ply"),
    )
    assert code == 2 and "describes another kind of output" in err
    assert (tmp_path / "w.json").read_bytes() == before and not (tmp_path / "w.ply").exists()


def test_quiet_scan_and_extract_of_a_blend_print_only_the_files_written(tmp_path):
    """Blender prints "Read blend: ..." on file descriptor 1 when the wheel opens a .blend."""
    from tests.helpers.scene_helpers import WILDSCAN

    def wildscan(*argv):
        done = subprocess.run([WILDSCAN, *argv], cwd=tmp_path, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        return done.stdout.splitlines()

    wildscan("world", "--seed", "3", "--detail", "low", "--quiet", "--out", "w.blend")
    scan = wildscan(
        "scan", "--world", "w.blend", "--pose", "0", "0", "0", "--rh", "6", "--quiet", "--out", "s.ply"
    )
    assert [line.split(" (")[0] for line in scan] == [
        f"wrote {tmp_path / 's.ply'}",
        f"wrote {tmp_path / 's.json'}",
    ]
    assert wildscan("extract", "--world", "w.blend", "--quiet", "--out", "g.npz") == [
        f"wrote {tmp_path / 'g.npz'}"
    ]


@pytest.mark.parametrize(
    "value, message",
    [
        ("１.５", "expected a number (digits 0-9, a point for decimals), got '１.５'"),  # full-width digits
        ("²", "expected a number (digits 0-9, a point for decimals), got '²'"),
        ("1_0", "expected a number (digits 0-9, a point for decimals), got '1_0'"),
        ("1,5", "expected a number with a decimal point, got '1,5' (write 1.5)"),
        ("-1,5", "expected a number with a decimal point, got '-1,5' (write -1.5)"),  # not an option
    ],
)
def test_numbers_are_ascii_decimals_and_a_comma_is_told_to_be_a_point(tmp_path, capsys, value, message):
    for argv in (["--pose", value, "0", "0"], ["--pose", "0", "0", "0", "--max-range", value]):
        with pytest.raises(SystemExit) as exited:  # argparse's own exit, in one line
            main(["scan", *PAPER, "--seed", "1", *argv, "--out", str(tmp_path / "s.ply")])
        err = capsys.readouterr().err
        assert exited.value.code == 2 and err.count("\n") == 1 and message in err, err
    assert list(tmp_path.iterdir()) == []


def test_numbers_as_people_type_them_still_parse(capsys):
    from wildscan.cli import build_parser

    args = build_parser().parse_args(
        ["scan", *PAPER, "--seed", "1", "--pose", "-1e3", ".5", "-.5", "--out", "s.ply"]
    )
    assert args.pose == [-1000.0, 0.5, -0.5]
