"""The benchmark's speed and accuracy goals, each met or not, with the figures that decide it."""

from __future__ import annotations

from .config import (
    AGREEMENT_TARGET,
    ANALYTIC_TARGET_M,
    FINE_RH,
    FINE_SCAN_TARGET_S,
    FLAT_TARGET,
    REFERENCE,
    SPEEDUP_TARGET,
)
from .report import Report, percent

# =============================================================================================
# targets


def targets(report: "Report", cfg) -> list[tuple[str, bool | None, str]]:
    """(goal, met (None: not measured in this run), figures) for each goal."""
    out = []
    default = cfg.fast_backends[0]
    head = report.headline
    if head is not None:
        runs = head["runs"]
        ref, mine = runs[REFERENCE][0], runs[default][0]
        agree, e2e = runs[default][2], runs[default][3]
        speed = ref.total / mine.total
        out.append(
            (
                f"full r_h = 1 deg scan with '{default}', placement to PLY, >= {SPEEDUP_TARGET:g}x faster "
                "than scene.ray_cast (same world and pose)",
                speed >= SPEEDUP_TARGET,
                f"{mine.total:.3f} s vs {ref.total:.1f} s = {speed:,.0f}x (default world, {head['detail']} "
                f"detail, {head['zone']} pose, measured)",
            )
        )
        labels, ranges = agree.labels_same / agree.rays, agree.ranges_ok / agree.rays
        worst = min(labels, ranges, e2e["e2e_label_agreement"], e2e["e2e_range_agreement"])
        out.append(
            (
                f">= {100 * AGREEMENT_TARGET:g}% identical labels, ranges within 1e-4 m (noise off), "
                "that scan",
                worst >= AGREEMENT_TARGET,
                f"same rays: labels {100 * labels:.4f}%, ranges {100 * ranges:.4f}% of {agree.rays:,} beams, "
                f"max |dr| {agree.max_range_diff_m:.1e} m, {agree.disagreements} disagreements of which "
                f"{agree.reference_wrong} scene.ray_cast's errors and {agree.backend_wrong} {default}'s by "
                f"exact brute force; as written (own placements, {e2e['placement_diff_m']:.1e} m apart): "
                f"labels {100 * e2e['e2e_label_agreement']:.4f}%, "
                f"ranges {100 * e2e['e2e_range_agreement']:.4f}%",
            )
        )
    else:
        out.append(
            (
                f"full r_h = 1 deg scan >= {SPEEDUP_TARGET:g}x faster than scene.ray_cast",
                None,
                "not measured in --quick (needs one full scene.ray_cast scan of the default world)",
            )
        )
    if report.test_world:
        rows = {r["backend"]: r for r in report.test_world}
        t = rows[default]
        out.append(
            (
                "(test world, for the record) same scan and comparison",
                None,
                f"{t['scan_s']:.3f} s vs {rows[REFERENCE]['scan_s']:.2f} s = "
                f"{t['speedup_vs_ray_cast']:,.0f}x; labels {percent(t['label_agreement'])}, "
                f"ranges {percent(t['range_agreement'])}",
            )
        )
    fine = [r for r in report.beam_rows if r["backend"] == default and r["rh_deg"] == FINE_RH]
    if fine:
        f = fine[0]
        prep = f["extract_s"] + f["crop_s"] + f["build_s"]
        out.append(
            (
                f"r_h = {FINE_RH:g} deg scan ({f['beams']:,} beams), placement to PLY written, "
                f"< {FINE_SCAN_TARGET_S:g} s once the scene is extracted",
                f["scan_s"] < FINE_SCAN_TARGET_S,
                f"{f['scan_s']:.3f} s (median of {f['runs']}); apart: whole-world extraction "
                f"{f['extract_s']:.3f} s + crop {f['crop_s']:.3f} s + {default} build "
                f"{f['build_s']:.3f} s = {prep:.3f} s",
            )
        )
    if len(report.object_rows) >= 2:
        mine = [r for r in report.object_rows if r["backend"] == default]
        refs = [r for r in report.object_rows if r["backend"] == REFERENCE]
        growth = mine[-1]["scan_s"] / mine[0]["scan_s"]
        ref_growth = refs[-1]["us_per_ray"] / refs[0]["us_per_ray"]
        out.append(
            (
                f"scan time flat in the number of objects (here: at most {FLAT_TARGET:g}x for "
                f"{mine[-1]['objects'] / mine[0]['objects']:.0f}x the objects)",
                growth <= FLAT_TARGET,
                f"'{default}' {mine[0]['scan_s']:.3f} -> {mine[-1]['scan_s']:.3f} s ({growth:.2f}x) from "
                f"{mine[0]['objects']:,} to {mine[-1]['objects']:,} objects (and {mine[0]['triangles']:,} -> "
                f"{mine[-1]['triangles']:,} triangles); scene.ray_cast's time a ray {ref_growth:.1f}x",
            )
        )
    if report.analytic:
        worst = max(r["analytic_max_m"] for r in report.analytic)
        wrong = sum(r["analytic_wrong"] for r in report.analytic)
        out.append(
            (
                f"range error against the analytic primitives <= {ANALYTIC_TARGET_M:g} m for every backend",
                worst <= ANALYTIC_TARGET_M and wrong == 0,
                ", ".join(f"{r['backend']} {r['analytic_max_m']:.1e} m" for r in report.analytic)
                + f"; {wrong} rays labelled wrong",
            )
        )
    return out


def format_targets(items) -> str:
    body = [
        [("met" if ok else "NOT MET") if ok is not None else "-", goal, figures]
        for goal, ok, figures in items
    ]
    return "\n== Targets\n" + "\n".join(f"[{m:>7}] {g}\n          {f}" for m, g, f in body)
