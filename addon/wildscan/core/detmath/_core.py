"""Constants and building blocks shared by the detmath modules: exact splits of pi/2 and
ln 2, series coefficients (exact rationals rounded once), error-free sums and products,
and the scalar/array dispatch. See the package docstring for why."""

from __future__ import annotations

import math
from fractions import Fraction

import numpy as np

# ---------------------------------------------------------------------------------------
# constants: exact splits (checked against `decimal` by tests/test_detmath.py)

TWO_OVER_PI = float.fromhex("0x1.45f306dc9c883p-1")
# pi/2 = P1 + P2 + P3 + P4: P1-P3 have 33 significant bits, so k*Pi is exact for k < 2^20
PIO2_1 = float.fromhex("0x1.921fb54400000p+0")
PIO2_2 = float.fromhex("0x1.0b4611a600000p-34")
PIO2_3 = float.fromhex("0x1.3198a2e000000p-69")
PIO2_4 = float.fromhex("0x1.b839a252049c1p-104")
PI_HI, PI_LO = float.fromhex("0x1.921fb54442d18p+1"), float.fromhex("0x1.1a62633145c07p-53")
REDUCE_LIMIT = 1647099.0  # ~2^20 * pi/2: beyond it the reduction uses Python integers
# ln 2 = LN2_HI + LN2_LO, LN2_HI with 32 significant bits (k * LN2_HI exact for |k| < 2^21)
LN2_HI = float.fromhex("0x1.62e42fee00000p-1")
LN2_LO = float.fromhex("0x1.a39ef35793c76p-33")
INV_LN2 = float.fromhex("0x1.71547652b82fep+0")
SQRT_HALF = float.fromhex("0x1.6a09e667f3bcdp-1")
EXP_MAX = 709.782712893384  # exp overflows above this
EXP_MIN = -745.1332191019412  # and underflows to 0 below this
SPLIT = 134217729.0  # 2^27 + 1 (Veltkamp)
# atan(j/8) (j = 0..8) and the three angles arctan2 builds from it, each as hi + lo:
# (base, sign) per case: result = hi + (lo + sign * atan(the rest)).
ATAN_TABLES_HEX = {
    "atan": (
        ("0x0.0p+0", "0x0.0p+0"),
        ("0x1.fd5ba9aac2f6ep-4", "-0x1.cd37686760c17p-59"),
        ("0x1.f5b75f92c80ddp-3", "0x1.8ab6e3cf7afbdp-57"),
        ("0x1.6f61941e4def1p-2", "-0x1.c63aae6f6e918p-56"),
        ("0x1.dac670561bb4fp-2", "0x1.a2b7f222f65e2p-56"),
        ("0x1.1e00babdefeb4p-1", "-0x1.928df287a668fp-58"),
        ("0x1.4978fa3269ee1p-1", "0x1.2419a87f2a458p-56"),
        ("0x1.700a7c5784634p-1", "-0x1.8c34d25aadef6p-56"),
        ("0x1.921fb54442d18p-1", "0x1.1a62633145c07p-55"),
    ),
    "pi/2 - atan": (
        ("0x1.921fb54442d18p+0", "0x1.1a62633145c07p-54"),
        ("0x1.7249faa996a21p+0", "0x1.a8cc1e7480c68p-54"),
        ("0x1.5368c951e9cfdp+0", "-0x1.96f47948a99f1p-54"),
        ("0x1.3647503caf55cp+0", "0x1.17e21d9a42c9ap-55"),
        ("0x1.1b6e192ebbe44p+0", "0x1.b1b466a88828ep-54"),
        ("0x1.031f57e54adbep+0", "0x1.338b4259c0270p-54"),
        ("0x1.dac670561bb4fp-1", "0x1.a2b7f222f65e2p-55"),
        ("0x1.b434ee31013fdp-1", "-0x1.0520d0701d877p-55"),
        ("0x1.921fb54442d18p-1", "0x1.1a62633145c07p-55"),
    ),
    "pi - atan": (
        ("0x1.921fb54442d18p+1", "0x1.1a62633145c07p-53"),
        ("0x1.8234d7f6ecb9dp+1", "-0x1.3cd17e5a39792p-54"),
        ("0x1.72c43f4b1650ap+1", "0x1.c1b6f4f44e10bp-53"),
        ("0x1.643382c07913ap+1", "0x1.a65371fe67254p-54"),
        ("0x1.56c6e7397f5aep+1", "0x1.660b64ece6f4bp-53"),
        ("0x1.4a9f8694c6d6bp+1", "0x1.26f6d2c582f3bp-53"),
        ("0x1.3fc176b7a8560p+1", "-0x1.441a3bd3f1083p-58"),
        ("0x1.361d162e61b8bp+1", "0x1.4be8fd7c9b7e6p-53"),
        ("0x1.2d97c7f3321d2p+1", "0x1.a79394c9e8a0ap-54"),
    ),
    "pi/2 + atan": (
        ("0x1.921fb54442d18p+0", "0x1.1a62633145c07p-54"),
        ("0x1.b1f56fdeef00fp+0", "0x1.17f14fdc1574cp-55"),
        ("0x1.d0d6a1369bd34p+0", "-0x1.a23602a65700cp-57"),
        ("0x1.edf81a4bd64d4p+0", "0x1.a8d3b7956a1c1p-54"),
        ("0x1.0468a8ace4df6p+1", "0x1.0620bf7406affp-55"),
        ("0x1.109009519d639p+1", "0x1.01398408cb59ep-54"),
        ("0x1.1b6e192ebbe44p+1", "0x1.b1b466a88828ep-53"),
        ("0x1.251279b802819p+1", "0x1.6eaa5d3534893p-55"),
        ("0x1.2d97c7f3321d2p+1", "0x1.a79394c9e8a0ap-54"),
    ),
}
# [case][j] -> (hi, lo); case = 2 * (x < 0) + (|y| > |x|), the order of ATAN_TABLES_HEX
# with "pi/2 - atan" (|y| > |x|, x >= 0) second and "pi - atan" (x < 0) third.
ATAN_CASES = ("atan", "pi/2 - atan", "pi - atan", "pi/2 + atan")
ATAN_SIGN = (1.0, -1.0, -1.0, 1.0)
ATAN_HI = tuple(tuple(float.fromhex(h) for h, _ in ATAN_TABLES_HEX[c]) for c in ATAN_CASES)
ATAN_LO = tuple(tuple(float.fromhex(lo) for _, lo in ATAN_TABLES_HEX[c]) for c in ATAN_CASES)
ATAN_HI_A, ATAN_LO_A, ATAN_SIGN_A = np.array(ATAN_HI), np.array(ATAN_LO), np.array(ATAN_SIGN)

