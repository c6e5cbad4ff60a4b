"""Where the world cache lives and how big it may grow: what `wildscan dataset --cache DIR
--cache-size GB | --no-cache` hands the workers.

Default: `$XDG_CACHE_HOME/wildscan` (`~/.cache/wildscan` when XDG_CACHE_HOME is unset),
resolved by each worker on its own machine (a remote Dask worker keeps its worlds in its
own user's cache unless --cache names a folder), at most DEFAULT_MAX_GB: room for the 20
default worlds of `wildscan bench-dataset` (which prints an entry's size), since a cap below a
run's worlds would make its least-recently-used order drop each world before the next run
reads it.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

from ...core.errors import UserError
from ...core.io.files import output_directory
from .store import DiskCache

DEFAULT_MAX_GB = 10.0
GB = 1e9


def default_cache_dir() -> Path:
    """The user's cache directory for WildScan (XDG base directory specification)."""
    base = os.environ.get("XDG_CACHE_HOME") or ""
    root = Path(base) if os.path.isabs(base) else Path.home() / ".cache"
    return root / "wildscan"


def cache_config(directory: str | os.PathLike | None, max_gb: float = DEFAULT_MAX_GB) -> dict:
    """What a worker gets: {"dir": the folder (None: the worker's default), "max_bytes"}."""
    return {"dir": None if directory is None else os.fspath(directory), "max_bytes": int(max_gb * GB)}


def open_cache(config: dict | None) -> DiskCache | None:
    """The worker's cache for a config (one per process and folder), or None for none."""
    if config is None:
        return None
    return _cache(config["dir"], int(config["max_bytes"]))


@functools.lru_cache(maxsize=4)
def _cache(directory: str | None, max_bytes: int) -> DiskCache:
    return DiskCache(Path(directory) if directory else default_cache_dir(), max_bytes)


def world_facts(source: str, cache: DiskCache | None) -> dict:
    """What a batch tells the client about its world: where it came from ("built", "cache",
    or "memory": the worker's last world) and the cache's warnings since the last batch."""
    warnings = []
    if cache is not None:
        warnings, cache.warnings[:] = list(cache.warnings), []
    return {"world_source": source, "cache_warnings": warnings}


def count_worlds(sources: dict[int, str], seed: int, facts: dict, warn) -> dict[str, int]:
    """On the client: note how a batch's world `seed` was loaded in `sources` (seed ->
    "built" or "cache": built when any worker built it, else from the cache; a worker's last
    world reused adds nothing, and a world several workers loaded counts once), pass its
    cache warnings to `warn`; return the worlds so far by source."""
    source = facts.get("world_source")
    if source == "built" or (source == "cache" and seed not in sources):
        sources[seed] = source
    for line in facts.get("cache_warnings", ()):
        warn(line)
    counts: dict[str, int] = {}
    for how in sources.values():
        counts[how] = counts.get(how, 0) + 1
    return counts


def worlds_text(counts: dict[str, int]) -> str:
    """'worlds: 20 from cache, 0 built' (the summary line's part)."""
    return f"worlds: {counts.get('cache', 0):,} from cache, {counts.get('built', 0):,} built"


def cache_from_options(
    directory: str | None, off: bool, size_gb: float | None, scheduler: str | None, warn
) -> dict | None:
    """The cache config of `wildscan dataset --cache DIR | --no-cache [--cache-size GB]`.
    A --cache folder that cannot be made or written is the user's to fix (UserError, before
    anything is written); the default one, the user never asked for: a warning, no cache."""
    if off:
        if size_gb is not None:
            raise UserError("--no-cache takes no --cache-size")
        return None
    size = DEFAULT_MAX_GB if size_gb is None else size_gb
    if directory is not None:
        return cache_config(output_directory(directory, "--cache"), size)
    if scheduler:
        return cache_config(None, size)  # each worker's own user cache
    try:
        return cache_config(output_directory(default_cache_dir(), "--cache"), size)
    except UserError as e:
        warn(f"{e}: worlds are built, not kept (give --cache DIR, or --no-cache)")
        return None
