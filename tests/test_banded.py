"""Banded LU against dense solves, including pivoting."""

import numpy as np
import pytest

from flagellum.integrate.banded import band_lu, band_solve, dense_to_band


@pytest.mark.parametrize("n,kl,ku,shift", [(207, 15, 12, 10.0), (50, 3, 7, 0.0), (9, 8, 8, 0.0), (30, 0, 2, 5.0)])
def test_band_solve_matches_dense(n, kl, ku, shift):
    rng = np.random.default_rng(n + kl)
    a = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + ku + 1)):
            a[i, j] = rng.normal()
    a += shift * np.eye(n)  # shift 0: pivoting is needed
    ab = dense_to_band(a, kl, ku)
    ipiv = np.zeros(n, np.int64)
    assert band_lu(ab, kl, ku, ipiv) == 0
    b = rng.normal(size=n)
    x = b.copy()
    band_solve(ab, kl, ku, ipiv, x)
    assert np.allclose(x, np.linalg.solve(a, b), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("n,kl,ku,shift", [(207, 15, 12, 10.0), (50, 3, 7, 0.0), (9, 8, 8, 0.0), (30, 0, 2, 5.0)])
def test_band_factor_without_and_with_pivoting(n, kl, ku, shift):
    """band_factor: elimination without row exchanges where the pivots are safe (diagonally
    dominant: shift > 0), partial pivoting otherwise; the solve agrees with a dense one."""
    from flagellum.integrate.banded import band_factor

    rng = np.random.default_rng(7 * n + ku)
    a = np.zeros((n, n))
    for i in range(n):
        for j in range(max(0, i - kl), min(n, i + ku + 1)):
            a[i, j] = rng.normal()
    a += shift * np.eye(n) * (kl + ku + 1)
    if shift == 0.0:
        a[0, 0] = 0.0  # forces a row exchange at the first column
    ab = dense_to_band(a, kl, ku)
    ipiv = np.zeros(n, np.int64)
    backup = np.zeros((n, kl + ku + 1))
    info, pivoted = band_factor(ab, kl, ku, ipiv, backup)
    assert info == 0
    assert pivoted == (shift == 0.0)
    b = rng.normal(size=n)
    exact = np.linalg.solve(a, b)
    x = b.copy()
    band_solve(ab, kl, ku, ipiv, x, pivoted)
    assert np.allclose(x, exact, rtol=1e-9, atol=1e-9)
