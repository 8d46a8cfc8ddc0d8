"""Numba settings and scalar helpers shared by the kernels.

``FASTMATH`` lets LLVM contract multiply–adds and use reciprocals (−20 % on the right-hand
side), but keeps IEEE NaN/Inf semantics (no ``nnan``/``ninf``), so the blow-up checks
(``isfinite``) are never optimized away. It leaves out ``reassoc``: with it, how LLVM
reorders a sum depends on the code a kernel is optimized together with (a kernel compiled
fresh is linked and optimized again with its callees), and a kernel compiled in this process
and the same kernel loaded from Numba's cache did not compute the same bits: the same seed
gave trajectories that differed at ~1e-12 between the first process after an install,
which compiles, and later ones, which load the cache. Without it every process computes the same bits (tests/test_reliability_errors.py);
the speed of the right-hand side is unchanged within the noise of a measurement.
The kernels also use ``error_model="numpy"``: a division by zero at a degenerate trial state
gives inf/NaN, which the integrators reject as a failed step, instead of raising
``ZeroDivisionError`` out of the solver.
"""

import math

from numba import njit

from . import _kernel_cache

# every kernel module imports this one before its first cache=True kernel
_kernel_cache.register()

FASTMATH = {"contract", "arcp", "nsz", "afn"}

# Cephes atan (S. L. Moshier): atan x = x + x z P(z)/Q(z), z = x², on |x| ≤ 0.66 after
# reduction by π/4 or π/2; relative error ≤ 2 ulp (tests/test_rod.py)
_P = (-8.750608600031904122785e-1, -1.615753718733365076637e1, -7.500855792314704667340e1,
      -1.228866684490136173410e2, -6.485021904942025371773e1)
_Q = (2.485846490142306297962e1, 1.650270098316988542046e2, 4.328810604912902668951e2,
      4.853903996359136964868e2, 1.945506571482613964425e2)
_MOREBITS = 6.123233995736765886130e-17  # π/2 − fl(π/2)
_T3P8 = 2.41421356237309504880  # tan(3π/8)


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _atan_nonneg(x):
    if x > _T3P8:
        y, x, extra = 0.5 * math.pi, -1.0 / x, _MOREBITS
    elif x <= 0.66:
        y, extra = 0.0, 0.0
    else:
        y, x, extra = 0.25 * math.pi, (x - 1.0) / (x + 1.0), 0.5 * _MOREBITS
    z = x * x
    p = (((_P[0] * z + _P[1]) * z + _P[2]) * z + _P[3]) * z + _P[4]
    q = ((((z + _Q[0]) * z + _Q[1]) * z + _Q[2]) * z + _Q[3]) * z + _Q[4]
    return y + (x * z * p / q + x + extra)


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def atan2(y, x):
    """math.atan2 to 2 ulp in ≈ 10 ns instead of ≈ 28 (the libm call dominated the bending
    and twist kernel). The sign of a zero result is not kept."""
    ay, ax = abs(y), abs(x)
    if ax >= ay:
        if ax == 0.0:
            return math.atan2(y, x)
        r = _atan_nonneg(ay / ax)
    else:
        r = 0.5 * math.pi - _atan_nonneg(ax / ay)
    if x < 0.0:
        r = math.pi - r
    return -r if y < 0.0 else r
