"""The benchmark's chart: time per scan against error, per backend and detail level."""

from __future__ import annotations

from pathlib import Path


def draw_chart(
    rows: list[dict], path: Path, reference: str = "blender", agreement_target: float = 0.9999
) -> Path:
    """Time per full scan (log x) against error (log y), one point per backend (marker) and
    detail level (colour): left, the share of rays disagreeing with scene.ray_cast; right,
    the terrain RMS height error against the analytic heightfield. `reference` names the
    backend the others are compared with (scene.ray_cast); `agreement_target` is drawn."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D

    summary = [r for r in rows if r["section"] == "detail"]
    floor = 1e-6
    fig = Figure(figsize=(13, 5.6), dpi=110)
    FigureCanvasAgg(fig)
    left, right = fig.subplots(1, 2)
    markers = {"embree": "o", "bvh": "s", reference: "^"}
    details = [d for d in ("low", "default", "high") if any(r["detail"] == d for r in summary)]
    colours = dict(zip(("low", "default", "high"), ("tab:green", "tab:blue", "tab:purple")))
    for r in summary:
        name = "ray_cast" if r["backend"] == reference else r["backend"]
        label = f"{name} {r['detail']}" + (" ~" if r["estimated"] else "")
        style = dict(
            marker=markers.get(r["backend"], "D"), color=colours.get(r["detail"], "k"), s=55, zorder=3
        )
        x = r["scan_s"]
        y_left = floor if r["backend"] == reference else max(1.0 - r["range_agreement"], floor)
        # the first fast backend is labelled on its left, the others on their right
        before = r["backend"] == "embree"
        offset = (-7 if before else 7, -12 + 8 * details.index(r["detail"]))
        for ax, y in ((left, y_left), (right, r["terrain_rms_m"])):
            ax.scatter([x], [y], **style)
            ax.annotate(
                label,
                (x, y),
                textcoords="offset points",
                xytext=offset,
                fontsize=7,
                ha="right" if before else "left",
            )
    worst = max([1.0 - r["range_agreement"] for r in summary if r["backend"] != reference] + [floor])
    left.set_ylim(floor / 3, max(worst * 5, 1e-3))
    left.axhline(floor, color="0.6", lw=0.8, ls="--")
    left.axhline(1.0 - agreement_target, color="tab:red", lw=0.8, ls=":")
    left.text(
        0.02,
        1.0 - agreement_target,
        " target: at most 1e-4 (99.99% agreement)",
        fontsize=7,
        color="tab:red",
        va="bottom",
        transform=left.get_yaxis_transform(),
    )
    left.text(
        0.98,
        0.02,
        "no disagreement: plotted at 1e-6 (dashed); scene.ray_cast is the reference",
        fontsize=7,
        color="0.35",
        ha="right",
        va="bottom",
        transform=left.transAxes,
    )
    left.set_ylabel("share of rays whose label or range (> 1e-4 m) differs from scene.ray_cast")
    right.set_ylabel("terrain RMS height error vs analytic heightfield (m)")
    times = [r["scan_s"] for r in summary] or [1.0]
    for ax, title in (
        (left, "agreement with scene.ray_cast"),
        (right, "terrain height error by detail level"),
    ):
        ax.set_xscale("log")
        ax.set_xlim(min(times) / 8, max(times) * 8)  # room for the labels either side
        ax.set_yscale("log")
        ax.set_xlabel("time per full r_h = 1 deg scan, placement to PLY written (s)")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.25)
    handles = [
        Line2D([], [], ls="", marker=m, color="0.3", label=f"{b} (scene.ray_cast)" if b == reference else b)
        for b, m in markers.items()
        if any(r["backend"] == b for r in summary)
    ]
    handles += [Line2D([], [], ls="", marker="o", color=colours[d], label=f"{d} detail") for d in details]
    right.legend(
        handles=handles, fontsize=7, loc="center", bbox_to_anchor=(0.55, 0.68)
    )  # clear of the points
    fig.suptitle(
        "wildscan bench: time against error per backend and detail level "
        "(default world, medians over the poses; ~ = scene.ray_cast extrapolated)",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(str(path), format="png")
    return path
