"""Per-stage random generators (the Infinigen habit), the same numbers on every machine.

Every stage draws from its own generator derived from (seed, stage name), so
adding or changing one stage never shifts the numbers another stage sees.
Never use the global `random`/`np.random` state anywhere in WildScan: make a
`Generator` (here) from a seed.

Why a subclass of numpy's Generator: its integer draws and `random()` (53 random bits
times 2^-53) are exact everywhere, but `uniform` computes low + range * u in C, which a
compiler may fuse into one FMA (numpy/numpy#22993: arm64 builds differ), and `normal`'s
ziggurat calls the C library's exp and log1p in its tails (glibc's FMA and SSE2 variants
differ: 1 draw in ~2e7 here). `uniform` below is numpy's own formula as separate
operations (bit for bit numpy's on x86-64, so worlds keep their numbers), and the
normal draws are numpy's ziggurat with tables and edge tests made by detmath.
"""

from __future__ import annotations

import functools
import hashlib
import math

import numpy as np

from . import detmath as dm


def stage_seed(seed: int, stage: str) -> int:
    digest = hashlib.sha256(f"{int(seed)}:{stage}".encode()).digest()
    return int.from_bytes(digest[:8], "little")


def stage_rng(seed: int, stage: str) -> Generator:
    return Generator(np.random.PCG64(stage_seed(seed, stage)))


def seeded(seed: int) -> Generator:
    """A generator from a plain seed (the range noise's --noise-seed)."""
    return Generator(np.random.PCG64(int(seed)))


class Generator(np.random.Generator):
    """numpy's Generator with machine-independent `uniform`, `normal` and `standard_normal`."""

    def uniform(self, low=0.0, high=1.0, size=None):
        """low + (high - low) * u, u from random(): numpy's formula, one draw per value."""
        if size is None and isinstance(low, (int, float)) and isinstance(high, (int, float)):
            low, high = float(low), float(high)  # the common case, kept lean (worlds draw ~10^4)
            span = high - low
            if not 0.0 <= span < math.inf:
                _check_span(span)
            return low + span * self.random()
        low, high = np.asarray(low, dtype=np.float64), np.asarray(high, dtype=np.float64)
        _check_span(high - low)
        return low + (high - low) * self.random(
            np.broadcast_shapes(low.shape, high.shape) if size is None else size
        )

    def standard_normal(self, size=None, dtype=np.float64, out=None):
        if np.dtype(dtype) != np.float64 or out is not None:
            raise TypeError("WildScan's generator draws float64 normals into new arrays only")
        if size is None:
            return float(ziggurat_normals(self, 1)[0])
        shape = (size,) if np.ndim(size) == 0 else tuple(size)
        return ziggurat_normals(self, int(np.prod(shape, dtype=np.int64))).reshape(shape)

    def normal(self, loc=0.0, scale=1.0, size=None):
        """loc + scale * z, z standard normal; loc and scale scalars."""
        z = self.standard_normal(size)
        return loc + scale * z


def _check_span(span) -> None:
    """numpy's own checks on high - low."""
    if np.any(span < 0):
        raise ValueError("high - low < 0")
    if not np.all(np.isfinite(span)):
        raise OverflowError("high - low range exceeds valid bounds")


# The ziggurat of Marsaglia & Tsang (2000) with 256 layers, as numpy's own (numpy/random/
# src/distributions): a draw is one 64-bit word (8 bits pick a layer, 1 the sign, 52 a
# position), accepted at once 99 % of the time: x = position * w[layer]. The tables are
# made here by detmath (numpy's are compiled in, and its wedge and tail tests call the C
# library's exp and log1p, which differ by CPU); the wedge and tail uniforms come from a
# second stream jumped from the first, in order, so the answers depend on the seed alone.
ZIGGURAT_R = 3.6541528853610088  # where the base layer's tail starts
ZIGGURAT_V = 0.00492867323399  # area of each layer
_MANTISSA = 2.0**52
_CHUNK = 1 << 16


