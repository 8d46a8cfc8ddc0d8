"""Fixed-step drift-implicit Euler scheme for the overdamped (Brownian) dynamics.

One step of size Δt from state q_n (paper Eqs. (6)–(10))::

    q_{n+1} = q_n + Δt f(q_{n+1}) + Δt M(q_n) ξ_n + Δt kT ∂_q·M(q_n),

with f the deterministic drift, M the configuration-dependent mobility and ξ the thermal
forces and torques, Gaussian with ⟨ξξᵀ⟩ = 2kT R/Δt where R is the local friction of
Eqs. (8)–(10) (beads: w[γ∥ tt + γ⊥(1 − tt)], bonds: γR h, hook: γR h t t + ½γ⊥h³(1 − tt)).
The Itô drift kT ∂_q·M (which the paper's equations leave implicit) is sampled without
bias by a random finite difference (Delong et al., J. Chem. Phys. 140, 134110 (2014))::

    kT ∂_q·M ≈ (kT/δ) [M(q + δW/2) − M(q − δW/2)] W,   W ~ N(0, 1),

so the scheme samples the Boltzmann distribution to first order in Δt. A cell body adds
its own force and torque noise (covariance 2kT R/Δt of its resistance, :func:`body_noise`),
its orientation φ to the random finite difference, and the torque kT ∇ ln det J(φ) of the
invariant measure of its orientation (docs/motor.md, "Whole cell"). The implicit
equation is solved by a chord (simplified Newton) iteration with a banded Jacobian that is
reused over steps, accelerated by Anderson mixing (:func:`_anderson`); the Jacobian is
refreshed only when the iteration diverges (the thermal kicks of a step are large at the bond
scale, so a stale Jacobian converges slowly, which the mixing tolerates). An update that grows
the next one more than :data:`REVERT` times is undone, and a Newton step is taken from the last
contracting iterate with the Jacobian evaluated there (soft filaments: their kicks are not
taken back by the bending within the step, and the step's end lies where a chord iteration
from y_n diverges). With noise the
tolerance is a small fraction of the thermal step (:data:`THERMAL_TOL_FRACTION`).
Random numbers come from numpy's PCG64 in chunks, so a stopped run resumes the same stream.
A nonlocal mobility's ΔM, the Cholesky factor of M and its Itô drift are kept between
renewals, as ΔM is in a deterministic run, with the noise corrected for the local part's
change (:meth:`ImplicitStepper._nonlocal_increment`, docs/hydrodynamics.md, "Thermal noise").
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.extending import overload
from scipy.linalg import solve_triangular

from .._jit import FASTMATH
from ..errors import SimulationError
from ..hydro import body as Bd
from ..hydro import dynamics as D
from ..hydro import local as L
from ..rod import kernels as K
from .banded import band_factor, band_solve

RFD_DELTA = 1e-6
#: the error of a thermal step whose nonlocal mobility has no Cholesky factor
NOT_POSITIVE = ("the nonlocal mobility is not positive definite at this state (beads closer "
                "than the filament radius?)")
#: Newton tolerance [µm, rad]: 100× below the local error of one step at the default Δt
#: (≈ (ωΔt)² R/2 ≈ 1e-4 µm at M = 1, Δt = 5e-5 s); 1e-8 cost 20 % more iterations for nothing
NEWTON_TOL = 1e-6
#: with thermal noise the tolerance is at least this fraction of the bead's thermal step
#: √(2kTΔt/(γ⊥h)) (≈ 0.027 µm at Δt = 5e-5 s): trajectories then differ from fully converged
#: ones by ≈ 1e-5 µm, without accumulating over 2000 steps (docs/numerics.md)
THERMAL_TOL_FRACTION = 2e-3
#: with a nonlocal mobility, the largest bead kick per step (:func:`bead_kick`) in bond
#: lengths: ΔM is frozen over the step, and a kick past the bond length makes the step's
#: chord iteration fail (docs/hydrodynamics.md, "Thermal noise", "Step size")
NONLOCAL_KICK_LIMIT = 1.0
#: with a nonlocal mobility kept over thermal steps: renewed when a bond has changed by more
#: than this fraction of the turn limit (the noise's correction for the local part is then
#: third order in ‖S‖ ≲ 0.36, docs/hydrodynamics.md, "Thermal noise")
THERMAL_TURN = 0.5
#: …and after this many steps: one sample of the nonlocal Itô drift serves them all, and its
#: scatter, held, raised a stiff rod's tilt diffusion by 0.2/0.6/0.3/1.2 % at 2/3/4/8 steps
#: (± 0.2–0.35 %; docs/hydrodynamics.md, "What keeping costs in accuracy")
THERMAL_HOLD = 3


def bead_kick(kT: float, dt: float, gperp: float, h: float) -> float:
    """A bead's thermal displacement per step across the filament, √(2kTΔt/(γ⊥h)) [µm]
    (γ⊥ per length, h the bond length)."""
    return math.sqrt(2.0 * kT * dt / (gperp * h))


def nonlocal_dt_limit(kT: float, gperp: float, h: float) -> float:
    """The largest Δt [s] of a thermal run with a nonlocal mobility: the one whose
    :func:`bead_kick` is :data:`NONLOCAL_KICK_LIMIT` bond lengths."""
    return (NONLOCAL_KICK_LIMIT * h) ** 2 * gperp * h / (2.0 * kT)
#: a chord step that grows the update more than this many times is undone (see implicit_steps)
REVERT = 4.0


@njit(cache=True)
def thermal_forces(y, prm, iprm, ref_u, ref_e, kT, dt, g_f, g_m, g_h, ws, xi_f, xi_m, xi_h):
    """Thermal forces/torques of covariance 2kT R/Δt at state y from unit normals g_*, with R
    the local friction of :mod:`flagellum.hydro.local` (the drag of the right-hand side)."""
    n = iprm[K.I_N]
    h, gpar, gperp, grot = prm[K.P_H], prm[K.P_GPAR], prm[K.P_GPERP], prm[K.P_GROT]
    anchor, zeta = iprm[K.I_ANCHOR], prm[K.P_SPHERE]
    T, E1, E2, LEN, S = ws[0], ws[1], ws[2], ws[3], ws[4]
    K.frames(y, n, ref_u, ref_e, T, E1, E2, LEN, S, ws[9])
    c = math.sqrt(2.0 * kT / dt)
    for i in range(n + 1):
        tx, ty, tz, zpar, zperp, mode = L.bead_friction(T, i, n, h, gpar, gperp, anchor, zeta)
        xi_f[i, 0], xi_f[i, 1], xi_f[i, 2] = L.bead_noise(c, g_f[i, 0], g_f[i, 1], g_f[i, 2],
                                                          tx, ty, tz, zpar, zperp, mode)
        xi_m[i] = c * math.sqrt(L.spin_friction(h, grot)) * g_m[i] if i > 0 else 0.0
    tx, ty, tz = T[0, 0], T[0, 1], T[0, 2]
    gt = g_h[0] * tx + g_h[1] * ty + g_h[2] * tz
    # on a cell body a clamped hook frame turns with the body, with its full friction
    # (rod.kernels.cell_motion): its noise then has that covariance too
    cell = anchor == K.ANCHOR_CELL
    zt, zp = L.hook_friction(h, gperp, grot, iprm[K.I_HOOK] == K.HOOK_CLAMPED and not cell)
    a, b = c * math.sqrt(zt), c * math.sqrt(zp)
    xi_h[0] = a * gt * tx + b * (g_h[0] - gt * tx)
    xi_h[1] = a * gt * ty + b * (g_h[1] - gt * ty)
    xi_h[2] = a * gt * tz + b * (g_h[2] - gt * tz)
    if cell:
        body_noise(y, prm, iprm, c, g_h, xi_h)


@njit(cache=True)
def body_noise(y, prm, iprm, c, g, xi):
    """xi[3:9] = the cell body's thermal force and torque about its centre, c R^{1/2} g[3:9]
    with R its resistance (:func:`flagellum.hydro.body.body_resistance`, diagonal along and
    across the axis: drawn in the body frame, turned with Q), independent of the beads'
    (bead 0's own friction is its own noise, :func:`thermal_forces`)."""
    ny = y.shape[0]
    off = K.P_LAW + 2 * (iprm[K.I_NLAW] + iprm[K.I_NLAW_CW])
    Q = np.empty((3, 3))
    Bd.rotation_matrix(y[ny - 3], y[ny - 2], y[ny - 1], Q)
    for j in range(2):  # j = 0: force (prm[off], prm[off + 1]), 1: torque (prm[off + 2], …)
        o = 3 + 3 * j
        gb = np.empty(3)  # g in the body frame, scaled by √R there, turned back
        for i in range(3):
            gb[i] = Q[0, i] * g[o] + Q[1, i] * g[o + 1] + Q[2, i] * g[o + 2]
        ab = gb[0] * prm[off + 4] + gb[1] * prm[off + 5] + gb[2] * prm[off + 6]
        sa, st = c * math.sqrt(prm[off + 2 * j]), c * math.sqrt(prm[off + 2 * j + 1])
        for i in range(3):
            gb[i] = sa * ab * prm[off + 4 + i] + st * (gb[i] - ab * prm[off + 4 + i])
        for i in range(3):
            xi[o + i] = Q[i, 0] * gb[0] + Q[i, 1] * gb[1] + Q[i, 2] * gb[2]


@njit(cache=True)
def _mobility(y, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_h, ws, out, gen, general):
    """out = M(y) applied to the given forces (no elastic forces, motor or frame rotation)."""
    el, om, tq, g0 = prm[K.P_ELASTIC], prm[K.P_OMEGA], prm[K.P_TORQUE], iprm[K.I_GEN]
    prm[K.P_ELASTIC] = 0.0
    prm[K.P_OMEGA] = 0.0
    iprm[K.I_GEN] = gen
    K.model_rhs(general, y, out, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_h, ws)
    prm[K.P_ELASTIC], prm[K.P_OMEGA], prm[K.P_TORQUE], iprm[K.I_GEN] = el, om, tq, g0


@njit(cache=True)
def thermal_increment(y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, b, yp, ym, f1, f2,
                      zf, zm, zh, xi_f, xi_m, xi_h, xi_bead, general):
    """b = Δt M(y) ξ + Δt kT ∂·M(y) (random finite difference) from the unit normals g.
    ``xi_bead`` (n+1, 3), if not empty, replaces the bead part of ξ (the thermal forces of a
    nonlocal mobility, :meth:`ImplicitStepper._nonlocal_increment`); (n+3, 3) with a cell
    body: its last two rows replace the body's force and torque, and a clamped hook's noise
    keeps only its part along the hook's tangent."""
    n1 = iprm[K.I_N] + 1
    ny = y.shape[0]
    cell = iprm[K.I_ANCHOR] == K.ANCHOR_CELL
    o = 0
    gf = g[o:o + 3 * n1].reshape((n1, 3))
    o += 3 * n1
    gm = g[o:o + n1]
    o += n1
    gh = g[o:o + xi_h.shape[0]]  # the hook's 3 (a cell body's: its 6 more)
    o += xi_h.shape[0]
    thermal_forces(y, prm, iprm, ref_u, ref_e, kT, dt, gf, gm, gh, ws, xi_f, xi_m, xi_h)
    if xi_bead.shape[0] > 0:
        xi_f[:, :] = xi_bead[:n1]
    if xi_bead.shape[0] > n1:  # a cell body's force and torque of the nonlocal mobility
        for c in range(3):
            xi_h[3 + c] = xi_bead[n1, c]
            xi_h[6 + c] = xi_bead[n1 + 1, c]
        if iprm[K.I_HOOK] == K.HOOK_CLAMPED:  # its friction across the axis is in M_s
            t = ws[0]
            ht = xi_h[0] * t[0, 0] + xi_h[1] * t[0, 1] + xi_h[2] * t[0, 2]
            for c in range(3):
                xi_h[c] = ht * t[0, c]
    if cell:  # the invariant measure of the orientation: a torque kT ∇ ln det J(φ) (= its
        # generalized force, J⁻ᵀ φ = φ); with it the stationary density is exp(−E/kT) det J(φ)
        hx, hy, hz = Bd.haar_gradient(y[ny - 3], y[ny - 2], y[ny - 1])
        xi_h[6] += kT * hx
        xi_h[7] += kT * hy
        xi_h[8] += kT * hz
    _mobility(y, prm, iprm, ref_u, ref_e, ref_m, xi_f, xi_m, xi_h, ws, f1, 0, general)
    for i in range(ny):
        b[i] = dt * f1[i]
    wv = g[o:o + ny]
    for i in range(n1):
        for c in range(3):
            zf[i, c] = wv[3 + 4 * i + c]
        zm[i] = wv[6 + 4 * i]
    zf[0, 0], zf[0, 1], zf[0, 2] = L.bead_directions(iprm[K.I_ANCHOR], zf[0, 0], zf[0, 1], zf[0, 2])
    for i in range(ny):
        yp[i] = y[i]
        ym[i] = y[i]
    for i in range(n1):
        for c in range(3):
            yp[3 + 4 * i + c] += 0.5 * RFD_DELTA * zf[i, c]
            ym[3 + 4 * i + c] -= 0.5 * RFD_DELTA * zf[i, c]
        yp[6 + 4 * i] += 0.5 * RFD_DELTA * zm[i]
        ym[6 + 4 * i] -= 0.5 * RFD_DELTA * zm[i]
    if cell:  # the orientation: its generalized force W_φ is the torque J⁻ᵀ(φ) W_φ at each
        # perturbed state (the force conjugate to bead 0 at fixed φ is zf[0], at bead 0)
        for c in range(3):
            yp[ny - 3 + c] += 0.5 * RFD_DELTA * wv[ny - 3 + c]
            ym[ny - 3 + c] -= 0.5 * RFD_DELTA * wv[ny - 3 + c]
        zh[6], zh[7], zh[8] = Bd.rotvec_torque(yp[ny - 3], yp[ny - 2], yp[ny - 1], wv[ny - 3],
                                               wv[ny - 2], wv[ny - 1])
    _mobility(yp, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws, f1, 1, general)
    if cell:
        zh[6], zh[7], zh[8] = Bd.rotvec_torque(ym[ny - 3], ym[ny - 2], ym[ny - 1], wv[ny - 3],
                                               wv[ny - 2], wv[ny - 1])
    _mobility(ym, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws, f2, 1, general)
    for i in range(ny):
        b[i] += dt * kT / RFD_DELTA * (f1[i] - f2[i])
    zf[:, :] = 0.0
    zm[:] = 0.0
    zh[:] = 0.0


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _anderson(y, d, f_prev, g_prev, df, dg, a, gam, na, m):
    """One Anderson-accelerated chord update, in place: y ← g − ΔG γ with
    γ = argmin ‖F − ΔF γ‖₂ over the last ≤ m differences of the chord steps F = d and of
    their images g = y + d (Walker & Ni, SIAM J. Numer. Anal. 49, 1715 (2011)); the normal
    equations (m × m at most, regularized) are solved by Cholesky in the workspace a, gam."""
    ny = y.shape[0]
    if na > 0:
        slot = (na - 1) % m
        for i in range(ny):
            df[slot, i] = d[i] - f_prev[i]
            dg[slot, i] = y[i] + d[i] - g_prev[i]
    for i in range(ny):
        f_prev[i] = d[i]
        g_prev[i] = y[i] + d[i]
    mk = min(na, m)
    tr = 0.0
    for p in range(mk):
        for q in range(p, mk):
            s = 0.0
            for i in range(ny):
                s += df[p, i] * df[q, i]
            a[q, p] = s
        s = 0.0
        for i in range(ny):
            s += df[p, i] * d[i]
        gam[p] = s
        tr += a[p, p]
    for p in range(mk):  # Cholesky a = L Lᵀ (lower triangle), then forward/back substitution
        a[p, p] += 1e-10 * tr + 1e-300
        for q in range(p, mk):
            s = a[q, p]
            for k in range(p):
                s -= a[q, k] * a[p, k]
            a[q, p] = math.sqrt(s) if q == p else s / a[p, p]
        s = gam[p]
        for k in range(p):
            s -= a[p, k] * gam[k]
        gam[p] = s / a[p, p]
    for p in range(mk - 1, -1, -1):
        s = gam[p]
        for k in range(p + 1, mk):
            s -= a[k, p] * gam[k]
        gam[p] = s / a[p, p]
    for i in range(ny):
        v = y[i] + d[i]
        for p in range(mk):
            v -= gam[p] * dg[p, i]
        y[i] = v


@njit(cache=True)
def implicit_steps(y, t, n_steps, dt, theta, prm, iprm, ref_u, ref_e, ref_m, kT, torques, normals,
                   ws, ab, ipiv, backup, jac_age, jac_every, work, xwork, tol, max_iter, slow, hist,
                   colors, increments, general):
    """Advance y in place by ``n_steps`` drift-implicit steps of size ``dt``.

    θ-method (``theta`` in [1/2, 1])::

        y_{n+1} = y_n + Δt [θ f(y_{n+1}) + (1 − θ) f(y_n)] + b_n

    θ = 1 is implicit Euler (L-stable), θ = 1/2 the trapezoidal rule (exact stationary
    variance of harmonic modes at any Δt). ``theta = 0`` selects the drift-implicit BDF2
    scheme (Buckwar & Winkler, SIAM J. Numer. Anal. 44, 779 (2006))::

        y_{n+1} − 4/3 y_n + 1/3 y_{n−1} = 2/3 Δt f(y_{n+1}) + b_n − 1/3 b_{n−1},

    second order and L-stable: it damps the stiff modes like implicit Euler but damps an
    oscillation of frequency ν only at the rate ≈ ν⁴Δt³/4 instead of ν²Δt/2 (implicit Euler
    suppresses the buckling mode, ν ≈ 1400 rad/s in the co-rotating frame, at Δt = 5e-5 s).
    Its first step, and every step after a change of Δt, is an implicit Euler step.
    b_n = Δt M(y_n) ξ_n + Δt kT ∂·M(y_n) is the thermal increment; ``increments``
    (n_steps, ny), if it has columns, gives b_n of each step instead (a nonlocal mobility,
    whose increment is computed outside; ``normals`` is then not used).

    ``ab``, ``ipiv``: the factorized iteration matrix, kept between calls (``backup``:
    scratch for :func:`~flagellum.integrate.banded.band_factor`). ``colors`` = (color, lo, hi)
    of the Jacobian's columns (see :func:`~flagellum.rod.kernels.colored_jacobian`).
    ``torques[k]`` is the motor torque at the end of step k. ``normals`` (n_steps, m) holds
    the unit normals of each step (m = 0 for deterministic runs). ``hist`` = [history valid,
    its Δt, β of the factorized Jacobian, factors pivoted]; work[11], work[12] hold y_{n−1}
    and b_{n−1}; ``xwork`` (length ny + kl + ku, the Jacobian's band: ``ab`` has 2kl + ku + 1 columns,
    ``backup`` kl + ku + 1) is scratch of the solve. Returns (status,
    steps done, Newton iterations, Jacobians, jac_age); status
    0 = ok, 1 = Newton failed, 2 = non-finite state.
    """
    n = iprm[K.I_N]
    ny = y.shape[0]
    n1 = n + 1
    yn, b, f, d, yw, fw, yp, ym, f1, f2, fn, y1, b1 = (work[0], work[1], work[2], work[3], work[4],
                                                         work[5], work[6], work[7], work[8], work[9],
                                                         work[10], work[11], work[12])
    zf = np.zeros((n1, 3))
    zm = np.zeros(n1)
    nh = 9 if iprm[K.I_ANCHOR] == K.ANCHOR_CELL else 3  # (a cell body's force and torque)
    zh = np.zeros(nh)
    xi_f = np.zeros((n1, 3))
    xi_m = np.zeros(n1)
    xi_h = np.zeros(nh)
    aa_m = 4
    aa_f, aa_g = np.zeros(ny), np.zeros(ny)
    aa_df, aa_dg = np.zeros((aa_m, ny)), np.zeros((aa_m, ny))
    aa_a, aa_gam = np.zeros((aa_m, aa_m)), np.zeros(aa_m)
    yw2, dw2 = np.zeros(ny), np.zeros(ny)
    n_iter = 0
    n_jac = 0
    kl = ab.shape[1] - backup.shape[1]  # the model's Jacobian band, from the storage sizes
    ku = backup.shape[1] - 1 - kl
    kv = kl + ku
    T, E1, E2, LEN, S = ws[0], ws[1], ws[2], ws[3], ws[4]
    bdf2 = theta == 0.0
    for k in range(n_steps):
        # charts centred on the current tangents: the spin connection s vanishes at y_n, which
        # decouples the angles from the stiff bead motions within the step (and leaves the
        # angles of y_{n−1} unchanged: transport there and back is the identity)
        K.rechart_all(y, n, ref_u, ref_e, T, E1, E2, LEN, S, ws[9])
        yn[:] = y
        b[:] = 0.0
        if increments.shape[1] > 0:
            b[:] = increments[k]
        elif kT > 0.0:
            thermal_increment(y, dt, kT, normals[k], prm, iprm, ref_u, ref_e, ref_m, ws, b, yp, ym,
                              f1, f2, zf, zm, zh, xi_f, xi_m, xi_h, zf[:0], general)
        two = bdf2 and hist[0] == 1.0 and abs(hist[1] - dt) <= 1e-9 * dt
        beta = 2.0 / 3.0 if two else (1.0 if bdf2 else theta)
        for i in range(ny):  # d ← everything of the residual that does not depend on y_{n+1}
            d[i] = (4.0 * yn[i] - y1[i] - b1[i]) / 3.0 + b[i] if two else yn[i] + b[i]
        if beta < 1.0 and not two:
            K.model_rhs(general, yn, fn, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws)
            for i in range(ny):
                d[i] += (1.0 - theta) * dt * fn[i]
        for i in range(ny):
            fn[i] = d[i]
        # a factorization of I − β'ΔtJ with another β' (an Euler step after a restart, then
        # BDF2 again) is kept: the chord iteration with it still contracts, by
        # |1 − β/β'| ≤ 1/2 along the stiff modes, and converges to the same solution
        prm[K.P_TORQUE] = torques[k]
        # predictor y_n: the linear solve filters the noise through the stiff modes
        converged = False
        prev = np.inf
        na = 0  # Anderson history (differences of chord steps and of their images)
        jac_here = False  # the factorized Jacobian was evaluated at the last accepted iterate
        for it in range(max_iter):
            fresh = jac_age < 0 or jac_age >= jac_every
            if fresh:
                K.model_rhs(general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws)
                K.model_colored_jacobian(general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh,
                                         ws, kl, ku, ab, -beta * dt, yw, fw, colors[0], colors[1],
                                         colors[2])
                for j in range(ny):
                    ab[j, kv] += 1.0
                hist[2] = beta
                info, pivoted = band_factor(ab, kl, ku, ipiv, backup)
                if info != 0:
                    return 1, k, n_iter, n_jac, -1
                hist[3] = 1.0 if pivoted else 0.0
                jac_age = 0
                n_jac += 1
                na = 0
            if not fresh:  # (a fresh Jacobian has just evaluated f at y)
                K.model_rhs(general, y, f, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws)
            for i in range(ny):
                d[i] = -(y[i] - fn[i] - beta * dt * f[i])
            band_solve(ab, kl, ku, ipiv, d, hist[3] != 0.0, xwork)
            err = 0.0
            for i in range(ny):
                err = max(err, abs(d[i]))
            n_iter += 1
            if not np.isfinite(err):
                err = np.inf
            # converged when the update is below tol or, with noise, the error left after it
            # estimated from the contraction rate ρ (Hairer & Wanner IV.8: ρ/(1 − ρ)·|d|)
            rho = err / prev if prev < np.inf and kT > 0.0 else 1.0
            if err < tol or (rho < 0.9 and rho / (1.0 - rho) * err < tol and err < 10.0 * tol):
                for i in range(ny):
                    y[i] += d[i]
                converged = True
                break
            if err > slow * prev and not fresh and err < REVERT * prev:
                jac_age = -1  # stale Jacobian too slow: refresh here (and judge it afresh)
                prev = np.inf
                continue
            if err > slow * prev:
                # far off: back to the last iterate that contracted, and from there a Newton
                # step with the Jacobian evaluated there (or, if it was, half the step): large
                # thermal kicks of soft filaments leave the region where a chord step converges
                for i in range(ny):
                    y[i] = yw2[i]
                if jac_here:
                    for i in range(ny):
                        y[i] += 0.5 * dw2[i]
                    jac_here = False
                jac_age = -1
                na = 0
                prev = np.inf
                continue
            prev = err
            for i in range(ny):
                yw2[i] = y[i]
                dw2[i] = d[i]
            jac_here = fresh
            _anderson(y, d, aa_f, aa_g, aa_df, aa_dg, aa_a, aa_gam, na, aa_m)
            na += 1
        if not converged:
            y[:] = yn  # leave the state at the start of the failed step
            return 1, k, n_iter, n_jac, -1
        nu = math.sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2])
        y[0] /= nu
        y[1] /= nu
        y[2] /= nu
        for i in range(ny):
            if not np.isfinite(y[i]):
                y[:] = yn
                return 2, k, n_iter, n_jac, -1
        y1[:] = yn
        b1[:] = b
        hist[0] = 1.0
        hist[1] = dt
        jac_age += 1
    return 0, n_steps, n_iter, n_jac, jac_age


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _lower_solve(chol, z, k):
    """z := L⁻¹ z, L = chol[:k, :k] lower triangular (rows read contiguously)."""
    for i in range(k):
        acc = z[i]
        for j in range(i):
            acc -= chol[i, j] * z[j]
        z[i] = acc / chol[i, i]


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _upper_solve_t(chol, z, k):
    """z := L⁻ᵀ z, L = chol[:k, :k] lower triangular: column form, each step subtracting a
    multiple of row i of L (read contiguously) from the unknowns before it."""
    for i in range(k - 1, -1, -1):
        zi = z[i] / chol[i, i]
        z[i] = zi
        for j in range(i):
            z[j] -= chol[i, j] * zi


