"""Which returns a sensor reports (numpy only): the return modes of a device's `[optics]`.

  multi      every echo up to `echoes` a beam, the strongest kept, in range order: the
             UTM-30LX-EW's multi-echo (up to 3 echoes a beam; Hokuyo's specification).
  strongest  one point a beam, its strongest return.
  last       one point a beam, its last (farthest) return.
  dual       two points a beam, as the device's manual defines the pair (`dual`):
             "strongest-last"  Velodyne (VLP-16 User Manual 63-9243 Rev D, 6.2 and 9.3.2.1; the
                               HDL-32E, HDL-64E S3 and VLS-128 manuals alike): the strongest and
                               the last return; when the strongest is also the last, the
                               second-strongest is reported with it; a beam with one return
                               reports it once.
             "two-strongest"   Ouster (sensor docs, firmware 2.2 and later, the dual-return
                               profile RNG19_RFL8_SIG16_NIR16_DUAL): the strongest and the
                               second-strongest return.

Returns are chosen among the echoes the receiver detected (after core/realism/lost_returns.py): a
return too weak to detect is neither strongest nor last. Each point of a dual scan carries
`return_type` (RETURN_TYPES) saying which return it is.
"""

from __future__ import annotations

import numpy as np

RETURN_MODES = ("strongest", "last", "dual", "multi")
DUAL_PAIRS = ("strongest-last", "two-strongest")
KEPT = {"strongest": 1, "last": 1, "dual": 2}  # points a beam; multi: the `echoes` setting
# a dual scan's per-point field: which return of its beam the point is
STRONGEST, LAST, STRONGEST_AND_LAST, SECOND_STRONGEST = 1, 2, 3, 4
RETURN_TYPES = {
    STRONGEST: "strongest",
    LAST: "last",
    STRONGEST_AND_LAST: "strongest and last (the beam's one return, or its strongest is its last)",
    SECOND_STRONGEST: "second strongest",
}


def kept_echoes(mode: str, multi_echoes: int) -> int:
    """The most points a beam gives in `mode` (multi: the scan's `echoes` setting)."""
    return multi_echoes if mode == "multi" else KEPT[mode]


def select_returns(beam: np.ndarray, intensity: np.ndarray, mode: str, dual: str = "strongest-last"):
    """(which of the echoes to keep, in their order; each kept echo's return type) for echoes
    grouped by `beam` in range order (core/echoes.py Echoes), their strength `intensity`.
    Ties in strength go to the nearer echo."""
    n = len(beam)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.uint8)
    index = np.arange(n)
    first = np.ones(n, dtype=bool)
    first[1:] = beam[1:] != beam[:-1]
    last = np.ones(n, dtype=bool)
    last[:-1] = first[1:]
    start = np.flatnonzero(first)
    if mode == "last":
        return index[last], np.full(int(last.sum()), LAST, dtype=np.uint8)
    if mode == "strongest":
        kept = strongest_of_each(np.asarray(intensity, dtype=np.float64), start)
        return kept, np.full(len(kept), STRONGEST, dtype=np.uint8)
    # each beam's strongest: the highest intensity, the nearest of equals (a stable order)
    order = np.lexsort((index, -np.asarray(intensity, dtype=np.float64), beam))
    rank = np.empty(n, dtype=np.int64)
    rank[order] = index - np.repeat(start, np.diff(np.append(start, n)))
    strongest = rank == 0
    if dual == "two-strongest":
        keep = rank <= 1
        kind = np.where(strongest, STRONGEST, SECOND_STRONGEST)
    else:
        strongest_is_last = np.repeat((strongest & last)[last], np.diff(np.append(start, n)))
        keep = strongest | last | (strongest_is_last & (rank == 1))
        kind = np.select(
            [strongest & last, strongest, last], [STRONGEST_AND_LAST, STRONGEST, LAST], SECOND_STRONGEST
        )
    return index[keep], kind[keep].astype(np.uint8)


def strongest_of_each(strength: np.ndarray, start: np.ndarray) -> np.ndarray:
    """The index of each group's strongest echo, the nearest (first) of equals: groups begin at
    `start`, echoes in range order. Per-group maxima in one pass each, where the dual modes'
    rank needs a sort of every echo (most beams of a scan have one echo)."""
    n = len(strength)
    counts = np.diff(np.append(start, n))
    top = np.maximum.reduceat(strength, start)
    is_top = strength == np.repeat(top, counts)
    return np.minimum.reduceat(np.where(is_top, np.arange(n), n), start)
