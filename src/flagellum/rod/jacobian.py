"""Banded Jacobian of the pruned rod right-hand side by the chain rule through its layers.

:func:`flagellum.rod.kernels.rod_rhs` is a chain of local maps: bond vectors d_i (d_0 = u0)
and material angles θ_i → frames (:func:`~flagellum.rod.kernels.frame_of`) → the joints'
G_t, G_Θ (:func:`~flagellum.rod.kernels.joint_of`, frames i and i+1) → the bonds' forces on
the beads (G_t projected, plus stretching) → bead velocities through the local drag
(:mod:`flagellum.hydro.local`, whose tangent also depends on the state) → rates of the chart
(positions in the rotating frame, θ̇_i = ω3 − Ω t_z − s·ṫ) and the hook frame's balance
(:func:`~flagellum.rod.kernels.hook_of`, with the motor's clamp or law). Each layer's local
derivative is taken once per bead or joint and the blocks are multiplied out, so the whole
band costs a few right-hand sides instead of one per colour (:func:`colored_jacobian`).

Derivatives: closed form for the bond forces (projection and stretching), the chart rates
(spin connection, frame rotation), the drag of the free beads (force and averaged tangent)
and a joint's dependence on θ_a (through the twist only); one-sided differences of a joint's
terms in its other 7 inputs (the Hessian of the bend/twist energy through the transported
frames, whose closed form is long); central differences of the anchored bead's drag in its
tangent and of the hook balance in its 7 inputs. Every difference is of a function of a few
numbers, so its step suits that function alone (the coloured Jacobian's steps are shared by
whole groups of columns).

A frozen nonlocal mobility (``HYDRO_FROZEN``) adds ΔM's near field: the Jacobian is that of
the banded operator (local drag plus ΔM's blocks between beads at most ``I_NEAR`` apart, the
Newton matrix of docs/hydrodynamics.md), each bead's velocity window widened by those beads'
force derivatives times the frozen blocks.

Covered (:func:`covered`): forces as physical forces (``I_GEN = 0``), no end load, no cell
body, no per-joint shape, elastic scale ≠ 0 — every anchor, hook, drive and hydrodynamic
model of :func:`rod_rhs`. :func:`model_jacobian` falls back to the coloured finite
differences otherwise.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._jit import FASTMATH
from ..hydro import local as L
from . import kernels as K

#: relative step of the one-sided differences of a joint (bond vectors: × |d|; angles: × 1)
JOINT_STEP = 1e-8
#: relative step of the central differences of bead 0's drag and of the hook balance
CENTRAL_STEP = 1e-6


def covered(iprm, prm) -> bool:
    """Whether :func:`rod_jacobian` serves the model of (iprm, prm) (see the module doc)."""
    return bool(_covered(iprm, prm))


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _covered(iprm, prm):
    return (iprm[K.I_ANCHOR] != K.ANCHOR_CELL and iprm[K.I_SEGMENTS] == 0
            and iprm[K.I_EXTRA] == 0 and iprm[K.I_GEN] == 0 and prm[K.P_ELASTIC] != 0.0)


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _bond(y, i):
    if i == 0:
        return y[0], y[1], y[2]
    o, p = 3 + 4 * i, 3 + 4 * (i - 1)
    return y[o] - y[p], y[o + 1] - y[p + 1], y[o + 2] - y[p + 2]


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _frame(dx, dy, dz, co, si, ref_u, ref_e, i):
    return K.frame_of(dx, dy, dz, co, si, ref_u[i, 0], ref_u[i, 1], ref_u[i, 2],
                      ref_e[i, 0], ref_e[i, 1], ref_e[i, 2])


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _joint(fa, fb, tha, thb, refm, h, A, C, kap, tau):
    """:func:`~flagellum.rod.kernels.joint_of` of two frames (tuples of ``frame_of``):
    (G_t of a (3), G_t of b (3), G_Θ of b, G_Θ of a)."""
    r = K.joint_of(fa[1], fa[2], fa[3], fb[1], fb[2], fb[3], fb[7], fb[8], fb[9], fb[10], fb[11],
                   fb[12], fa[4], fa[5], fa[6], fb[4], fb[5], fb[6], tha, thb, refm, h, A, C,
                   kap, tau)
    return r[4], r[5], r[6], r[7], r[8], r[9], r[10], -r[11]


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _hook_rows(prm, iprm, el, ext_hook, ux, uy, uz, gx, gy, gz, gth, ref_u, ref_e):
    """ẏ[0:3] and θ̇0 of :func:`rod_rhs` from u0 and the hook frame's G_t, G_Θ."""
    fr = _frame(ux, uy, uz, 1.0, 0.0, ref_u, ref_e, 0)
    tx, ty, tz = fr[1], fr[2], fr[3]
    wx, wy, wz, _, _ = K.hook_of(prm, iprm, el, ext_hook[0], ext_hook[1], ext_hook[2],
                                 tx, ty, tz, gx, gy, gz, gth)
    wz -= prm[K.P_OMEGA]
    px, py, pz = K._cross(wx, wy, wz, ux, uy, uz)
    dtx, dty, dtz = K._cross(wx, wy, wz, tx, ty, tz)
    r6 = wx * tx + wy * ty + wz * tz - (fr[13] * dtx + fr[14] * dty + fr[15] * dtz)
    return px, py, pz, r6


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _put(ab, kv, kl, ku, scale, row, col, val):
    if -ku <= row - col <= kl:
        ab[col, kv + row - col] += scale * val


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _scatter(ab, kv, kl, ku, scale, row, q, f0, n):
    """Add the row ``q`` (4 values per frame f0, f0 + 1, …: ∂/∂d_f (3), ∂/∂θ_f) of output
    ``row`` to the band, turned into state columns: d_0 = u0, d_f = r_f − r_{f−1}, so
    ∂/∂r_b = ∂/∂d_b − ∂/∂d_{b+1} (b ≥ 1) and ∂/∂r_0 = −∂/∂d_1."""
    w = q.shape[0] // 4
    for s in range(-1, w):
        b = f0 + s
        if b < 0 or b > n:
            continue
        for c in range(3):
            v = 0.0
            if s >= 0 and b >= 1:
                v += q[4 * s + c]
            if s + 1 < w and b + 1 <= n:
                v -= q[4 * (s + 1) + c]
            if v != 0.0:
                _put(ab, kv, kl, ku, scale, row, 3 + 4 * b + c, v)
        if s >= 0:
            _put(ab, kv, kl, ku, scale, row, 6 + 4 * b, q[4 * s + 3])
    if f0 <= 0 < f0 + w:
        for c in range(3):
            _put(ab, kv, kl, ku, scale, row, c, q[-4 * f0 + c])


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def rod_jacobian(y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws, kl, ku, ab,
                 scale, y_work, f_work):
    """Jacobian of :func:`~flagellum.rod.kernels.rod_rhs` at y into LU-ready band storage
    (``ab[j, kl+ku+i−j] = scale · ∂f_i/∂y_j``, as :func:`colored_jacobian`) for a model
    that :func:`covered` accepts; ``f0`` is unused (the rhs at y is recomputed into
    ``f_work`` for the layers' intermediate values), ``y_work`` is scratch."""
    n = iprm[K.I_N]
    n1 = n + 1
    kv = kl + ku
    h = prm[K.P_H]
    A, C, Kst, kap, tau = prm[K.P_A], prm[K.P_C], prm[K.P_K], prm[K.P_KAPPA], prm[K.P_TAU]
    gpar, gperp, grot = prm[K.P_GPAR], prm[K.P_GPERP], prm[K.P_GROT]
    om = prm[K.P_OMEGA]
    el = prm[K.P_ELASTIC]
    anchor, zeta = iprm[K.I_ANCHOR], prm[K.P_SPHERE]
    # a frozen nonlocal ΔM: the Jacobian of the banded operator (its blocks between beads at
    # most nb apart), as the coloured differences take it
    nb = 0
    ip = iprm
    if iprm[K.I_HYDRO] != K.HYDRO_LOCAL:
        nb = min(iprm[K.I_NEAR], n)
        ip = iprm.copy()
        ip[K.I_HYDRO] = K.HYDRO_BANDED
    K.rod_rhs(y, f_work, prm, ip, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws)
    T, E1, E2, LEN, S, GT, GTH, DR, V, A1, CW, DG, DM = ws
    sw = prm[K.P_SECANT]  # ΔM = DM + sw DG (a secant model's value)
    ab[:, :] = 0.0
    # joints: d(G_t, G_Θ of frames k) over frames k−1 … k+1 (4 values each)
    dGT = np.zeros((n1, 3, 12))
    dGTH = np.zeros((n1, 12))
    fr = np.empty((n1, 16))
    for i in range(n1):
        dx, dy, dz = _bond(y, i)
        fri = _frame(dx, dy, dz, math.cos(y[6 + 4 * i]), math.sin(y[6 + 4 * i]), ref_u, ref_e, i)
        for k in range(16):
            fr[i, k] = fri[k]
    for j in range(n):
        a, b = j, j + 1
        tha, thb = y[6 + 4 * a], y[6 + 4 * b]
        fa = (fr[a, 0], fr[a, 1], fr[a, 2], fr[a, 3], fr[a, 4], fr[a, 5], fr[a, 6], fr[a, 7],
              fr[a, 8], fr[a, 9], fr[a, 10], fr[a, 11], fr[a, 12], fr[a, 13], fr[a, 14], fr[a, 15])
        fb = (fr[b, 0], fr[b, 1], fr[b, 2], fr[b, 3], fr[b, 4], fr[b, 5], fr[b, 6], fr[b, 7],
              fr[b, 8], fr[b, 9], fr[b, 10], fr[b, 11], fr[b, 12], fr[b, 13], fr[b, 14], fr[b, 15])
        g0 = _joint(fa, fb, tha, thb, ref_m[b], h, A, C, kap, tau)
        dax, day, daz = _bond(y, a)
        dbx, dby, dbz = _bond(y, b)
        coa, sia = math.cos(tha), math.sin(tha)
        cob, sib = math.cos(thb), math.sin(thb)
        for side in range(2):
            for c in range(4):
                if side == 0 and c == 3:
                    # θ_a enters only the twist ψ = θ_b − θ_a + m: dm3 = −C/h, G_t gets dm3 c/(1 + cos φ)
                    ux, uy, uz = K._cross(fa[1], fa[2], fa[3], fb[1], fb[2], fb[3])
                    cosp = fa[1] * fb[1] + fa[2] * fb[2] + fa[3] * fb[3]
                    dm3 = -el * C / h
                    kb = dm3 / (1.0 + cosp)
                    dGT[a, 0, 7] += kb * ux
                    dGT[a, 1, 7] += kb * uy
                    dGT[a, 2, 7] += kb * uz
                    dGT[b, 0, 3] += kb * ux
                    dGT[b, 1, 3] += kb * uy
                    dGT[b, 2, 3] += kb * uz
                    dGTH[b, 3] += dm3
                    dGTH[a, 7] -= dm3
                    continue
                if side == 0:
                    st = JOINT_STEP * fa[0]
                    ex, ey, ez = dax + (st if c == 0 else 0.0), day + (st if c == 1 else 0.0), \
                        daz + (st if c == 2 else 0.0)
                    g1 = _joint(_frame(ex, ey, ez, coa, sia, ref_u, ref_e, a), fb, tha, thb,
                                ref_m[b], h, A, C, kap, tau)
                elif c < 3:
                    st = JOINT_STEP * fb[0]
                    ex, ey, ez = dbx + (st if c == 0 else 0.0), dby + (st if c == 1 else 0.0), \
                        dbz + (st if c == 2 else 0.0)
                    g1 = _joint(fa, _frame(ex, ey, ez, cob, sib, ref_u, ref_e, b), tha, thb,
                                ref_m[b], h, A, C, kap, tau)
                else:
                    st = JOINT_STEP
                    th = thb + st
                    g1 = _joint(fa, _frame(dbx, dby, dbz, math.cos(th), math.sin(th), ref_u, ref_e,
                                           b), tha, th, ref_m[b], h, A, C, kap, tau)
                inv = el / st
                # a's window starts at frame a − 1 (a: slot 1), b's at frame a (a: slot 0)
                ca = 4 * (1 + side) + c
                cb = 4 * side + c
                for k in range(3):
                    dGT[a, k, ca] += (g1[k] - g0[k]) * inv
                    dGT[b, k, cb] += (g1[3 + k] - g0[3 + k]) * inv
                dGTH[b, cb] += (g1[6] - g0[6]) * inv
                dGTH[a, ca] += (g1[7] - g0[7]) * inv
    # bonds' forces fb_i = (g − (g·t)t)/ℓ + el K (ℓ/h − 1) t (bead_gradient), over frames i−1 … i+1
    dFB = np.zeros((n1, 3, 12))
    for i in range(1, n1):
        ln = LEN[i]
        t = (T[i, 0], T[i, 1], T[i, 2])
        g = (GT[i, 0], GT[i, 1], GT[i, 2])
        gt = g[0] * t[0] + g[1] * t[1] + g[2] * t[2]
        st = el * Kst * (ln / h - 1.0)
        for r in range(3):
            for c in range(3):
                P_rc = (1.0 if r == c else 0.0) - t[r] * t[c]
                gP_c = g[c] - gt * t[c]  # (gᵀP)_c
                m = (-(t[r] * gP_c + gt * P_rc) - (g[r] - gt * t[r]) * t[c]) / (ln * ln)
                m += el * Kst / h * t[r] * t[c] + st * P_rc / ln
                dFB[i, r, 4 + c] += m
                for qq in range(12):
                    dFB[i, r, qq] += P_rc / ln * dGT[i, c, qq]
    # bead forces DR_i = fb_i − fb_{i+1} (DR_0 = −fb_1, DR_n = fb_n), over frames i−1 … i+2
    dDR = np.zeros((n1, 3, 16))
    for i in range(n1):
        for r in range(3):
            for qq in range(12):
                if i >= 1:
                    dDR[i, r, qq] += dFB[i, r, qq]
                if i < n:
                    dDR[i, r, 4 + qq] -= dFB[i + 1, r, qq]
    # bead velocities V_i = M(t̄_i) (−DR_i), over frames i−1 … i+2
    dV = np.zeros((n1, 3, 16))
    G = np.empty((3, 3))
    for i in range(n1):
        tx, ty, tz, zpar, zperp, mode = L.bead_friction(T, i, n, h, gpar, gperp, anchor, zeta)
        fx, fy, fz = -DR[i, 0], -DR[i, 1], -DR[i, 2]
        for c in range(3):
            ux, uy, uz = L.bead_velocity(1.0 if c == 0 else 0.0, 1.0 if c == 1 else 0.0,
                                         1.0 if c == 2 else 0.0, tx, ty, tz, zpar, zperp, mode)
            for qq in range(16):
                dq = -dDR[i, c, qq]
                dV[i, 0, qq] += ux * dq
                dV[i, 1, qq] += uy * dq
                dV[i, 2, qq] += uz * dq
        # the drag's tangent t̄ (bead_node: bonds i and i+1, frames in slots 1 and 2)
        if i >= 1:  # free beads: dV = (1/ζ∥ − 1/ζ⊥)[t̄ Fᵀ + (F·t̄)] dt̄, dt̄ = (1 − t̄t̄ᵀ) dm/|m|
            if i < n:
                mx, my, mz = T[i, 0] + T[i + 1, 0], T[i, 1] + T[i + 1, 1], T[i, 2] + T[i + 1, 2]
                mn = math.sqrt(mx * mx + my * my + mz * mz)
            else:
                mn = 1.0
            tb = (tx, ty, tz)
            ff = (fx, fy, fz)
            ft = fx * tx + fy * ty + fz * tz
            dz = 1.0 / zpar - 1.0 / zperp
            for r in range(3):
                for c in range(3):
                    acc = 0.0
                    for k in range(3):  # [t̄ Fᵀ + (F·t̄)] (1 − t̄t̄ᵀ)
                        acc += (tb[r] * ff[k] + (ft if r == k else 0.0)) * \
                            ((1.0 if k == c else 0.0) - tb[k] * tb[c])
                    G[r, c] = dz * acc / mn
            for bnd in range(i, min(i + 1, n) + 1):
                sl = bnd - i + 1
                ln = LEN[bnd]
                for c in range(3):  # dm = dT_b = (1 − t_b t_bᵀ) dd_b/ℓ_b
                    for r in range(3):
                        acc = 0.0
                        for k in range(3):
                            acc += G[r, k] * ((1.0 if k == c else 0.0) - T[bnd, k] * T[bnd, c])
                        dV[i, r, 4 * sl + c] += acc / ln
            continue
        for bnd in range(1, 2):  # bead 0 (its anchor's mode): central differences
            sl = bnd - i + 1
            bx, by, bz = _bond(y, bnd)
            t0x, t0y, t0z = T[bnd, 0], T[bnd, 1], T[bnd, 2]
            for c in range(3):
                st = CENTRAL_STEP * LEN[bnd]
                v0, v1, v2 = 0.0, 0.0, 0.0
                for sg in range(2):
                    sgn = 1.0 if sg == 0 else -1.0
                    ex = bx + (sgn * st if c == 0 else 0.0)
                    ey = by + (sgn * st if c == 1 else 0.0)
                    ez = bz + (sgn * st if c == 2 else 0.0)
                    ln = math.sqrt(ex * ex + ey * ey + ez * ez)
                    T[bnd, 0], T[bnd, 1], T[bnd, 2] = ex / ln, ey / ln, ez / ln
                    px, py, pz, zp_, zn_, md = L.bead_friction(T, i, n, h, gpar, gperp, anchor, zeta)
                    vx, vy, vz = L.bead_velocity(fx, fy, fz, px, py, pz, zp_, zn_, md)
                    v0 += sgn * vx
                    v1 += sgn * vy
                    v2 += sgn * vz
                T[bnd, 0], T[bnd, 1], T[bnd, 2] = t0x, t0y, t0z
                dV[i, 0, 4 * sl + c] += v0 / (2.0 * st)
                dV[i, 1, 4 * sl + c] += v1 / (2.0 * st)
                dV[i, 2, 4 * sl + c] += v2 / (2.0 * st)
    # ΔM's near field: V_i += Σ_k ΔM_ik (−DR_k) over |k − i| ≤ nb, so each bead's window
    # widens by nb frames on either side (frames i − 1 − nb … i + 2 + nb)
    if nb > 0:
        wide = np.zeros((n1, 3, 4 * (4 + 2 * nb)))
        for i in range(n1):
            for r in range(3):
                for qq in range(16):
                    wide[i, r, 4 * nb + qq] = dV[i, r, qq]
            for k in range(max(0, i - nb), min(n, i + nb) + 1):
                off = 4 * (k - i + nb)  # bead k's window starts at frame k − 1
                for r in range(3):
                    for c in range(3):
                        d = DM[3 * i + r, 3 * k + c]
                        if sw != 0.0:
                            d += sw * DG[3 * i + r, 3 * k + c]
                        if d != 0.0:
                            for qq in range(16):
                                wide[i, r, off + qq] -= d * dDR[k, c, qq]
        dV = wide
    wv = dV.shape[2]
    # positions in the rotating frame: ẏ_i = V_i + Ω (y_i, −x_i, 0)
    for i in range(n1):
        o = 3 + 4 * i
        for k in range(3):
            _scatter(ab, kv, kl, ku, scale, o + k, dV[i, k], i - 1 - nb, n)
        _put(ab, kv, kl, ku, scale, o, o + 1, om)
        _put(ab, kv, kl, ku, scale, o + 1, o, -om)
    # bond spins: θ̇_i = −G_Θ,i/(γR h) − Ω t_z − s·Δ/ℓ, Δ = ẏ_i − ẏ_{i−1}; over frames i−2 … i+2
    zs = L.spin_friction(h, grot)
    q = np.zeros(wv + 4)  # frames i − 2 − nb … i + 2 + nb
    sh = 4 * nb
    for i in range(1, n1):
        o, p = 3 + 4 * i, 3 + 4 * (i - 1)
        q[:] = 0.0
        ln = LEN[i]
        t = (T[i, 0], T[i, 1], T[i, 2])
        sv = (S[i, 0], S[i, 1], S[i, 2])
        dl = (f_work[o] - f_work[p], f_work[o + 1] - f_work[p + 1], f_work[o + 2] - f_work[p + 2])
        sd = sv[0] * dl[0] + sv[1] * dl[1] + sv[2] * dl[2]
        for c in range(12):
            q[sh + 4 + c] -= dGTH[i, c] / zs
        for k in range(3):
            for c in range(wv):
                q[4 + c] -= sv[k] * dV[i, k, c] / ln
                q[c] += sv[k] * dV[i - 1, k, c] / ln
        # t, s and ℓ of frame i (slot 2): dt = P dd/ℓ, ds = −(u × dt)/D + c (u·dt)/D²
        ux, uy, uz = ref_u[i, 0], ref_u[i, 1], ref_u[i, 2]
        cx, cy, cz = K._cross(ux, uy, uz, t[0], t[1], t[2])
        D = 1.0 + ux * t[0] + uy * t[1] + uz * t[2]
        qx, qy, qz = K._cross(dl[0], dl[1], dl[2], ux, uy, uz)  # Δ × u
        cd = cx * dl[0] + cy * dl[1] + cz * dl[2]
        wt = (-qx / D + cd * ux / (D * D), -qy / D + cd * uy / (D * D),
              -qz / D + cd * uz / (D * D))
        for c in range(3):
            acc = 0.0
            for r in range(3):
                P_rc = (1.0 if r == c else 0.0) - t[r] * t[c]
                coef = -wt[r] / ln  # −(ds·Δ)/ℓ
                if r == 2:
                    coef -= om  # −Ω dt_z
                acc += coef * P_rc / ln
            q[sh + 8 + c] += acc + sd / (ln * ln) * t[c]
        _scatter(ab, kv, kl, ku, scale, o + 3, q, i - 2 - nb, n)
        # Δ's rotating-frame part Ω (δy_i − δy_{i−1}, −(δx_i − δx_{i−1}), 0)
        for bead, sg in ((i, 1.0), (i - 1, -1.0)):
            c0 = 3 + 4 * bead
            _put(ab, kv, kl, ku, scale, o + 3, c0 + 1, -sg * sv[0] * om / ln)
            _put(ab, kv, kl, ku, scale, o + 3, c0, sg * sv[1] * om / ln)
    # hook frame: ẏ[0:3], θ̇0 from (u0, G_t,0, G_Θ,0); G over frames −1 … 1
    inp = np.empty(7)
    inp[0], inp[1], inp[2] = y[0], y[1], y[2]
    inp[3], inp[4], inp[5], inp[6] = GT[0, 0], GT[0, 1], GT[0, 2], GTH[0]
    dh = np.zeros((4, 7))
    work = np.empty(7)
    for c in range(7):
        mag = LEN[0] if c < 3 else max(abs(inp[3]), abs(inp[4]), abs(inp[5]), abs(inp[6]), 1e-300)
        st = CENTRAL_STEP * mag
        for sg in range(2):
            sgn = 1.0 if sg == 0 else -1.0
            work[:] = inp
            work[c] += sgn * st
            r0, r1, r2, r3 = _hook_rows(prm, iprm, el, ext_hook, work[0], work[1], work[2], work[3],
                                        work[4], work[5], work[6], ref_u, ref_e)
            dh[0, c] += sgn * r0 / (2.0 * st)
            dh[1, c] += sgn * r1 / (2.0 * st)
            dh[2, c] += sgn * r2 / (2.0 * st)
            dh[3, c] += sgn * r3 / (2.0 * st)
    qh = np.zeros(12)
    for k in range(4):
        row = k if k < 3 else 6
        qh[:] = 0.0
        for c in range(3):
            qh[4 + c] += dh[k, c]
        for q12 in range(12):
            acc = dh[k, 6] * dGTH[0, q12]
            for c in range(3):
                acc += dh[k, 3 + c] * dGT[0, c, q12]
            qh[q12] += acc
        _scatter(ab, kv, kl, ku, scale, row, qh, -1, n)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def model_jacobian(general, y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws, kl,
                   ku, ab, scale, y_work, f_work, color, lo, hi):
    """:func:`rod_jacobian` where it is covered (``general`` None and :func:`covered`), else
    :func:`~flagellum.rod.kernels.model_colored_jacobian`. Returns the number of right-hand
    sides it cost (the chain rule: 1; the coloured differences: one per colour)."""
    if general is None and _covered(iprm, prm):
        rod_jacobian(y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws, kl, ku,
                     ab, scale, y_work, f_work)
        return 1
    K.model_colored_jacobian(general, y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m,
                             ext_hook, ws, kl, ku, ab, scale, y_work, f_work, color, lo, hi)
    return color.max() + 1