@njit(cache=True)
def _local_change(T, tm, n, h, gpar, gperp, anchor, zeta, f, out):
    """out = E f, E = M_loc(T) − M_loc(tm) the change of the local mobility between the bond
    tangents tm and T (block-diagonal, :func:`flagellum.hydro.local.bead_velocity`)."""
    for i in range(n + 1):
        fx, fy, fz = f[i, 0], f[i, 1], f[i, 2]
        tx, ty, tz, zpar, zperp, mode = L.bead_friction(T, i, n, h, gpar, gperp, anchor, zeta)
        ax, ay, az = L.bead_velocity(fx, fy, fz, tx, ty, tz, zpar, zperp, mode)
        tx, ty, tz, zpar, zperp, mode = L.bead_friction(tm, i, n, h, gpar, gperp, anchor, zeta)
        cx, cy, cz = L.bead_velocity(fx, fy, fz, tx, ty, tz, zpar, zperp, mode)
        out[i, 0], out[i, 1], out[i, 2] = ax - cx, ay - cy, az - cz


@njit(cache=True)
def add_kept_terms(y, dt, drift, xi, frozen, build, chol, b, iprm, ref_u, ref_e, ws):
    """b += Δt · (the nonlocal Itô drift kept from the renewal, ``drift``, bead velocities
    (3(n+1)) per unit time, plus the correction of the noise for the local mobility's change
    since the renewal, −½ E ξ − ⅛ E M_s⁻¹ E ξ, of the bead forces ``xi`` (n+1, 3)).

    E = M_loc(y) − M_loc(y*), y* the renewal's beads ``frozen``; M_s = M_s(y*) = L Lᵀ
    (``chol``, over the components the anchor leaves free; ``build`` ΔM's build arguments).
    :func:`thermal_increment` applies M_s' = M_s + E (the step's mobility) to
    ξ = √(2kT/Δt) L⁻ᵀ g, whose covariance would be 2kT/Δt (M_s' + E + E M_s⁻¹ E): first
    order off, a spurious drift. With the correction the noise is √(2kT/Δt) L (I + S/2 −
    S²/8) g, S = L⁻¹ E L⁻ᵀ, the series of L (I + S)^{1/2}, of covariance
    2kT/Δt (M_s' − L (S³/8 − S⁴/64) Lᵀ): third order in the bonds' turn since the renewal.
    Bead velocities enter as positions and as the bond angles' rates −s_i·ṫ_i in y's charts
    (every chart moves each step, :func:`flagellum.rod.kernels.rechart_all`)."""
    n = iprm[K.I_N]
    n1 = n + 1
    h, gpar, gperp, anchor, zeta = build[1], build[2], build[3], build[4], build[5]
    T, E1, E2, LEN, S, A1 = ws[0], ws[1], ws[2], ws[3], ws[4], ws[9]
    K.frames(y, n, ref_u, ref_e, T, E1, E2, LEN, S, A1)
    tm = D._bond_tangents(frozen)
    ex = np.empty((n1, 3))
    _local_change(T, tm, n, h, gpar, gperp, anchor, zeta, xi, ex)
    # w = M_s⁻¹ E ξ over the free components: L z = E ξ, then Lᵀ w = z (row-wise)
    nf = D.fixed_components(anchor)
    k = 3 * n1 - nf
    z = ex.reshape(3 * n1)[nf:].copy()
    _lower_solve(chol, z, k)
    _upper_solve_t(chol, z, k)
    wv = np.zeros((n1, 3))
    wf = wv.reshape(3 * n1)
    for i in range(k):
        wf[nf + i] = z[i]
    ew = np.empty((n1, 3))
    _local_change(T, tm, n, h, gpar, gperp, anchor, zeta, wv, ew)
    v = np.empty((n1, 3))
    for i in range(n1):
        for a in range(3):
            v[i, a] = drift[3 * i + a] - 0.5 * ex[i, a] - 0.125 * ew[i, a]
    for i in range(n1):
        o = 3 + 4 * i
        for a in range(3):
            b[o + a] += dt * v[i, a]
        if i > 0:
            b[o + 3] -= dt * (S[i, 0] * (v[i, 0] - v[i - 1, 0]) + S[i, 1] * (v[i, 1] - v[i - 1, 1])
                              + S[i, 2] * (v[i, 2] - v[i - 1, 2])) / LEN[i]


