"""Revisits (core/truth/revisits.py, app/dataset/revisits.py): Wild-Places' radii applied to
scans whose distances are known by construction."""

from __future__ import annotations

import json

import numpy as np

from wildscan.app.dataset.revisits import revisits_text, sequence_revisits
from wildscan.core.truth import revisits as rv


def test_pairs_within_3_m_are_listed_once_and_negatives_counted_beyond_25_m():
    # 0-1: 3.0 m exactly (a positive), 1-2: 3.0001 m (neither), 0-3: 25 m (neither), 0-4: 25.01 m
    xy = np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 3.0001], [0.0, 25.0], [0.0, -25.01]])
    doc = rv.revisits(xy, times=np.array([0.0, 4.5, 9.0, 13.5, 18.0]))
    assert doc["columns"] == ["scan_a", "scan_b", "distance_m", "time_apart_s"]
    assert doc["positives"] == [[0, 1, 3.0, 4.5]]
    expected = [1, 2, 1, 2, 4]  # scan 0: only 4 (25.01 m); 2 only 4 (3 to 22.2 m); 4 far from all
    assert doc["negatives_per_scan"] == expected and doc["scans"] == 5


def test_blocks_of_queries_give_the_pairs_of_one_distance_matrix(monkeypatch):
    rng = np.random.default_rng(4)
    xy = rng.uniform(0, 60, (300, 2))
    monkeypatch.setattr(rv, "_BLOCK", 7)
    pairs, dist, negatives = rv.pairs_and_counts(xy)
    full = np.hypot(xy[:, None, 0] - xy[None, :, 0], xy[:, None, 1] - xy[None, :, 1])
    a, b = np.nonzero(np.triu(full <= 3.0, k=1))
    assert np.array_equal(pairs, np.column_stack([a, b])) and len(pairs) > 20
    assert np.allclose(dist, full[a, b]) and np.array_equal(negatives, (full > 25).sum(axis=1))


def test_a_datasets_revisits_use_only_written_scans_and_name_their_manifest_scan():
    rows = [
        {"scan": 0, "status": "ok", "placement": {"optical_centre": [10.0, 5.0, 2.0]}},
        {"scan": 1, "status": "failed"},
        {"scan": 2, "status": "ok", "placement": {"optical_centre": [11.0, 5.0, 7.0]}},  # 1 m away
        {"scan": 3, "status": "ok", "placement": {"optical_centre": [60.0, 5.0, 2.0]}},
    ]
    seq = sequence_revisits(rows)
    assert seq["manifest_scan"] == [0, 2, 3] and seq["positives"] == [[0, 1, 1.0]]
    assert seq["negatives_per_scan"] == [1, 1, 2]
    text = revisits_text({"01": rows, "00": rows[:1]})
    doc = json.loads(text)
    assert list(doc["sequences"]) == ["00", "01"] and doc["sequences"]["00"]["scans"] == 1
    assert text == revisits_text({"00": rows[:1], "01": rows})  # the same rows, the same bytes