# Series coefficients: exact rationals, each rounded once to float64.
# Each series stops where the next term is below 1/1000 ulp on its interval.
SIN = tuple(float(Fraction((-1) ** n, math.factorial(2 * n + 1))) for n in range(1, 9))  # x^3..x^17
COS = tuple(float(Fraction((-1) ** n, math.factorial(2 * n))) for n in range(2, 10))  # x^4..x^18
SINH = tuple(float(Fraction(1, math.factorial(2 * n + 1))) for n in range(1, 10))  # x^3..x^19
BERNOULLI = (  # B2, B4, ..., B14
    Fraction(1, 6), Fraction(-1, 30), Fraction(1, 42), Fraction(-1, 30), Fraction(5, 66),
    Fraction(-691, 2730), Fraction(7, 6),
)  # fmt: skip
# r*coth(r/2) = 2 + sum P_n r^2n, P_n = 2 B_2n / (2n)!  (exp's rational form, as fdlibm)
EXP_P = tuple(float(2 * b / math.factorial(2 * n)) for n, b in enumerate(BERNOULLI, 1))
LOG_L = tuple(float(Fraction(2, 2 * n + 1)) for n in range(1, 11))  # 2 atanh(s) = 2s + s R(s^2)
ATAN_A = tuple(float(Fraction((-1) ** n, 2 * n + 1)) for n in range(1, 9))  # x^3..x^17

ERRSTATE = dict(divide="ignore", invalid="ignore", over="ignore", under="ignore")


def is_scalar(x) -> bool:
    return isinstance(x, (float, int)) and not isinstance(x, np.ndarray)


def as_array(x) -> np.ndarray:
    return np.asarray(x, dtype=np.float64)


def unwrap(a: np.ndarray):
    return a[()] if a.ndim == 0 else a


def each(scalar_fn, array_fn, x):
    """scalar_fn on a Python/numpy float, else array_fn on the values as a flat float64
    array (so every numpy operation inside sees an array), reshaped back."""
    if is_scalar(x):
        return scalar_fn(float(x))
    a = as_array(x)
    result = array_fn(a.reshape(-1))
    if isinstance(result, tuple):
        return tuple(unwrap(r.reshape(a.shape)) for r in result)
    return unwrap(result.reshape(a.shape))


# ---------------------------------------------------------------------------------------
# building blocks: the same operations on Python floats and on arrays


def horner(z, coeffs):
    """c0 + z*(c1 + z*(c2 + ...)), innermost first; in place for arrays (same roundings)."""
    if isinstance(z, np.ndarray):
        r = z * coeffs[-1]
        r += coeffs[-2]
        for c in coeffs[-3::-1]:
            r *= z
            r += c
        return r
    r = coeffs[-1]
    for c in coeffs[-2::-1]:
        r = r * z + c
    return r


def two_sum(a, b):
    """a + b = s + e exactly (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def two_prod(a, b):
    """a * b = p + e exactly (Dekker with Veltkamp splitting: no FMA anywhere)."""
    p = a * b
    t = SPLIT * a
    ah = t - (t - a)
    al = a - ah
    t = SPLIT * b
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl
