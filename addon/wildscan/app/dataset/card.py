"""The dataset card: dataset.json (spec, versions, totals, runs, the files beside the
manifest with their checksums) and CARD.md (tables, and figures when matplotlib is there),
with the class mix beside RELLIS-3D's published shares."""

from __future__ import annotations

import json
import platform
import warnings
from importlib import metadata
from pathlib import Path

from ... import __version__
from ...core.classes import BY_ID, PARTICLE
from ...core.effects.weather import weather_on
from ...core.errors import UserError
from ...core.io.files import atomic_outputs, write_durably
from ...core.label_schemes import RELLIS_POINT_COUNTS
from ...core.realism.lost_returns import add_stats
from ...core.runtime.pause import pause_here
from .classes import dataset_classes
from .intensity import intensity_lines, remission_totals
from .land_card import land_lines, land_totals
from .layout import CARD, CARD_FIGURES, DATASET_JSON
from .manifest import Manifest
from .spec import SPLITS, DatasetSpec
from .worker import RANGE_BIN, RANGE_BINS

FORMAT = "WildScan dataset 1"
# WildScan classes -> the categories compared with RELLIS-3D, and RELLIS-3D's classes in each
CATEGORIES = {
    "grass": (("low grass", "high grass"), ("grass",)),
    "bush": (("bush",), ("bush",)),
    "tree": (("trunk", "treetop", "log"), ("tree", "log")),
    "ground": (("terrain",), ("dirt", "mud", "puddle", "asphalt", "concrete")),
}
_PACKAGES = ("numpy", "embreex", "dask", "distributed", "laspy", "tqdm", "matplotlib")


def versions() -> dict[str, str]:
    out = {"wildscan": __version__, "python": platform.python_version()}
    for name in _PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def totals(spec: DatasetSpec, manifest: Manifest) -> dict:
    rows = list(manifest.rows.values())
    ok = [r for r in rows if r["status"] == "ok"]
    # the classes the scans' effects declare (a paper, clear dataset's card keeps its bytes)
    class_points = {c.name: 0 for c in dataset_classes(spec.weather, spec.biome)}
    class_scans = dict.fromkeys(class_points, 0)
    listed = tuple(class_points)
    ranges = [0] * RANGE_BINS
    zones: dict[str, dict[str, int]] = {}
    for r in ok:
        for cid, n in r["class_counts"].items():
            name = BY_ID[int(cid)].name
            class_points[name] = class_points.get(name, 0) + n
            class_scans[name] = class_scans.get(name, 0) + 1
        ranges = [a + b for a, b in zip(ranges, r["range_histogram"], strict=True)]
        zones.setdefault(r["zone"], dict.fromkeys(SPLITS, 0))[r["split"]] += 1
    if len(class_points) > len(listed):  # classes only some worlds carry (the endless world's materials)
        order = [c.name for c in dataset_classes(spec.weather, spec.biome, class_points)]
        class_points = {n: class_points.get(n, 0) for n in order}
        class_scans = {n: class_scans.get(n, 0) for n in order}
    return {
        "scans_planned": len(spec.seeds) * spec.scans_per_world,
        "scans_ok": len(ok),
        "scans_failed": len(rows) - len(ok),
        "points": sum(r["points"] for r in ok),
        "bytes": sum(f["bytes"] for r in ok for f in r["files"]),
        "class_points": class_points,
        "class_scans": class_scans,
        "range_histogram": {"bin_m": RANGE_BIN, "counts": ranges},
        "scans_by_zone_and_split": dict(sorted(zones.items())),
        "scan_seconds": sum(r.get("seconds", 0.0) for r in rows),
        "failures": sorted({r["reason"] for r in rows if r["status"] != "ok"}),
        **_echo_totals(ok),
        **_particle_totals(spec, ok, class_points),
        **_height_totals(ok),
        **remission_totals(ok),
        **land_totals(ok),
    }


def _height_totals(ok: list[dict]) -> dict:
    """Points of each class per height above the ground (core/truth/traversability.py HEIGHT_BINS)."""
    heights: dict[str, list[int]] = {}
    for r in ok:
        for cid, counts in r.get("class_heights", {}).items():
            name = BY_ID[int(cid)].name
            heights[name] = [a + b for a, b in zip(heights.get(name, [0] * len(counts)), counts)]
    return {"class_heights": heights} if heights else {}


def _particle_totals(spec: DatasetSpec, ok: list[dict], class_points: dict) -> dict:
    """The share of the points that are weather's particles (a dataset with [weather] only)."""
    if not weather_on(spec.weather):
        return {}
    points = sum(r["points"] for r in ok)
    return {"particle_share": class_points[PARTICLE.name] / points if points else 0.0}


