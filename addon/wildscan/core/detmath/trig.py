"""sin, cos, tan (Cody-Waite reduction by pi/2 in four exact parts, Python integers beyond
2^20 pi/2), arctan and arctan2 (a table of atan(j/8) plus a short series), arcsin and
arccos (on arctan2), degrees and radians."""

from __future__ import annotations

import functools
import math
from fractions import Fraction

import numpy as np

from ._core import (
    ATAN_A,
    ATAN_HI,
    ATAN_HI_A,
    ATAN_LO,
    ATAN_LO_A,
    ATAN_SIGN,
    ATAN_SIGN_A,
    COS,
    ERRSTATE,
    PIO2_1,
    PIO2_2,
    PIO2_3,
    PIO2_4,
    REDUCE_LIMIT,
    SIN,
    TWO_OVER_PI,
    as_array,
    each,
    horner,
    is_scalar,
    two_prod,
    two_sum,
    unwrap,
)


def _reduce_pio2(x, k):
    """x - k*pi/2 as hi + lo, for |k| < 2^20 (the first product and difference are exact)."""
    r = x - k * PIO2_1
    hi, lo = two_sum(r, -(k * PIO2_2))
    hi, e = two_sum(hi, -(k * PIO2_3))
    lo = (lo + e) - k * PIO2_4
    s = hi + lo
    return s, lo - (s - hi)


