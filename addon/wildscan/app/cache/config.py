"""Where the world cache lives and how big it may grow: what `wildscan dataset --cache DIR
--cache-size GB | --no-cache` hands the workers.

Default: `$XDG_CACHE_HOME/wildscan` (`~/.cache/wildscan` when XDG_CACHE_HOME is unset),
resolved by each worker on its own machine (a remote Dask worker keeps its worlds in its
own user's cache unless --cache names a folder), at most DEFAULT_MAX_GB. A world of the
default detail with porous vegetation is an entry of about a quarter of a gigabyte (the bench
says: `wildscan bench-dataset`), so the default keeps some forty worlds.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path

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
