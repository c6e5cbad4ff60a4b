"""Deterministic elementwise math: the same bits on every CPU and numpy build (numpy only).

    from wildscan.core import detmath as dm
    dm.sin(theta), dm.exp(-d2 / s2), dm.arctan2(y, x), dm.apply(R, points), dm.dot3(n, d)

Why: the same inputs must give the same bytes on every machine, and the usual tools do
not. numpy picks float64 kernels by instruction set at run time (its AVX-512 exp, log,
arctan, power... differ in the last bit from its AVX2/SSE ones); np.sin, np.cos and
Python's `math` call the C library, and glibc picks FMA or SSE2 code by CPU (measured here:
they disagree on ~1 in 1,300 sines, exps, atans); einsum, dot and matmul sum in the order
and with the FMA use the SIMD width or BLAS kernel decides; and compilers may contract
a*b + c into one FMA on arm64. A world or scan built from those differs in the last bits
from machine to machine, and sometimes by a point.

How: every function here is made only of operations IEEE 754 rounds the same way on
every machine - +, -, *, /, sqrt, rint, frexp/ldexp, comparisons - each its own numpy
ufunc call or Python float operation, so nothing can be fused or reordered. Arguments are
reduced with constants split into exact parts (Cody-Waite; Python integers for huge
arguments), and the series' coefficients are exact rationals rounded once to float64.

Accuracy against 60-digit `decimal` references (tests/test_detmath.py; the maxima over
more than 100,000 random arguments each): sin 0.72 ulp, cos 0.71, exp 0.86, log 0.80,
log1p 1.14, hypot 1.15, cosh 1.27, arctan 1.55, sinh 1.58, arctan2 1.72, tan 1.84,
arcsinh 1.94, arcsin 2.37, arccos 2.39: within 1 ulp for the first four, 2.5 for all.

A Python or numpy float takes a pure-Python path through the very same operations (bit
for bit the array result, tested), about 1-2 us a call, so `math.cos(yaw)` becomes
`dm.cos(yaw)`; anything else is taken as a float64 array and gives one back. Names follow
numpy, so `np.sin` becomes `dm.sin`. Arrays cost 30-100 ns an element (numpy's own:
1-20), so use them on the output path, not in inner loops that do not reach an output.
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
