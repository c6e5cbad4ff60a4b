"""High-precision references for tests/test_detmath.py: Python's `decimal` at 60 digits
(exact float inputs, series or decimal's own exp/ln), and the ulp error of a float64
result against them. Slow (~50 us a value) and independent of any libm or numpy kernel."""

from __future__ import annotations

import math
from decimal import Decimal, localcontext

DIGITS = 60


def _series_atan(x: Decimal, digits: int = DIGITS) -> Decimal:
    """atan(x) for |x| <= 1: halve the angle three times, then the alternating series."""
    m = 1
    for _ in range(3):
        x = x / (1 + (1 + x * x).sqrt())
        m *= 2
    x2, term, total, k = x * x, x, x, 1
    eps = Decimal(10) ** -(digits + 5)
    while True:
        term = -term * x2
        k += 2
        if abs(term / k) < eps:
            return m * total
        total += term / k


def pi(digits: int = DIGITS + 10) -> Decimal:
    with localcontext() as ctx:
        ctx.prec = digits
        return 16 * _series_atan(Decimal(1) / 5, digits) - 4 * _series_atan(Decimal(1) / 239, digits)


def _sin_cos(x: float) -> tuple[Decimal, Decimal]:
    with localcontext() as ctx:
        ctx.prec = DIGITS + 30 + max(0, int(math.log10(abs(x) + 1)))
        p = pi(ctx.prec)
        d = Decimal(x)
        r = d - (d / (2 * p)).to_integral_value() * 2 * p
        eps = Decimal(10) ** -(DIGITS + 10)
        s = term = r
        k = 1
        while abs(term) > eps:
            term = -term * r * r / ((k + 1) * (k + 2))
            s += term
            k += 2
        c = term = Decimal(1)
        k = 0
        while abs(term) > eps:
            term = -term * r * r / ((k + 1) * (k + 2))
            c += term
            k += 2
        return +s, +c


def reference(name: str, *args: float) -> Decimal:
    """The exact (to ~60 digits) value of numpy's function `name` at float arguments."""
    with localcontext() as ctx:
        ctx.prec = DIGITS + 20
        d = [Decimal(a) for a in args]
        if name in ("sin", "cos", "tan"):
            s, c = _sin_cos(args[0])
            return {"sin": s, "cos": c, "tan": s / c}[name]
        if name == "exp":
            return d[0].exp()
        if name == "log":
            return d[0].ln()
        if name == "log1p":
            return (1 + d[0]).ln()
        if name in ("sinh", "cosh"):
            e = d[0].exp()
            return (e - 1 / e) / 2 if name == "sinh" else (e + 1 / e) / 2
        if name == "arcsinh":
            x = abs(d[0])
            y = (x + (x * x + 1).sqrt()).ln()
            return y if d[0] >= 0 else -y
        if name == "hypot":
            return (d[0] * d[0] + d[1] * d[1]).sqrt()
        if name == "arctan":
            return atan(d[0])
        if name == "arctan2":
            return atan2(d[0], d[1])
        if name == "arcsin":
            return atan2(d[0], ((1 - d[0]) * (1 + d[0])).sqrt())
        if name == "arccos":
            return 2 * atan2((1 - d[0]).sqrt(), (1 + d[0]).sqrt())
    raise ValueError(name)


def atan(x: Decimal) -> Decimal:
    if abs(x) <= 1:
        return _series_atan(x)
    half = pi() / 2
    return (half if x > 0 else -half) - _series_atan(1 / x)


def atan2(y: Decimal, x: Decimal) -> Decimal:
    if x > 0:
        return atan(y / x)
    if x == 0:
        return pi() / 2 if y > 0 else -pi() / 2
    return atan(y / x) + (pi() if y >= 0 else -pi())


def ulp_error(value: float, exact: Decimal) -> float:
    """|value - exact| in units of the last place of float64 at `exact`."""
    with localcontext() as ctx:
        ctx.prec = DIGITS + 20
        unit = math.ulp(float(exact)) if float(exact) != 0 else math.ulp(0.0)
        return float(abs(Decimal(value) - exact) / Decimal(unit))