@functools.cache
def _pi_fixed(bits: int) -> int:
    """floor(pi * 2^bits) (to within a unit), from Machin's formula in integers."""
    guard = bits + 32

    def arctan_inv(n: int) -> int:  # atan(1/n) * 2^guard
        total = term = (1 << guard) // n
        k, sign = 1, -1
        while term:
            term //= n * n
            k += 2
            total += sign * (term // k)
            sign = -sign
        return total

    return (16 * arctan_inv(5) - 4 * arctan_inv(239)) >> 32


def _reduce_exact(x: float) -> tuple[float, float, int]:
    """(hi, lo, k mod 4) with x = k*pi/2 + hi + lo, exactly rounded, for any finite x."""
    bits = 1400
    pi = _pi_fixed(bits)
    num, den = abs(x).as_integer_ratio()
    scaled = num * ((1 << (2 * bits + 1)) // pi)  # x * 2/pi * den * 2^bits
    unit = den << bits
    k = (2 * scaled + unit) // (2 * unit)
    rest = Fraction((scaled - k * unit) * (pi >> 1), unit << bits)
    hi = float(rest)
    lo = float(rest - Fraction(hi))
    return (hi, lo, k & 3) if x > 0 else (-hi, -lo, -k & 3)


def _sin_kernel(x, y):
    """sin(x + y), |x| <= ~pi/4, |y| tiny (fdlibm's arrangement)."""
    z = x * x
    v = z * x
    r = horner(z, SIN[1:])
    return x - ((z * (0.5 * y - v * r) - y) - v * SIN[0])


def _cos_kernel(x, y):
    """cos(x + y), |x| <= ~pi/4: 1 - x^2/2 kept exact in two parts, so < 1 ulp."""
    zh, zl = two_prod(x, x)
    hz = 0.5 * zh
    w = 1.0 - hz
    c = ((1.0 - w) - hz) - 0.5 * zl
    r = zh * zh * horner(zh, COS)
    return w + (c + (r - x * y))


def _atan_rest(t, j):
    """atan((t - j/8) / (1 + t j/8)) for 0 <= t <= 1 and j = rint(8t): at most ~1/16."""
    c = j * 0.125
    xr = (t - c) / (1.0 + t * c)
    z = xr * xr
    return xr + xr * z * horner(z, ATAN_A)


# ---------------------------------------------------------------------------------------
# sin, cos, tan


def _sincos_scalar(x: float) -> tuple[float, float]:
    if not math.isfinite(x):
        return math.nan, math.nan
    if abs(x) < REDUCE_LIMIT:
        k = float(round(x * TWO_OVER_PI))
        hi, lo = _reduce_pio2(x, k)
        q = int(k) & 3
    else:
        hi, lo, q = _reduce_exact(x)
    s, c = _sin_kernel(hi, lo), _cos_kernel(hi, lo)
    if q & 1:
        s, c = c, s
    s = -s if q & 2 else s
    c = -c if (q + 1) & 2 else c
    return (x if x == 0 else s), c


def _sincos_array(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    with np.errstate(**ERRSTATE):
        small = np.abs(x) < REDUCE_LIMIT
        xs = np.where(small, x, 0.0)
        k = np.rint(xs * TWO_OVER_PI)
        hi, lo = _reduce_pio2(xs, k)
        q = k.astype(np.int64)
        for i in np.flatnonzero(~small & np.isfinite(x)):
            hi.flat[i], lo.flat[i], q.flat[i] = _reduce_exact(float(x.flat[i]))
        s, c = _sin_kernel(hi, lo), _cos_kernel(hi, lo)
        odd = (q & 1) == 1
        s, c = np.where(odd, c, s), np.where(odd, s, c)
        np.negative(s, out=s, where=(q & 2) != 0)
        np.negative(c, out=c, where=((q + 1) & 2) != 0)
        finite = np.isfinite(x)
        s = np.where(finite, np.where(x == 0, x, s), np.nan)
        c = np.where(finite, c, np.nan)
    return s, c


def sincos(x):
    """(sin x, cos x), x in radians; one argument reduction for both."""
    return each(_sincos_scalar, _sincos_array, x)


def sin(x):
    return sincos(x)[0]


def cos(x):
    return sincos(x)[1]


def tan(x):
    s, c = sincos(x)
    if is_scalar(x):
        return s / c
    with np.errstate(**ERRSTATE):
        return unwrap(as_array(s) / c)


# ---------------------------------------------------------------------------------------
# arctan, arctan2, arcsin, arccos


def _atan2_scalar(y: float, x: float) -> float:
    """atan2 as C's: the angle of (x, y) in [-pi, pi], signed zeros and infinities included."""
    if x != x or y != y:
        return math.nan
    ay, ax = abs(y), abs(x)
    big = ay > ax
    if ay == ax:  # both zero, both infinite, or equal: t = 1 unless zero
        t = 1.0 if ax != 0 else 0.0
    else:
        t = ax / ay if big else ay / ax
    j = float(round(8.0 * t))
    case = 2 * (math.copysign(1.0, x) < 0) + big
    i = int(j)
    a = ATAN_HI[case][i] + (ATAN_LO[case][i] + ATAN_SIGN[case] * _atan_rest(t, j))
    return math.copysign(a, y)


def _atan2_array(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    with np.errstate(**ERRSTATE):
        ay, ax = np.abs(y), np.abs(x)
        big = ay > ax
        t = np.where(big, ax, ay) / np.where(big, ay, ax)
        t = np.where(ay == ax, np.where(ax != 0, 1.0, 0.0), t)
        t = np.where(t == t, t, 0.0)
        j = np.rint(8.0 * t)
        case = 2 * np.signbit(x) + big
        i = j.astype(np.intp)
        a = ATAN_HI_A[case, i] + (ATAN_LO_A[case, i] + ATAN_SIGN_A[case] * _atan_rest(t, j))
        return np.where((x == x) & (y == y), np.copysign(a, y), np.nan)


def arctan2(y, x):
    """The angle of (x, y), in [-pi, pi]; IEEE special cases as C's atan2."""
    if is_scalar(y) and is_scalar(x):
        return _atan2_scalar(float(y), float(x))
    y, x = np.broadcast_arrays(as_array(y), as_array(x))
    return unwrap(_atan2_array(y.reshape(-1), x.reshape(-1)).reshape(x.shape))


def arctan(x):
    """atan x = atan2(x, 1)."""
    return each(lambda v: _atan2_scalar(v, 1.0), lambda a: _atan2_array(a, np.ones_like(a)), x)


def _arcsin_scalar(x: float) -> float:
    return _atan2_scalar(x, math.sqrt((1.0 - x) * (1.0 + x))) if abs(x) <= 1 else math.nan


def _arcsin_array(x: np.ndarray) -> np.ndarray:
    with np.errstate(**ERRSTATE):
        return arctan2(x, np.sqrt((1.0 - x) * (1.0 + x)))


def arcsin(x):
    """asin x = atan2(x, sqrt((1 - x)(1 + x))); nan outside [-1, 1]."""
    return each(_arcsin_scalar, _arcsin_array, x)


def _arccos_scalar(x: float) -> float:
    return 2.0 * _atan2_scalar(math.sqrt(1.0 - x), math.sqrt(1.0 + x)) if abs(x) <= 1 else math.nan


def _arccos_array(x: np.ndarray) -> np.ndarray:
    with np.errstate(**ERRSTATE):
        return 2.0 * arctan2(np.sqrt(1.0 - x), np.sqrt(1.0 + x))


def arccos(x):
    """acos x = 2 atan2(sqrt(1 - x), sqrt(1 + x)); nan outside [-1, 1]."""
    return each(_arccos_scalar, _arccos_array, x)


_DEG = math.pi / 180.0  # the constants numpy and Python's math use: same bits as np.deg2rad
_RAD = 180.0 / math.pi


def deg2rad(x):
    return float(x) * _DEG if is_scalar(x) else unwrap(as_array(x) * _DEG)


def rad2deg(x):
    return float(x) * _RAD if is_scalar(x) else unwrap(as_array(x) * _RAD)


radians, degrees = deg2rad, rad2deg