@njit(cache=True)
def _rfd_forces(g, o, n1, nf, S, T, LEN):
    """The physical bead forces (n1, 3) of the random finite difference's perturbation W
    (its normals g[o + 3 + 4i …], the beads' positions and bond angles in the state's
    order; the anchor's ``nf`` fixed components zero): W's bead part, with the chart's
    correction of the θ-forces as the kernel's (I_GEN, :func:`flagellum.rod.kernels.chart_force`)."""
    F = np.empty((n1, 3))
    for i in range(n1):
        for a in range(3):
            F[i, a] = g[o + 3 + 4 * i + a] if 3 * i + a >= nf else 0.0
    for i in range(1, n1):
        gv = K.chart_force(g[o + 3 + 4 * i + 3], S, T, LEN, i)
        for a in range(3):
            F[i, a] -= gv[a]
            F[i - 1, a] += gv[a]
    return F


@njit(cache=True)
def _difference_product(perturbed, base, f, scale, out):
    """out = ``scale`` (perturbed − base) f: the random finite difference's product, with no
    copy of the matrices."""
    for i in range(out.shape[0]):
        acc = 0.0
        for j in range(out.shape[0]):
            acc += (perturbed[i, j] - base[i, j]) * f[j]
        out[i] = scale * acc


@njit(cache=True)
def nonlocal_increment(y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, frozen, build, ms, b,
                       yp, ym, f1, f2, general, chol, drift, limits):
    """:meth:`ImplicitStepper._nonlocal_increment` compiled, for a filament without a cell
    body (anchored, on a load sphere or a free swimmer's sphere); returns whether it renewed
    the mobility. Renewal (``limits`` = (refresh [µm], bond change [µm], force, steps since
    the renewal, hold), the steps counted here): when ``refresh`` is 0, ``force`` is set,
    the mobility has served ``hold`` steps, or the beads have used the limits since
    ``frozen`` (:func:`flagellum.hydro.dynamics.limits_used`): ΔM rebuilt at y (into the workspace's DM,
    ``frozen`` := the beads), M_s = M_loc + ΔM factorized over the components the anchor
    leaves free (into ``chol``) and the nonlocal Itô drift by random finite difference (into
    ``drift``, bead velocities per unit time; the rates of the bond angles that they imply
    are taken at each step, :func:`add_kept_terms`). Every step: the noise M ξ from the kept factor
    and the drift into ``b``. ``build`` the arguments of ΔM's compiled build (symmetric),
    ``ms`` scratch of ΔM's size. One call per step instead of a dozen numpy and scipy calls
    from Python (docs/hydrodynamics.md, "Thermal cost"). Raises numpy's LinAlgError where
    M_s is not positive definite."""
    n = iprm[K.I_N]
    n1 = n + 1
    ny = y.shape[0]
    K.rechart_all(y, n, ref_u, ref_e, ws[0], ws[1], ws[2], ws[3], ws[4], ws[9])
    x = np.empty((n1, 3))
    for i in range(n1):
        for a in range(3):
            x[i, a] = y[3 + 4 * i + a]
    dm = ws[-1]
    m = 3 * n1
    anchor = build[4]
    nf = D.fixed_components(anchor)
    k = m - nf
    renew = limits[0] <= 0.0 or limits[2] != 0.0 or limits[3] >= limits[4] or \
        D.limits_used(x, frozen, n1, limits[0], limits[1]) > 1.0
    limits[3] = 1.0 if renew else limits[3] + 1.0
    if renew:
        D._correction_into(x, *build, dm)
        for i in range(n1):
            for a in range(3):
                frozen[i, a] = x[i, a]
        for i in range(m):
            for j in range(m):
                ms[i, j] = dm[i, j]
        D._fill_local(D._bond_tangents(x), n, build[1], build[2], build[3], anchor, build[5], ms, 1.0)
        c = np.linalg.cholesky(ms[nf:, nf:])
        for i in range(k):
            for j in range(k):
                chol[i, j] = c[i, j]
    # ξ = √(2kT/Δt) L⁻ᵀ g over the free components (back substitution)
    c = math.sqrt(2.0 * kT / dt)
    zq = g[nf:m].copy()
    _upper_solve_t(chol, zq, k)
    xq = np.zeros(m)
    for i in range(k):
        xq[nf + i] = zq[i]
    xi = np.empty((n1, 3))
    for i in range(n1):
        for a in range(3):
            xi[i, a] = c * xq[3 * i + a]
    nh = 3
    zf, zm, zh = np.zeros((n1, 3)), np.zeros(n1), np.zeros(nh)
    thermal_increment(y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, b, yp, ym, f1, f2,
                      zf, zm, zh, np.zeros((n1, 3)), np.zeros(n1), np.zeros(nh), xi, general)
    if renew:
        o = 4 * n1 + nh
        for i in range(n1):
            for a in range(3):
                w = g[o + 3 + 4 * i + a] if 3 * i + a >= nf else 0.0
                x[i, a] = y[3 + 4 * i + a] + RFD_DELTA * w
        D._correction_into(x, *build, ms)  # ΔM(y + δW), DM keeps ΔM(y)
        T, E1, E2, LEN, S, A1 = ws[0], ws[1], ws[2], ws[3], ws[4], ws[9]
        K.frames(y, n, ref_u, ref_e, T, E1, E2, LEN, S, A1)
        F = _rfd_forces(g, o, n1, nf, S, T, LEN)
        _difference_product(ms, dm, F.reshape(m), kT / RFD_DELTA, drift)
    add_kept_terms(y, dt, drift, xi, frozen, build, chol, b, iprm, ref_u, ref_e, ws)
    return renew


