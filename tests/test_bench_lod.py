"""The lod suite's measures (bench/lod.py), on clouds made by hand: what agreement counts."""

from __future__ import annotations

import numpy as np

from wildscan.bench.lod import agreement, peak_resident_kb
from wildscan.core.pointcloud import PointCloud


def cloud(rings, sweeps, labels, ranges) -> PointCloud:
    n = len(rings)
    return PointCloud(
        xyz=np.zeros((n, 3)),
        intensity=np.zeros(n, np.float32),
        label=np.asarray(labels, np.uint16),
        instance=np.zeros(n, np.uint32),
        ring=np.asarray(rings, np.uint16),
        sweep=np.asarray(sweeps, np.uint16),
        range=np.asarray(ranges, np.float32),
    )


def test_agreement_counts_each_beam_either_scan_returned_once():
    full = cloud([0, 1, 2, 3], [0, 0, 0, 0], [1, 3, 3, 2], [5.0, 10.0, 20.0, 7.0])
    assert agreement(full, full, 0.02) == (1.0, 1.0, 4)
    # beam 1 labelled otherwise, beam 2 0.05 m away (beyond sigma), beam 3 not returned, beam (9, 4) only here
    lod = cloud([0, 1, 2, 9], [0, 0, 0, 4], [1, 2, 3, 1], [5.01, 10.0, 20.05, 3.0])
    labels, ranges, beams = agreement(lod, full, 0.02)
    assert beams == 5 and labels == 2 / 5 and ranges == 2 / 5


def test_the_peak_resident_set_is_this_processs_own():
    assert 10_000 < peak_resident_kb() < 50_000_000
