"""The README and the docs site hold no figure copied by hand: the demo table comes from the
golden scans, the label-scheme and LAS tables from the code, the benchmark page from
`wildscan bench --markdown`; the README stays short and the site builds strictly."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.helpers.scene_helpers import REPO

sys.path.insert(0, str(REPO / "tools"))
try:
    import docs_tables
finally:
    sys.path.pop(0)

README = REPO / "README.md"
MAX_README_LINES = 250


def table_cells(table: str) -> list[tuple[str, ...]]:
    """The body rows of a markdown table, cell by cell (header and rule dropped)."""
    rows = [tuple(c.strip() for c in line.strip().strip("|").split("|")) for line in table.splitlines()]
    return rows[2:]


# ---------------------------------------------------------------------------------------
# the README


def test_readme_is_short():
    assert len(README.read_text(encoding="utf-8").splitlines()) <= MAX_README_LINES


def test_readme_keeps_its_two_commands():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert any(line.startswith("make demo ") for line in lines)
    assert any(line.startswith("make test ") for line in lines)


def test_readme_demo_table_is_what_the_golden_demo_scans_give():
    assert docs_tables.current_table("demo") == docs_tables.demo_table(), (
        "README.md's demo table differs from tests/golden/scans.json: run python tools/docs_tables.py --write"
    )


def test_demo_table_rows_are_the_golden_seed_1_scans_zone_by_zone():
    """Read back from the README, independently of the renderer: each zone's points and pose
    are those of the golden scan of that zone."""
    from wildscan.core.world.plan import ZONES

    golden = docs_tables.json.loads(docs_tables.GOLDEN_SCANS.read_text())
    rows = table_cells(docs_tables.current_table("demo"))
    assert [r[0] for r in rows] == list(ZONES)
    for zone, pose, points, _paper in rows:
        scan = golden[f"seed1/{zone}"]
        assert int(points.replace(",", "")) == scan["points"], zone
        x, y = (float(v) for v in re.match(r"\(([-\d.]+), ([-\d.]+),", pose).groups())
        assert abs(x - scan["pose"][0]) <= 0.05 and abs(y - scan["pose"][1]) <= 0.05, zone
        assert ("z_start" in pose) == (scan["pose"][3] is not None), zone


# ---------------------------------------------------------------------------------------
# docs/formats.md


def test_label_scheme_table_is_mapping_table_rows():
    from wildscan.core.label_schemes import mapping_table_rows

    assert table_cells(docs_tables.current_table("label-schemes")) == [tuple(r) for r in mapping_table_rows()]


def test_asprs_table_is_asprs_table_rows():
    from wildscan.core.io.las import asprs_table_rows

    expected = [(str(code), name, held) for code, name, held in asprs_table_rows()]
    assert table_cells(docs_tables.current_table("asprs")) == expected


def test_every_generated_table_is_current():
    tables = docs_tables.TABLES.items()
    stale = [name for name, (_, render) in tables if docs_tables.current_table(name) != render()]
    assert stale == [], "run python tools/docs_tables.py --write"


# ---------------------------------------------------------------------------------------
# docs/benchmarks.md and wildscan bench --markdown


def test_every_benchmark_section_was_written_by_the_bench():
    from wildscan.bench.markdown import begin_marker, end_marker
    from wildscan.cli.bench import SUITES

    page = (REPO / "docs" / "benchmarks.md").read_text(encoding="utf-8")
    for suite in SUITES:
        start, stop = page.index(begin_marker(suite)), page.index(end_marker(suite))
        section = page[start:stop]
        command = r"^- Command: `wildscan bench [^`]*--markdown docs/benchmarks.md`$"
        assert re.search(command, section, re.M), suite
        assert f"--suite {suite}" in section.split("\n")[1] or suite == "backends", suite
        assert "- Date: " in section and "- Machine: " in section and "- WildScan version: " in section


def test_replace_section_keeps_the_rest_of_the_page():
    from wildscan.bench.markdown import begin_marker, end_marker, replace_section

    old = f"intro\n\n{begin_marker('far')}\nold\n{end_marker('far')}\n\noutro\n"
    new = f"{begin_marker('far')}\nnew\n{end_marker('far')}"
    assert replace_section(old, "far", new) == f"intro\n\n{new}\n\noutro\n"
    assert replace_section("intro\n", "far", new) == f"intro\n\n{new}\n"
    assert replace_section("", "far", new) == f"{new}\n"


@pytest.mark.parametrize(
    "name,message", [("bench.txt", "must end in .md"), ("missing/bench.md", "does not exist")]
)
def test_markdown_path_mistakes_are_refused_before_any_work(tmp_path, capsys, name, message):
    from wildscan import cli

    code = cli.main(["bench", "--suite", "far", "--markdown", str(tmp_path / name)])
    assert code == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "--markdown" in err and message in err
    assert list(tmp_path.iterdir()) == []


def test_bench_markdown_writes_the_suite_output_with_date_machine_version_and_command(
    tmp_path, monkeypatch, capsys
):
    """A small real suite (far, one offset, embree only) written into a page that already
    has text of its own: the text stays, the section carries the run's facts."""
    import wildscan
    from wildscan import cli
    from wildscan.bench import far

    monkeypatch.setattr(far, "QUICK_OFFSETS", (0.0,))
    page = tmp_path / "bench.md"
    page.write_text("# Benchmarks\n\nhand-written intro\n", encoding="utf-8")
    argv = ["bench", "--suite", "far", "--quick", "--backends", "embree", "--markdown", str(page)]
    assert cli.main(argv) == 0
    printed = capsys.readouterr().out
    text = page.read_text(encoding="utf-8")
    assert text.startswith("# Benchmarks\n\nhand-written intro\n\n<!-- begin wildscan bench --suite far")
    lines = text.splitlines()
    assert f"- Command: `wildscan bench --suite far --quick --backends embree --markdown {page}`" in lines
    assert any(re.fullmatch(r"- Date: \d{4}-\d\d-\d\d \d\d:\d\d UTC", line) for line in lines)
    (machine,) = [line for line in lines if line.startswith("- Machine: ")]
    assert machine.startswith(f"- Machine: {os.cpu_count()} cores, ")
    assert f"- WildScan version: {wildscan.__version__}" in lines
    table = "Largest error of a point clear of edges"
    assert table in printed and table in text  # the terminal still gets the output
    assert not [p for p in tmp_path.iterdir() if p.name != "bench.md"]  # no temporary left


