"""Row-by-row arithmetic over big arrays, done a block of rows at a time (numpy only).

Why: a porous world has a million triangles, and numpy's whole-array steps make every
temporary an array of that many rows that streams through main memory. A block of 16,384
rows keeps the temporaries in the CPU's cache, so each step reads them back from there
rather than from memory. The values are the same bits (each row is computed by the same operations).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

BLOCK_ROWS = 16_384


def by_blocks(fn: Callable, *arrays: np.ndarray, rows: int = BLOCK_ROWS):
    """fn(*arrays) computed over blocks of their first axis and joined. `fn` must treat every
    row on its own (no sums or extremes across rows); it may return an array or a tuple."""
    count = len(arrays[0])
    if count <= rows:
        return fn(*arrays)
    parts = [fn(*(a[start : start + rows] for a in arrays)) for start in range(0, count, rows)]
    if isinstance(parts[0], tuple):
        return tuple(np.concatenate(column) for column in zip(*parts, strict=True))
    return np.concatenate(parts)
