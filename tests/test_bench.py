"""`wildscan bench --quick`: the files it writes, the accuracy it measures, clean-up, user errors.

No timing is asserted here (speed goals are reported by the benchmark itself); what is
asserted are the accuracy figures and the shape of the CSV and the chart.
"""

from __future__ import annotations

import contextlib
import csv
import io
import struct

import bpy
import numpy as np
import pytest

from wildscan.bench import config, primitives, report
from wildscan.core.errors import UserError

pytestmark = pytest.mark.slow  # tens of seconds or more: `make test` runs it, `make test-fast` not

FAST = ("embree", "bvh")
ALL = ("blender",) + FAST


def run_bench(argv: list[str]) -> int:
    """`wildscan bench ARGS`, in this process."""
    from wildscan import cli

    return cli.main(["bench", *argv])


def _bench_state():
    return (len(bpy.data.scenes), len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.collections))


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    before = _bench_state()
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = run_bench(["--quick", "--out", str(out)])
    with (out / "bench.csv").open() as f:
        reader = csv.DictReader(f)
        header, rows = reader.fieldnames, list(reader)
    return {
        "code": code,
        "out": out,
        "header": header,
        "rows": rows,
        "text": printed.getvalue(),
        "before": before,
        "after": _bench_state(),
    }


def rows_of(quick, section):
    return [r for r in quick["rows"] if r["section"] == section]


def test_quick_bench_writes_the_csv_chart_and_tables_and_nothing_else(quick):
    assert quick["code"] == 0
    assert sorted(p.name for p in quick["out"].iterdir()) == ["bench.csv", "bench.png", "scaling.md"]
    assert tuple(quick["header"]) == report.CSV_COLUMNS
    sections = {}
    for r in quick["rows"]:
        sections.setdefault(r["section"], []).append(r["backend"])
    assert sorted(sections["phases"]) == sorted(ALL)  # the test world, every backend in full
    assert sorted(sections["analytic"]) == sorted(ALL)
    assert sorted(sections["detail"]) == sorted(ALL)  # --quick: the low level only
    assert sorted(sections["pose"]) == sorted(ALL * config.QUICK_ZONES)
    assert sorted(sections["beams"]) == sorted(ALL * len(config.QUICK_BEAM_STEPS))
    assert sorted(sections["objects"]) == sorted(ALL * len(config.QUICK_OBJECT_COUNTS))
    for r in quick["rows"]:
        if r["section"] in ("phases", "pose", "detail", "beams", "objects"):
            assert float(r["scan_s"]) > 0 and float(r["speedup_vs_ray_cast"]) > 0, r
    # scene.ray_cast is timed whole on the test world, extrapolated (and said so) elsewhere
    test_world = {r["backend"]: r for r in rows_of(quick, "phases")}
    assert test_world["blender"]["estimated"] == "0" and int(test_world["blender"]["beams"]) == 194_400
    assert {r["estimated"] for r in rows_of(quick, "detail") if r["backend"] == "blender"} == {"1"}
    assert [float(r["rh_deg"]) for r in rows_of(quick, "beams") if r["backend"] == "embree"] == list(
        config.QUICK_BEAM_STEPS
    )

    png = (quick["out"] / "bench.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = struct.unpack(">II", png[16:24])
    assert width > 1000 and height > 500 and len(png) > 20_000

    md = (quick["out"] / "scaling.md").read_text()
    assert md.count("| r_h (deg) |") == 1 and "| objects |" in md and "| detail |" in md


def test_phases_of_the_full_test_world_scans_add_up(quick):
    for r in rows_of(quick, "phases"):
        parts = sum(float(r[f"{p}_s"]) for p in config.PHASES)
        assert parts == pytest.approx(float(r["scan_s"]), rel=0.02, abs=2e-3), r["backend"]
    text = quick["text"]
    for title in config.PHASE_TITLES.values():
        assert title in text
    assert "scene.ray_cast scan:" in text and "dominated by ray casting" in text


def test_every_backend_agrees_with_scene_ray_cast(quick):
    for section in ("phases", "detail", "objects"):
        for r in rows_of(quick, section):
            if r["backend"] == "blender":
                continue
            assert int(r["rays_compared"]) >= config.QUICK_REFERENCE_RAYS, (section, r["backend"])
            assert float(r["label_agreement"]) >= 0.9999, (section, r["backend"], r["label_agreement"])
            assert float(r["range_agreement"]) >= 0.9999, (section, r["backend"], r["range_agreement"])
            assert int(r["backend_wrong"]) == 0, (section, r["backend"])
    full = [r for r in rows_of(quick, "phases") if r["backend"] != "blender"]
    assert all(int(r["rays_compared"]) == 194_400 for r in full)
    for r in full:  # the scans as written, each placed by its own lasers
        assert float(r["e2e_label_agreement"]) >= 0.9999 and float(r["e2e_range_agreement"]) >= 0.9999
        assert float(r["placement_diff_m"]) < 1e-4


def test_range_error_against_the_analytic_primitives_is_within_1e_4_m(quick):
    for r in rows_of(quick, "analytic"):
        assert int(r["analytic_rays"]) > 20_000, r["backend"]  # plenty of hits on the four shapes
        assert float(r["analytic_max_m"]) <= 1e-4, (r["backend"], r["analytic_max_m"])
        assert float(r["analytic_rms_m"]) <= float(r["analytic_max_m"])
        assert int(r["analytic_wrong"]) == 0, r["backend"]
        assert int(r["analytic_excluded"]) < 0.001 * int(r["beams"])


def test_terrain_error_is_measured_against_the_field_and_the_mesh(quick):
    from wildscan.core.world import DETAILS

    for r in rows_of(quick, "detail"):
        tolerance = DETAILS[r["detail"]].terrain_tolerance
        assert int(r["terrain_rays"]) >= 100
        # the level's modelling error shows against the analytic field ...
        assert 0 < float(r["terrain_rms_m"]) <= tolerance, r
        assert float(r["terrain_max_m"]) > 10 * float(r["terrain_mesh_max_m"]), r
        # ... while every backend hits the triangulated terrain mesh itself within 1e-4 m
        assert float(r["terrain_mesh_max_m"]) <= 1e-4, (r["backend"], r["terrain_mesh_max_m"])


def test_the_bench_leaves_the_users_scenes_as_they_were(quick):
    assert quick["after"] == quick["before"]
    assert not any(c.name.startswith(config.BENCH_COLLECTION) for c in bpy.data.collections)


def test_targets_are_reported(quick):
    text = quick["text"]
    assert "== Targets\n" in text
    assert "range error against the analytic primitives" in text and "[    met]" in text
    assert "not measured in --quick" in text  # the headline needs a full scene.ray_cast scan


# -- the analytic truth itself ------------------------------------------------------------


def test_closed_form_truth_of_the_primitives():
    solids = {s.name: s for s in primitives.primitive_solids()}
    sphere, prism, box = solids["bench sphere"], solids["bench prism"], solids["bench box"]
    # straight down onto the sphere's top pole and the prism's top cap
    for solid, top in ((sphere, sphere.vertices[0]), (prism, prism.vertices[48:].mean(axis=0))):
        o = (top + [0.0, 0.0, 5.0])[None]
        t = solid.first_hit(o, np.array([[0.0, 0.0, -1.0]]))
        assert t[0] == pytest.approx(5.0, abs=1e-12)
    # through the box's centre along one of its axes: half its size along that axis
    axis = (box.vertices[1] - box.vertices[0]) / np.linalg.norm(box.vertices[1] - box.vertices[0])
    centre = box.vertices.mean(axis=0)
    t = box.first_hit((centre - 10 * axis)[None], axis[None])
    assert t[0] == pytest.approx(10.0 - 1.0, abs=1e-12)
    # rays along -x past the prism's outermost vertex in +y (the 48-gon's vertex 12, at 90 deg):
    # within 1e-4 m of that silhouette they are left out as unclear, farther in they count
    tip = prism.vertices[12] + [5.0, 0.0, 0.5]
    origins = tip + np.array([[0.0, 1e-5, 0.0], [0.0, -1e-5, 0.0], [0.0, -0.01, 0.0], [0.0, 0.01, 0.0]])
    truth = primitives.analytic_truth([prism], origins, np.tile([-1.0, 0.0, 0.0], (4, 1)), 25.0)
    assert truth["clear"].tolist() == [False, False, True, True]
    assert np.isfinite(truth["distance"]).tolist() == [False, True, True, False]


# -- user mistakes -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--details", "low,ultra"], "--details must list levels from low, default, high"),
        (["--backends", "optix"], "--backends must list names from auto, embree, bvh, blender"),
        (["--backends", "blender"], "at least one fast backend"),
        (["--runs", "0"], "--runs must be a whole number from 1 to 50"),
        (["--reference-rays", "ten"], "--reference-rays must be a whole number"),
        (["--seed", "-3"], "--seed must be a whole number from 0 to 2147483647"),
    ],
)
def test_bad_options_are_refused_in_one_line(argv, message, tmp_path, capsys):
    assert run_bench(argv + ["--out", str(tmp_path / "b")]) == 2
    captured = capsys.readouterr()
    lines = [ln for ln in (captured.out + captured.err).splitlines() if "error" in ln]
    assert len(lines) == 1 and message in lines[0]
    assert not (tmp_path / "b" / "bench.csv").exists()