def _echo_totals(ok: list[dict]) -> dict:
    """Points by echo and mixed pixels over the realistic scans (none: no such keys), and the
    returns their detection step lost (core/realism/lost_returns.py)."""
    realistic = [r for r in ok if "echo_counts" in r]
    if not realistic:
        return {}
    by_echo = [sum(r["echo_counts"][k] for r in realistic) for k in range(3)]
    out = {"echo_counts": by_echo, "mixed_points": sum(r["mixed_points"] for r in realistic)}
    lost: dict = {}
    for r in realistic:
        if "lost_returns" in r:
            lost = add_stats(lost, r["lost_returns"])
    return {**out, "lost_returns": lost} if lost else out


def category_shares(class_points: dict[str, int]) -> dict[str, tuple[float, float]]:
    """category -> (RELLIS-3D share, this dataset's share) of labeled points."""
    ours_total = sum(n for name, n in class_points.items() if name != "unlabeled") or 1
    rellis_total = sum(RELLIS_POINT_COUNTS.values())
    out = {}
    for cat, (ours, theirs) in CATEGORIES.items():
        out[cat] = (
            sum(RELLIS_POINT_COUNTS[c] for c in theirs) / rellis_total,
            sum(class_points.get(c, 0) for c in ours) / ours_total,
        )
    out["other"] = (1 - sum(v[0] for v in out.values()), 1 - sum(v[1] for v in out.values()))
    return out


def write_dataset_json(root: Path, data: dict) -> None:
    text = (json.dumps(data, indent=1, sort_keys=True) + "\n").encode("utf-8")
    with atomic_outputs(root / DATASET_JSON) as (tmp,):
        write_durably(tmp, lambda f: f.write(text))


def read_dataset_json(root: Path) -> dict | None:
    path = root / DATASET_JSON
    if not path.exists():
        return None
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise UserError(f"cannot read {path}: {e}") from None
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise UserError(f"{path} is not the card of a WildScan dataset")
    return data


def write_card(root: Path, spec: DatasetSpec, data: dict) -> None:
    pause_here("card")  # the test hook: a signal after the last scan, before the card
    figures = _figures(root, data)
    text = card_markdown(spec, data, figures).encode("utf-8")
    with atomic_outputs(root / CARD) as (tmp,):
        write_durably(tmp, lambda f: f.write(text))


def _figures(root: Path, data: dict) -> list[tuple[str, str]]:
    from ...viz import have_matplotlib

    if not have_matplotlib():  # the card is written without its pictures
        return []
    from ...viz.dataset_card import render_card_figures

    with warnings.catch_warnings():  # matplotlib's layout notes (an empty card's axes) are not the user's
        warnings.simplefilter("ignore", UserWarning)
        return render_card_figures(root / CARD_FIGURES, data, category_shares(data["totals"]["class_points"]))


def _pct(x: float) -> str:
    return f"{100 * x:.1f} %"


def _echo_lines(t: dict) -> list[str]:
    if "echo_counts" not in t:
        return []
    first, second, third = t["echo_counts"]
    total = max(1, first + second + third)
    return [
        f"Echoes (realistic model): {_pct(first / total)} of points are a beam's first echo, "
        f"{_pct(second / total)} its second, {_pct(third / total)} its third; "
        f"{_pct(t['mixed_points'] / total)} are mixed pixels."
    ]


def _lost_lines(t: dict) -> list[str]:
    """The card's lost returns: how many, and their share by class, range and incidence."""
    lost = t.get("lost_returns")
    if not lost or not lost["weighed"]:
        return []

    def shares(part: dict, name=lambda k: k) -> str:
        return ", ".join(f"{name(k)} {_pct(g / w)}" for k, (w, g) in part.items() if w)

    by_class = shares(lost["by_class"], lambda k: BY_ID[int(k)].name)
    return [
        f"Lost returns (realistic model: a return below the device's detection limit, docs/sensors.md): "
        f"{lost['lost']:,} of {lost['weighed']:,} echoes ({_pct(lost['lost'] / lost['weighed'])}); "
        f"lost share by class: {by_class}; by range: {shares(lost['by_range'])}; "
        f"by incidence: {shares(lost['by_incidence'])}.",
    ]


def _weather_lines(spec: DatasetSpec, t: dict) -> list[str]:
    if "particle_share" not in t:
        return []
    drawn = ", ".join(
        f"{k}={v if not isinstance(v, tuple) else f'{v[0]:g}..{v[1]:g}'}" for k, v in spec.weather
    )
    return [
        f"Weather ({drawn}; docs/weather.md): {_pct(t['particle_share'])} of points are particles "
        "(class particle: returns from rain, snow, fog or dust)."
    ]


def _scans_with_lines(spec: DatasetSpec, t: dict) -> list[str]:
    """The share of scans containing each class, beside [poses] min_scans_with where it asks
    for one (core/posesampler.py: those scans are drawn near the class)."""
    if not spec.poses.min_scans_with:
        return []
    scans = max(1, t["scans_ok"])
    wanted = dict(spec.poses.min_scans_with)
    lines = ["", "Scans containing a class, beside [poses] min_scans_with:", ""]
    lines += ["| class | scans | share of scans | min_scans_with |", "|---|---:|---:|---:|"]
    for name, n in t["class_scans"].items():
        target = (
            f"{_pct(wanted[name])} ({'met' if n / scans >= wanted[name] else 'not met'})"
            if name in wanted
            else "-"
        )
        lines.append(f"| {name} | {n:,} | {_pct(n / scans)} | {target} |")
    return lines


