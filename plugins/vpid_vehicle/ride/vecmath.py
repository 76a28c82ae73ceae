"""Arc tangent and sine the compiler can run 4 candidates at once (numba; inlined).

Why: the Magic Formula model's 16 arc tangents and 8 sines per RK4 step were nearly all its
time as the C library's opaque calls (numba vectorises them only through SVML, which the
llvmlite wheels do not ship). Straight-line Cephes (S. L. Moshier, *Methods and Programs for
Mathematical Functions*, 1989): range reduction, Cephes' coefficients, selects for branches.
Accuracy (``tests/vehicle/test_vecmath.py``): ``atan`` within 1 ulp; ``sin`` within 2 ulp for
``|x| < 2**30``; signed zeros, infinities, NaN as the C library. numba caches
:mod:`.kernel` keyed on ``kernel.py`` alone: after editing this file, touch ``kernel.py``.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# atan: tan(3 pi / 8), the low bits of pi / 2, and the rational approximation on [0, 0.66].
_T3P8 = 2.41421356237309504880
_MOREBITS = 6.123233995736765886130e-17
_PIO2 = 1.57079632679489661923
_PIO4 = 7.85398163397448309616e-1
_P0, _P1, _P2, _P3, _P4 = (-8.750608600031904122785e-1, -1.615753718733365076637e1,
                           -7.500855792314704667340e1, -1.228866684490136173410e2,
                           -6.485021904942025371773e1)
_Q0, _Q1, _Q2, _Q3, _Q4 = (2.485846490142306297962e1, 1.650270098316988542046e2,
                           4.328810604912902668951e2, 4.853903996359136964868e2,
                           1.945506571482613964425e2)

# sin: 4 / pi, pi / 4 in three parts, and the polynomials of sine and cosine on [0, pi / 4].
_FOPI = 1.27323954473516268615
_DP1, _DP2, _DP3 = 7.85398125648498535156e-1, 3.77489470793079817668e-8, 2.69515142907905952645e-15
_S0, _S1, _S2, _S3, _S4, _S5 = (1.58962301576546568060e-10, -2.50507477628578072866e-8,
                                2.75573136213857245213e-6, -1.98412698295895385996e-4,
                                8.33333333332211858878e-3, -1.66666666666666307295e-1)
_C0, _C1, _C2, _C3, _C4, _C5 = (-1.13585365213876817300e-11, 2.08757008419747316778e-9,
                                -2.75573141792967388112e-7, 2.48015872888517045348e-5,
                                -1.38888888888730564116e-3, 4.16666666666665929218e-2)
#: Above this the reduction index is clamped (only to keep the integer defined: the sine of
#: such an argument is not accurate here, as the module docstring says).
_JMAX = 2.0**52


@numba.njit(inline="always", error_model="numpy")
def atan(x: float) -> float:  # pragma: no cover - compiled
    """The arc tangent of ``x`` (rad), within 1 ulp of the C library's."""
    a = abs(x)
    big = a > _T3P8
    mid = a > 0.66
    # The reduced argument: -1/a, (a-1)/(a+1) or a (= a/1), one division for all three.
    t = (-1.0 if big else (a - 1.0 if mid else a)) / (a if big else (a + 1.0 if mid else 1.0))
    base = _PIO2 if big else (_PIO4 if mid else 0.0)
    low = _MOREBITS if big else (0.5 * _MOREBITS if mid else 0.0)
    z = t * t
    p = (((_P0 * z + _P1) * z + _P2) * z + _P3) * z + _P4
    q = ((((z + _Q0) * z + _Q1) * z + _Q2) * z + _Q3) * z + _Q4
    y = base + ((t * (z * p / q) + t) + low)
    return math.copysign(y, x)


@numba.njit(inline="always", error_model="numpy")
def sin(x: float) -> float:  # pragma: no cover - compiled
    """The sine of ``x`` (rad), within 2 ulp of the C library's for ``|x| < 2**30``."""
    a = abs(x)
    j = np.int64(a * _FOPI if a * _FOPI < _JMAX else _JMAX)
    j = j + (j & 1)
    y = float(j)
    octant = j & 7
    flip = octant > 3
    octant = octant - 4 if flip else octant
    z = ((a - y * _DP1) - y * _DP2) - y * _DP3
    zz = z * z
    cos_part = 1.0 - 0.5 * zz + zz * zz * (((((_C0 * zz + _C1) * zz + _C2) * zz + _C3) * zz
                                           + _C4) * zz + _C5)
    sin_part = z + z * zz * (((((_S0 * zz + _S1) * zz + _S2) * zz + _S3) * zz + _S4) * zz
                             + _S5)
    v = cos_part if (octant == 1) | (octant == 2) else sin_part
    v = -v if flip else v
    v = v if a < math.inf else math.nan  # sin(inf) and sin(nan) are nan
    return math.copysign(1.0, x) * v
