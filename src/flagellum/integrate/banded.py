"""Banded LU with partial pivoting in Numba (LAPACK's dgbtf2/dgbtrs algorithm).

Written out (rather than calling LAPACK through ctypes) so that every caller stays
cacheable by Numba and pays no call overhead. Band storage, C-order ``(n, ldab)`` (the
transpose of LAPACK's column-major ``(ldab, n)``)::

    ab[j, kl + ku + i − j] = A[i, j]   for max(0, j − ku) ≤ i ≤ min(n − 1, j + kl),

with ``ldab = 2 kl + ku + 1``; the first kl slots hold the fill-in of the pivoted factors.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
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


@njit(cache=True)
def band_solve(ab, kl, ku, ipiv, b):
    """Solve A x = b in place with the factors of :func:`band_lu`."""
    n = ab.shape[0]
    kv = ku + kl
    for j in range(n - 1):
        lm = min(kl, n - 1 - j)
        p = ipiv[j]
        if p != j:
            tmp = b[p]
            b[p] = b[j]
            b[j] = tmp
        bj = b[j]
        for i in range(1, lm + 1):
            b[j + i] -= ab[j, kv + i] * bj
    for j in range(n - 1, -1, -1):
        b[j] /= ab[j, kv]
        bj = b[j]
        for i in range(max(0, j - kv), j):
            b[i] -= ab[j, kv + i - j] * bj


def dense_to_band(a: np.ndarray, kl: int, ku: int) -> np.ndarray:
    """Pack a dense matrix into LU-ready band storage (for tests and small problems)."""
    n = a.shape[0]
    ab = np.zeros((n, 2 * kl + ku + 1))
    for j in range(n):
        for i in range(max(0, j - ku), min(n, j + kl + 1)):
            ab[j, kl + ku + i - j] = a[i, j]
    return ab
