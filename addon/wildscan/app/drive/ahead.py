"""A long drive's pieces of world made one piece ahead, on a thread of their own.

A drive over the endless world builds, for each piece of its route, the tiles near it and a
ray caster over their triangles (trails.py): about a quarter of the drive's time, on one
core, while the other waited. Made one piece ahead, the next piece's world is built while
the current piece is placed or swept. The pieces are still made one after the other, in the
drive's order, on one thread (the tile memory sees the same requests in the same order), and
only the main thread's use of them moves: every output byte stays the same. Memory: the
piece in use and the one being made, never more.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

T = TypeVar("T")
Item = TypeVar("Item")


def one_ahead(make: Callable[[Item], T], items: list[Item]) -> Iterator[T]:
    """make(item) for each item in order, the next one begun on a thread while the caller
    uses the current one; an error raised where its value would have come. Closing the
    iterator early waits for the one being made (nothing is left running)."""
    if not items:
        return
    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="wildscan-drive-ahead") as pool:
        coming = pool.submit(make, items[0])
        for k in range(len(items)):
            value = coming.result()
            if k + 1 < len(items):
                coming = pool.submit(make, items[k + 1])
            yield value
            del value  # the caller's reference is the only one left