# ---------------------------------------------------------------------------------------
# the site


def mkdocs_build(root: Path, site: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=root,
        capture_output=True,
        text=True,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=600,
    )


@pytest.fixture(scope="module")
def docs_tools():
    """Skipped only where the docs extra (mkdocs, mkdocs-material) is not installed; CI has it."""
    pytest.importorskip("mkdocs", reason="the docs extra is not installed")
    pytest.importorskip("material", reason="the docs extra is not installed")


def test_make_docs_builds_the_site_strictly(docs_tools, tmp_path):
    done = mkdocs_build(REPO, tmp_path / "site")
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "site" / "index.html").exists()
    assert (tmp_path / "site" / "benchmarks" / "index.html").exists()


def test_a_broken_link_fails_the_strict_build(docs_tools, tmp_path):
    copy = tmp_path / "repo"
    shutil.copytree(REPO / "docs", copy / "docs")
    shutil.copy(REPO / "mkdocs.yml", copy / "mkdocs.yml")
    sensors = copy / "docs" / "sensors.md"
    sensors.write_text(sensors.read_text() + "\nSee [nowhere](no-such-page.md).\n")
    done = mkdocs_build(copy, tmp_path / "site")
    assert done.returncode != 0
    assert "no-such-page.md" in done.stdout + done.stderr

    sensors.write_text(sensors.read_text().replace("(no-such-page.md)", "(formats.md#no-such-anchor)"))
    done = mkdocs_build(copy, tmp_path / "site")
    assert done.returncode != 0
    assert "no-such-anchor" in done.stdout + done.stderr


def test_the_readme_class_table_lists_every_class_with_its_id_and_reflectivity():
    from wildscan.core.classes import BY_ID

    rows = {}
    for line in README.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) == 4 and cells[0].isdigit():
            rows[int(cells[0])] = (cells[1].split(" (")[0], float(cells[2]))
    assert rows == {c.id: (c.name, c.reflectivity) for c in BY_ID.values()}