def _height_lines(t: dict) -> list[str]:
    """Points of each class against height above the ground the robot stands on (hag)."""
    if "class_heights" not in t:
        return []
    from ...core.truth.traversability import HEIGHT_BINS

    lines = ["", "## Points of each class against height above the ground", ""]
    lines += [
        "| class | " + " | ".join(f"{b} m" for b in HEIGHT_BINS) + " |",
        "|---|" + "---:|" * len(HEIGHT_BINS),
    ]
    for name, counts in t["class_heights"].items():
        total = max(1, sum(counts))
        lines.append(f"| {name} | " + " | ".join(_pct(c / total) for c in counts) + " |")
    return lines


def _device_words(spec: DatasetSpec) -> str:
    """ ", device vlp16" for a dataset with another device than the default, " at 1.14 m" for one
    with a mount height of its own (a card with neither reads as before)."""
    device, height = spec.sensor.device, spec.sensor.mount_height
    at = ""
    if height is not None:
        at = f" at {height[0]:g}-{height[1]:g} m" if isinstance(height, tuple) else f" at {height:g} m"
    if device == "utm30lx-ew":
        return f", mounted{at}" if at else ""
    names = device if isinstance(device, tuple) else (device,)
    return f", device {' / '.join(Path(n).name for n in names)}{at}"


def card_markdown(spec: DatasetSpec, data: dict, figures: list[tuple[str, str]]) -> str:
    t = data["totals"]
    lines = [
        f"# WildScan dataset ({'complete' if data['complete'] else 'incomplete: rerun the same command'})",
        "",
        f"{len(spec.seeds)} worlds (detail {spec.detail}, {spec.vegetation} vegetation, "
        f"{spec.biome} biome) x "
        f"{spec.scans_per_world} scans, {spec.sensor.model} sensor model{_device_words(spec)}; formats "
        f"{', '.join(spec.formats)}; label ids: {spec.label_scheme}; "
        f"config hash `{data['config_hash'][:16]}`.",
        f"Scans written: {t['scans_ok']:,} of {t['scans_planned']:,} "
        f"({t['scans_failed']:,} without a valid pose); {t['points']:,} points; {t['bytes'] / 1e9:.2f} GB.",
        *_echo_lines(t),
        *_lost_lines(t),
        *_weather_lines(spec, t),
        *intensity_lines(spec, t),
        "",
        "## Classes",
        "",
        "| class | points | share | scans containing it |",
        "|---|---:|---:|---:|",
    ]
    total = max(1, t["points"])
    for name, n in t["class_points"].items():
        lines.append(f"| {name} | {n:,} | {_pct(n / total)} | {t['class_scans'][name]:,} |")
    lines += _scans_with_lines(spec, t)
    lines += ["", "Beside RELLIS-3D (share of labeled points; RELLIS-3D's published counts):", ""]
    lines += ["| category | RELLIS-3D | this dataset |", "|---|---:|---:|"]
    for cat, (theirs, ours) in category_shares(t["class_points"]).items():
        lines.append(f"| {cat} | {_pct(theirs)} | {_pct(ours)} |")
    lines += [
        "",
        "GOOSE publishes its label mapping but no per-class point counts this card could cite, so "
        "it is not compared here.",
    ]
    lines += _height_lines(t)
    lines += land_lines(t)
    lines += ["", "## Points against range", "", "| range (m) | points |", "|---|---:|"]
    counts = t["range_histogram"]["counts"]
    step = 5  # 2.5 m rows
    for start in range(0, len(counts), step):
        lo, hi = start * RANGE_BIN, (start + step) * RANGE_BIN
        lines.append(f"| {lo:g}-{hi:g} | {sum(counts[start : start + step]):,} |")
    lines += [
        "",
        "## Scans per zone and split",
        "",
        "| zone | " + " | ".join(SPLITS) + " |",
        "|---|" + "---:|" * 3,
    ]
    for zone, by_split in t["scans_by_zone_and_split"].items():
        lines.append(f"| {zone} | " + " | ".join(f"{by_split[s]:,}" for s in SPLITS) + " |")
    lines += [
        "",
        "## Time",
        "",
        "| run | scans written | seconds | scans/s | workers |",
        "|---|---:|---:|---:|---|",
    ]
    for k, run in enumerate(data["runs"], 1):
        lines.append(
            f"| {k} | {run['scans_written']:,} | {run['seconds']:.1f} | "
            f"{run['scans_per_second']:.1f} | {run['engine']} |"
        )
    if t["failures"]:
        lines += ["", "## Scans without a pose", ""] + [f"- {reason}" for reason in t["failures"]]
    if figures:
        lines += ["", "## Figures", ""] + [f"![{title}]({path})" for title, path in figures]
    return "\n".join(lines) + "\n"
