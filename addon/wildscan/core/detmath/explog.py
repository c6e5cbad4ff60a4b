"""exp and log (fdlibm's reductions and arrangements, with exact-rational series), log1p,
sinh, cosh, arcsinh, hypot and sqrt."""

from __future__ import annotations

import functools
import math

import numpy as np

from ._core import (
    ERRSTATE,
    EXP_MAX,
    EXP_MIN,
    EXP_P,
    INV_LN2,
    LN2_HI,
    LN2_LO,
    LOG_L,
    SINH,
    SQRT_HALF,
    as_array,
    each,
    horner,
    is_scalar,
    unwrap,
)


def _exp_kernel(x, k):
    """exp(x) / 2^k for x = k ln2 + r, |r| <= ~ln2/2 (fdlibm's rational form)."""
    hi = x - k * LN2_HI
    lo = k * LN2_LO
    r = hi - lo
    t = r * r
    c = r - t * horner(t, EXP_P)
    return 1.0 - ((lo - (r * c) / (2.0 - c)) - hi)


def _log_kernel(f, k):
    """log(2^k (1 + f)), sqrt(1/2) <= 1 + f < sqrt(2) (fdlibm's arrangement)."""
    hfsq = 0.5 * f * f
    s = f / (2.0 + f)
    z = s * s
    r = z * horner(z, LOG_L)
    return k * LN2_HI - ((hfsq - (s * (hfsq + r) + k * LN2_LO)) - f)


# The same two kernels on arrays, operation for operation, in place (fewer temporaries
# on the big arrays of a world's terrain and a scan's noise). The test that the
# scalar path gives the array path's bits holds them to the scalar kernels above.


def _exp_kernel_array(x: np.ndarray, k: np.ndarray) -> np.ndarray:
    hi = k * LN2_HI
    np.subtract(x, hi, out=hi)
    lo = k * LN2_LO
    r = hi - lo
    t = r * r
    c = horner(t, EXP_P)
    c *= t
    np.subtract(r, c, out=c)
    r *= c  # r * c
    np.subtract(2.0, c, out=c)  # 2 - c
    r /= c
    np.subtract(lo, r, out=r)
    r -= hi
    return np.subtract(1.0, r, out=r)


def _log_kernel_array(f: np.ndarray, k: np.ndarray) -> np.ndarray:
    hfsq = 0.5 * f
    hfsq *= f
    s = 2.0 + f
    np.divide(f, s, out=s)
    z = s * s
    r = horner(z, LOG_L)
    r *= z
    r += hfsq
    r *= s
    t = k * LN2_LO
    r += t
    np.subtract(hfsq, r, out=r)
    r -= f
    np.multiply(k, LN2_HI, out=t)
    return np.subtract(t, r, out=r)


# ---------------------------------------------------------------------------------------
# exp, log, log1p


def _exp_scalar(x: float) -> float:
    if x != x:
        return x
    if x > EXP_MAX:
        return math.inf
    if x < EXP_MIN:
        return 0.0
    k = float(round(x * INV_LN2))
    return math.ldexp(_exp_kernel(x, k), int(k))


def _exp_array(x: np.ndarray) -> np.ndarray:
    with np.errstate(**ERRSTATE):
        special = ~((x >= EXP_MIN) & (x <= EXP_MAX))  # nan, overflow, underflow
        xs = np.where(special, 0.0, x) if special.any() else x
        k = np.rint(xs * INV_LN2)
        y = np.ldexp(_exp_kernel_array(xs, k), k.astype(np.int32))
        if special.any():
            y = np.where(x > EXP_MAX, np.inf, np.where(x < EXP_MIN, 0.0, np.where(special, np.nan, y)))
        return y


def exp(x):
    return each(_exp_scalar, _exp_array, x)


def _log_scalar(x: float) -> float:
    if x != x or x < 0:
        return math.nan
    if x == 0:
        return -math.inf
    if x == math.inf:
        return x
    m, e = math.frexp(x)
    if m < SQRT_HALF:
        m, e = m + m, e - 1
    return _log_kernel(m - 1.0, float(e))


def _log_array(x: np.ndarray) -> np.ndarray:
    with np.errstate(**ERRSTATE):
        ok = (x > 0) & (x < np.inf)
        special = not ok.all()
        m, e = np.frexp(np.where(ok, x, 1.0) if special else x)
        low = m < SQRT_HALF
        np.add(m, m, out=m, where=low)
        m -= 1.0
        y = _log_kernel_array(m, (e - low).astype(np.float64))
        if special:
            y = np.where(ok, y, np.where(x == 0, -np.inf, np.where(x == np.inf, np.inf, np.nan)))
        return y


def log(x):
    """Natural logarithm; nan below 0, -inf at 0."""
    return each(_log_scalar, _log_array, x)


