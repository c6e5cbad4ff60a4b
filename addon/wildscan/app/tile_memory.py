"""Where the endless world's tiles live in a process, and the work of making them (numpy-free).

A process keeps the tiles of its last scans in one least-recently-used set bounded in bytes
(`process_memory`), so a process that scans poses kilometres apart holds only the tiles near
its last scans; `TileCounts` says where one request's tiles came from, `TILE_WORK` what the
whole process built and read (app/tiles.py tile_part fills both).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Protocol


class Held(Protocol):
    """What the memory keeps: anything that says its size (app/tiles.py TilePart)."""

    def nbytes(self) -> int: ...


# Tiles kept in memory: five full-detail tiles (~150 MB each at the default detail), more
# than the four a Hokuyo's disc can touch, so that scans near each other rebuild nothing,
# while with a scan's own work a process stays under the 1.5 GB budget of one that
# scans kilometres apart (bench/lod.py scan_spread measures it).
DEFAULT_MEMORY_BYTES = 800_000_000


@dataclass
class TileMemory:
    """Tiles a process keeps between scans, least recently used dropped past `max_bytes`."""

    max_bytes: int = DEFAULT_MEMORY_BYTES
    parts: OrderedDict = field(default_factory=OrderedDict)
    held: int = 0

    def get(self, key: str) -> Held | None:
        part = self.parts.get(key)
        if part is not None:
            self.parts.move_to_end(key)
        return part

    def put(self, key: str, part: Held) -> None:
        if key in self.parts:
            return
        self.parts[key] = part
        self.held += part.nbytes()
        while self.held > self.max_bytes and len(self.parts) > 1:
            _, dropped = self.parts.popitem(last=False)
            self.held -= dropped.nbytes()


@dataclass
class TileCounts:
    """Where the tiles of a request came from, and the seconds spent making them."""

    built: int = 0
    cache: int = 0
    memory: int = 0
    seconds: float = 0.0

    def text(self) -> str:
        return (
            f"{self.built + self.cache + self.memory} tiles: {self.built} built, {self.cache} from the "
            f"cache, {self.memory} in memory ({self.seconds:.2f} s)"
        )


@dataclass
class TileWork:
    """The tiles this process built, or read from the world cache, and the seconds they took
    (a dataset worker reports them per task: `wildscan bench-dataset`'s floor counts the
    builds). One per process (`TILE_WORK`); `copy()` before and after a task for its share."""

    built: int = 0
    build_seconds: float = 0.0  # planning, triangles, object boxes, and storing in the cache
    read: int = 0
    read_seconds: float = 0.0

    def copy(self) -> TileWork:
        return TileWork(self.built, self.build_seconds, self.read, self.read_seconds)

    def since(self, before: TileWork) -> TileWork:
        return TileWork(
            self.built - before.built,
            self.build_seconds - before.build_seconds,
            self.read - before.read,
            self.read_seconds - before.read_seconds,
        )


TILE_WORK = TileWork()
_MEMORY = TileMemory()


def process_memory() -> TileMemory:
    """The tiles this process keeps (one set per process: every command shares it)."""
    return _MEMORY
