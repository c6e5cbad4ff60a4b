"""The realistic model's coarse-to-fine footprint (core/realism/coarse_footprint.py) against casting every
sub-ray, on the realism suite's poses (part of suite "realism").

Both scans of a pose are taken in clear air without the ground cover's medium: the sward
draws a depth for each sub-ray from a stream a part of rays (core/effects/cover.py), so the
change of one sub-ray's hit in a part moves the draws of the others behind it, and a
comparison with it would measure those redraws, not the footprint. Noise stays on (its draws
are a beam's own, the same in both). Per zone: the ring sub-rays cast, the beams returning
in either scan, the share of them whose echoes differ in any way (how many, label, instance,
mixed flag, range by more than 1 mm, intensity by more than 1 %), the largest range
difference, and the class that lost the largest share of its points.
"""

from __future__ import annotations

import numpy as np

from ..core.classes import BY_ID, NUM_IDS

RANGE_TOLERANCE = 1e-3  # m: echoes this close count as the same
INTENSITY_TOLERANCE = 0.01  # relative


def scan_pair(backend, pose, sensor, z_start):
    """(full footprint, coarse to fine) scans of one pose, in clear air."""
    from ..core.realism import realistic
    from ..core.scan import run_scan

    fine = run_scan(backend, pose, sensor, z_start=z_start)
    coarse_grid = realistic.scan_grid
    realistic.scan_grid = lambda *a: None  # every sub-ray cast
    try:
        full = run_scan(backend, pose, sensor, z_start=z_start)
    finally:
        realistic.scan_grid = coarse_grid
    return full, fine


def compare(full, fine, beam_count: int, per_column: int) -> dict:
    """How the echoes of the two scans' clouds differ, per beam (see the module docstring)."""
    a, b = full.cloud, fine.cloud
    key_a = a.sweep.astype(np.int64) * per_column + a.ring
    key_b = b.sweep.astype(np.int64) * per_column + b.ring
    count_a, count_b = np.bincount(key_a, minlength=beam_count), np.bincount(key_b, minlength=beam_count)
    returning = (count_a > 0) | (count_b > 0)
    differ = count_a != count_b
    same_count = (count_a == count_b) & (count_a > 0)
    order_a = np.lexsort((a.extra["echo"], key_a))
    order_b = np.lexsort((b.extra["echo"], key_b))
    ia, ib = order_a[same_count[key_a[order_a]]], order_b[same_count[key_b[order_b]]]
    dr = np.abs(a.range[ia].astype(np.float64) - b.range[ib].astype(np.float64))
    di = np.abs(a.intensity[ia].astype(np.float64) - b.intensity[ib]) / np.maximum(a.intensity[ia], 1e-9)
    echo_differs = (
        (a.label[ia] != b.label[ib])
        | (a.instance[ia] != b.instance[ib])
        | (a.extra["mixed"][ia] != b.extra["mixed"][ib])
        | (dr > RANGE_TOLERANCE)
        | (di > INTENSITY_TOLERANCE)
    )
    differ[key_a[ia][echo_differs]] = True
    by_class_a = np.bincount(a.label, minlength=NUM_IDS)
    by_class_b = np.bincount(b.label, minlength=NUM_IDS)
    with np.errstate(divide="ignore", invalid="ignore"):
        lost = np.where(by_class_a > 0, (by_class_a - by_class_b) / by_class_a, 0.0)
    worst = int(np.argmax(lost))
    return {
        "returning": int(returning.sum()),
        "differ": float(differ.sum() / max(returning.sum(), 1)),
        "count_differs": float((count_a != count_b).sum() / max(returning.sum(), 1)),
        "max_range_diff": float(dr.max()) if len(dr) else 0.0,
        "points_full": len(a),
        "points_fine": len(b),
        "worst_class": BY_ID[worst].name if worst in BY_ID else str(worst),
        "worst_class_lost": float(lost[worst]),
        "ring_cast": fine.metadata["echoes"].get("ring_subrays_cast", 0) / (4 * beam_count),
    }


def accuracy_rows(geometry, poses: dict) -> list[dict]:
    """Per zone (its first valid pose): the coarse-to-fine scan against the full footprint."""
    from ..app.scan import make_scene_backend
    from ..core.placement import Pose
    from ..core.sensors import SensorConfig

    sensor = SensorConfig(model="realistic").validate()
    rows = []
    for zone, found in poses.items():
        if not found:
            continue
        p = found[0]
        pose = Pose(p["x"], p["y"], p["yaw"])
        backend = make_scene_backend("auto", pose, sensor, notify=lambda _t: None, geometry=geometry)
        full, fine = scan_pair(backend, pose, sensor, p.get("z_start"))
        rows.append({"zone": zone, **compare(full, fine, sensor.beam_count, sensor.device.beams.count)})
    return rows


def accuracy_table(rows: list[dict]) -> tuple[list[str], list[list[str]]]:
    """(headers, rows) of the table the suite prints."""
    headers = [
        "zone",
        "ring sub-rays cast",
        "beams returning",
        "beams differing",
        "echo count differs",
        "max range diff",
        "points full / coarse to fine",
        "class losing most points",
    ]
    return headers, [
        [
            r["zone"],
            f"{r['ring_cast']:.1%}",
            f"{r['returning']:,}",
            f"{r['differ']:.2%}",
            f"{r['count_differs']:.2%}",
            f"{r['max_range_diff'] * 1000:.1f} mm",
            f"{r['points_full']:,} / {r['points_fine']:,}",
            f"{r['worst_class']} {r['worst_class_lost']:.1%}" if r["worst_class_lost"] > 0 else "none",
        ]
        for r in rows
    ]
