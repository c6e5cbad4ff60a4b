"""The tables of the README and the docs that come from the code or the golden files, so no
figure in them is copied by hand. Each lives between two markers in its page:

    <!-- begin generated: NAME (python tools/docs_tables.py --write) -->
    ...
    <!-- end generated: NAME -->

    python tools/docs_tables.py            print every table
    python tools/docs_tables.py --write    rewrite them in their pages

tests/test_docs.py fails when a page's table differs from what this renders.

- `demo`: what `make demo` prints for each zone (README.md). The points come from
  tests/golden/scans.json, whose seed-1 scans are the demo's (the first valid pose of each
  zone of the default world, r_h = 1 deg, leveled frame, embree) and which
  tests/test_golden.py holds every change of the scan path to.
- `label-schemes`, `asprs`: the label-scheme mapping and the LAS classification codes
  (docs/formats.md), from `mapping_table_rows()` and `asprs_table_rows()`.
- `sensors`: the device presets as `wildscan sensors` lists them (docs/sensors.md).
- `detection`: each preset's [detection] pairs and return modes, from its device file
  (docs/sensors.md).
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
GOLDEN_SCANS = REPO / "tests" / "golden" / "scans.json"
DEMO_SEED = 1  # `make demo`: wildscan demo --seed 1


def begin_marker(name: str) -> str:
    return f"<!-- begin generated: {name} (python tools/docs_tables.py --write) -->"


def end_marker(name: str) -> str:
    return f"<!-- end generated: {name} -->"


def markdown_table(headers: list[str], rows: list[list[str]], right: set[int] = frozenset()) -> str:
    rule = ["---:" if i in right else "---" for i in range(len(headers))]
    lines = [headers, rule, *rows]
    return "\n".join("| " + " | ".join(str(c) for c in line) + " |" for line in lines)


def demo_table() -> str:
    """Zone, pose, points and the paper's point count, as `wildscan demo --seed 1` prints
    them, from the golden scans of seed 1 (porous vegetation, the paper sensor model)."""
    from wildscan.app.demo import PAPER_POINTS, pose_label
    from wildscan.core.placement import Pose
    from wildscan.core.world.plan import ZONES

    golden = json.loads(GOLDEN_SCANS.read_text())
    rows = []
    for zone in ZONES:
        scan = golden[f"seed{DEMO_SEED}/{zone}"]
        x, y, yaw, z_start = scan["pose"]
        paper = f"{PAPER_POINTS[zone]:,}" if zone in PAPER_POINTS else "-"
        rows.append([zone, pose_label(Pose(x, y, yaw), z_start), f"{scan['points']:,}", paper])
    return markdown_table(["zone", "pose (x, y, yaw)", "points", "paper"], rows, right={2, 3})


def label_scheme_table() -> str:
    from wildscan.core.label_schemes import mapping_table_rows

    headers = ["WildScan", "SemanticKITTI", "RELLIS-3D", "GOOSE"]
    rows = [list(r) for r in mapping_table_rows()]
    if any(len(r) != len(headers) for r in rows):
        raise SystemExit(f"mapping_table_rows() has {len(rows[0])} columns; name them in {__file__}")
    return markdown_table(headers, rows)


def asprs_table() -> str:
    from wildscan.core.io.las import asprs_table_rows

    rows = [[str(code), name, held] for code, name, held in asprs_table_rows()]
    return markdown_table(["ASPRS code", "name", "WildScan classes"], rows, right={0})


def sensors_table() -> str:
    """Every device preset as `wildscan sensors` lists it (docs/sensors.md)."""
    from wildscan.cli.sensors import HEADERS, rows

    return markdown_table(list(HEADERS), [list(r) for r in rows()], right={2})


def detection_table() -> str:
    """Each preset's [detection] pairs (and the 10 % / 80 % ranges its limit gives) and return
    modes, read from its device file (docs/sensors.md)."""
    from wildscan.core.sensors import device_named, preset_names
    from wildscan.core.sensors.detection import REFERENCE_REFLECTANCES

    rows = []
    for name in preset_names():
        d = device_named(name)
        table, optics = d.detection, d.optics
        if table is None:
            pairs = targets = "none"
        else:
            pairs = "; ".join(
                f"{100 * rho:g} %: {r:g} m{' (estimate)' if est else ''}"
                for rho, r, est in zip(table.reflectance, table.range_m, table.estimate, strict=True)
            )
            targets = " / ".join(f"{table.farthest_range(rho):.1f} m" for rho in REFERENCE_REFLECTANCES)
        dual = f" ({optics.dual})" if optics.dual else ""
        modes = ", ".join(m + dual if m == "dual" else m for m in optics.returns)
        rows.append([name, pairs, targets, f"{modes}; default {optics.return_mode}"])
    headers = ["preset", "[detection] pairs", "10 % / 80 % target to", "return modes"]
    return markdown_table(headers, rows)


TABLES: dict[str, tuple[Path, Callable[[], str]]] = {
    "demo": (REPO / "README.md", demo_table),
    "label-schemes": (REPO / "docs" / "formats.md", label_scheme_table),
    "asprs": (REPO / "docs" / "formats.md", asprs_table),
    "sensors": (REPO / "docs" / "sensors.md", sensors_table),
    "detection": (REPO / "docs" / "sensors.md", detection_table),
}


def section_span(page: str, name: str) -> tuple[int, int]:
    """(start, end) of the text between the table's markers, or ValueError naming them."""
    begin, end = begin_marker(name), end_marker(name)
    start = page.find(begin)
    stop = page.find(end, start + 1)
    if start < 0 or stop < 0:
        raise ValueError(f"the page has no {begin!r} ... {end!r} pair")
    return start + len(begin), stop


def current_table(name: str) -> str:
    """The table as its page holds it now."""
    path, _ = TABLES[name]
    page = path.read_text(encoding="utf-8")
    start, stop = section_span(page, name)
    return page[start:stop].strip("\n")


def write_table(name: str) -> bool:
    """Rewrite the table in its page; True when it changed."""
    path, render = TABLES[name]
    page = path.read_text(encoding="utf-8")
    start, stop = section_span(page, name)
    new = page[:start] + "\n" + render() + "\n" + page[stop:]
    if new != page:
        path.write_text(new, encoding="utf-8")
    return new != page


def main(argv: list[str]) -> int:
    if argv == ["--write"]:
        for name, (path, _) in TABLES.items():
            try:
                changed = write_table(name)
            except ValueError as e:
                print(f"{path.relative_to(REPO)}: {e}", file=sys.stderr)
                return 1
            print(f"{'rewrote' if changed else 'unchanged'} {name} in {path.relative_to(REPO)}")
        return 0
    if argv:
        print(__doc__, file=sys.stderr)
        return 2
    for name, (path, render) in TABLES.items():
        print(f"{begin_marker(name)}   ({path.relative_to(REPO)})\n{render()}\n{end_marker(name)}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
