"""The dataset card's figures (matplotlib, imported when drawing): class mix beside
RELLIS-3D, points against range, scans per zone and split."""

from __future__ import annotations

from pathlib import Path

from ..core.classes import LABELS
from ..core.io.files import atomic_outputs

_METADATA = {"Software": None}  # no version stamp: the same data gives the same PNG


def _figure(figsize, columns: int = 1):
    """A figure drawn off-screen (no pyplot state) and its axes."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, columns)
    return fig, axes


def _save(fig, path: Path) -> None:
    with atomic_outputs(path) as (tmp,):
        fig.savefig(tmp, dpi=110, format="png", metadata=_METADATA)


def render_card_figures(
    folder: Path, data: dict, shares: dict[str, tuple[float, float]]
) -> list[tuple[str, str]]:
    """Write the PNGs into `folder`; return (title, path relative to the card) of each."""
    folder.mkdir(parents=True, exist_ok=True)
    t = data["totals"]
    out = []

    fig, (ax1, ax2) = _figure((11, 4), 2)
    shown = [c for c in LABELS if not c.optional or c.name in t["class_points"]]  # the card's classes
    names = [c.name for c in shown]
    total = max(1, t["points"])
    colours = [tuple(v / 255 for v in c.color) for c in shown]
    ax1.barh(names, [100 * t["class_points"][n] / total for n in names], color=colours, edgecolor="0.3")
    ax1.invert_yaxis()
    ax1.set_xlabel("share of points (%)")
    ax1.set_title("class histogram")
    for k, n in enumerate(names):
        ax1.text(0.5, k, f"{t['class_scans'][n]:,} scans", va="center", fontsize=7)
    cats = list(shares)
    x = range(len(cats))
    ax2.bar([i - 0.2 for i in x], [100 * shares[c][0] for c in cats], 0.4, label="RELLIS-3D")
    ax2.bar([i + 0.2 for i in x], [100 * shares[c][1] for c in cats], 0.4, label="this dataset")
    ax2.set_xticks(list(x), cats)
    ax2.set_ylabel("share of labeled points (%)")
    ax2.set_title("beside RELLIS-3D")
    ax2.legend()
    fig.tight_layout()
    _save(fig, folder / "classes.png")
    out.append(("class histogram and RELLIS-3D", f"{folder.name}/classes.png"))

    fig, ax = _figure((6, 3.5))
    h = t["range_histogram"]
    edges = [k * h["bin_m"] for k in range(len(h["counts"]))]
    ax.bar(edges, h["counts"], width=h["bin_m"], align="edge", color="0.4")
    ax.set_xlabel("range (m)")
    ax.set_ylabel("points")
    ax.set_title("points against range")
    fig.tight_layout()
    _save(fig, folder / "range.png")
    out.append(("points against range", f"{folder.name}/range.png"))

    fig, ax = _figure((6, 3.5))
    zones = list(t["scans_by_zone_and_split"])
    bottom = [0] * len(zones)
    for split in ("train", "val", "test"):
        values = [t["scans_by_zone_and_split"][z][split] for z in zones]
        ax.bar(zones, values, bottom=bottom, label=split)
        bottom = [a + b for a, b in zip(bottom, values, strict=True)]
    ax.set_ylabel("scans")
    ax.set_title("scans per zone and split")
    ax.legend()
    fig.tight_layout()
    _save(fig, folder / "zones.png")
    out.append(("scans per zone and split", f"{folder.name}/zones.png"))
    return out
