"""Ground truth for place recognition (numpy only): which scans see the same place.

Wild-Places (J. Knights et al., "Wild-Places: A Large-Scale Dataset for Lidar Place
Recognition in Unstructured Natural Environments", ICRA 2023) counts a database scan as a
true match of a query when it lies within 3 m of it, and as a true non-match beyond 25 m;
scans in between are neither. `revisits.json` (drives and datasets) states both sets per
scan without guessing:

  positives  every pair of scans within POSITIVE_RADIUS, listed (a, b) with a < b, with
             their distance (and, in a drive, the time between them): few, so all listed
  negatives  not listed (N^2 / 2 pairs): for query a, every scan b with distance > 25 m;
             its count per scan is given, so an evaluation can check its own rule

Distances are horizontal, between the scans' optical centres (x, y): a place is where the
robot stood, whatever the height of its sensor over the ground there.
"""

from __future__ import annotations

import json

import numpy as np

POSITIVE_RADIUS = 3.0  # m, Wild-Places' positive radius (Knights et al., ICRA 2023)
NEGATIVE_RADIUS = 25.0  # m, Wild-Places' negative radius
SOURCE = (
    "J. Knights et al., Wild-Places: A Large-Scale Dataset for Lidar Place Recognition in "
    "Unstructured Natural Environments, ICRA 2023 (positives within 3 m, negatives beyond 25 m)"
)
NEGATIVE_RULE = "for query scan a, every scan b of the same sequence farther than 25 m (horizontally)"
_BLOCK = 1024  # query rows a block: (1024, N) distances at a time


def distances(xy: np.ndarray, rows: slice) -> np.ndarray:
    """(len(rows), N) horizontal distances from scans `rows` to every scan: sqrt(dx dx + dy dy)."""
    dx = xy[rows, None, 0] - xy[None, :, 0]
    dy = xy[rows, None, 1] - xy[None, :, 1]
    return np.sqrt(dx * dx + dy * dy)


def pairs_and_counts(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(pairs (P, 2) a < b within POSITIVE_RADIUS in (a, b) order, their distances (P,),
    negatives per scan (N,)) of the scans at `xy` (N, 2)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    n = len(xy)
    pairs, dist, negatives = [], [], np.zeros(n, dtype=np.int64)
    for start in range(0, n, _BLOCK):
        rows = slice(start, min(n, start + _BLOCK))
        d = distances(xy, rows)
        negatives[rows] = np.count_nonzero(d > NEGATIVE_RADIUS, axis=1)
        a, b = np.nonzero(d <= POSITIVE_RADIUS)
        a += start
        keep = a < b
        pairs.append(np.column_stack([a[keep], b[keep]]))
        dist.append(d[a[keep] - start, b[keep]])
    if not pairs:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0), negatives
    return np.concatenate(pairs), np.concatenate(dist), negatives


def revisits(xy: np.ndarray, times: np.ndarray | None = None) -> dict:
    """One sequence's revisits: {"scans", "columns", "positives", "negatives_per_scan"}; with
    `times` (s, one per scan) each positive carries the time between its scans."""
    found, dist, negatives = pairs_and_counts(xy)
    columns = ["scan_a", "scan_b", "distance_m"]
    rows = [[int(a), int(b), round(float(d), 6)] for (a, b), d in zip(found.tolist(), dist)]
    if times is not None:
        times = np.asarray(times, dtype=np.float64)
        columns.append("time_apart_s")
        for row in rows:
            row.append(round(float(times[row[1]] - times[row[0]]), 6))
    return {
        "scans": int(len(negatives)),
        "columns": columns,
        "positives": rows,
        "negatives_per_scan": negatives.tolist(),
    }


def revisits_document(sequences: dict[str, dict], scan_ids: str) -> dict:
    """revisits.json: the radii, their source, the rule for negatives, what a scan id is, and
    each sequence's `revisits`."""
    return {
        "source": SOURCE,
        "positive_radius_m": POSITIVE_RADIUS,
        "negative_radius_m": NEGATIVE_RADIUS,
        "distance": "horizontal (x, y) between the scans' optical centres, world frame",
        "negatives": NEGATIVE_RULE,
        "scan_ids": scan_ids,
        "sequences": sequences,
    }


def revisits_json(document: dict) -> str:
    """The document as JSON text, keys sorted, on one line (tens of thousands of pairs and
    counts stay one compact file; every JSON reader takes it)."""
    return json.dumps(document, sort_keys=True) + "\n"
