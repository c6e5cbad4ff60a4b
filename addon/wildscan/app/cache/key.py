"""The key of a cache entry: a SHA-256 of everything the entry is a pure function of.

A world's triangles, planes, padding and settling index follow from its inputs (seed,
detail, vegetation, biome) and from the code that makes them. `__version__` does not say
when that code changes (it stays 0.1.0 through many changes), so the key holds a hash of
the code itself: every file under the package's `core/` and `raycast/` (the world plan, the
triangles, the padding, the settling, the placement the poses are checked with), this
`app/cache/` package (what is stored and how) and `app/tiles.py` (what a tile entry of the
endless world holds), read once per process. Any edit there, even
a comment, gives new keys: the old entries are never read again and age out of the cache
(store.py's cap). `FORMAT` rises when the layout of an entry changes without the hashed code
changing. numpy's version is in the key as well: the worlds are drawn from numpy's
generators, and a numpy release could change a value.
"""

from __future__ import annotations

import functools
import hashlib
import json
from pathlib import Path

import numpy as np

from ... import __version__

FORMAT = 1
PACKAGE = Path(__file__).resolve().parents[2]  # addon/wildscan
SOURCES = ("core", "raycast", "app/cache", "app/tiles.py")  # folders, and a file (a tile entry's layout)


@functools.lru_cache(maxsize=1)
def source_hash() -> str:
    """SHA-256 over the path and bytes of every file under SOURCES (no bytecode)."""
    digest = hashlib.sha256()
    for folder in SOURCES:
        root = PACKAGE / folder
        for path in [root] if root.is_file() else sorted(root.rglob("*")):
            if not path.is_file() or "__pycache__" in path.parts or path.suffix == ".pyc":
                continue
            data = path.read_bytes()
            name = path.relative_to(PACKAGE).as_posix().encode("utf-8")
            digest.update(b"%d:%s:%d:" % (len(name), name, len(data)))
            digest.update(data)
    return digest.hexdigest()


def entry_key(kind: str, inputs: dict) -> str:
    """The key of the `kind` entry made from `inputs` (plain JSON values) by this code."""
    text = json.dumps(
        {
            "format": FORMAT,
            "kind": kind,
            "inputs": inputs,
            "source": source_hash(),
            "wildscan": __version__,
            "numpy": np.__version__,
        },
        sort_keys=True,
        allow_nan=False,
    )
    return hashlib.sha256(text.encode("utf-8")).hexdigest()
