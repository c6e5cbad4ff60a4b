"""Deterministic elementwise math: the same bits on every CPU and numpy build (numpy only).

    from wildscan.core import detmath as dm
    dm.sin(theta), dm.exp(-d2 / s2), dm.arctan2(y, x), dm.apply(R, points), dm.dot3(n, d)

Why: the same inputs must give the same bytes on every machine, and the usual tools do
not. numpy picks float64 kernels by instruction set at run time (its AVX-512 exp, log,
arctan, power... differ in the last bit from its AVX2/SSE ones); np.sin, np.cos and
Python's `math` call the C library, and glibc picks FMA or SSE2 code by CPU (they
disagree in the last bit on some sines, exps, atans); einsum, dot and matmul sum in the order
and with the FMA use the SIMD width or BLAS kernel decides; and compilers may contract
a*b + c into one FMA on arm64. A world or scan built from those differs in the last bits
from machine to machine, and sometimes by a point.

How: every function here is made only of operations IEEE 754 rounds the same way on
every machine - +, -, *, /, sqrt, rint, frexp/ldexp, comparisons - each its own numpy
ufunc call or Python float operation, so nothing can be fused or reordered. Arguments are
reduced with constants split into exact parts (Cody-Waite; Python integers for huge
arguments), and the series' coefficients are exact rationals rounded once to float64.

Accuracy against 60-digit `decimal` references over many random arguments
(tests/test_detmath.py holds each function to its bound): within 1 ulp for sin, cos, exp
and log, 2.5 ulp for all.

A Python or numpy float takes a pure-Python path through the very same operations (bit
for bit the array result, tested), so `math.cos(yaw)` becomes
`dm.cos(yaw)`; anything else is taken as a float64 array and gives one back. Names follow
numpy, so `np.sin` becomes `dm.sin`. Arrays cost many times numpy's own kernels an
element, so use them on the output path, not in inner loops that do not reach an output.
"""

from .explog import arcsinh, cosh, exp, hypot, log, log1p, sinh, sqrt
from .linalg import apply, cross, dot3, interp, matmul, norm
from .trig import arccos, arcsin, arctan, arctan2, cos, deg2rad, degrees, rad2deg, radians, sin, sincos, tan

__all__ = [
    "apply",
    "arccos",
    "arcsin",
    "arcsinh",
    "arctan",
    "arctan2",
    "cos",
    "cosh",
    "cross",
    "deg2rad",
    "degrees",
    "dot3",
    "exp",
    "hypot",
    "interp",
    "log",
    "log1p",
    "matmul",
    "norm",
    "rad2deg",
    "radians",
    "sin",
    "sincos",
    "sinh",
    "sqrt",
    "tan",
]