@functools.cache
def ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(k uint64 acceptance limits, w float64 widths / 2^52, f float64 densities) per layer."""
    k, w, f = np.zeros(256, dtype=np.uint64), np.zeros(256), np.zeros(256)
    x = ZIGGURAT_R
    q = ZIGGURAT_V / dm.exp(-0.5 * x * x)
    k[0], w[0], f[0] = int(x / q * _MANTISSA), q / _MANTISSA, 1.0
    w[255], f[255] = x / _MANTISSA, dm.exp(-0.5 * x * x)
    for i in range(254, 0, -1):
        inner = dm.sqrt(-2.0 * dm.log(ZIGGURAT_V / x + dm.exp(-0.5 * x * x)))
        k[i + 1] = int(inner / x * _MANTISSA)
        x = inner
        f[i], w[i] = dm.exp(-0.5 * x * x), x / _MANTISSA
    return k, w, f


def ziggurat_normals(rng: np.random.Generator, count: int) -> np.ndarray:
    """`count` standard normal draws. Value i depends only on the stream, not on `count` (a
    longer ask starts with the same values), as with numpy's own normals."""
    k, w, f = ziggurat_tables()
    wedges = Generator(rng.bit_generator.jumped(1))  # one uniform a wedge draw, in order
    tails = Generator(rng.bit_generator.jumped(2))  # as many as a tail draw takes, in order
    out = np.empty(count)
    filled = 0
    while filled < count:
        # in chunks that stay in cache; 1 % more words than values (the rejections)
        want = min(count - filled, _CHUNK)
        raw = rng.bit_generator.random_raw(want + want // 50 + 16)
        layer = (raw & np.uint64(0xFF)).astype(np.intp)
        position = (raw >> np.uint64(9)) & np.uint64(0xFFFFFFFFFFFFF)
        x = position.astype(np.float64)
        x *= w[layer]
        x.view(np.uint64)[:] |= (raw >> np.uint64(8)) << np.uint64(63)  # the sign bit
        accept = position < k[layer]
        # ~1 % fall outside their layer's rectangle: in a wedge (kept with probability
        # (f(x) - f_i) / (f_{i-1} - f_i)) or, from the base layer, in the tail beyond R
        wedge = np.flatnonzero(~accept & (layer > 0))
        below = (f[layer[wedge] - 1] - f[layer[wedge]]) * wedges.random(len(wedge)) + f[layer[wedge]]
        accept[wedge] = below < dm.exp(-0.5 * x[wedge] * x[wedge])
        for j in np.flatnonzero(~accept & (layer == 0)):
            x[j] = _tail(tails, x[j] < 0)
            accept[j] = True
        x = x[accept]
        take = min(len(x), count - filled)
        out[filled : filled + take] = x[:take]
        filled += take
    return out


def _tail(tails: Generator, negative: bool) -> float:
    """A draw from the normal tail beyond R (Marsaglia 1964), with the sign given."""
    while True:
        xx = -dm.log1p(-tails.random()) / ZIGGURAT_R
        yy = -dm.log1p(-tails.random())
        if yy + yy > xx * xx:
            return -(ZIGGURAT_R + xx) if negative else ZIGGURAT_R + xx


def hash_unit(*keys: np.ndarray) -> np.ndarray:
    """A uniform number in [0, 1) per row of integer keys (splitmix64 of their mix): the same
    on every machine, and one surface's number does not depend on which others were seen."""
    shape = np.broadcast_shapes(*(np.shape(k) for k in keys))
    # element by element, so mixed while it is still one number for the leading scalar keys
    # (a scan's seed and number) and broadcast only by the keys that vary: the same bits
    h = np.zeros((), dtype=np.uint64)
    with np.errstate(over="ignore"):
        for k in keys:
            h = _splitmix(h ^ np.asarray(k).astype(np.int64).astype(np.uint64))
    return np.array(np.broadcast_to((h >> np.uint64(11)).astype(np.float64) * 2.0**-53, shape))


def _splitmix(x: np.ndarray) -> np.ndarray:
    x = x + np.uint64(0x9E3779B97F4A7C15)
    x = (x ^ (x >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    x = (x ^ (x >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return x ^ (x >> np.uint64(31))
