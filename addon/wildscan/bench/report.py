"""What a run reports: the rows it collects (one CSV row each), its printed tables and the
files it writes (bench.csv, bench.png and scaling.md, all three or none)."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from .config import AGREEMENT_TARGET, PHASE_TITLES, PHASES, REFERENCE, SCAN_RH

CSV_COLUMNS = (
    "section",
    "world",
    "detail",
    "seed",
    "zone",
    "pose",
    "backend",
    "objects",
    "triangles",
    "crop_triangles",
    "rh_deg",
    "beams",
    "runs",
    "estimated",
    "scan_s",
    "placement_s",
    "beam_directions_s",
    "ray_casting_s",
    "labels_leveling_s",
    "ply_write_s",
    "us_per_ray",
    "build_world_s",
    "extract_s",
    "crop_s",
    "build_s",
    "speedup_vs_ray_cast",
    "rays_compared",
    "label_agreement",
    "range_agreement",
    "max_range_diff_m",
    "disagreements",
    "reference_wrong",
    "backend_wrong",
    "e2e_label_agreement",
    "e2e_range_agreement",
    "e2e_max_range_diff_m",
    "placement_diff_m",
    "terrain_max_m",
    "terrain_rms_m",
    "terrain_rays",
    "terrain_mesh_max_m",
    "analytic_max_m",
    "analytic_rms_m",
    "analytic_rays",
    "analytic_wrong",
    "analytic_excluded",
)


@dataclass
class Report:
    out: Callable[[str], None] = print
    rows: list[dict] = field(default_factory=list)
    test_world: list[dict] = field(default_factory=list)
    analytic: list[dict] = field(default_factory=list)
    level_rows: list[dict] = field(default_factory=list)
    beam_rows: list[dict] = field(default_factory=list)
    object_rows: list[dict] = field(default_factory=list)
    poses: list = field(default_factory=list)
    headline: dict | None = None

    def say(self, text: str) -> None:
        self.out(text)

    def add_rows(self, rows: list[dict]) -> None:
        self.rows += rows


# =============================================================================================
# formatting


def text_table(
    headers: Sequence[str], rows: Sequence[Sequence[str]], right: Sequence[bool] | None = None
) -> str:
    """A plain aligned table."""
    right = right or [i > 0 for i in range(len(headers))]
    widths = [
        max(len(str(h)), *(len(str(r[i])) for r in rows)) if rows else len(str(h))
        for i, h in enumerate(headers)
    ]

    def line(cells):
        return "  ".join(
            str(c).rjust(w) if r else str(c).ljust(w) for c, w, r in zip(cells, widths, right)
        ).rstrip()

    return "\n".join([line(headers), line(["-" * w for w in widths])] + [line(r) for r in rows])


def markdown_table(headers: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    out = [
        "| " + " | ".join(headers) + " |",
        "|" + "|".join("---:" if i else "---" for i in range(len(headers))) + "|",
    ]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def fmt_s(value, estimated: bool = False) -> str:
    """Seconds with their unit, '~' in front when extrapolated."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    mark = "~" if estimated else ""
    if value >= 100:
        return f"{mark}{value:.0f} s"
    if value >= 1:
        return f"{mark}{value:.2f} s"
    return f"{mark}{value:.3f} s" if value >= 0.01 else f"{mark}{value * 1e3:.2f} ms"


def ratio(value, estimated: bool = False) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    mark = "~" if estimated else ""
    return f"{mark}{value:,.0f}x" if value >= 10 else f"{mark}{value:.2f}x"


def percent(value) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{100 * value:.4f}%"


def metres(value) -> str:
    return "-" if value is None or (isinstance(value, float) and math.isnan(value)) else f"{value:.1e}"


def backend_title(name: str) -> str:
    return "blender (scene.ray_cast)" if name == REFERENCE else name