@njit(cache=True)
def _cell_local_parts(points, n, build):
    """(bond tangents, the 6×6 body block) of a cell's local mobility at its mobility
    points (:func:`flagellum.hydro.dynamics.cell_local_mobility`); ``build``
    :func:`flagellum.hydro.dynamics.cell_build_arguments`."""
    h, gpar, gperp = build[1], build[2], build[3]
    radius, aspect, rb, hf = build[5], build[6], build[7], build[8]
    beads = points[:n + 1]
    centre, axis = D.cell_frame(points)
    return D._bond_tangents(beads), D._body_block(beads, h, gpar, gperp, centre, axis, rb, hf,
                                                  radius, aspect)


@njit(cache=True)
def _cell_local_change(now, then, n, build, f, out):
    """out = E f over a cell's slots (V, beads 1 … n, Ω), E = M_cell,loc(now) −
    M_cell,loc(then) the change of the local mobility (block-diagonal over the beads, a
    6×6 block over (V, Ω)) between two sets of mobility points, given by their
    :func:`_cell_local_parts` ``now`` and ``then`` (taken once per step, applied twice)."""
    h, gpar, gperp = build[1], build[2], build[3]
    k = 3 * (n + 1)
    for i in range(k + 3):
        out[i] = 0.0
    for sign, parts in ((1.0, now), (-1.0, then)):
        T, gi = parts
        for i in range(1, n + 1):
            tx, ty, tz, zpar, zperp, mode = L.bead_friction(T, i, n, h, gpar, gperp, L.CELL, 0.0)
            o = 3 * i
            ax, ay, az = L.bead_velocity(f[o], f[o + 1], f[o + 2], tx, ty, tz, zpar, zperp, mode)
            out[o] += sign * ax
            out[o + 1] += sign * ay
            out[o + 2] += sign * az
        for a in range(6):
            oa = a if a < 3 else k + a - 3
            acc = 0.0
            for c in range(6):
                acc += gi[a, c] * f[c if c < 3 else k + c - 3]
            out[oa] += sign * acc


