"""Per-stage random generators (the Infinigen habit).

Every stage draws from its own generator derived from (seed, stage name), so
adding or changing one stage never shifts the numbers another stage sees.
Never use the global `random` or `np.random` state anywhere in WildScan.
"""

from __future__ import annotations

import hashlib

import numpy as np


def stage_seed(seed: int, stage: str) -> int:
    digest = hashlib.sha256(f"{int(seed)}:{stage}".encode()).digest()
    return int.from_bytes(digest[:8], "little")


def stage_rng(seed: int, stage: str) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(stage_seed(seed, stage)))
