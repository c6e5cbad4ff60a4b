"""The card's facts of a dataset over the endless landscape: the land-cover mix of its poses, the
area its scans cover, and the share of its points within NEAR_SENSOR_M of the sensor (a sensor
standing in tall grass sees mostly the blades around it)."""

from __future__ import annotations

import math

NEAR_SENSOR_M = 0.8  # m (the worker counts the points nearer than this: worker.py near_points)


def convex_hull(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """The hull's corners counter-clockwise (Andrew's monotone chain)."""
    pts = sorted(set(points))
    if len(pts) < 3:
        return pts

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list = []
    upper: list = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def hull_area(hull: list[tuple[float, float]]) -> float:
    """Shoelace formula."""
    n = len(hull)
    return 0.5 * abs(
        sum(hull[k][0] * hull[(k + 1) % n][1] - hull[(k + 1) % n][0] * hull[k][1] for k in range(n))
    )


def span(points: list[tuple[float, float]]) -> float:
    """The largest distance between two points (over the hull's corners)."""
    hull = convex_hull(points)
    return max((math.dist(a, b) for a in hull for b in hull), default=0.0)


def land_totals(ok: list[dict]) -> dict:
    """The endless rows' land-cover mix, area and near-sensor share; {} for a paper dataset."""
    if not ok or "near_points" not in ok[0]:
        return {}
    covers: dict[str, int] = {}
    worlds: dict[str, list[tuple[float, float]]] = {}
    for r in ok:
        covers[r["zone"]] = covers.get(r["zone"], 0) + 1
        worlds.setdefault(r["sequence"], []).append(tuple(r["placement"]["optical_centre"][:2]))
    area = {}
    for seq, xy in sorted(worlds.items()):
        xs, ys = [p[0] for p in xy], [p[1] for p in xy]
        area[seq] = {
            "bbox": [min(xs), min(ys), max(xs), max(ys)],
            "hull_area_m2": hull_area(convex_hull(xy)),
            "span_m": span(xy),
        }
    points = sum(r["points"] for r in ok)
    near = sum(r["near_points"] for r in ok)
    return {
        "land": {
            "cover_scans": dict(sorted(covers.items())),
            "area": area,
            "near_sensor_m": NEAR_SENSOR_M,
            "near_sensor_share": near / points if points else 0.0,
        }
    }


def land_lines(t: dict) -> list[str]:
    """The card's lines of land_totals (none for a paper dataset)."""
    land = t.get("land")
    if not land:
        return []
    scans = max(1, sum(land["cover_scans"].values()))
    mix = ", ".join(f"{c} {100 * n / scans:.1f} %" for c, n in land["cover_scans"].items())
    lines = ["", "## Land covered", "", f"Land cover of the poses: {mix}.", ""]
    lines += ["| sequence | bounding box (m) | convex hull | span |", "|---|---|---:|---:|"]
    for seq, a in land["area"].items():
        box = ", ".join(f"{v:.0f}" for v in a["bbox"])
        lines.append(f"| {seq} | [{box}] | {a['hull_area_m2'] / 1e6:.3f} km² | {a['span_m']:.0f} m |")
    lines += [
        "",
        f"Points within {land['near_sensor_m']:g} m of the sensor: {100 * land['near_sensor_share']:.1f} % "
        "(a sensor standing in tall grass, reeds or undergrowth: [poses] tall_cover).",
    ]
    return lines