def _log1p_scalar(x: float) -> float:
    u = 1.0 + x
    if u == 1.0 or x != x:
        return x
    if u == math.inf:
        return math.inf
    return _log_scalar(u) + ((x - (u - 1.0)) / u if u > 0 else 0.0)


def _log1p_array(x: np.ndarray) -> np.ndarray:
    with np.errstate(**ERRSTATE):
        u = 1.0 + x
        finite = (u > 0) & (u < np.inf)
        y = _log_array(u) + np.where(finite, (x - (u - 1.0)) / np.where(finite, u, 1.0), 0.0)
        return np.where((u == 1.0) | (x != x), x, y)


def log1p(x):
    """log(1 + x), accurate for tiny x: log(u) for u = 1 + x, plus the rounding of u."""
    return each(_log1p_scalar, _log1p_array, x)


# ---------------------------------------------------------------------------------------
# sinh, cosh, arcsinh, hypot, degrees


def _sinh_cosh_scalar(x: float, odd: bool) -> float:
    ax = abs(x)
    if x != x:
        return x
    if odd and ax < 1.0:
        return x + x * (x * x) * horner(x * x, SINH)
    if ax > EXP_MAX - 1.0:  # e^x/2 as (e^(x/2)/2) e^(x/2): no overflow before the result's
        w = _exp_scalar(0.5 * ax)
        y = (0.5 * w) * w
    else:
        e = _exp_scalar(ax)
        y = 0.5 * (e - 1.0 / e) if odd else 0.5 * (e + 1.0 / e)
    return math.copysign(y, x) if odd else y


def _sinh_cosh_array(x: np.ndarray, odd: bool) -> np.ndarray:
    with np.errstate(**ERRSTATE):
        ax = np.abs(x)
        e = _exp_array(ax)
        y = 0.5 * (e - 1.0 / e) if odd else 0.5 * (e + 1.0 / e)
        w = _exp_array(0.5 * ax)
        y = np.where(ax > EXP_MAX - 1.0, (0.5 * w) * w, y)
        if odd:
            y = np.copysign(y, x)
            z = x * x
            y = np.where(ax < 1.0, x + x * z * horner(z, SINH), y)
        return np.where(x == x, y, np.nan)


def sinh(x):
    return each(
        functools.partial(_sinh_cosh_scalar, odd=True), functools.partial(_sinh_cosh_array, odd=True), x
    )


def cosh(x):
    return each(
        functools.partial(_sinh_cosh_scalar, odd=False), functools.partial(_sinh_cosh_array, odd=False), x
    )


_TINY, _HUGE = float.fromhex("0x1p-28"), float.fromhex("0x1p28")  # asinh x = x below, log 2x above


def _arcsinh_scalar(x: float) -> float:
    ax = abs(x)
    if ax < _TINY or not math.isfinite(x):
        return x
    if ax > _HUGE:
        y = _log_scalar(ax) + (LN2_HI + LN2_LO)
    elif ax > 2.0:
        y = _log_scalar(2.0 * ax + 1.0 / (math.sqrt(x * x + 1.0) + ax))
    else:
        z = x * x
        y = _log1p_scalar(ax + z / (1.0 + math.sqrt(1.0 + z)))
    return math.copysign(y, x)


def _arcsinh_array(x: np.ndarray) -> np.ndarray:
    with np.errstate(**ERRSTATE):
        ax = np.abs(x)
        z = x * x
        mid = _log1p_array(ax + z / (1.0 + np.sqrt(1.0 + z)))
        large = _log_array(2.0 * ax + 1.0 / (np.sqrt(z + 1.0) + ax))
        huge = _log_array(ax) + (LN2_HI + LN2_LO)
        y = np.where(ax > _HUGE, huge, np.where(ax > 2.0, large, mid))
        y = np.where((ax < _TINY) | ~np.isfinite(x), ax, y)
        return np.copysign(y, x)


def arcsinh(x):
    """asinh x (fdlibm's three ranges, on log and log1p)."""
    return each(_arcsinh_scalar, _arcsinh_array, x)


def hypot(x, y):
    """sqrt(x^2 + y^2) (no scaling: fine below 1e150)."""
    if is_scalar(x) and is_scalar(y):
        return math.sqrt(float(x) * float(x) + float(y) * float(y))
    x, y = as_array(x), as_array(y)
    return unwrap(np.sqrt(x * x + y * y))


def sqrt(x):
    """Correctly rounded everywhere already; here so a module can use dm for all its math."""
    if is_scalar(x):
        return math.nan if x < 0 else math.sqrt(float(x))
    with np.errstate(**ERRSTATE):
        return unwrap(np.sqrt(as_array(x)))
