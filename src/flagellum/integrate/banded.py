"""Banded LU with partial pivoting in Numba (LAPACK's dgbtf2/dgbtrs algorithm).

Written out (rather than calling LAPACK through ctypes) so that every caller stays
cacheable by Numba and pays no call overhead. Band storage, C-order ``(n, ldab)`` (the
transpose of LAPACK's column-major ``(ldab, n)``)::

    ab[j, kl + ku + i − j] = A[i, j]   for max(0, j − ku) ≤ i ≤ min(n − 1, j + kl),

with ``ldab = 2 kl + ku + 1``; the first kl slots hold the fill-in of the pivoted factors.

:func:`band_factor` first tries elimination without row exchanges (U keeps bandwidth ku, so
it costs kl·ku instead of kl·(kl + ku) per column, and the solve kl + ku instead of 2kl + ku),
and falls back to partial pivoting when a pivot is small against its column.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._jit import FASTMATH


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def band_lu(ab, kl, ku, ipiv):
    """In-place LU factorization; returns 0, or j+1 if U[j, j] is exactly zero."""
    n = ab.shape[0]
    kv = ku + kl
    info = 0
    for j in range(ku + 1, min(kv, n)):
        for i in range(kv - j, kl):
            ab[j, i] = 0.0
    ju = 0
    for j in range(n):
        if j + kv < n:
            for i in range(kl):
                ab[j + kv, i] = 0.0
        km = min(kl, n - 1 - j)
        jp = 0
        best = abs(ab[j, kv])
        for i in range(1, km + 1):
            if abs(ab[j, kv + i]) > best:
                best = abs(ab[j, kv + i])
                jp = i
        ipiv[j] = j + jp
        if ab[j, kv + jp] == 0.0:
            if info == 0:
                info = j + 1
            continue
        ju = max(ju, min(j + ku + jp, n - 1))
        if jp != 0:
            for c in range(j, ju + 1):
                tmp = ab[c, kv + j + jp - c]
                ab[c, kv + j + jp - c] = ab[c, kv + j - c]
                ab[c, kv + j - c] = tmp
        if km > 0:
            inv = 1.0 / ab[j, kv]
            for i in range(1, km + 1):
                ab[j, kv + i] *= inv
            for c in range(j + 1, ju + 1):
                a = ab[c, kv + j - c]
                if a != 0.0:
                    for i in range(1, km + 1):
                        ab[c, kv + j + i - c] -= ab[j, kv + i] * a
    return info


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def band_lu_nopivot(ab, kl, ku, rel):
    """In-place LU without row exchanges; returns 0, or j+1 if the pivot of column j is below
    ``rel`` times the largest entry of its column (or not finite): then ``ab`` is spoilt."""
    n = ab.shape[0]
    kv = ku + kl
    for j in range(n):
        row = ab[j]
        km = min(kl, n - 1 - j)
        p = row[kv]
        big = abs(p)
        for i in range(1, km + 1):
            big = max(big, abs(row[kv + i]))
        if not abs(p) > rel * big or not math.isfinite(p):
            return j + 1
        inv = 1.0 / p
        for i in range(1, km + 1):
            row[kv + i] *= inv
        for c in range(j + 1, min(j + ku, n - 1) + 1):
            rc = ab[c]
            o = kv + j - c
            a = rc[o]
            if a != 0.0:
                for i in range(1, km + 1):
                    rc[o + i] -= row[kv + i] * a
    return 0


@njit(cache=True)
def band_factor(ab, kl, ku, ipiv, backup, rel=1e-6):
    """Factorize without pivoting if that is safe (see :func:`band_lu_nopivot`), else with
    partial pivoting; ``backup`` is scratch of shape (n, kl + ku + 1). Returns (info, pivoted)."""
    backup[:, :] = ab[:, kl:]  # the band (the fill-in slots are zero before factorization)
    if band_lu_nopivot(ab, kl, ku, rel) == 0:
        for i in range(ab.shape[0]):
            ipiv[i] = i
        return 0, False
    ab[:, :kl] = 0.0
    ab[:, kl:] = backup
    return band_lu(ab, kl, ku, ipiv), True


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def band_solve(ab, kl, ku, ipiv, b, pivoted=True, work=None):
    """Solve A x = b in place with the factors of :func:`band_lu` (``pivoted``) or of
    :func:`band_lu_nopivot`; ``work``: optional scratch of length ≥ n + kl + ku."""
    n = ab.shape[0]
    kv = ku + kl
    if not pivoted:  # on a zero-padded copy: loops of fixed length kl and ku (−30 %)
        x = np.empty(n + kl + ku) if work is None else work
        x[:ku] = 0.0
        x[ku:ku + n] = b
        x[ku + n:n + kl + ku] = 0.0
        for j in range(n):
            xj = x[ku + j]
            row = ab[j]
            for i in range(1, kl + 1):  # ab[j, kv + i] = 0 beyond the last row
                x[ku + j + i] -= row[kv + i] * xj
        for j in range(n - 1, -1, -1):
            row = ab[j]
            xj = x[ku + j] / row[kv]
            x[ku + j] = xj
            for i in range(1, ku + 1):  # ab[j, kv − i] = 0 before the first row
                x[ku + j - i] -= row[kv - i] * xj
        b[:] = x[ku:ku + n]
        return
    for j in range(n - 1):
        lm = min(kl, n - 1 - j)
        p = ipiv[j]
        if p != j:
            tmp = b[p]
            b[p] = b[j]
            b[j] = tmp
        bj = b[j]
        row = ab[j]
        for i in range(1, lm + 1):
            b[j + i] -= row[kv + i] * bj
    for j in range(n - 1, -1, -1):
        row = ab[j]
        b[j] /= row[kv]
        bj = b[j]
        lo = max(0, j - kv)
        o = kv - j
        for i in range(lo, j):
            b[i] -= row[o + i] * bj


def dense_to_band(a: np.ndarray, kl: int, ku: int) -> np.ndarray:
    """Pack a dense matrix into LU-ready band storage (for tests and small problems)."""
    n = a.shape[0]
    ab = np.zeros((n, 2 * kl + ku + 1))
    for j in range(n):
        for i in range(max(0, j - ku), min(n, j + kl + 1)):
            ab[j, kl + ku + i - j] = a[i, j]
    return ab