@njit(cache=True)
def _set_turn(prm, iprm, R, turned):
    """Let the kernel apply the frozen ΔM turned by R, R ΔM Rᵀ (``turned``), or as built:
    the rotation in the cell body's block (:data:`flagellum.hydro.body.ROTATION`)."""
    off = K.P_LAW + 2 * (iprm[K.I_NLAW] + iprm[K.I_NLAW_CW]) + Bd.ROTATION
    for a in range(3):
        for c in range(3):
            prm[off + 3 * a + c] = R[a, c]
    prm[off + 9] = 1.0 if turned else 0.0


@njit(cache=True)
def cell_nonlocal_increment(y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, frozen, geometry,
                            build, ms, b, yp, ym, f1, f2, general, chol, drift, limits):
    """:func:`nonlocal_increment` for a cell body, over its slots q = (V, beads 1 … n, Ω)
    (:func:`flagellum.hydro.dynamics.cell_mobility`); returns whether it renewed. ``frozen``
    the mobility points of the last renewal (beads, the body's centre and front pole),
    ``geometry`` the arguments of :func:`flagellum.hydro.dynamics.cell_points`, ``build``
    those of :func:`flagellum.hydro.dynamics.cell_correction_points` (symmetric). Renewal
    as :func:`nonlocal_increment`: ΔM rebuilt, M_s = M_cell,loc + ΔM factorized, and the
    nonlocal Itô drift kT [ΔM(y + δW) − ΔM(y)] g_W/δ (g_W the slot forces of the
    perturbation W of beads, bond angles and orientation: the bead forces with the chart's
    θ-forces, the body's torque J⁻ᵀ(φ) W_φ + d × F_0) kept as the slot force
    u = M_s⁻¹ v (``drift``). Every step the slot forces
    ξ' = ξ + u + M_s⁻¹ E (−½ ξ − u + ⅜ M_s⁻¹ E ξ), ξ = √(2kT/Δt) L⁻ᵀ g, go through the
    kernel, which applies M_s + E (E = M_cell,loc(y) − M_cell,loc(y*)) and the cell's
    kinematics: the noise M (I + A)^{1/2} ξ + O(A³) (A = M_s⁻¹ E) has the covariance
    2kT (M_s + E)/Δt to third order in A, and the drift (M_s + E)(I − A) u = v to second
    (docs/hydrodynamics.md, "Thermal noise")."""
    n = iprm[K.I_N]
    n1 = n + 1
    ny = y.shape[0]
    K.rechart_all(y, n, ref_u, ref_e, ws[0], ws[1], ws[2], ws[3], ws[4], ws[9])
    pts = np.empty((n1 + 2, 3))
    D.cell_points(y, n1, geometry[0], geometry[1], geometry[2], pts)
    dm = ws[-1]
    k = 3 * n1 + 3
    R = np.eye(3)
    renew = limits[0] <= 0.0 or limits[2] != 0.0 or limits[3] >= limits[4]
    turned = False
    if not renew:  # the limits used after the best rotation of the frozen points, or without
        fit = np.empty((3, 3))
        used = D.rotated_limits_used(pts, frozen, n1, limits[0], limits[1], fit)
        plain = D.limits_used(pts, frozen, n1, limits[0], limits[1])
        turned = used < plain
        if turned:
            R[:, :] = fit
        renew = min(used, plain) > 1.0
        turned = turned and not renew
    limits[3] = 1.0 if renew else limits[3] + 1.0
    _set_turn(prm, iprm, R, turned)
    h, gpar, gperp = build[1], build[2], build[3]
    radius, aspect, rb, hf = build[5], build[6], build[7], build[8]
    if renew:
        D.cell_correction_points(pts, *build, dm)
        for i in range(n1 + 2):
            for a in range(3):
                frozen[i, a] = pts[i, a]
        for i in range(k):
            for j in range(k):
                ms[i, j] = dm[i, j]
        D.cell_local_points(pts, h, gpar, gperp, radius, aspect, rb, hf, 1.0, ms)
        c = np.linalg.cholesky(ms)
        for i in range(k):
            for j in range(k):
                chol[i, j] = c[i, j]
    # ξ = √(2kT/Δt) L⁻ᵀ g over the slots: bead 0's normals for V, the body torque's for Ω
    xq = np.empty(k)
    for i in range(3 * n1):
        xq[i] = g[i]
    for a in range(3):
        xq[3 * n1 + a] = g[4 * n1 + 6 + a]
    _upper_solve_t(chol, xq, k)
    c = math.sqrt(2.0 * kT / dt)
    for i in range(k):
        xq[i] *= c
    T, E1, E2, LEN, S, A1 = ws[0], ws[1], ws[2], ws[3], ws[4], ws[9]
    if renew:
        o = 4 * n1 + 9
        for i in range(ny):
            yp[i] = y[i]
        for i in range(n1):
            for a in range(3):
                yp[3 + 4 * i + a] += RFD_DELTA * g[o + 3 + 4 * i + a]
        for a in range(3):
            yp[ny - 3 + a] += RFD_DELTA * g[o + ny - 3 + a]
        ppts = np.empty((n1 + 2, 3))
        D.cell_points(yp, n1, geometry[0], geometry[1], geometry[2], ppts)
        D.cell_correction_points(ppts, *build, ms)  # ΔM(y + δW); DM keeps ΔM(y)
        K.frames(y, n, ref_u, ref_e, T, E1, E2, LEN, S, A1)
        F = _rfd_forces(g, o, n1, 0, S, T, LEN)
        gen = np.empty(k)
        for i in range(3 * n1):
            gen[i] = F[i // 3, i % 3]
        d0, d1, d2 = pts[0, 0] - pts[n1, 0], pts[0, 1] - pts[n1, 1], pts[0, 2] - pts[n1, 2]
        tx, ty, tz = Bd.rotvec_torque(y[ny - 3], y[ny - 2], y[ny - 1], g[o + ny - 3],
                                      g[o + ny - 2], g[o + ny - 1])
        gen[3 * n1] = tx + d1 * F[0, 2] - d2 * F[0, 1]
        gen[3 * n1 + 1] = ty + d2 * F[0, 0] - d0 * F[0, 2]
        gen[3 * n1 + 2] = tz + d0 * F[0, 1] - d1 * F[0, 0]
        if iprm[K.I_HOOK] == K.HOOK_CLAMPED:  # the hook frame's θ-force, a torque about t_0 on
            # the body, less its part about the motor axis m (the hook's own rate there)
            centre, axis = D.cell_frame(pts)
            mm = D._motor_axis(pts[0], centre, axis, radius, aspect)
            w0 = g[o + 6]
            tm = T[0, 0] * mm[0] + T[0, 1] * mm[1] + T[0, 2] * mm[2]
            for a in range(3):
                gen[3 * n1 + a] += w0 * (T[0, a] - tm * mm[a])
        _difference_product(ms, dm, gen, kT / RFD_DELTA, drift)
        _lower_solve(chol, drift, k)  # kept as the slot force M_s⁻¹ v
        _upper_solve_t(chol, drift, k)
        for i in range(k):
            xq[i] += drift[i]
    else:  # in the renewal's orientation: the points turned back, Q = Rᵀ P about point 0
        q = np.empty_like(pts)
        for i in range(n1 + 2):
            for a in range(3):
                q[i, a] = frozen[0, a] + R[0, a] * (pts[i, 0] - pts[0, 0]) + \
                    R[1, a] * (pts[i, 1] - pts[0, 1]) + R[2, a] * (pts[i, 2] - pts[0, 2])
        e = np.empty(k)
        w = np.empty(k)
        now, then = _cell_local_parts(q, n, build), _cell_local_parts(frozen, n, build)
        _cell_local_change(now, then, n, build, xq, e)  # E ξ
        _lower_solve(chol, e, k)
        _upper_solve_t(chol, e, k)
        for i in range(k):
            w[i] = -0.5 * xq[i] - drift[i] + 0.375 * e[i]
        _cell_local_change(now, then, n, build, w, e)
        _lower_solve(chol, e, k)
        _upper_solve_t(chol, e, k)
        for i in range(k):
            xq[i] += drift[i] + e[i]
        if turned:  # the slot forces turned by R, as the cell (each slot a 3-vector)
            for i in range(0, k, 3):
                a0, a1, a2 = xq[i], xq[i + 1], xq[i + 2]
                for a in range(3):
                    xq[i + a] = R[a, 0] * a0 + R[a, 1] * a1 + R[a, 2] * a2
    xi = np.zeros((n1 + 2, 3))  # bead forces (none on bead 0), the body's force and torque
    for i in range(1, n1):
        for a in range(3):
            xi[i, a] = xq[3 * i + a]
    for a in range(3):
        xi[n1, a] = xq[a]
        xi[n1 + 1, a] = xq[3 * n1 + a]
    nh = 9
    zf, zm, zh = np.zeros((n1, 3)), np.zeros(n1), np.zeros(nh)
    thermal_increment(y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, b, yp, ym, f1, f2,
                      zf, zm, zh, np.zeros((n1, 3)), np.zeros(n1), np.zeros(nh), xi, general)
    return renew


def _increment(geometry, y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, frozen, build, ms, b,
               yp, ym, f1, f2, general, chol, drift, limits):
    """:func:`nonlocal_increment` (``geometry`` None) or :func:`cell_nonlocal_increment`
    (``geometry`` a cell body's), chosen by type when Numba compiles the caller."""


@overload(_increment)
def _increment_by_type(geometry, y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, frozen, build,
                       ms, b, yp, ym, f1, f2, general, chol, drift, limits):
    if isinstance(geometry, types.NoneType):
        def filament(geometry, y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, frozen, build,
                     ms, b, yp, ym, f1, f2, general, chol, drift, limits):
            return nonlocal_increment(y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, frozen,
                                      build, ms, b, yp, ym, f1, f2, general, chol, drift, limits)
        return filament

    def cell(geometry, y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, frozen, build, ms, b,
             yp, ym, f1, f2, general, chol, drift, limits):
        return cell_nonlocal_increment(y, dt, kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, frozen,
                                       geometry, build, ms, b, yp, ym, f1, f2, general, chol,
                                       drift, limits)
    return cell


@njit(cache=True)
def nonlocal_steps(y, t, n_steps, dt, theta, prm, iprm, ref_u, ref_e, ref_m, kT, torques, normals,
                   ws, ab, ipiv, backup, jac_age, jac_every, work, xwork, tol, max_iter, slow, hist,
                   colors, general, frozen, geometry, build, ms, chol, drift, limits, inc):
    """:func:`implicit_steps` one step at a time, each after its thermal increment from
    :func:`nonlocal_increment` at y_n (``geometry`` None) or, with a cell body, from
    :func:`cell_nonlocal_increment` (``geometry`` its body's, the branch Numba keeps): one
    compiled call per chunk of steps instead of two Python calls per step. ``inc`` (1, ny)
    scratch; the arguments after ``general`` are the increment's (``limits[2]``, the force
    flag, is cleared after the first step). Returns (status, steps done, Newton
    iterations, Jacobians, jac_age, renewals) with the status of :func:`implicit_steps`."""
    n_iter, n_jac, renewals = 0, 0, 0
    for j in range(n_steps):
        if _increment(geometry, y, dt, kT, normals[j], prm, iprm, ref_u, ref_e, ref_m, ws, frozen,
                      build, ms, inc[0], work[6], work[7], work[8], work[9], general, chol,
                      drift, limits):
            renewals += 1
        limits[2] = 0.0
        status, _, it, nj, jac_age = implicit_steps(
            y, t + j * dt, 1, dt, theta, prm, iprm, ref_u, ref_e, ref_m, kT, torques[j:j + 1],
            normals[j:j + 1], ws, ab, ipiv, backup, jac_age, jac_every, work, xwork, tol,
            max_iter, slow, hist, colors, inc, general)
        n_iter += it
        n_jac += nj
        if status != 0:
            return status, j, n_iter, n_jac, jac_age, renewals
    return 0, n_steps, n_iter, n_jac, jac_age, renewals


class ImplicitStepper:
    """Fixed-step drift-implicit stepper: BDF2 (``theta=None`` or ``"bdf2"``, the default) or
    the θ-method (θ in [1/2, 1]); see :func:`implicit_steps`.

    ``tol``: Newton tolerance [µm, rad]; by default :data:`NEWTON_TOL`, raised with thermal
    noise to :data:`THERMAL_TOL_FRACTION` of a bead's thermal step.
    ``advance(t)`` takes ⌈(t − t_now)/dt⌉ equal steps (the step is shortened evenly so that
    t is hit exactly); the random stream is numpy's PCG64 seeded with ``seed`` and can be
    restored from ``rng_state`` (see :attr:`rng_state`). Satisfies
    :class:`flagellum.integrate.base.Stepper`.
    """

    def __init__(self, model, t0: float, y0: np.ndarray, dt: float, kT: float = 0.0,
                 seed: int = 0, rng_state=None, theta: float | None = None,
                 jac_every: int = 50, tol: float | None = None, slow: float = 1.5, max_iter: int = 30):
        self.model = model
        self.dt = float(dt)
        self.kT = float(kT)
        self.theta = 0.0 if theta is None or theta == "bdf2" else float(theta)  # 0: BDF2
        self.seed = int(seed)
        self.rng = np.random.Generator(np.random.PCG64(seed))
        if rng_state is not None:
            self.rng.bit_generator.state = rng_state
        self.jac_every = int(jac_every)
        self.tol = NEWTON_TOL if tol is None else float(tol)
        if self.kT > 0 and tol is None:
            gperp, h = model.prm[K.P_GPERP], model.prm[K.P_H]
            step = bead_kick(self.kT, self.dt, gperp, h)
            self.tol = max(self.tol, THERMAL_TOL_FRACTION * step)
        self.slow, self.max_iter = float(slow), int(max_iter)
        ny = len(y0)
        self._kl, self._ku = kl, ku = model.jacobian_band
        self._ab = np.zeros((ny, 2 * kl + ku + 1))
        self._ipiv = np.zeros(ny, np.int64)
        self._backup = np.zeros((ny, kl + ku + 1))
        self._work = np.zeros((13, ny))
        self._xwork = np.zeros(ny + kl + ku)
        self._hist = np.zeros(4)
        # per step: beads (3 + 1 each), hook (3), a cell body's force and torque (6), the
        # random finite difference (ny)
        self._n_normals = (4 * (model.n + 1) + 3 + 6 * model.cell + ny) if self.kT > 0 else 0
        # thermal noise of a nonlocal mobility: increments built outside the kernel each step
        self._nonlocal_noise = self.kT > 0 and model.iprm[K.I_HYDRO] != K.HYDRO_LOCAL
        if self._nonlocal_noise:
            model.symmetric_mobility = True  # fluctuation–dissipation: noise of M_s, drift M_s F
            model.refresh_mobility(np.asarray(y0, float), force=True)
        # deterministic, frozen nonlocal mobility: ΔM checked (rebuilt, turned or kept) before
        # every step, not only between the simulator's chunks
        # (refresh 0: rebuilt before every step, the fixed-step scheme's unfrozen reference)
        self._checks = self.kT == 0 and model.iprm[K.I_HYDRO] != K.HYDRO_LOCAL
        self._no_increments = np.zeros((0, 0))
        self._fast = None  # (build arguments, scratch) of nonlocal_increment
        # the thermal mobility kept between renewals: its Cholesky factor (and the free
        # components), the Itô drift per unit time (state layout); renewed at the next step
        # when None (a new or reset stepper)
        self._kept = None
        # nonlocal_increment's limits: refresh, bond change, renew now, steps since the
        # renewal, THERMAL_HOLD
        self._limits = np.zeros(5)
        #: renewals of the thermal mobility (ΔM, its factor and drift) so far
        self.n_renewals = 0
        #: without a cell body, the nonlocal increment in one compiled call
        #: (:func:`nonlocal_increment`; False: the numpy path a cell body takes)
        self.compiled_increment = True
        self.n_steps = self.n_iter = self.n_jac = 0
        self.reset(t0, y0)

    @property
    def tracks_mobility(self) -> bool:
        """Whether :meth:`advance` checks a frozen nonlocal ΔM itself (deterministic runs:
        before every step; thermal ones rebuild it at every step)."""
        return self._checks or self._nonlocal_noise

    @classmethod
    def from_options(cls, model, t: float, y: np.ndarray, options, *, kT: float = 0.0,
                     seed: int = 0, rng_state=None) -> "ImplicitStepper":
        """The stepper of ``options`` (``dt``; ``theta`` when ``scheme`` is ``"theta"``,
        else BDF2) with noise at ``kT`` from the stream ``seed`` / ``rng_state``."""
        return cls(model, t, y, options.dt, kT=kT, seed=seed, rng_state=rng_state,
                   theta=options.theta if options.scheme == "theta" else None)

    @property
    def fixed_step(self) -> float:
        """Δt [s] (:meth:`advance` shortens its steps evenly when the span is no multiple of it)."""
        return self.dt

    @property
    def rng_state(self):
        """State of the PCG64 stream (a JSON-serializable dict)."""
        return self.rng.bit_generator.state

    def reset(self, t0: float, y0: np.ndarray) -> None:
        """Restart at (t0, y0) as a new stepper would (no BDF2 history, a fresh Jacobian), so
        that a run resumed from a checkpoint repeats the uninterrupted one bit for bit."""
        self.t = float(t0)
        self.y = np.array(y0, float)
        self._jac_age = -1
        self._hist = np.zeros(4)  # new right-hand side: no BDF2 history
        self._kept = None  # a thermal nonlocal mobility: renewed at the next step

    def carry(self, t0: float, y0: np.ndarray, transform=None, fresh_jacobian: bool = False,
              frame_turned: bool = True) -> bool:
        """Continue at (t0, y0) after a change of the state's coordinates (a chart
        re-centred, the frame's rate changed): as :meth:`reset` (BDF2's history is not
        carried: returns False), but a thermal nonlocal mobility kept between renewals stays
        kept where only charts moved, for it depends on the bead positions alone, which a
        chart leaves as they are (its drift's bond-angle rates are taken in the step's charts
        anyway). Where the frame's rate changed the kept beads would have to turn with the
        past: it is renewed, and a deterministic run's ΔM rebuilt, as at a reset."""
        keep = self._nonlocal_noise and not frame_turned and self._kept is not None
        if not keep:
            self.model.refresh_mobility(y0, force=True)
        kept = self._kept
        self.reset(t0, y0)
        if keep:
            self._kept = kept
        return False

    def advance(self, t: float) -> np.ndarray:
        span = t - self.t
        if span <= 0:
            return self.y
        k = max(1, int(math.ceil(span / self.dt - 1e-9)))
        dt = span / k
        times = self.t + dt * np.arange(1, k + 1)
        normals = (self.rng.standard_normal((k, self._n_normals)) if self._n_normals
                   else np.zeros((k, 0)))
        done = 0
        while done < k:
            n_ok = self._steps(self.t + done * dt, k - done, dt, times[done:], normals[done:])
            done += n_ok
            if done < k:  # step `done` failed: redo it as two half steps (Brownian bridge)
                self._split_step(self.t + done * dt, dt, normals[done], depth=1)
                done += 1
        self.t = float(t)
        return self.y

    def _steps(self, t0, k, dt, times, normals) -> int:
        if self._nonlocal_noise and self.compiled_increment:
            return self._compiled_steps(t0, k, dt, times, normals)
        if self._nonlocal_noise:  # one step at a time: the increment needs the mobility at y_n
            for j in range(k):
                inc = self._nonlocal_increment(self.y, normals[j], dt)
                if self._kernel_steps(t0 + j * dt, 1, dt, times[j:j + 1], normals[j:j + 1], inc[None]) != 1:
                    return j
            return k
        if self._checks:  # one step at a time: ΔM checked at y_n (a rebuild jumps: no ramp)
            for j in range(k):
                self.model.refresh_mobility(self.y)
                if self._kernel_steps(t0 + j * dt, 1, dt, times[j:j + 1], normals[j:j + 1],
                                      self._no_increments) != 1:
                    return j
            return k
        return self._kernel_steps(t0, k, dt, times, normals, self._no_increments)

    def _kernel_steps(self, t0, k, dt, times, normals, increments) -> int:
        m = self.model
        torques = np.array([m.motor(s) for s in times])
        status, done, it, nj, self._jac_age = implicit_steps(
            self.y, t0, k, dt, self.theta, m.prm, m.iprm, m.ref_u, m.ref_e, m.ref_m, self.kT, torques,
            np.ascontiguousarray(normals), m.kernel_arrays[-1], self._ab, self._ipiv, self._backup, self._jac_age,
            self.jac_every, self._work, self._xwork, self.tol, self.max_iter, self.slow, self._hist,
            m.jacobian_colors(self._kl, self._ku), increments, K.general_flag(m.iprm))
        self.n_steps += done
        self.n_iter += it
        self.n_jac += nj
        return done if status != 0 else k

    def _fast_arguments(self):
        """(build arguments, ΔM scratch, Cholesky factor, kept drift, limits) of
        :func:`nonlocal_increment` (``limits[2]``: renew at the next step)."""
        m = self.model
        if self._fast is None:
            ws = m.kernel_arrays[-1]
            build = m.cell_build_arguments() if m.cell else m.build_arguments()
            self._fast = (build, np.empty_like(ws[-1]), np.empty_like(ws[-1]),
                          np.zeros(len(ws[-1])))
        self._limits[:3] = (m.hydrodynamics.refresh, THERMAL_TURN * m.turn_limit * m.h,
                            float(self._kept is None))
        self._limits[4] = THERMAL_HOLD
        return (*self._fast, self._limits)

    def _frozen_arguments(self) -> tuple:
        """(frozen points, geometry) of the compiled increments: the beads and None, or a cell
        body's mobility points and :meth:`RodModel.cell_geometry`."""
        m = self.model
        return (m.mobility_points, m.cell_geometry()) if m.cell else (m.frozen_beads, None)

    def _compiled_steps(self, t0, k, dt, times, normals) -> int:
        m = self.model
        torques = np.array([m.motor(s) for s in times])
        build, scratch, chol, drift, limits = self._fast_arguments()
        try:
            status, done, it, nj, self._jac_age, renewals = nonlocal_steps(
                self.y, t0, k, dt, self.theta, m.prm, m.iprm, m.ref_u, m.ref_e, m.ref_m, self.kT,
                torques, np.ascontiguousarray(normals), m.kernel_arrays[-1], self._ab, self._ipiv,
                self._backup, self._jac_age, self.jac_every, self._work, self._xwork, self.tol,
                self.max_iter, self.slow, self._hist, m.jacobian_colors(self._kl, self._ku),
                K.general_flag(m.iprm), *self._frozen_arguments(), build, scratch, chol, drift,
                limits, np.empty((1, len(self.y))))
        except np.linalg.LinAlgError:
            raise SimulationError(NOT_POSITIVE) from None
        self._kept = True
        self.n_steps += done
        self.n_iter += it
        self.n_jac += nj
        self.n_renewals += renewals
        return done if status != 0 else k

    def _nonlocal_increment(self, y, g, dt) -> np.ndarray:
        """Thermal increment b = Δt M ξ + Δt kT ∂·M of one step from y with the nonlocal
        mobility (docs/hydrodynamics.md, "Thermal noise").

        Without a cell body the mobility is kept between renewals, as in a deterministic
        run: it is renewed (ΔM rebuilt at y, its symmetric part M_s:
        :attr:`RodModel.symmetric_mobility`) at the first step after construction or
        :meth:`reset`, and when a bead has moved by more than ``hydrodynamics.refresh`` or a
        bond by more than the turn limit since the last renewal
        (:meth:`RodModel.mobility_use`; ``refresh`` 0: every step). A cell body's is renewed
        at every step. At a renewal M_s = L Lᵀ is factorized (Cholesky, over the components
        the anchor leaves free) and the Itô drift is sampled: the random finite difference
        of :func:`thermal_increment` covers the local part and the charts (ΔM held),
        kT [ΔM(y + δW) − ΔM(y)] W/δ the nonlocal correction (Delong et al. 2014; a cell
        body's orientation among the perturbed coordinates), kept per unit time. Every step
        draws ξ = √(2kT/Δt) L⁻ᵀ g from the kept factor and applies the mobility of the step
        (M_loc at y, the kept ΔM), so that the noise has the covariance 2kT M_s/Δt at the
        renewal's state; between renewals the local part's change is corrected to first
        order and the kept drift is taken in the step's charts (:func:`add_kept_terms`).
        Spins and the hook frame keep their local noise.
        With a cell body M_s is over its slots
        (V, beads 1 … n, Ω; :meth:`RodModel.mobility_matrix`): ξ's first and last parts are
        the body's force and torque about its centre (from the normals of bead 0 and of the
        body's torque), bead 0 has none of its own, and a clamped hook's noise keeps only its
        part about the motor axis (the part across it, the hook's friction turning with the
        body, is in M_s).
        """
        m = self.model
        prm, iprm, ref_u, ref_e, ref_m, _, _, _, ws = m.kernel_arrays
        n1 = m.n + 1
        ny = len(y)
        w = self._work
        if self.compiled_increment:
            build, scratch, chol, drift, limits = self._fast_arguments()
            b = np.empty(ny)
            try:
                if m.cell:
                    renewed = cell_nonlocal_increment(
                        y, dt, self.kT, g, prm, iprm, ref_u, ref_e, ref_m, ws,
                        *self._frozen_arguments(), build, scratch, b, w[6], w[7], w[8], w[9],
                        K.general_flag(iprm), chol, drift, limits)
                else:
                    renewed = nonlocal_increment(y, dt, self.kT, g, prm, iprm, ref_u, ref_e, ref_m,
                                                 ws, m.frozen_beads, build, scratch, b, w[6], w[7],
                                                 w[8], w[9], K.general_flag(iprm), chol, drift,
                                                 limits)
            except np.linalg.LinAlgError:
                raise SimulationError(NOT_POSITIVE) from None
            self._kept = True
            self.n_renewals += renewed
            return b
        K.rechart_all(y, m.n, ref_u, ref_e, ws[0], ws[1], ws[2], ws[3], ws[4], ws[9])  # as the kernel
        refresh = m.hydrodynamics.refresh
        renew = (m.cell or self._kept is None or refresh <= 0.0 or self._limits[3] >= THERMAL_HOLD
                 or m.mobility_use(y) > 1.0)
        self._limits[3] = 1.0 if renew else self._limits[3] + 1.0
        if renew:
            m.refresh_mobility(y, force=True)
            ms, free = m.mobility_matrix(y)
            try:
                chol = np.linalg.cholesky(ms[np.ix_(free, free)])
            except np.linalg.LinAlgError:
                raise SimulationError(NOT_POSITIVE) from None
        else:
            chol, free, drift = self._kept
        nh = 9 if m.cell else 3
        gq = g[:3 * n1]
        if m.cell:  # the slots (V, beads 1 … n, Ω): bead 0's normals and the body torque's
            gq = np.concatenate([gq, g[4 * n1 + 6:4 * n1 + 9]])
        xq = np.zeros(len(free))
        xq[free] = math.sqrt(2.0 * self.kT / dt) * solve_triangular(chol, gq[free], lower=True,
                                                                    trans="T")
        if m.cell:  # bead forces (none on bead 0), then the body's force and torque
            xi = np.zeros((n1 + 2, 3))
            xi[1:n1] = xq[3:3 * n1].reshape(-1, 3)
            xi[n1], xi[n1 + 1] = xq[:3], xq[3 * n1:]
        else:
            xi = xq.reshape(n1, 3)
        b, yp, ym, f1, f2 = np.empty(ny), w[6], w[7], w[8], w[9]
        zf, zm, zh = np.zeros((n1, 3)), np.zeros(n1), np.zeros(nh)
        thermal_increment(y, dt, self.kT, g, prm, iprm, ref_u, ref_e, ref_m, ws, b, yp, ym, f1, f2,
                          zf, zm, zh, np.zeros((n1, 3)), np.zeros(n1), np.zeros(nh), xi,
                          K.general_flag(iprm))
        if renew:
            o = 4 * n1 + nh
            wv = g[o:o + ny]
            zf[:] = wv[3:3 + 4 * n1].reshape(n1, 4)[:, :3]
            zf.reshape(-1)[~free[:3 * n1]] = 0.0
            zm[:] = wv[3:3 + 4 * n1].reshape(n1, 4)[:, 3]
            yp = y.copy()
            yp[3:3 + 4 * n1].reshape(n1, 4)[:, :3] += RFD_DELTA * zf
            if m.cell:  # the orientation's generalized force: the torque J⁻ᵀ(φ) W_φ at y
                yp[-3:] += RFD_DELTA * wv[-3:]
                zh[6:9] = Bd.rotvec_torque(y[-3], y[-2], y[-1], wv[-3], wv[-2], wv[-1])
            dm = ws[-1]
            frozen = dm.copy()
            dm[:] = m.correction_at(yp)
            _mobility(y, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws, f1, 1, K.general_flag(iprm))
            dm[:] = frozen
            _mobility(y, prm, iprm, ref_u, ref_e, ref_m, zf, zm, zh, ws, f2, 1, K.general_flag(iprm))
            # bead velocities: the kernel's angle and hook rates follow from them (zero here)
            drift = self.kT / RFD_DELTA * (f1 - f2)[3:3 + 4 * n1].reshape(n1, 4)[:, :3].ravel()
            self._kept = (chol, free, drift)
            self.n_renewals += 1
        if m.cell:  # renewed at every step (this order of the products: the same bits as ever)
            b += dt * self.kT / RFD_DELTA * (f1 - f2)
        else:
            add_kept_terms(y, dt, drift, xi, m.frozen_beads, m.build_arguments(), chol, b, iprm,
                           ref_u, ref_e, ws)
        return b

    def _split_step(self, t0, dt, g, depth):
        """Two half steps whose noise increments add up to the failed step's (bridge)."""
        if depth > 6:
            raise SimulationError(f"implicit step failed at t = {t0:.6g} s even with the step "
                                  f"divided by {2 ** (depth - 1)}: Newton iteration did not "
                                  f"converge (the filament may have blown up; try a smaller --dt)")
        h = dt / 2
        if len(g):  # seeded by the step's start time: the same bits in a resumed run
            key = [self.seed, int(np.float64(t0).view(np.uint64)), depth]
            extra = np.random.Generator(np.random.PCG64(key)).standard_normal(len(g))
            halves = ((g + extra) / math.sqrt(2), (g - extra) / math.sqrt(2))
        else:
            halves = (g, g)
        for j, gj in enumerate(halves):
            tj = t0 + j * h
            if self._steps(tj, 1, h, np.array([tj + h]), gj[None, :]) != 1:
                self._split_step(tj, h, gj, depth + 1)
