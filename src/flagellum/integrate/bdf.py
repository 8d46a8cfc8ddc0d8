"""Deterministic stiff integration compiled end to end: variable-order BDF in Numba.

The method is the quasi-constant-step, fixed-leading-coefficient BDF of orders 1–5 in
backward-difference form with the NDF error constants κ of Shampine & Reichelt (SIAM J. Sci.
Comput. 18, 1997), the algorithm of scipy's ``BDF`` (difference array D, step changes by
the transformation R·U of D, order chosen from the error estimates of orders k − 1, k,
k + 1 after k + 1 equal steps). Newton's method is modified Newton: the banded
Jacobian (by the chain rule, :mod:`flagellum.rod.jacobian`, where it covers the model; else
the coloured finite difference :func:`flagellum.rod.kernels.colored_jacobian`) is kept across steps and refreshed only when the iteration fails to
converge, as CVODE does; the iteration matrix I − cJ is refactorized (banded LU,
:mod:`.banded`) when c = h/α_k changes (with a nonlocal mobility: by more than
:data:`REFACTOR_NONLOCAL`). Output between steps is the interpolating
polynomial of the BDF (the integrator steps past the requested time, as CVODE does).

Everything per step — right-hand side, Jacobian, LU, error control, the motor's time
dependence — runs inside one compiled call per :meth:`BdfStepper.advance`: no Python and
no SUNDIALS marshalling per step (docs/numerics.md, "Hand-written BDF").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..errors import ParameterError, SimulationError
from . import MAX_STEPS_PER_ADVANCE
from ..rod import jacobian as RJ
from ..rod import kernels as K
from .banded import band_factor, band_solve
from ..hydro.dynamics import limits_used
from .frozen import (FrozenMobility, next_target, renew_secant, renewal_due, replan,
                     secant_weight)

MAX_ORDER = 5
NEWTON_MAXITER = 3  #: CVODE's maxcor
#: Newton constants: CVODE's crdown and rdiv; the convergence coefficient 0.03 (CVODE: 0.1,
#: which took 1.8× the steps and 4× the error-test failures on the buckled run, 0.3 s)
NLS_COEF, CRDOWN, RDIV = 0.03, 0.3, 2.0
MIN_FACTOR, MAX_FACTOR = 0.2, 10.0
#: NDF coefficients κ_k (Shampine & Reichelt 1997, Table 1; κ_5 = 0: plain BDF5)
KAPPA = np.array([0.0, -0.1850, -1.0 / 9.0, -0.0823, -0.0415, 0.0])
_GAMMA = np.concatenate(([0.0], np.cumsum(1.0 / np.arange(1, MAX_ORDER + 1))))
ALPHA = (1.0 - KAPPA) * _GAMMA
ERROR_CONST = KAPPA * _GAMMA + 1.0 / np.arange(1, MAX_ORDER + 2)

# float state st[...] (S_DGMAX: the refactorization ratio, :data:`REFACTOR_NONLOCAL`)
S_T, S_H, S_RTOL, S_ATOL, S_C, S_RATE, S_DGMAX = range(7)
#: I − cJ is refactorized only where c has changed by more than this fraction since its
#: factorization (CVODE's dgmax, Hindmarsh et al., ACM TOMS 31, 2005), the Newton step scaled
#: by 2/(1 + c/c_LU) in between, with a nonlocal mobility: its wider band (the near field of
#: ΔM) makes a factorization 2.2× RFT's, and this saved 4–10 % of SBT's CPU time at
#: N = 50 (more steps, fewer factorizations). RFT refactorizes at every change of c (0): the
#: same rule there took 6–25 % more steps for −6 … +3 % CPU (docs/numerics.md).
REFACTOR_NONLOCAL = 0.3
# int state ist[...]
I_ORDER, I_EQUAL, I_LU_OK, I_JAC_CUR, I_PIVOTED, I_STEPS, I_RHS, I_JAC, I_LU, I_STARTED, \
    I_JAC_OK, I_NFAIL, I_EFAIL = range(13)
#: why the Jacobian was renewed (counts): at a (re)start; after a Newton failure with the kept
#: one, by the iteration's diverging or its running out of iterations; the steps the renewed
#: Jacobians had been kept in all (their age); the step of the last renewal
I_JAC_START, I_JAC_DIVERGED, I_JAC_MAXITER, I_JAC_AGE, I_JAC_STEP = range(13, 18)
#: steps left in which the Jacobian is renewed ahead of the Newton iteration; how many were
I_AHEAD_LEFT, I_JAC_AHEAD = 18, 19
#: the largest number of GMRES iterations per Newton step (0: modified Newton with the banded
#: matrix alone); the GMRES iterations taken in all
I_KRYLOV, I_KRYLOV_ITERS = 20, 21
N_ISTATE = 22
#: GMRES stops when the weighted RMS norm of its residual is below this fraction of the Newton
#: convergence bound (CVODE's eplifac, Hindmarsh et al., ACM TOMS 31, 2005)
KRYLOV_EPS = 0.05
#: GMRES iterations per Newton step with a frozen nonlocal mobility, and the N above which
#: they are used (docs/hydrodynamics.md, "Scaling with N")
KRYLOV_MAX, KRYLOV_MIN_SEGMENTS = 5, 100
#: Jacobian policy alternatives, off as shipped (benchmarks/bench_jacobian_refresh.py measures
#: them; neither wins in the buckled run, whose kept Jacobian fails within ~1–2 steps):
#: up to STALE_MAXITER Newton iterations with a kept Jacobian while the rate stays below
#: STALE_RATE; after a failure with a kept Jacobian, renew it ahead of the iteration in the
#: next PROBE steps
STALE_MAXITER, STALE_RATE, PROBE = NEWTON_MAXITER, 0.5, 0

# drive kinds: the motor's drive value M(t) (flagellum.motor.Motor.__call__)
DRIVE_CONST, DRIVE_RAMP, DRIVE_SCHEDULE = 0, 1, 2


@njit(cache=True)
def drive_value(t, kind, value, ramp, sched_t, sched_v, switches):
    """The drive value prm[P_TORQUE] at time t: :meth:`flagellum.motor.Motor.__call__`
    (constant, cosine ramp on [0, ramp], or a piecewise-linear schedule held at its ends),
    with the sign flipped after every reversal time in ``switches`` (sorted)."""
    if kind == DRIVE_SCHEDULE:
        m = np.interp(t, sched_t, sched_v)
    elif kind == DRIVE_RAMP and t < ramp:
        m = value * 0.5 * (1.0 - math.cos(math.pi * t / ramp))
    else:
        m = value
    k = np.searchsorted(switches, t, side="right")
    return -m if k % 2 else m


@njit(cache=True)
def _fun(t, y, out, ka, drive, general):
    """The rod's right-hand side at (t, y); ``drive`` is the pair (the motor's
    :func:`drive_table`, the secant model of a frozen nonlocal ΔM: the arrays of
    :class:`~flagellum.integrate.frozen.FrozenMobility`), the inputs besides the state;
    ``general`` as in :func:`~flagellum.rod.kernels.model_rhs`."""
    table, secant = drive
    ka[0][K.P_TORQUE] = drive_value(t, *table)
    # ΔM = base + w G, applied by the kernel as DM + w DG (DM holds the base, DG is G)
    ka[0][K.P_SECANT] = secant_weight(y, secant[2], secant[3])
    K.model_rhs(general, y, out, *ka)
    for i in range(out.shape[0]):
        if not math.isfinite(out[i]):
            return False
    return True


@njit(cache=True)
def _norm(x, scale):
    s = 0.0
    for i in range(x.shape[0]):
        v = x[i] / scale[i]
        s += v * v
    return math.sqrt(s / x.shape[0])


@njit(cache=True)
def _compute_r(order, factor):
    m = np.zeros((order + 1, order + 1))
    m[0, :] = 1.0
    for i in range(1, order + 1):
        for j in range(1, order + 1):
            m[i, j] = (i - 1 - factor * j) / i
    for i in range(1, order + 1):  # cumulative product down the columns
        for j in range(order + 1):
            m[i, j] *= m[i - 1, j]
    return m


@njit(cache=True)
def _change_d(D, order, factor):
    """Re-express the differences D[:order+1] on the step h·factor (scipy's change_D)."""
    ru = _compute_r(order, factor) @ _compute_r(order, 1.0)
    n = D.shape[1]
    tmp = np.zeros((order + 1, n))
    for i in range(order + 1):
        for k in range(order + 1):
            c = ru[k, i]
            if c != 0.0:
                for j in range(n):
                    tmp[i, j] += c * D[k, j]
    # element loops, not slice assignments: those compile Numba's shape-error text (≈ 3 s)
    for i in range(order + 1):
        for j in range(n):
            D[i, j] = tmp[i, j]


#: the Jacobian by the chain rule through the rod kernel's layers where it covers the model
#: (:func:`flagellum.rod.jacobian.model_jacobian`), else the coloured differences; False: the
#: coloured differences always (the reference the tests compare runs with)
CHAIN_JACOBIAN = True


@njit(cache=True)
def _jacobian(t, y, f, ka, drive, kl, ku, jab, yw, fw, color, lo, hi, ist, general):
    ok = _fun(t, y, f, ka, drive, general)
    prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws = ka
    if CHAIN_JACOBIAN:
        cost = RJ.model_jacobian(general, y, f, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m,
                                 ext_hook, ws, kl, ku, jab, 1.0, yw, fw, color, lo, hi)
    else:
        K.model_colored_jacobian(general, y, f, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m,
                                 ext_hook, ws, kl, ku, jab, 1.0, yw, fw, color, lo, hi)
        cost = color.max() + 1
    ist[I_JAC] += 1
    ist[I_JAC_STEP] = ist[I_STEPS]
    ist[I_RHS] += 1 + cost
    ist[I_JAC_CUR] = 1
    ist[I_JAC_OK] = 1
    ist[I_LU_OK] = 0
    return ok


@njit(cache=True)
def _factor(c, jab, lu, kl, ku, ipiv, backup, ist):
    kv = kl + ku
    for i in range(lu.shape[0]):
        for j in range(lu.shape[1]):
            lu[i, j] = -c * jab[i, j]
        lu[i, kv] += 1.0
    info, pivoted = band_factor(lu, kl, ku, ipiv, backup)
    ist[I_PIVOTED] = 1 if pivoted else 0
    ist[I_LU] += 1
    ist[I_LU_OK] = 1 if info == 0 else 0
    return info == 0


@njit(cache=True)
def _krylov_solve(t, y, f0, r, c, scale, lu, kl, ku, ipiv, pivoted, work, V, H, g, cs, sn,
                  yw, fw, tol, ka, drive, general, ist):
    """Solve (I − c J) x = r for the Newton step, J the full Jacobian at y, by GMRES with the
    banded iteration matrix as right preconditioner (as CVODE's SPGMR with a banded
    preconditioner): J v by a difference of right-hand sides, (f(y + σ v) − f0)/σ with
    ‖σ v‖ = 1 (weighted RMS), f0 = f(y). Works in the scaled space r/scale; at most
    ``V.shape[0] − 1`` iterations. Returns x in ``r`` and the weighted RMS norm of the
    residual of (I − c J) x = r it leaves (with right preconditioning the system's own;
    −1.0 on a non-finite right-hand side): a truncated GMRES can return a small step that is
    not the Newton step, so the Newton iteration must not read a small step as convergence
    unless the residual is small too."""
    n = r.shape[0]
    m = V.shape[0] - 1
    rn = math.sqrt(n)
    beta = 0.0
    for j in range(n):
        V[0, j] = r[j] / scale[j]
        beta += V[0, j] * V[0, j]
    beta = math.sqrt(beta)
    if beta == 0.0:
        return 0.0
    for j in range(n):
        V[0, j] /= beta
    g[:] = 0.0
    g[0] = beta
    k = 0
    for i in range(m):
        for j in range(n):
            yw[j] = V[i, j] * scale[j]
        band_solve(lu, kl, ku, ipiv, yw, pivoted, work)
        wn = _norm(yw, scale)
        sigma = 1.0 / wn if wn > 0.0 else 1.0
        for j in range(n):
            fw[j] = y[j] + sigma * yw[j]
        ist[I_RHS] += 1
        ist[I_KRYLOV_ITERS] += 1
        fv = np.empty(n)
        if not _fun(t, fw, fv, ka, drive, general):
            return -1.0
        u = V[i + 1]
        for j in range(n):
            u[j] = (yw[j] - c * (fv[j] - f0[j]) / sigma) / scale[j]
        for l in range(i + 1):  # modified Gram–Schmidt
            h = 0.0
            for j in range(n):
                h += V[l, j] * u[j]
            H[l, i] = h
            for j in range(n):
                u[j] -= h * V[l, j]
        h = 0.0
        for j in range(n):
            h += u[j] * u[j]
        h = math.sqrt(h)
        H[i + 1, i] = h
        if h > 0.0:
            for j in range(n):
                u[j] /= h
        for l in range(i):  # the earlier Givens rotations, then a new one
            a, b = H[l, i], H[l + 1, i]
            H[l, i] = cs[l] * a + sn[l] * b
            H[l + 1, i] = -sn[l] * a + cs[l] * b
        a, b = H[i, i], H[i + 1, i]
        d = math.hypot(a, b)
        cs[i], sn[i] = (a / d, b / d) if d > 0.0 else (1.0, 0.0)
        H[i, i] = d
        H[i + 1, i] = 0.0
        g[i + 1] = -sn[i] * g[i]
        g[i] = cs[i] * g[i]
        k = i + 1
        if abs(g[i + 1]) / rn <= KRYLOV_EPS * tol or h == 0.0:
            break
    for i in range(k - 1, -1, -1):  # back substitution, coefficients in g
        s = g[i]
        for l in range(i + 1, k):
            s -= H[i, l] * g[l]
        g[i] = s / H[i, i]
    for j in range(n):
        s = 0.0
        for i in range(k):
            s += V[i, j] * g[i]
        r[j] = s * scale[j]
    band_solve(lu, kl, ku, ipiv, r, pivoted, work)
    return abs(g[k]) / rn if k > 0 else beta / rn


@njit(cache=True)
def bdf_start(t, y, D, st, ist, ka, drive, f, yw, general):
    """Begin at (t, y): order 1, the initial step of Hairer, Nørsett & Wanner (Solving ODEs I,
    Sec. II.4) as scipy's ``select_initial_step`` chooses it; returns False on a non-finite
    right-hand side."""
    n = y.shape[0]
    rtol, atol = st[S_RTOL], st[S_ATOL]
    if not _fun(t, y, f, ka, drive, general):
        return False
    scale = atol + rtol * np.abs(y)
    d0, d1 = _norm(y, scale), _norm(f, scale)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    for i in range(n):
        yw[i] = y[i] + h0 * f[i]
    f1 = np.empty(n)
    if not _fun(t + h0, yw, f1, ka, drive, general):
        return False
    d2 = _norm(f1 - f, scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** 0.5
    h = min(100.0 * h0, h1)
    D[:, :] = 0.0
    for i in range(n):  # (element loops: see _change_d)
        D[0, i] = y[i]
        D[1, i] = f[i] * h
    st[S_T], st[S_H], st[S_C] = t, h, 0.0
    ist[I_ORDER], ist[I_EQUAL], ist[I_LU_OK], ist[I_JAC_CUR], ist[I_JAC_OK] = 1, 0, 0, 0, 0
    ist[I_RHS] += 2
    ist[I_STARTED] = 1
    return True


@njit(cache=True)
def bdf_advance(t_out, y_out, D, st, ist, ka, drive, kl, ku, jab, lu, ipiv, backup,
                color, lo, hi, max_steps, general):
    """Step until the internal time reaches ``t_out``, then interpolate y(t_out) into
    ``y_out``. Returns 0, 1 (step size below the rounding of t) or 2 (``max_steps`` steps).
    ``general``: :func:`flagellum.rod.kernels.general_flag` of the model."""
    n = D.shape[1]
    rtol, atol = st[S_RTOL], st[S_ATOL]
    f = np.empty(n)
    yw, fw = np.empty(n), np.empty(n)
    ypred, psi, ynew, d, dy, scale = (np.empty(n), np.empty(n), np.empty(n), np.empty(n),
                                      np.empty(n), np.empty(n))
    work = np.empty(n + 2 * (kl + ku))
    mk = ist[I_KRYLOV]
    V, H = np.empty((mk + 1, n)), np.zeros((mk + 1, max(mk, 1)))
    g, cs, sn = np.zeros(mk + 1), np.zeros(max(mk, 1)), np.zeros(max(mk, 1))
    fk = np.empty(n)
    steps = 0
    while st[S_T] < t_out:
        if steps >= max_steps:
            return 2
        t = st[S_T]
        h = st[S_H]
        order = ist[I_ORDER]
        min_step = 10.0 * (np.nextafter(t, np.inf) - t)
        if h < min_step:
            _change_d(D, order, min_step / h)
            h = min_step
            ist[I_EQUAL] = 0
        accepted = False
        n_iter = 0
        err = 0.0
        t_new = t
        while not accepted:
            if h < min_step:
                st[S_H] = h
                return 1
            t_new = t + h
            for j in range(n):
                s = 0.0
                for k in range(order + 1):
                    s += D[k, j]
                ypred[j] = s
                p = 0.0
                for k in range(1, order + 1):
                    p += D[k, j] * _GAMMA[k]
                psi[j] = p / ALPHA[order]
                scale[j] = atol + rtol * abs(s)
            c = h / ALPHA[order]
            converged = False
            while not converged:
                if ist[I_JAC_OK] == 0:  # the first step after a (re)start
                    ist[I_JAC_START] += 1
                    _jacobian(t_new, ypred, fw, ka, drive, kl, ku, jab, yw, f, color, lo, hi, ist, general)
                elif ist[I_JAC_CUR] == 0 and ist[I_AHEAD_LEFT] > 0:
                    ist[I_AHEAD_LEFT] -= 1
                    ist[I_JAC_AHEAD] += 1
                    _jacobian(t_new, ypred, fw, ka, drive, kl, ku, jab, yw, f, color, lo, hi, ist, general)
                if ist[I_LU_OK] == 0 or (c != st[S_C] and abs(c / st[S_C] - 1.0) > st[S_DGMAX]):
                    if not _factor(c, jab, lu, kl, ku, ipiv, backup, ist):
                        break
                    st[S_C] = c
                    st[S_RATE] = 1.0
                # modified Newton with CVODE's convergence test (Hindmarsh et al., ACM TOMS
                # 31, 2005): converged when the estimated remaining error of d, ‖Δ‖ min(1, rate),
                # is below NLS_COEF of the error-test bound on d (scipy's BDF asks 10–100× more
                # at rtol 1e-4 … 1e-6, and so renews the Jacobian far more often); rate kept
                tol = NLS_COEF / ERROR_CONST[order]
                for j in range(n):  # (element loops: see _change_d)
                    ynew[j] = ypred[j]
                    d[j] = 0.0
                old = 0.0
                crate = st[S_RATE]
                diverged = False
                for k in range(max(NEWTON_MAXITER, STALE_MAXITER)):
                    n_iter = k + 1
                    ist[I_RHS] += 1
                    if not _fun(t_new, ynew, f, ka, drive, general):
                        break
                    for j in range(n):
                        dy[j] = c * f[j] - psi[j] - d[j]
                    inexact = False
                    if mk > 0:
                        res = _krylov_solve(t_new, ynew, f, dy, c, scale, lu, kl, ku, ipiv,
                                            ist[I_PIVOTED] == 1, work, V, H, g, cs, sn, yw, fk,
                                            tol, ka, drive, general, ist)
                        if res < 0.0:
                            break
                        inexact = res > tol
                    else:
                        band_solve(lu, kl, ku, ipiv, dy, ist[I_PIVOTED] == 1, work)
                        if c != st[S_C]:  # factorized at c' = st[S_C]: CVODE's scaling
                            gam = 2.0 / (1.0 + c / st[S_C])
                            for j in range(n):
                                dy[j] *= gam
                    dn = _norm(dy, scale)
                    if k > 0:
                        crate = max(CRDOWN * crate, dn / old)
                    for j in range(n):
                        ynew[j] += dy[j]
                        d[j] += dy[j]
                    if dn * min(1.0, crate) <= tol and not inexact:
                        converged = True
                        break
                    if k > 0 and dn > RDIV * old:
                        diverged = True
                        break
                    if n_iter >= NEWTON_MAXITER and (ist[I_JAC_CUR] == 1 or crate > STALE_RATE):
                        break
                    old = dn
                st[S_RATE] = crate
                if converged or ist[I_JAC_CUR] == 1:
                    break
                ist[I_JAC_DIVERGED if diverged else I_JAC_MAXITER] += 1
                ist[I_AHEAD_LEFT] = PROBE
                ist[I_JAC_AGE] += ist[I_STEPS] - ist[I_JAC_STEP]
                _jacobian(t_new, ypred, fw, ka, drive, kl, ku, jab, yw, f, color, lo, hi, ist, general)
            if not converged:
                ist[I_NFAIL] += 1
                h *= 0.5
                _change_d(D, order, 0.5)
                ist[I_EQUAL] = 0
                continue
            safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + min(n_iter, NEWTON_MAXITER))
            for j in range(n):
                scale[j] = atol + rtol * abs(ynew[j])
                dy[j] = ERROR_CONST[order] * d[j]
            err = _norm(dy, scale)
            if err > 1.0:
                factor = max(MIN_FACTOR, safety * err ** (-1.0 / (order + 1)))
                ist[I_EFAIL] += 1
                h *= factor
                _change_d(D, order, factor)
                ist[I_EQUAL] = 0
            else:
                accepted = True
        steps += 1
        ist[I_STEPS] += 1
        ist[I_EQUAL] += 1
        ist[I_JAC_CUR] = 0
        st[S_T] = t_new
        # the differences of the new interpolating polynomial (d = ∇^{k+1} y_{n+1})
        for j in range(n):
            D[order + 2, j] = d[j] - D[order + 1, j]
            D[order + 1, j] = d[j]
        for i in range(order, -1, -1):
            for j in range(n):
                D[i, j] += D[i + 1, j]
        if ist[I_EQUAL] >= order + 1:
            em = ep = np.inf
            if order > 1:
                for j in range(n):
                    dy[j] = ERROR_CONST[order - 1] * D[order, j]
                em = _norm(dy, scale)
            if order < MAX_ORDER:
                for j in range(n):
                    dy[j] = ERROR_CONST[order + 1] * D[order + 2, j]
                ep = _norm(dy, scale)
            fm = em ** (-1.0 / order) if em > 0.0 else np.inf
            fc = err ** (-1.0 / (order + 1)) if err > 0.0 else np.inf
            fp = ep ** (-1.0 / (order + 2)) if ep > 0.0 else np.inf
            best, delta = fm, -1
            if fc > best:
                best, delta = fc, 0
            if fp > best:
                best, delta = fp, 1
            order += delta
            ist[I_ORDER] = order
            factor = min(MAX_FACTOR, safety * best)
            h *= factor
            _change_d(D, order, factor)
            ist[I_EQUAL] = 0
        st[S_H] = h
    # y(t_out) from the interpolating polynomial of the last step
    t, h, order = st[S_T], st[S_H], ist[I_ORDER]
    for j in range(n):
        y_out[j] = D[0, j]
    p = 1.0
    for k in range(order):
        p *= (t_out - (t - h * k)) / (h * (k + 1))
        for j in range(n):
            y_out[j] += D[k + 1, j] * p
    return 0


@njit(cache=True)
def bdf_frozen_advance(t_from, t_out, y_out, D, st, ist, ka, drive, kl, ku, jab, lu, ipiv,
                       backup, color, lo, hi, max_steps, general, plan, frozen, work, x, turn,
                       build, refresh, bond):
    """:func:`bdf_advance` from the output time ``t_from`` to ``t_out`` with a frozen
    nonlocal ΔM renewed at planned sub-targets: the loop of
    :meth:`FrozenMobility.advance <flagellum.integrate.frozen.FrozenMobility.advance>` with
    its own compiled pieces (the sub-targets, the limits' use, the renewal
    :func:`~flagellum.integrate.frozen.renew_secant`, the next interval), so a renewal costs
    no round trip to Python. ``plan``, ``work``: the frozen mobility's; ``frozen`` the
    model's frozen beads; ``x`` scratch for the bead positions; ``turn``, ``build``: the
    renewal's arguments; ``refresh``, ``bond``: the limits. Returns :func:`bdf_advance`'s
    code, or 3 for a non-finite state."""
    dm = ka[-1][-1]
    secant = drive[1]
    n1 = x.shape[0]
    tc = t_from
    while True:
        tn, due = next_target(plan, tc, t_out)
        code = bdf_advance(tn, y_out, D, st, ist, ka, drive, kl, ku, jab, lu, ipiv, backup,
                           color, lo, hi, max_steps, general)
        if code != 0:
            return code
        for j in range(y_out.shape[0]):
            if not math.isfinite(y_out[j]):
                return 3
        for i in range(n1):
            for a in range(3):
                x[i, a] = y_out[3 + 4 * i + a]
        used = limits_used(x, frozen, n1, refresh, bond)
        if renewal_due(tn, due, used):
            ka[0][K.P_SECANT] = 0.0
            renew_secant(y_out, x, dm, work, secant, frozen, turn, build)
            replan(plan, tn, used)
        tc = tn
        if tn >= t_out:
            return 0


def _difference_matrix(m: int) -> np.ndarray:
    """P[j, i] = (−1)^i C(j, i): values y_{n−j} from backward differences ∇^i y_n and back."""
    return np.array([[(-1.0) ** i * math.comb(j, i) for i in range(m)] for j in range(m)])


def krylov_iterations(model) -> int:
    """GMRES iterations per Newton step for ``model``: :data:`KRYLOV_MAX` with a frozen
    nonlocal mobility above :data:`KRYLOV_MIN_SEGMENTS` segments, whose far field the banded
    matrix misses; 0 (modified Newton) otherwise."""
    if model.hydrodynamics.is_local or model.n <= KRYLOV_MIN_SEGMENTS:
        return 0
    return KRYLOV_MAX


def drive_table(motor, t_end: float) -> tuple:
    """The arguments of :func:`drive_value` for ``motor`` up to ``t_end`` [s] (reversal
    times drawn that far)."""
    value = {"torque": motor.torque, "speed": motor.speed, "law": 1.0}[motor.drive]
    if motor.schedule is not None:
        kind = DRIVE_SCHEDULE
        st, sv = (np.array(v, float) for v in zip(*motor.schedule))
    else:
        kind = DRIVE_RAMP if motor.ramp_time > 0 else DRIVE_CONST
        st = sv = np.zeros(0)
    switches = np.array(motor.switching_times(t_end), float)
    return (kind, float(value), float(motor.ramp_time), st, sv, switches)


class BdfStepper:
    """Variable-order BDF (orders 1–5) with error control, compiled in Numba (see module
    docstring). Satisfies :class:`flagellum.integrate.base.Stepper` (adaptive, deterministic).

    ``rtol``/``atol``: the weighted RMS norm of the local error estimate is kept ≤ 1 with
    weights 1/(atol + rtol |y|), as CVODE's. ``max_num_steps``: the limit of internal steps
    per :meth:`advance`.

    A frozen nonlocal mobility (``hydrodynamics.refresh`` > 0) is renewed at planned
    sub-targets and continued by its secant model inside the compiled right-hand side
    (:class:`~flagellum.integrate.frozen.FrozenMobility`); Newton's iteration matrix is then
    the banded one of the local operator plus the near field of ΔM, the operator CVODE
    preconditions its GMRES with (docs/hydrodynamics.md). Above :data:`KRYLOV_MIN_SEGMENTS`
    that matrix alone misses too much of the far field and each Newton step is solved by up
    to ``krylov`` (default :func:`krylov_iterations`) GMRES iterations preconditioned by it.
    ``refactor``: the change of c = h/α_k that refactorizes I − cJ (default
    :data:`REFACTOR_NONLOCAL` with a nonlocal mobility, 0: every change). Refused: a cell body (it couples
    outside the band) and the unfrozen ``refresh`` = 0, which rebuilds ΔM in
    :meth:`RodModel.rhs <flagellum.rod.model.RodModel.rhs>`, a call the compiled loop skips.
    """

    fixed_step = None
    rng_state = None

    def __init__(self, model, t0: float, y0: np.ndarray, rtol: float = 1e-6,
                 atol: float = 1e-8, max_num_steps: int = MAX_STEPS_PER_ADVANCE,
                 krylov: int | None = None, refactor: float | None = None):
        if model.cell:
            raise ParameterError("method", "bdf", "'cvode' with a cell body (the BDF stepper "
                                 "needs the rod's banded Jacobian)")
        if not model.hydrodynamics.is_local and model.hydrodynamics.refresh == 0:
            raise ParameterError("method", "bdf", "'cvode' with a nonlocal mobility rebuilt at "
                                 "every right-hand side (--hydro-refresh 0)")
        if model.end_load is not None and model.end_load.pull_rate != 0.0:
            # the trap's centre moves with t, set by RodModel.rhs, which the compiled loop skips
            raise ParameterError("method", "bdf", "'cvode' with a moving trap (--pull-rate)")
        self.model = model
        self.rtol, self.atol = float(rtol), float(atol)
        self.max_num_steps = int(max_num_steps)
        self._kl, self._ku = model.jacobian_band  # wider with a nonlocal mobility
        self._frozen = FrozenMobility(model)
        n = len(y0)
        self._D = np.zeros((MAX_ORDER + 3, n))
        self._st = np.zeros(7)
        self._ist = np.zeros(N_ISTATE, np.int64)
        self._st[S_RTOL], self._st[S_ATOL] = self.rtol, self.atol
        if refactor is None:
            refactor = 0.0 if model.hydrodynamics.is_local else REFACTOR_NONLOCAL
        self._st[S_DGMAX] = float(refactor)
        if krylov is None:
            krylov = krylov_iterations(model)
        self._ist[I_KRYLOV] = int(krylov)
        ldab = 2 * self._kl + self._ku + 1
        self._jab = np.zeros((n, ldab))
        self._lu = np.zeros((n, ldab))
        self._ipiv = np.zeros(n, np.int64)
        self._backup = np.zeros((n, self._kl + self._ku + 1))
        self._f = np.zeros(n)
        self._yw = np.zeros(n)
        self._drive_end = -np.inf
        self._drive = None
        self._steps0 = 0
        self.reset(t0, y0)

    @classmethod
    def from_options(cls, model, t: float, y: np.ndarray, options, *, kT: float = 0.0,
                     seed: int = 0, rng_state=None) -> "BdfStepper":
        """The stepper of ``options`` (``rtol``, ``atol``, ``max_steps``); deterministic only."""
        if kT:
            raise ParameterError("method", "bdf", "'implicit' for a thermal run")
        return cls(model, t, y, options.rtol, options.atol, max_num_steps=options.max_steps)

    @property
    def n_steps(self) -> int:
        return int(self._ist[I_STEPS])

    @property
    def tracks_mobility(self) -> bool:
        """Whether :meth:`advance` renews a frozen nonlocal ΔM itself (and applies its secant model)."""
        return self._frozen.active

    @property
    def stats(self) -> dict:
        """Counters since construction: steps, right-hand sides, Jacobians, factorizations,
        failures, and the Jacobians by cause of renewal (at a start, after the kept one's
        Newton iteration diverged or ran out of iterations, ahead of the iteration) with the
        steps the renewed ones had been kept in all (``jacobian_age_steps``), and the renewals
        of a frozen nonlocal ΔM (``mobility_renewals``)."""
        i = self._ist
        return {"steps": int(i[I_STEPS]), "rhs": int(i[I_RHS]), "jacobians": int(i[I_JAC]),
                "factorizations": int(i[I_LU]), "convergence_failures": int(i[I_NFAIL]),
                "error_test_failures": int(i[I_EFAIL]), "jacobians_at_start": int(i[I_JAC_START]),
                "jacobians_after_divergence": int(i[I_JAC_DIVERGED]),
                "jacobians_after_max_iterations": int(i[I_JAC_MAXITER]),
                "jacobian_age_steps": int(i[I_JAC_AGE]), "jacobians_ahead": int(i[I_JAC_AHEAD]),
                "krylov_iterations": int(i[I_KRYLOV_ITERS]),
                "mobility_renewals": self._frozen.renewals}

    def _drive_for(self, t: float) -> tuple:
        if t > self._drive_end:  # reversal times drawn well past the next output
            self._drive_end = 2.0 * t + 1.0
            self._drive = drive_table(self.model.motor, self._drive_end)
        return self._drive

    def reset(self, t0: float, y0: np.ndarray) -> None:
        self.t = float(t0)
        self.y = np.array(y0, float)
        self._ist[I_STARTED] = 0  # started lazily: the first advance sees the current rhs
        self._frozen.reset(t0)

    def carry(self, t0: float, y0: np.ndarray, transform, fresh_jacobian: bool = False,
              frame_turned: bool = True) -> bool:
        """Continue at (t0, y0) after a smooth change of the state's coordinates (a chart
        re-centred, the frame's rate changed) without restarting: the history is mapped
        into the new coordinates and order and step size are kept. ``transform(times,
        values)``: the states ``values`` (one row per time) in the new coordinates. The
        differences D[:k+2] are those of the values y_{n−j} = y(t_n − j h), j = 0 … k + 1, of
        the interpolating polynomial (∇^j y_n = Σ_i (−1)^i C(j, i) y_{n−i}, a matrix that is
        its own inverse): the values are mapped and the differences of their changes added.
        The Jacobian is kept (stale: the first Newton failure renews it) unless
        ``fresh_jacobian``. Returns False, after a :meth:`reset`, where the history is not
        carried (not started yet).

        A frozen nonlocal ΔM is a function of the bead positions: a chart's change leaves
        them, and so ΔM, its secant model and their plan, as they are. ``frame_turned`` (the
        frame's rate changed): the past positions turn by −ΔΩ (s − t0) about e_z, those the
        secant model extrapolates from among them, so ΔM is rebuilt at y0 and the secant
        starts again from there (:meth:`FrozenMobility.restart_at
        <flagellum.integrate.frozen.FrozenMobility.restart_at>`), the history carried."""
        if self._ist[I_STARTED] == 0:
            self.reset(t0, y0)
            return False
        if self._frozen.active and frame_turned:
            self._frozen.restart_at(t0, y0)
        order, h, tn = int(self._ist[I_ORDER]), float(self._st[S_H]), float(self._st[S_T])
        m = order + 2
        P = _difference_matrix(m)
        D = self._D
        values = P @ D[:m]
        change = transform(tn - h * np.arange(m), values) - values
        D[:m] += P @ change  # the differences of the changes, added: no rounding of large y
        self.t, self.y = float(t0), np.array(y0, float)
        self._ist[I_JAC_CUR] = 0
        if fresh_jacobian:
            self._ist[I_JAC_OK] = 0
        return True

    def advance(self, t: float) -> np.ndarray:
        if self._frozen.active:
            # the compiled steps are not stopped at the sub-targets: it interpolates, as CVODE
            self._frozen.begin(self.t, self.y, t)
        return self._advance(t)

    def _advance(self, t: float, renew: bool = True) -> np.ndarray:
        """The compiled call to t (with ``renew``, the frozen ΔM's renewals on the way)."""
        m = self.model
        fz = self._frozen
        drive = (self._drive_for(float(t)), fz.arrays)
        ka = m.kernel_arrays
        if self._ist[I_STARTED] == 0:
            if not bdf_start(self.t, self.y, self._D, self._st, self._ist, ka, drive,
                             self._f, self._yw, K.general_flag(m.iprm)):
                raise SimulationError(f"BDF: non-finite right-hand side at t = {self.t:.6g} s")
        if t <= self.t:
            return self.y
        y = np.empty_like(self.y)
        common = (self._D, self._st, self._ist, ka, drive, self._kl, self._ku, self._jab,
                  self._lu, self._ipiv, self._backup, *m.jacobian_colors(self._kl, self._ku),
                  self.max_num_steps, K.general_flag(m.iprm))
        if fz.active and renew:
            code = bdf_frozen_advance(self.t, float(t), y, *common, fz.plan, m.frozen_beads,
                                      fz.work, *fz.renewal_arguments())
        else:
            code = bdf_advance(float(t), y, *common)
        if code != 0 or not np.all(np.isfinite(y)):
            why = {1: "step size fell below the rounding of t",
                   2: f"more than {self.max_num_steps} steps"}.get(code, "non-finite state")
            raise SimulationError(f"BDF failed at t = {self._st[S_T]:.6g} s: {why}")
        self.t, self.y = float(t), y
        return y