def format_phases(rows: list[dict], title: str, extract_s: float) -> str:
    names = [r["backend"] for r in rows]
    headers = ["phase"] + [backend_title(n) for n in names]
    body = []
    for p in PHASES:
        body.append(
            [PHASE_TITLES[p]]
            + [f"{fmt_s(r[f'{p}_s'])} ({100 * r[f'{p}_s'] / r['scan_s']:.0f}%)" for r in rows]
        )
    body.append(["total: placement to PLY"] + [fmt_s(r["scan_s"]) for r in rows])
    body.append(["x vs scene.ray_cast"] + [ratio(r["speedup_vs_ray_cast"]) for r in rows])
    body.append(["runs (median)"] + [str(r["runs"]) for r in rows])
    body.append(
        ["scene prep (apart)"]
        + [
            "none" if r["backend"] == REFERENCE else f"{fmt_s(r['crop_s'] + r['build_s'])} crop+build"
            for r in rows
        ]
    )

    def fast(fn):
        return ["reference" if r["backend"] == REFERENCE else fn(r) for r in rows]

    body.append(["same rays: labels identical"] + fast(lambda r: percent(r.get("label_agreement"))))
    body.append(["same rays: ranges within 1e-4 m"] + fast(lambda r: percent(r.get("range_agreement"))))
    body.append(["same rays: max |dr|"] + fast(lambda r: f"{metres(r.get('max_range_diff_m'))} m"))
    body.append(
        ["  wrong by brute force (ref/own)"]
        + fast(lambda r: f"{r['reference_wrong']}/{r['backend_wrong']} of {r['disagreements']}")
    )
    body.append(["own placement: labels identical"] + fast(lambda r: percent(r.get("e2e_label_agreement"))))
    body.append(["own placement: ranges within 1e-4"] + fast(lambda r: percent(r.get("e2e_range_agreement"))))
    body.append(["optical centre vs ray_cast's"] + fast(lambda r: f"{metres(r.get('placement_diff_m'))} m"))
    lines = [
        f"\nfull r_h = {SCAN_RH:g} deg scan ({rows[0]['beams']:,} beams, noise off), {title}, by phase "
        "(same rays = the backend re-casts scene.ray_cast's beams; own placement = the two scans as written, "
        "each placed by its own lasers):",
        text_table(headers, body),
    ]
    ref = next((r for r in rows if r["backend"] == REFERENCE), None)
    if ref is not None:
        top = max(PHASES, key=lambda p: ref[f"{p}_s"])
        lines.append(
            f"scene.ray_cast scan: {fmt_s(ref['scan_s'])}, dominated by {PHASE_TITLES[top]} "
            f"({100 * ref[f'{top}_s'] / ref['scan_s']:.1f}%, {ref['us_per_ray']:.1f} us a ray over "
            f"{ref['objects']:,} objects); whole-scene extraction for the fast backends "
            f"{fmt_s(extract_s)}, reported apart"
        )
    return "\n".join(lines)


# =============================================================================================
# CSV, chart, markdown (written together, all or none)


def write_bench_files(rows: list[dict], tables, out_dir: Path) -> tuple[Path, Path, Path]:
    """bench.csv, bench.png and scaling.md, all three or none."""
    from ..core.io.files import atomic_outputs
    from ..viz.charts import draw_chart

    paths = (out_dir / "bench.csv", out_dir / "bench.png", out_dir / "scaling.md")
    with atomic_outputs(*paths) as (tmp_csv, tmp_png, tmp_md):
        tmp_csv.write_text(bench_csv_text(rows))
        draw_chart(rows, tmp_png, REFERENCE, AGREEMENT_TARGET)
        tmp_md.write_text(markdown_text(tables))
    return paths


def _cell(value):
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.9g}"
    return value


def bench_csv_text(rows: list[dict]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=CSV_COLUMNS, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: _cell(row.get(k, "")) for k in CSV_COLUMNS})
    return buf.getvalue()


def markdown_text(tables) -> str:
    return "\n\n".join(f"**{title}**\n\n{markdown_table(h, b)}" for title, h, b in tables) + "\n"