def test_out_must_be_a_directory(tmp_path):
    target = tmp_path / "file.txt"
    target.write_text("x")
    with pytest.raises(UserError, match="it is a file") as info:
        config.make_config(out=str(target))
    assert info.value.setting == "out"


# -- suites ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "argv, expected",
    [
        (["bench", "--suite", "world"], (0, ["low", "default", "high"])),
        (["bench", "--suite", "world", "--seed", "3", "--details", "low,high"], (3, ["low", "high"])),
        (["bench", "--suite", "world", "--quick"], (0, ["low"])),
        (["bench-world"], (0, ["low", "default", "high"])),
        (["bench-world", "--seed", "3", "--detail", "low", "--detail", "high"], (3, ["low", "high"])),
    ],
)
def test_bench_world_is_the_world_suite_of_bench(argv, expected, monkeypatch):
    from wildscan import cli
    from wildscan.bench import world_build

    calls = []
    monkeypatch.setattr(world_build, "bench_world", lambda seed, details: calls.append((seed, details)))
    assert cli.main(argv) == 0
    assert calls == [expected]


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["bench", "--suite", "world", "--backends", "embree"],
            "--backends applies to --suite backends only",
        ),
        (["bench", "--suite", "world", "--out", "x"], "--out applies to --suite backends only"),
        (["bench", "--suite", "world", "--details", "low,ultra"], "--details must list levels from low"),
        (["bench", "--suite", "fast"], "argument --suite: invalid choice: 'fast'"),
        (["bench-world", "--detail", "ultra"], "--detail must be one of low, default, high"),
        (["bench-world", "--seed", "-1"], "--seed must be a whole number from 0 to 2147483647"),
    ],
)
def test_bad_suite_options_are_refused_in_one_line(argv, message, capsys):
    from wildscan import cli

    try:
        code = cli.main(argv)
    except SystemExit as e:  # argparse's own errors exit from inside parse_args
        code = e.code
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
