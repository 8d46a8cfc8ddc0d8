"""Numba kernels of the discrete Kirchhoff rod (paper Sec. 2.1–2.3).

State layout (bead by bead, so that the Jacobian is banded)::

    y = [u0x, u0y, u0z,  x0, y0, z0, θ0,  x1, y1, z1, θ1,  …,  xN, yN, zN, θN]

``u0`` is the (unnormalized) tangent of the hook frame 0, ``θ0`` its material angle;
``r_i`` are the beads, ``θ_i`` (i ≥ 1) the material angle of bond i (bead i−1 → bead i).
A cell body (anchor ``ANCHOR_CELL``) appends its orientation, a rotation vector φ (3 values,
:mod:`flagellum.hydro.body`); bead 0 is then the motor point on the body's surface.

Material frames. Frame i has tangent t_i (t_0 = u0/|u0|, t_i = (r_i − r_{i−1})/|…|) and a
reference vector a1 = P(u_i → t_i) e_i obtained by parallel transport from a chart pole u_i
(a lab-fixed unit vector, e_i ⟂ u_i); e1 = cos θ a1 + sin θ a2, e2 = t × e1. A chart is
singular only at t = −u_i; the simulator moves the pole before it gets there (θ unchanged).
When t moves, a1 spins about t at the rate s·ṫ with s = −(u × t)/(1 + u·t).

Strains between frames a = j and b = j+1 follow the paper's construction (twist about e3,
then bend about e3⁽ʲ⁾ × e3⁽ʲ⁺¹⁾): with c = t_a × t_b and φ the bend angle, ::

    h Ω1 = φ/sin φ · c·e1_b,   h Ω2 = φ/sin φ · c·e2_b,   h Ω3 = ψ = ∠(P_ab e1_a, e1_b),

(ψ is accumulated as θ_b − θ_a plus the reference twist, i.e. not wrapped to (−π, π]),

and E_j = h/2 [A Ω1² + A (Ω2 − κ0)² + C (Ω3 − τ0)²]; stretching K h/2 (|r_i − r_{i−1}|/h − 1)².

Gradients are taken with the material frames *transported* in the variation (the
gauge-invariant derivative): δe1 = δΘ e2 − (e1·δt) t with material spin δΘ = δθ + s·δt.
This gives G_t (∂E/∂t at fixed material spin) and G_Θ = ∂E/∂θ; the physical force on the
beads follows from G_t alone, so it does not depend on the choice of reference frames.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._jit import FASTMATH, atan2
from ..hydro import body as B
from ..hydro import local as L

HOOK_FREE, HOOK_ELASTIC, HOOK_CLAMPED = 0, 1, 2
#: how bead 0 moves: the drag kernels' codes (anchored, on a load sphere, free swimmer with a
#: centred body sphere, on a cell body free in 3D)
ANCHOR_FIXED, ANCHOR_SPHERE, ANCHOR_FREE, ANCHOR_CELL = L.FIXED, L.AXIAL, L.FREE, L.CELL


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def chart_force(m, S, T, LEN, i):
    """The bead force g that a generalized force m conjugate to θ_i (i ≥ 1) stands for through
    the chart's spin connection s_i: g = (m s_i − (m s_i·t_i) t_i)/|b_i|, taken off bead i and
    added to bead i − 1 (the Itô drift's generalized forces, :func:`rhs` with I_GEN)."""
    sx, sy, sz = m * S[i, 0], m * S[i, 1], m * S[i, 2]
    st = sx * T[i, 0] + sy * T[i, 1] + sz * T[i, 2]
    return ((sx - st * T[i, 0]) / LEN[i], (sy - st * T[i, 1]) / LEN[i],
            (sz - st * T[i, 2]) / LEN[i])


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def frame_of(dx, dy, dz, co, si, ux, uy, uz, ex, ey, ez):
    """One frame of :func:`frames` from its bond vector d (u0 for the hook frame), material
    angle θ (co, si = cos θ, sin θ) and chart (pole u, vector e): (|d|, t (3), a1 (3),
    e1 (3), e2 (3), s (3))."""
    ln = math.sqrt(dx * dx + dy * dy + dz * dz)
    tx, ty, tz = dx / ln, dy / ln, dz / ln
    d = ux * tx + uy * ty + uz * tz
    cx, cy, cz = _cross(ux, uy, uz, tx, ty, tz)
    # a1 = P(u→t) e = d e + c×e + (c·e)/(1+d) c
    qx, qy, qz = _cross(cx, cy, cz, ex, ey, ez)
    ce = (cx * ex + cy * ey + cz * ez) / (1.0 + d)
    a1x, a1y, a1z = d * ex + qx + ce * cx, d * ey + qy + ce * cy, d * ez + qz + ce * cz
    a2x, a2y, a2z = _cross(tx, ty, tz, a1x, a1y, a1z)
    return (ln, tx, ty, tz, a1x, a1y, a1z,
            co * a1x + si * a2x, co * a1y + si * a2y, co * a1z + si * a2z,
            co * a2x - si * a1x, co * a2y - si * a1y, co * a2z - si * a1z,
            -cx / (1.0 + d), -cy / (1.0 + d), -cz / (1.0 + d))


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def frames(y, n, ref_u, ref_e, T, E1, E2, LEN, S, A1):
    """Fill tangents T, material vectors E1, E2, bond lengths LEN, spin connections S and
    reference vectors A1 = P(u→t) e (so that E1 = cos θ A1 + sin θ t × A1).

    Arrays have shape (n+1, 3) (LEN: n+1); row 0 is the hook frame (LEN[0] = |u0|).
    """
    for i in range(n + 1):
        if i == 0:
            dx, dy, dz = y[0], y[1], y[2]
        else:
            o, p = 3 + 4 * i, 3 + 4 * (i - 1)
            dx, dy, dz = y[o] - y[p], y[o + 1] - y[p + 1], y[o + 2] - y[p + 2]
        th = y[6 + 4 * i]
        (LEN[i], T[i, 0], T[i, 1], T[i, 2], A1[i, 0], A1[i, 1], A1[i, 2], E1[i, 0], E1[i, 1],
         E1[i, 2], E2[i, 0], E2[i, 1], E2[i, 2], S[i, 0], S[i, 1], S[i, 2]) = frame_of(
            dx, dy, dz, math.cos(th), math.sin(th), ref_u[i, 0], ref_u[i, 1], ref_u[i, 2],
            ref_e[i, 0], ref_e[i, 1], ref_e[i, 2])


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def joint_of(tax, tay, taz, tbx, tby, tbz, e1x, e1y, e1z, e2x, e2y, e2z, vx, vy, vz, rx, ry, rz,
             tha, thb, refm, h, A, C, kap, tau):
    """One joint of :func:`elastic` between frames a and b (tangents, b's material vectors,
    both reference vectors a1, material angles, the twist's branch ``refm``, intrinsic
    curvature ``kap`` and torsion ``tau``): (energy, Ω1, Ω2, ψ, its parts of G_t of a (3)
    and of b (3), of G_Θ of b, minus its part of G_Θ of a)."""
    cx, cy, cz = _cross(tax, tay, taz, tbx, tby, tbz)
    cosp = tax * tbx + tay * tby + taz * tbz
    sinp = math.sqrt(cx * cx + cy * cy + cz * cz)
    phi = atan2(sinp, cosp)
    if phi < 1e-4:
        p2 = phi * phi
        f = 1.0 + p2 / 6.0 + 7.0 * p2 * p2 / 360.0
        g = 1.0 / 3.0 + 2.0 * p2 / 15.0
    else:
        f = phi / sinp
        g = (sinp - phi * cosp) / (sinp * sinp * sinp)
    k1 = f * (cx * e1x + cy * e1y + cz * e1z) / h
    k2 = f * (cx * e2x + cy * e2y + cz * e2z) / h
    # twist ψ = θ_b − θ_a + m, with m the angle from P(ta→tb) a1_a to a1_b about tb
    # (reference vectors a1 = cos θ e1 − sin θ e2), taken on the branch nearest to the
    # last known value refm: ψ is never wrapped, so the energy has no cusp and a 2π
    # twist costs what it should (no spurious twist slips).
    qx, qy, qz = _cross(cx, cy, cz, vx, vy, vz)
    cv = (cx * vx + cy * vy + cz * vz) / (1.0 + cosp)
    px, py, pz = cosp * vx + qx + cv * cx, cosp * vy + qy + cv * cy, cosp * vz + qz + cv * cz
    wx, wy, wz = _cross(px, py, pz, rx, ry, rz)
    mr = atan2(wx * tbx + wy * tby + wz * tbz, px * rx + py * ry + pz * rz)
    mr += 2.0 * math.pi * math.floor((refm - mr) / (2.0 * math.pi) + 0.5)
    psi = thb - tha + mr
    d2 = k2 - kap
    d3 = psi / h - tau
    energy = 0.5 * h * (A * (k1 * k1 + d2 * d2) + C * d3 * d3)
    m1, m2, m3 = A * k1 * h, A * d2 * h, C * d3
    Vx, Vy, Vz = m1 * e1x + m2 * e2x, m1 * e1y + m2 * e2y, m1 * e1z + m2 * e2z
    cV = g * (cx * Vx + cy * Vy + cz * Vz)
    kb = m3 / (1.0 + cosp)  # (m3/2) κb = m3 c/(1 + cos φ)
    rx, ry, rz = _cross(tbx, tby, tbz, Vx, Vy, Vz)
    gax = (-cV * tbx + f * rx) / h + kb * cx
    gay = (-cV * tby + f * ry) / h + kb * cy
    gaz = (-cV * tbz + f * rz) / h + kb * cz
    rx, ry, rz = _cross(Vx, Vy, Vz, tax, tay, taz)
    gbx = (-cV * tax + f * rx) / h + kb * cx
    gby = (-cV * tay + f * ry) / h + kb * cy
    gbz = (-cV * taz + f * rz) / h + kb * cz
    return energy, k1, k2, psi, gax, gay, gaz, gbx, gby, gbz, m1 * k2 - m2 * k1 + m3, m3


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def elastic(y, n, h, A, C, K, kappa0, tau0, hook_k, ref_u, ref_e, ref_m,
            T, E1, E2, LEN, S, GT, GTH, A1, kappa=None, tau=None, strains=None):
    """Elastic energy; fills GT (n+1, 3) = ∂E/∂t at fixed material spin, GTH = ∂E/∂θ.

    ``kappa``, ``tau`` (n): the intrinsic curvature and torsion of each joint j (between
    frames j and j+1) instead of the scalars κ0, τ0 (a polymorphic filament,
    :mod:`flagellum.rod.polymorph`); ``strains`` (n, 3), if given, receives the joints'
    strains (Ω1, Ω2, Ω3)."""
    frames(y, n, ref_u, ref_e, T, E1, E2, LEN, S, A1)
    GT[:, :] = 0.0
    GTH[:] = 0.0
    energy = 0.0
    for j in range(n):
        a, b = j, j + 1
        if kappa is None:
            kj, tj = kappa0, tau0
        else:
            kj, tj = kappa[j], tau[j]
        ej, k1, k2, psi, gax, gay, gaz, gbx, gby, gbz, gthb, m3 = joint_of(
            T[a, 0], T[a, 1], T[a, 2], T[b, 0], T[b, 1], T[b, 2], E1[b, 0], E1[b, 1], E1[b, 2],
            E2[b, 0], E2[b, 1], E2[b, 2], A1[a, 0], A1[a, 1], A1[a, 2], A1[b, 0], A1[b, 1],
            A1[b, 2], y[6 + 4 * a], y[6 + 4 * b], ref_m[b], h, A, C, kj, tj)
        if strains is not None:
            strains[j, 0], strains[j, 1], strains[j, 2] = k1, k2, psi / h
        energy += ej
        GT[a, 0] += gax
        GT[a, 1] += gay
        GT[a, 2] += gaz
        GT[b, 0] += gbx
        GT[b, 1] += gby
        GT[b, 2] += gbz
        GTH[b] += gthb
        GTH[a] -= m3
    for i in range(1, n + 1):
        st = LEN[i] / h - 1.0
        energy += 0.5 * K * h * st * st
    if hook_k > 0.0:  # E_hook = k (1 + t0·e_z): minimum with the hook along −z
        energy += hook_k * (1.0 + T[0, 2])
        GT[0, 2] += hook_k
    return energy


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def rechart_all(y, n, ref_u, ref_e, T, E1, E2, LEN, S, A1):
    """Move every chart pole to its current tangent, keeping the reference vector a1 (and so
    θ and the reference twists) unchanged: discrete time-parallel transport."""
    frames(y, n, ref_u, ref_e, T, E1, E2, LEN, S, A1)
    for i in range(n + 1):
        for k in range(3):
            ref_u[i, k] = T[i, k]
            ref_e[i, k] = A1[i, k]


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def change_coordinates(Y, n, ref_u0, ref_e0, ref_u1, ref_e1, angles, only, OUT, T, E1, E2, LEN,
                       S, A1):
    """OUT[k] = the state Y[k] given in the charts (ref_u0, ref_e0), in the charts (ref_u1,
    ref_e1) and in coordinates turned by ``angles[k]`` about e_z (positions and u0 turned, the
    charts fixed in the new coordinates): the same material frames e1, so θ_i changes by the
    angle between the two reference vectors at the tangent, taken on the branch nearest θ_i;
    only the frames with ``only[i]`` are measured anew (θ of the others copied). The arrays
    after ``OUT`` are scratch (see :func:`frames`)."""
    E = np.empty((n + 1, 3))
    for k in range(Y.shape[0]):
        y, out = Y[k], OUT[k]
        frames(y, n, ref_u0, ref_e0, T, E1, E2, LEN, S, A1)
        c, s = math.cos(angles[k]), math.sin(angles[k])
        out[:] = y
        for i in range(n + 2):  # u0, then the beads
            o = 0 if i == 0 else 3 + 4 * (i - 1)
            out[o], out[o + 1] = c * y[o] - s * y[o + 1], s * y[o] + c * y[o + 1]
        for i in range(n + 1):
            E[i, 0], E[i, 1], E[i, 2] = c * E1[i, 0] - s * E1[i, 1], s * E1[i, 0] + c * E1[i, 1], E1[i, 2]
        frames(out, n, ref_u1, ref_e1, T, E1, E2, LEN, S, A1)
        for i in range(n + 1):
            if not only[i]:
                continue
            tx, ty, tz = T[i, 0], T[i, 1], T[i, 2]
            ax, ay, az = A1[i, 0], A1[i, 1], A1[i, 2]
            bx, by, bz = _cross(tx, ty, tz, ax, ay, az)
            raw = math.atan2(E[i, 0] * bx + E[i, 1] * by + E[i, 2] * bz,
                             E[i, 0] * ax + E[i, 1] * ay + E[i, 2] * az)
            th = y[6 + 4 * i]
            out[6 + 4 * i] = th + ((raw - th + math.pi) % (2.0 * math.pi) - math.pi)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def reference_twists(n, T, A1, out):
    """Raw reference twist m_b ∈ (−π, π] of every joint (a, b) (see :func:`elastic`)."""
    for b in range(1, n + 1):
        a = b - 1
        vx, vy, vz = A1[a, 0], A1[a, 1], A1[a, 2]
        rx, ry, rz = A1[b, 0], A1[b, 1], A1[b, 2]
        cx, cy, cz = _cross(T[a, 0], T[a, 1], T[a, 2], T[b, 0], T[b, 1], T[b, 2])
        cosp = T[a, 0] * T[b, 0] + T[a, 1] * T[b, 1] + T[a, 2] * T[b, 2]
        qx, qy, qz = _cross(cx, cy, cz, vx, vy, vz)
        cv = (cx * vx + cy * vy + cz * vz) / (1.0 + cosp)
        px, py, pz = cosp * vx + qx + cv * cx, cosp * vy + qy + cv * cy, cosp * vz + qz + cv * cz
        wx, wy, wz = _cross(px, py, pz, rx, ry, rz)
        out[b] = atan2(wx * T[b, 0] + wy * T[b, 1] + wz * T[b, 2], px * rx + py * ry + pz * rz)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def bead_gradient(n, h, K, T, LEN, GT, DR):
    """DR (n+1, 3) = ∂E/∂r_i from GT (bond part) and stretching."""
    DR[:, :] = 0.0
    for i in range(1, n + 1):
        tx, ty, tz = T[i, 0], T[i, 1], T[i, 2]
        gx, gy, gz = GT[i, 0], GT[i, 1], GT[i, 2]
        gt = gx * tx + gy * ty + gz * tz
        st = K * (LEN[i] / h - 1.0)
        inv = 1.0 / LEN[i]
        fx = (gx - gt * tx) * inv + st * tx
        fy = (gy - gt * ty) * inv + st * ty
        fz = (gz - gt * tz) * inv + st * tz
        DR[i, 0] += fx
        DR[i, 1] += fy
        DR[i, 2] += fz
        DR[i - 1, 0] -= fx
        DR[i - 1, 1] -= fy
        DR[i - 1, 2] -= fz


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def end_load(y, n, force, trap_k, trap_z):
    """z component of the load on the last bead [pN]: a constant pull ``force`` along −e_z
    plus an axial trap of stiffness ``trap_k`` centred at ``trap_z``."""
    return -force + trap_k * (trap_z - y[3 + 4 * n + 2])


# indices into the packed parameter arrays of :func:`rhs`
P_H, P_A, P_C, P_K, P_KAPPA, P_TAU, P_HOOKK, P_SPHERE, P_GPAR, P_GPERP, P_GROT, P_TORQUE, \
    P_OMEGA, P_ELASTIC, P_BODY, P_SECANT, P_LAW = range(17)
I_N, I_HOOK, I_ANCHOR, I_GEN, I_HYDRO, I_DRIVE, I_NLAW, I_NLAW_CW = range(8)
#: iprm[I_EXTRA]: offset of the extra block in prm (0: none); iprm[I_SEGMENTS] = 1: the block
#: holds per-joint intrinsic curvatures and torsions. The block: prm[off + X_FORCE] a constant
#: force pulling the last bead along −e_z, prm[off + X_TRAP_K] the stiffness of an axial trap
#: on it centred at z = prm[off + X_TRAP_Z], then (iprm[I_SEGMENTS] = 1) the n curvatures
#: and the n torsions of the joints from prm[off + X_SEG] on
I_EXTRA, I_SEGMENTS = 8, 9
#: iprm[I_NEAR]: the near field's width in beads (HYDRO_BANDED below)
I_NEAR = 10
X_FORCE, X_TRAP_K, X_TRAP_Z, X_SEG = range(4)
#: iprm[I_DRIVE]: what prm[P_TORQUE] is (:class:`flagellum.motor.Motor`). DRIVE_TORQUE: the
#: motor torque; DRIVE_SPEED: the clamped motor speed relative to the body; DRIVE_LAW: the
#: direction ±1 of a torque–speed law whose CCW and CW branches follow prm[P_LAW:] as
#: [speeds, torques] of iprm[I_NLAW] and iprm[I_NLAW_CW] nodes. prm[P_BODY] = 1/(8πηa³):
#: the body's counter-rotation per unit motor torque of a free swimmer (0 otherwise). A cell
#: body's parameters (:func:`flagellum.hydro.body.kernel_block`) follow the law's nodes.
#: prm[P_SECANT] = w: the applied ΔM is DM + w DG (the workspace's last two arrays: a secant
#: model's base and slope, :mod:`flagellum.integrate.frozen`; 0 leaves DM as it is; a cell
#: body's motion reads DM alone: its steppers write the model's value into DM).
DRIVE_TORQUE, DRIVE_SPEED, DRIVE_LAW = 0, 1, 2
#: iprm[I_HYDRO]: the bead mobility of :func:`rhs`. HYDRO_LOCAL: the local drag of
#: :mod:`flagellum.hydro.local` alone (RFT); HYDRO_FROZEN: plus the frozen dense correction
#: ΔM (the workspace's last array DM, with prm[P_SECANT] ≠ 0 plus that times the one before,
#: U += ΔM F; :mod:`flagellum.hydro.dynamics`); HYDRO_BANDED:
#: plus its 3×3 blocks between beads at most iprm[I_NEAR] apart (the banded operator the
#: Jacobian is taken of: the near field that sets the stiff bead-scale modes;
#: :func:`flagellum.hydro.dynamics.near_beads`)
HYDRO_LOCAL, HYDRO_FROZEN, HYDRO_BANDED = 0, 1, 2


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def workspace(n, nonlocal_size=0):
    """(T, E1, E2, LEN, S, GT, GTH, DR, V, A1, CW, DG, DM): see :func:`frames`,
    :func:`elastic`, :func:`rhs`, :func:`cell_motion` (CW); DM (``nonlocal_size`` square,
    3(n+1) for a nonlocal mobility) is the frozen mobility correction ΔM, DG the slope of its
    secant model (applied as DM + prm[P_SECANT] DG)."""
    n1 = n + 1
    return (np.zeros((n1, 3)), np.zeros((n1, 3)), np.zeros((n1, 3)), np.zeros(n1),
            np.zeros((n1, 3)), np.zeros((n1, 3)), np.zeros(n1), np.zeros((n1, 3)),
            np.zeros((n1, 3)), np.zeros((n1, 3)), np.zeros((6, 6)),
            np.zeros((nonlocal_size, nonlocal_size)), np.zeros((nonlocal_size, nonlocal_size)))


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _add_correction(DM, DG, w, DR, V, n, width):
    """V += ΔM F with F = −DR and ΔM = DM + w DG, from the blocks of ΔM between beads at most
    ``width`` apart. All of it: one or two dense matrix–vector products (BLAS); two products
    cost less than writing DM + w DG first (5.2 against 8.7 µs at N = 50), and w changes at
    every right-hand side of a Newton iteration."""
    if width >= n:
        f = DR.reshape(3 * (n + 1))
        u = np.dot(DM, f)
        if w != 0.0:
            g = np.dot(DG, f)
            for i in range(u.shape[0]):
                u[i] += w * g[i]
        for i in range(n + 1):
            for a in range(3):
                V[i, a] -= u[3 * i + a]
        return
    for i in range(n + 1):
        lo, hi = max(0, i - width), min(n + 1, i + width + 1)
        for a in range(3):
            row = 3 * i + a
            acc = 0.0
            for k in range(lo, hi):
                c = 3 * k
                acc -= DM[row, c] * DR[k, 0] + DM[row, c + 1] * DR[k, 1] + DM[row, c + 2] * DR[k, 2]
                if w != 0.0:
                    acc -= w * (DG[row, c] * DR[k, 0] + DG[row, c + 1] * DR[k, 1]
                                + DG[row, c + 2] * DR[k, 2])
            V[i, a] += acc


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _law_torque(prm, off, nn, a, b):
    """The torque N of the law with nodes prm[off:off+nn] (speeds), prm[off+nn:off+2nn]
    (torques; held outside the nodes) on the load line u = a + b N (b > 0): the root of the
    increasing N − f(a + b N), exact for the piecewise-linear f."""
    for k in range(nn):
        sk, mk = prm[off + k], prm[off + nn + k]
        if (sk - a) / b - mk >= 0.0:  # the load line has passed the law at node k
            if k == 0:
                return mk
            s0, m0 = prm[off + k - 1], prm[off + nn + k - 1]
            sl = (mk - m0) / (sk - s0)
            u = (a / b + m0 - sl * s0) / (1.0 / b - sl)
            return m0 + sl * (u - s0)
    return prm[off + 2 * nn - 1]


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def _hook_rate(tz, zt, zp):
    """Rate of the hook frame about e_z per unit torque M e_z (Eq. (12))."""
    return tz * tz / zt + ((1.0 - tz * tz) / zp if zp != 0.0 else 0.0)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def motor_torque(prm, iprm, w0, tz, zt, zp):
    """Motor torque of a speed clamp or a torque–speed law (iprm[I_DRIVE]). By the hook
    balance Eq. (12) the hook frame's rate about e_z is linear in the torque M e_z, and so is
    the motor speed relative to the body: ω = w0 + B M, with w0 the rate without the motor
    torque and B = t_z²/zt + (1 − t_z²)/zp + prm[P_BODY] (tangent component t_z, friction zt
    about the tangent and zp across it; zp = 0: a clamped hook). So the clamp's torque
    (ω_c − w0)/B and the law's operating point are exact; NaN when B ≤ 0 (no operating point)."""
    return drive_torque(prm, iprm, w0, _hook_rate(tz, zt, zp) + prm[P_BODY])


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def drive_torque(prm, iprm, w0, b):
    """Torque of a speed clamp or a law (iprm[I_DRIVE]) on the load line ω = w0 + b M of the
    motor speed relative to the body (:func:`motor_torque`); NaN when b ≤ 0."""
    if not b > 0.0:
        return math.nan
    d = prm[P_TORQUE]
    if iprm[I_DRIVE] == DRIVE_SPEED:
        return (d - w0) / b
    n1 = iprm[I_NLAW]
    if d >= 0.0:
        return _law_torque(prm, P_LAW, n1, w0, b)
    return -_law_torque(prm, P_LAW + 2 * n1, iprm[I_NLAW_CW], -w0, b)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _solve2(G, r, size):
    """Solve G x = r in place for the two columns of r (rows 0 … size−1; Gaussian
    elimination with partial pivoting: G is the small symmetric positive definite
    resistance of the cell, 6×6 or 7×7)."""
    for k in range(size):
        p = k
        for i in range(k + 1, size):
            if abs(G[i, k]) > abs(G[p, k]):
                p = i
        if p != k:
            for j in range(size):
                G[k, j], G[p, j] = G[p, j], G[k, j]
            for j in range(2):
                r[k, j], r[p, j] = r[p, j], r[k, j]
        for i in range(k + 1, size):
            f = G[i, k] / G[k, k]
            for j in range(k, size):
                G[i, j] -= f * G[k, j]
            for j in range(2):
                r[i, j] -= f * r[k, j]
    for k in range(size - 1, -1, -1):
        for j in range(2):
            acc = r[k, j]
            for i in range(k + 1, size):
                acc -= G[k, i] * r[i, j]
            r[k, j] = acc / G[k, k]


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _cell_bead_correction(DM, scale, DR, V, g, n, width):
    """V[k] += ``scale`` DM g for beads k = 1 … n over the cell's slots (V, beads, Ω;
    F_j = −DR[j]), blocks at most ``width`` beads apart (the body's slots count as bead 0)."""
    last = 3 * (n + 1)
    for k in range(1, n + 1):
        lo, hi = max(1, k - width), min(n, k + width)
        for a in range(3):
            row = 3 * k + a
            acc = 0.0
            if k <= width:
                for q in range(3):
                    acc += DM[row, q] * g[q] + DM[row, last + q] * g[3 + q]
            for j in range(lo, hi + 1):
                c = 3 * j
                acc -= DM[row, c] * DR[j, 0] + DM[row, c + 1] * DR[j, 1] + DM[row, c + 2] * DR[j, 2]
            V[k, a] += scale * acc


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _cell_body_rows(DM, scale, gb, DR, dq, n, kmax):
    """dq += ``scale`` times DM's rows of the body's slots (V, Ω) applied to the body's
    generalized forces ``gb`` (column 0: without the motor torque, 1: per unit torque) and,
    in column 0, to the bead forces −DR[k] of beads k ≤ ``kmax``."""
    last = 3 * (n + 1)
    for ii in range(6):
        row = ii if ii < 3 else last + ii - 3
        for c in range(2):
            acc = 0.0
            for q in range(3):
                acc += DM[row, q] * gb[q, c] + DM[row, last + q] * gb[3 + q, c]
            if c == 0:
                for k in range(1, kmax + 1):
                    o = 3 * k
                    acc -= DM[row, o] * DR[k, 0] + DM[row, o + 1] * DR[k, 1] + DM[row, o + 2] * DR[k, 2]
            dq[ii, c] += scale * acc


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _cell_slot_product(DM, DG, w, DR, g, V, n, rot):
    """V[k] += ΔM g for beads k = 1 … n with all of ΔM = DM + w DG over the cell's slots
    (V, beads, Ω; the body's force and torque g[:6], bead forces −DR[1:]): one dense
    matrix–vector product per matrix (BLAS; the hand loop of :func:`_cell_bead_correction`
    over all blocks took ≈ 3× as long at N = 50), its bead rows turned by R (``rot``, 9
    values row by row) unless ``rot`` is empty."""
    last = 3 * (n + 1)
    q = np.empty(last + 3)
    for a in range(3):
        q[a] = g[a]
        q[last + a] = g[3 + a]
    for j in range(1, n + 1):
        for a in range(3):
            q[3 * j + a] = -DR[j, a]
    u = np.dot(DM, q)
    if w != 0.0:
        ug = np.dot(DG, q)
        for i in range(u.shape[0]):
            u[i] += w * ug[i]
    for k in range(1, n + 1):
        x, y, z = u[3 * k], u[3 * k + 1], u[3 * k + 2]
        if rot.shape[0] == 9:
            for a in range(3):
                V[k, a] += rot[3 * a] * x + rot[3 * a + 1] * y + rot[3 * a + 2] * z
        else:
            V[k, 0] += x
            V[k, 1] += y
            V[k, 2] += z


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def _turn_rows(rot, a, column, back):
    """Turn the 3-vectors of ``a`` in place by R (``rot``, 9 values row by row) or, with
    ``back``, by Rᵀ: the rows of a 2-D array (n, 3) when ``column`` is 0, else each triplet
    of rows (0–2, 3–5) of each column of a (6, c) array."""
    if column == 0:
        for k in range(a.shape[0]):
            x, y, z = a[k, 0], a[k, 1], a[k, 2]
            for i in range(3):
                if back:
                    a[k, i] = rot[i] * x + rot[3 + i] * y + rot[6 + i] * z
                else:
                    a[k, i] = rot[3 * i] * x + rot[3 * i + 1] * y + rot[3 * i + 2] * z
        return
    for c in range(a.shape[1]):
        for t in range(2):
            x, y, z = a[3 * t, c], a[3 * t + 1, c], a[3 * t + 2, c]
            for i in range(3):
                if back:
                    a[3 * t + i, c] = rot[i] * x + rot[3 + i] * y + rot[6 + i] * z
                else:
                    a[3 * t + i, c] = rot[3 * i] * x + rot[3 * i + 1] * y + rot[3 * i + 2] * z


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def cell_motion(y, prm, iprm, T, GT, GTH, DR, ext_hook, el, V, DM, DG, width, CW):
    """Motion of a cell body (anchor ``ANCHOR_CELL``) and of the hook frame on it.

    The body (centre X, orientation Q = exp([φ]×) from the state's last three values) carries
    bead 0 at the motor point X + d and the motor axis m, both turning with it; its Stokes
    resistance about the centre is diagonal along and across its axis
    (:mod:`flagellum.hydro.body`), and bead 0's own friction ζ0 acts at d. Forces on the body:
    the filament's force f0 on bead 0 (with its torque d × f0), the motor's reaction −M m and,
    for an elastic hook E = k(1 + t0·m), the torque k t0 × m. The hook frame turns under
    M m and the elastic torque τh on it (Eq. (12) with e_z → m); a clamped hook (t0 = −m)
    turns with the body plus ω_r about m, and the two are solved together (the constraint
    torque across m is internal). Both problems are linear in M: solved for M = 0 and M = 1,
    the motor speed relative to the body is ω = w0 + b M, and a clamp's or a law's torque
    follows from :func:`drive_torque`. Returns (torque, hook frame's ω (3), body's Ω (3),
    body's velocity V (3), bead 0's velocity (3), m (3), rate ω_hook·m, relative motor speed).
    Adds the hook term with m to GT[0]; out[18] is the change of the hook energy, out[19] a
    clamped hook's rate about m relative to the body (0 otherwise), which the hook frame's
    vector u0 does not take (on t0 = −m it would not move it).

    ``width`` ≥ 0: a nonlocal mobility, the frozen ΔM of
    :func:`flagellum.hydro.dynamics.cell_correction` in ``DM`` over the slots (V, beads 1 … n,
    Ω) (plus prm[P_SECANT] times the secant model's slope ``DG``), adds ΔM g to the body's
    (V, Ω) and to the beads' velocities ``V`` (blocks between slots at most ``width`` beads
    apart; V and Ω count as bead 0), with g the generalized
    forces: the bead forces and the body's (f0, d × f0 + …) of the 6×6 problem (a clamped
    hook's rate about m eliminated: the torque less m times its row). The clamped hook frame
    follows ΔΩ across m (its rate about m is its own balance), and the motor's load line
    w0 + b M takes the same correction, so clamp and law stay exact.

    ``ext_hook`` of 9 values: after the hook frame's torque, a force (3) and a torque about
    the centre (3) on the body (its thermal noise, :func:`flagellum.integrate.brownian.thermal_forces`).

    ``CW`` (6, 6): scratch of the generalized forces and their corrections (columns 0–1 gb,
    2–3 ΔM gb, 4 g, 5 ΔΩ), from the workspace: the right-hand side allocates none of them."""
    n = iprm[I_N]
    h, gpar, gperp, grot = prm[P_H], prm[P_GPAR], prm[P_GPERP], prm[P_GROT]
    off = P_LAW + 2 * (iprm[I_NLAW] + iprm[I_NLAW_CW])
    ny = y.shape[0]
    Q = np.empty((3, 3))
    B.rotation_matrix(y[ny - 3], y[ny - 2], y[ny - 1], Q)
    ax, d, m = np.empty(3), np.empty(3), np.empty(3)
    for i in range(3):
        ax[i] = Q[i, 0] * prm[off + 4] + Q[i, 1] * prm[off + 5] + Q[i, 2] * prm[off + 6]
        d[i] = Q[i, 0] * prm[off + 7] + Q[i, 1] * prm[off + 8] + Q[i, 2] * prm[off + 9]
        m[i] = Q[i, 0] * prm[off + 10] + Q[i, 1] * prm[off + 11] + Q[i, 2] * prm[off + 12]
    t = T[0]
    # the hook's energy E = k (1 + t0·m) with the body's axis m in place of the e_z of
    # :func:`elastic` (whose term is taken off again here: elastic scaled by el in GT)
    k = el * prm[P_HOOKK]
    e_hook = prm[P_HOOKK] * (t[0] * m[0] + t[1] * m[1] + t[2] * m[2] - t[2]) if el != 0.0 else 0.0
    GT[0, 2] -= k
    for i in range(3):
        GT[0, i] += k * m[i]
    qx, qy, qz = _cross(t[0], t[1], t[2], GT[0, 0], GT[0, 1], GT[0, 2])
    tau = np.empty(3)  # elastic (and external) torque on the hook frame, without the motor
    tau[0] = ext_hook[0] - (qx + GTH[0] * t[0])
    tau[1] = ext_hook[1] - (qy + GTH[0] * t[1])
    tau[2] = ext_hook[2] - (qz + GTH[0] * t[2])
    tkx, tky, tkz = _cross(t[0], t[1], t[2], k * m[0], k * m[1], k * m[2])  # k t0 × m on the body
    f0 = np.empty(3)
    for i in range(3):
        f0[i] = -DR[0, i]
    t1x, t1y, t1z, z0p, z0n, _ = L.bead_friction(T, 0, n, h, gpar, gperp, ANCHOR_CELL, 0.0)
    t1 = (t1x, t1y, t1z)
    clamped = iprm[I_HOOK] == HOOK_CLAMPED
    zt, zp = L.hook_friction(h, gperp, grot, False)  # the hook frame moves with the body
    size = 7 if clamped else 6
    G = np.zeros((size, size))
    r = np.zeros((size, 2))
    Z0 = np.empty((3, 3))
    At = np.empty((3, 3))
    Br = np.empty((3, 3))
    Dx = np.zeros((3, 3))  # [d]×
    Dx[0, 1], Dx[0, 2], Dx[1, 2] = -d[2], d[1], -d[0]
    Dx[1, 0], Dx[2, 0], Dx[2, 1] = d[2], -d[1], d[0]
    for i in range(3):
        for j in range(3):
            e = 1.0 if i == j else 0.0
            Z0[i, j] = z0n * e + (z0p - z0n) * t1[i] * t1[j]
            At[i, j] = prm[off + 1] * e + (prm[off] - prm[off + 1]) * ax[i] * ax[j]
            Br[i, j] = prm[off + 3] * e + (prm[off + 2] - prm[off + 3]) * ax[i] * ax[j]
    DZ = Dx @ Z0
    ZD = Z0 @ Dx
    DZD = DZ @ Dx
    for i in range(3):
        for j in range(3):
            G[i, j] = At[i, j] + Z0[i, j]
            G[i, 3 + j] = -ZD[i, j]
            G[3 + i, j] = DZ[i, j]
            G[3 + i, 3 + j] = Br[i, j] - DZD[i, j]
    dfx, dfy, dfz = _cross(d[0], d[1], d[2], f0[0], f0[1], f0[2])
    df = (dfx, dfy, dfz)
    tk = (tkx, tky, tkz)
    for i in range(3):
        r[i, 0] = f0[i]
    if clamped:  # body + hook frame: ω_h = Ω + ω_r m, t0 = −m
        Zh = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                Zh[i, j] = zp * (1.0 if i == j else 0.0) + (zt - zp) * m[i] * m[j]
        zm = Zh @ m
        for i in range(3):
            for j in range(3):
                G[3 + i, 3 + j] += Zh[i, j]
            G[3 + i, 6] = zm[i]
            G[6, 3 + i] = zm[i]
            r[3 + i, 0] = df[i] + tau[i]
        G[6, 6] = zm[0] * m[0] + zm[1] * m[1] + zm[2] * m[2]
        r[6, 0] = tau[0] * m[0] + tau[1] * m[1] + tau[2] * m[2]
        r[6, 1] = 1.0
    else:
        for i in range(3):
            r[3 + i, 0] = df[i] + tk[i]
            r[3 + i, 1] = -m[i]
    if ext_hook.shape[0] >= 9:  # the body's own external force and torque (thermal noise)
        for i in range(3):
            r[i, 0] += ext_hook[3 + i]
            r[3 + i, 0] += ext_hook[6 + i]
    gb = CW[:, 0:2]  # generalized forces on (V, Ω), for the nonlocal correction
    dq = CW[:, 2:4]  # ΔM g on (V, Ω): column 0 without, column 1 per unit motor torque
    gb[:, :] = 0.0
    dq[:, :] = 0.0
    if width >= 0:
        for c in range(2):
            for i in range(6):
                gb[i, c] = r[i, c]
            if clamped:
                for i in range(3):
                    gb[3 + i, c] -= m[i] * r[6, c]
    turned = width >= 0 and prm[off + B.ROTATION + 9] != 0.0
    rot = prm[off + B.ROTATION:off + B.ROTATION + 9]
    w = prm[P_SECANT] if width >= 0 else 0.0  # ΔM = DM + w DG (the secant model)
    if turned:  # ΔM turned by R (R ΔM Rᵀ g): its forces turned back by Rᵀ, its velocities by R
        _turn_rows(rot, gb, 1, True)
        DR = DR.copy()
        _turn_rows(rot, DR, 0, True)
    _solve2(G, r, size)
    wh0, wh1 = np.empty(3), np.empty(3)
    if clamped:
        w0, b = r[6, 0], r[6, 1]
    else:  # the hook frame alone: [zt t t + zp (1 − t t)] ω = τh + M m
        tt0 = tau[0] * t[0] + tau[1] * t[1] + tau[2] * t[2]
        tm = m[0] * t[0] + m[1] * t[1] + m[2] * t[2]
        for i in range(3):
            wh0[i] = tt0 * t[i] / zt + (tau[i] - tt0 * t[i]) / zp
            wh1[i] = tm * t[i] / zt + (m[i] - tm * t[i]) / zp
        w0 = (wh0[0] - r[3, 0]) * m[0] + (wh0[1] - r[4, 0]) * m[1] + (wh0[2] - r[5, 0]) * m[2]
        b = (wh1[0] - r[3, 1]) * m[0] + (wh1[1] - r[4, 1]) * m[1] + (wh1[2] - r[5, 1]) * m[2]
    if width >= 0:
        _cell_body_rows(DM, 1.0, gb, DR, dq, n, min(n, width))
        if w != 0.0:  # the secant model's slope: ΔM = DM + w DG
            _cell_body_rows(DG, w, gb, DR, dq, n, min(n, width))
        if turned:
            _turn_rows(rot, dq, 1, False)
        w0 -= dq[3, 0] * m[0] + dq[4, 0] * m[1] + dq[5, 0] * m[2]
        b -= dq[3, 1] * m[0] + dq[4, 1] * m[1] + dq[5, 1] * m[2]
    if iprm[I_DRIVE] == DRIVE_TORQUE:
        torque = el * prm[P_TORQUE]
    else:
        torque = 0.0 if el == 0.0 else drive_torque(prm, iprm, w0, b)
    out = np.empty(20)
    out[0] = torque
    dw = CW[:3, 5]
    for i in range(3):
        dw[i] = dq[3 + i, 0] + torque * dq[3 + i, 1]
    dwm = dw[0] * m[0] + dw[1] * m[1] + dw[2] * m[2]
    for i in range(3):
        om = r[3 + i, 0] + torque * r[3 + i, 1] + dw[i]
        vc = r[i, 0] + torque * r[i, 1] + dq[i, 0] + torque * dq[i, 1]
        if clamped:  # the hook frame follows the body's correction across m only
            wh = om - dwm * m[i] + (r[6, 0] + torque * r[6, 1]) * m[i]
        else:
            wh = wh0[i] + torque * wh1[i]
        out[1 + i], out[4 + i], out[7 + i], out[13 + i] = wh, om, vc, m[i]
    if width >= 0:  # the beads: U_k += ΔM g
        g = CW[:, 4]
        for i in range(6):
            g[i] = gb[i, 0] + torque * gb[i, 1]
        if width >= n:  # all of ΔM: one dense product over the slots (BLAS)
            _cell_slot_product(DM, DG, w, DR, g, V, n, rot if turned else prm[:0])
        elif turned:
            dv = np.zeros((n + 1, 3))
            _cell_bead_correction(DM, 1.0, DR, dv, g, n, width)
            if w != 0.0:
                _cell_bead_correction(DG, w, DR, dv, g, n, width)
            _turn_rows(rot, dv, 0, False)
            for k in range(1, n + 1):
                for a in range(3):
                    V[k, a] += dv[k, a]
        else:
            _cell_bead_correction(DM, 1.0, DR, V, g, n, width)
            if w != 0.0:
                _cell_bead_correction(DG, w, DR, V, g, n, width)
    ox, oy, oz = _cross(out[4], out[5], out[6], d[0], d[1], d[2])
    out[10], out[11], out[12] = out[7] + ox, out[8] + oy, out[9] + oz  # bead 0 = X + d
    out[16] = out[1] * m[0] + out[2] * m[1] + out[3] * m[2]
    out[17] = w0 + b * torque
    out[18] = e_hook
    # a clamped hook frame's own rate about m: it leaves the tangent t0 = −m where it is
    out[19] = r[6, 0] + torque * r[6, 1] if clamped else 0.0
    return out


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def hook_of(prm, iprm, el, hx, hy, hz, tx, ty, tz, gx, gy, gz, gth):
    """The hook frame's angular velocity in the lab (Eq. (12)) from its tangent t, its G_t
    (g) and G_Θ (gth) and an external torque (hx, hy, hz), with the motor's drive (a clamp's
    or a law's torque solved, :func:`motor_torque`): (ω (3), motor torque, motor speed
    relative to the body). The same operations as the hook part of :func:`rhs`, which keeps
    them inline (a call there changes the last bit of θ̇0 where LLVM contracts differently:
    the pruned and general kernels' coloured Jacobians then differ in the last bit,
    tests/test_kernel_variants.py); tests/test_rod_jacobian.py checks the two agree."""
    h, gperp, grot = prm[P_H], prm[P_GPERP], prm[P_GROT]
    qx, qy, qz = _cross(tx, ty, tz, gx, gy, gz)
    mx = hx - (qx + gth * tx)
    my = hy - (qy + gth * ty)
    if iprm[I_DRIVE] == DRIVE_TORQUE:
        torque = el * prm[P_TORQUE]
        mz = hz + el * prm[P_TORQUE] - (qz + gth * tz)
    else:  # a clamp's or a law's drive value is no torque: its torque is added below, once
        # solved (applying the drive value and taking it off again loses digits)
        torque = 0.0
        mz = hz - (qz + gth * tz)
    mt = mx * tx + my * ty + mz * tz
    zt, zp = L.hook_friction(h, gperp, grot, iprm[I_HOOK] == HOOK_CLAMPED)
    wt = mt / zt
    if zp == 0.0:  # clamped: turns about its tangent only
        wx, wy, wz = wt * tx, wt * ty, wt * tz
    else:
        ipp = 1.0 / zp
        wx = wt * tx + ipp * (mx - mt * tx)
        wy = wt * ty + ipp * (my - mt * ty)
        wz = wt * tz + ipp * (mz - mt * tz)
    if iprm[I_DRIVE] != DRIVE_TORQUE:  # speed clamp or law: the rates are linear in the
        # torque M e_z, and w are the rates without it: add the solved motor torque
        torque = 0.0 if el == 0.0 else motor_torque(prm, iprm, wz, tz, zt, zp)
        dm = torque
        wt = dm * tz / zt
        wx, wy, wz = wx + wt * tx, wy + wt * ty, wz + wt * tz
        if zp != 0.0:
            ipp = dm / zp
            wx, wy, wz = wx - ipp * tz * tx, wy - ipp * tz * ty, wz + ipp * (1.0 - tz * tz)
    relative = wz + prm[P_BODY] * torque
    return wx, wy, wz, torque, relative


def _rhs_kernel(GENERAL):
    """:func:`rhs` (``GENERAL``) or :func:`rod_rhs`: the same source; without ``GENERAL`` the
    cell-body and per-joint-shape paths are pruned at compile time (neither they nor
    :func:`cell_motion` are compiled, and the kernel is smaller)."""

    @njit(cache=True, fastmath=FASTMATH, error_model="numpy")
    def rhs(y, ydot, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws):
        """Overdamped dynamics (paper Eqs. (6)–(7) and the hook balance Eq. (12), Sec. 2.3).

        Lab-frame velocities from [γ∥ tt + γ⊥(1 − tt)] w v = f (w = h, end beads h/2, t the
        averaged tangent; with iprm[I_HYDRO] ≠ HYDRO_LOCAL plus the frozen nonlocal correction
        ΔM f of the bead forces, see :func:`_add_correction`), spin γR h ω3 = m, hook [γR h t0t0 + ½γ⊥h³(1 − t0t0)] ω = M e_z − τ;
        then written in a frame rotating at Ω = prm[P_OMEGA] about e_z.

        ``ext_f`` (n+1, 3), ``ext_m`` (n+1): extra forces on the beads and torques about the
        frame tangents and ``ext_hook`` (3) a torque on the hook frame (thermal noise), added to
        the elastic forces and the motor torque scaled by prm[P_ELASTIC]; with a cell body it
        may carry 9 values, the last six a force and a torque on the body (:func:`cell_motion`).
        If iprm[I_GEN] = 1 they are *generalized* forces conjugate to (r_i, θ_i) and are turned
        into physical ones with the chart's spin connection (used for the Itô drift).
        The motor torque is prm[P_TORQUE] or, for a speed clamp or a torque–speed law
        (iprm[I_DRIVE]), solved from the hook balance (:func:`motor_torque`).
        A cell body (iprm[I_ANCHOR] = ANCHOR_CELL) moves bead 0 and the hook frame with it
        (:func:`cell_motion`) and its orientation φ (the state's last three values) at
        φ̇ = J⁻¹(φ)(Ω − Ω_frame e_z) (:func:`flagellum.hydro.body.rotvec_rate`).
        Returns (energy, elastic force on bead 0 (3 values), motor speed ω_hook·e_z in the lab
        (ω_hook·m about a cell body's motor axis m), motor torque applied, motor speed relative
        to the body, a cell body's motion (:func:`cell_motion`; else a placeholder; not
        returned by :func:`rod_rhs`)).
        """
        n = iprm[I_N]
        h = prm[P_H]
        gpar, gperp, grot = prm[P_GPAR], prm[P_GPERP], prm[P_GROT]
        omega_frame = prm[P_OMEGA]
        T, E1, E2, LEN, S, GT, GTH, DR, V, A1, CW, DG, DM = ws
        el = prm[P_ELASTIC]
        if el == 0.0:  # mobility only (thermal increments): no elastic forces to compute
            frames(y, n, ref_u, ref_e, T, E1, E2, LEN, S, A1)
            GT[:, :] = 0.0
            GTH[:] = 0.0
            DR[:, :] = 0.0
            energy = 0.0
        elif GENERAL and iprm[I_SEGMENTS] == 1:
            o = iprm[I_EXTRA] + X_SEG
            energy = elastic(y, n, h, prm[P_A], prm[P_C], prm[P_K], prm[P_KAPPA], prm[P_TAU],
                             prm[P_HOOKK], ref_u, ref_e, ref_m, T, E1, E2, LEN, S, GT, GTH, A1,
                             prm[o:o + n], prm[o + n:o + 2 * n])
            bead_gradient(n, h, prm[P_K], T, LEN, GT, DR)
        else:
            energy = elastic(y, n, h, prm[P_A], prm[P_C], prm[P_K], prm[P_KAPPA], prm[P_TAU],
                             prm[P_HOOKK], ref_u, ref_e, ref_m, T, E1, E2, LEN, S, GT, GTH, A1)
            bead_gradient(n, h, prm[P_K], T, LEN, GT, DR)
        f0x, f0y, f0z = -DR[0, 0], -DR[0, 1], -DR[0, 2]
        for i in range(n + 1):
            for k in range(3):
                DR[i, k] = el * DR[i, k] - ext_f[i, k]
            GTH[i] = el * GTH[i] - ext_m[i]
        if iprm[I_EXTRA] > 0 and el != 0.0:  # load on the free end: −F e_z + trap k (z_c − z_N) e_z
            o = iprm[I_EXTRA]
            DR[n, 2] -= el * end_load(y, n, prm[o + X_FORCE], prm[o + X_TRAP_K], prm[o + X_TRAP_Z])
        if el != 1.0:
            for i in range(n + 1):
                for k in range(3):
                    GT[i, k] *= el
        if iprm[I_GEN] == 1:  # physical force = generalized − chart correction of the θ-forces
            for i in range(1, n + 1):
                g = chart_force(ext_m[i], S, T, LEN, i)
                for k in range(3):
                    DR[i, k] += g[k]
                    DR[i - 1, k] -= g[k]
        # bead velocities (lab frame): the local drag of each bead (hydro.local)
        anchor, zeta = iprm[I_ANCHOR], prm[P_SPHERE]
        for i in range(n + 1):
            tx, ty, tz, zpar, zperp, mode = L.bead_friction(T, i, n, h, gpar, gperp, anchor, zeta)
            V[i, 0], V[i, 1], V[i, 2] = L.bead_velocity(-DR[i, 0], -DR[i, 1], -DR[i, 2], tx, ty, tz,
                                                        zpar, zperp, mode)
        cell = anchor == ANCHOR_CELL
        hydro = iprm[I_HYDRO]
        # nonlocal mobility: U = M_local(y) F + ΔM F, ΔM frozen (the blocks within `width` beads)
        width = -1 if hydro == HYDRO_LOCAL else (iprm[I_NEAR] if hydro == HYDRO_BANDED else n)
        cm = V[0]  # (unused placeholder of the same type)
        if GENERAL and cell:  # bead 0 and the hook frame move with the cell body (and it applies ΔM)
            cm = cell_motion(y, prm, iprm, T, GT, GTH, DR, ext_hook, el, V, DM, DG, width, CW)
            energy += cm[18]
            V[0, 0], V[0, 1], V[0, 2] = cm[10], cm[11], cm[12]
        elif width >= 0:
            _add_correction(DM, DG, prm[P_SECANT], DR, V, n, width)
        for i in range(n + 1):  # positions in the rotating frame
            o = 3 + 4 * i
            ydot[o] = V[i, 0] + omega_frame * y[o + 1]
            ydot[o + 1] = V[i, 1] - omega_frame * y[o]
            ydot[o + 2] = V[i, 2]
        # bond spins: γR h ω3 = −∂E/∂θ + m_th; θ̇ = ω3 − Ω t_z − s·ṫ
        for i in range(1, n + 1):
            o, p = 3 + 4 * i, 3 + 4 * (i - 1)
            om = -GTH[i] / L.spin_friction(h, grot) - omega_frame * T[i, 2]
            inv = 1.0 / LEN[i]
            dx = (ydot[o] - ydot[p]) * inv
            dy = (ydot[o + 1] - ydot[p + 1]) * inv
            dz = (ydot[o + 2] - ydot[p + 2]) * inv
            ydot[o + 3] = om - (S[i, 0] * dx + S[i, 1] * dy + S[i, 2] * dz)  # s ⟂ t
        # hook frame: torque balance on frame 0
        tx, ty, tz = T[0, 0], T[0, 1], T[0, 2]
        qx, qy, qz = _cross(tx, ty, tz, GT[0, 0], GT[0, 1], GT[0, 2])
        mx = ext_hook[0] - (qx + GTH[0] * tx)
        my = ext_hook[1] - (qy + GTH[0] * ty)
        if iprm[I_DRIVE] == DRIVE_TORQUE:
            torque = el * prm[P_TORQUE]
            mz = ext_hook[2] + el * prm[P_TORQUE] - (qz + GTH[0] * tz)
        else:  # a clamp's or a law's drive value is no torque: its torque is added below, once
            # solved (applying the drive value and taking it off again loses digits)
            torque = 0.0
            mz = ext_hook[2] - (qz + GTH[0] * tz)
        mt = mx * tx + my * ty + mz * tz
        zt, zp = L.hook_friction(h, gperp, grot, iprm[I_HOOK] == HOOK_CLAMPED)
        wt = mt / zt
        if zp == 0.0:  # clamped: turns about its tangent only
            wx, wy, wz = wt * tx, wt * ty, wt * tz
        else:
            ipp = 1.0 / zp
            wx = wt * tx + ipp * (mx - mt * tx)
            wy = wt * ty + ipp * (my - mt * ty)
            wz = wt * tz + ipp * (mz - mt * tz)
        if iprm[I_DRIVE] != DRIVE_TORQUE:  # speed clamp or law: the rates are linear in the
            # torque M e_z, and w are the rates without it: add the solved motor torque
            torque = 0.0 if el == 0.0 else motor_torque(prm, iprm, wz, tz, zt, zp)
            dm = torque
            wt = dm * tz / zt
            wx, wy, wz = wx + wt * tx, wy + wt * ty, wz + wt * tz
            if zp != 0.0:
                ipp = dm / zp
                wx, wy, wz = wx - ipp * tz * tx, wy - ipp * tz * ty, wz + ipp * (1.0 - tz * tz)
        relative = wz + prm[P_BODY] * torque
        if GENERAL and cell:  # the cell's hook frame (cell_motion) replaces the rod's
            torque, wx, wy, wz = cm[0], cm[1], cm[2], cm[3]
            relative = cm[17]
        wz -= omega_frame
        ydot[0], ydot[1], ydot[2] = _cross(wx, wy, wz, y[0], y[1], y[2])
        if GENERAL and cell and cm[19] != 0.0:  # u0 turns with the body, not with a clamped
            # hook's turn about m, which moves no tangent on t0 = −m but, a few radians per
            # thermal step, turned the Newton iterates' u0 (≈ 1e-4 rad off −m) about m and
            # split the steps
            cx, cy, cz = _cross(cm[19] * cm[13], cm[19] * cm[14], cm[19] * cm[15], y[0], y[1], y[2])
            ydot[0] -= cx
            ydot[1] -= cy
            ydot[2] -= cz
        dtx, dty, dtz = _cross(wx, wy, wz, tx, ty, tz)
        ydot[6] = wx * tx + wy * ty + wz * tz - (S[0, 0] * dtx + S[0, 1] * dty + S[0, 2] * dtz)
        speed = wz + omega_frame
        if GENERAL and cell:
            ny = y.shape[0]
            speed = cm[16]
            ydot[ny - 3], ydot[ny - 2], ydot[ny - 1] = B.rotvec_rate(y[ny - 3], y[ny - 2], y[ny - 1],
                                                                     cm[4], cm[5], cm[6] - omega_frame)
        if GENERAL:
            return energy, f0x, f0y, f0z, speed, torque, relative, cm
        # (no cell-body motion to return: a returned array costs a box per Python call)
        return energy, f0x, f0y, f0z, speed, torque, relative
    return rhs


rhs = _rhs_kernel(True)
#: :func:`rhs` for a filament without a cell body and without per-joint intrinsic shapes
#: (iprm[I_ANCHOR] ≠ ANCHOR_CELL, iprm[I_SEGMENTS] = 0; :func:`specialised`): the same
#: numbers bit for bit (tests/test_rod.py), less to compile
rod_rhs = _rhs_kernel(False)


def specialised(iprm) -> bool:
    """Whether :func:`rod_rhs` serves the model of ``iprm`` (no cell body, no per-joint shape)."""
    return int(iprm[I_ANCHOR]) != ANCHOR_CELL and int(iprm[I_SEGMENTS]) == 0


def _jacobian_kernel(f):
    """:func:`colored_jacobian` of the right-hand side kernel ``f`` (:func:`rhs` or
    :func:`rod_rhs`)."""

    @njit(cache=True, fastmath=FASTMATH, error_model="numpy")
    def colored_jacobian(y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws, kl, ku,
                         ab, scale, y_work, f_work, color, lo, hi):
        """Finite-difference Jacobian of :func:`rhs` into LU-ready band storage ``ab``
        (``ab[j, kl+ku+i−j] = scale · ∂f_i/∂y_j``), one right-hand side per colour.

        Column j can change only rows lo[j] … hi[j] (within the band); columns of equal
        ``color`` have disjoint row ranges and are perturbed together (Curtis, Powell & Reid).
        With the frozen nonlocal mobility (``HYDRO_FROZEN``) this is the Jacobian of the banded
        operator (``HYDRO_BANDED``: the near-field blocks of ΔM), ``f0`` then recomputed with it.
        """
        n = y.shape[0]
        kv = kl + ku
        ab[:, :] = 0.0
        ip, base = iprm.copy(), f0.copy()
        if ip[I_HYDRO] == HYDRO_FROZEN:
            ip[I_HYDRO] = HYDRO_BANDED
            f(y, base, prm, ip, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws)
        for g in range(color.max() + 1):
            for j in range(n):  # (an element loop: a slice copy compiles Numba's shape-error text)
                y_work[j] = y[j]
            for j in range(n):
                if color[j] == g:
                    y_work[j] += 1e-7 * max(1.0, abs(y[j]))
            f(y_work, f_work, prm, ip, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws)
            for j in range(n):
                if color[j] == g:
                    inv = scale / (y_work[j] - y[j])
                    for i in range(lo[j], hi[j] + 1):
                        ab[j, kv + i - j] = (f_work[i] - base[i]) * inv
    return colored_jacobian


colored_jacobian = _jacobian_kernel(rhs)
#: :func:`colored_jacobian` of :func:`rod_rhs`
rod_colored_jacobian = _jacobian_kernel(rod_rhs)


def general_flag(iprm):
    """The ``general`` argument of :func:`model_rhs` for the model of ``iprm``: None where
    :func:`specialised` (the pruned kernels), else True."""
    return None if specialised(iprm) else True


# The compiled solvers' loops call the kernels through these two: Numba drops an
# ``is None`` branch on a None argument before typing, so a loop compiled for
# ``general = None`` compiles only the pruned kernels (the compile pause of a first run).
@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def model_rhs(general, y, ydot, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws):
    """:func:`rod_rhs` if ``general`` is None, else :func:`rhs` (:func:`general_flag`)."""
    if general is None:
        rod_rhs(y, ydot, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws)
    else:
        rhs(y, ydot, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def model_colored_jacobian(general, y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook,
                           ws, kl, ku, ab, scale, y_work, f_work, color, lo, hi):
    """:func:`rod_colored_jacobian` if ``general`` is None, else :func:`colored_jacobian`."""
    if general is None:
        rod_colored_jacobian(y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws, kl,
                             ku, ab, scale, y_work, f_work, color, lo, hi)
    else:
        colored_jacobian(y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws, kl, ku,
                         ab, scale, y_work, f_work, color, lo, hi)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def band_colors(n, kl, ku):
    """Colouring of a full band: columns j, j + w, j + 2w, … together (w = kl + ku + 1)."""
    color = np.arange(n) % (kl + ku + 1)
    lo = np.maximum(np.arange(n) - ku, 0)
    hi = np.minimum(np.arange(n) + kl, n - 1)
    return color, lo, hi


def interval_colors(lo, hi):
    """Fewest colours for columns with row ranges [lo, hi] such that columns of one colour
    have disjoint ranges (greedy by left end: optimal for intervals)."""
    order = np.argsort(lo, kind="stable")
    color = np.full(len(lo), -1, np.int64)
    ends: list[int] = []  # last row used by each colour
    for j in order:
        free = [c for c, e in enumerate(ends) if e < lo[j]]
        c = min(free, key=lambda c: ends[c]) if free else len(ends)
        if c == len(ends):
            ends.append(0)
        ends[c] = hi[j]
        color[j] = c
    return color


def reach_colors(reach, lo):
    """Colours for columns that move the rows ``reach[:, j]`` (a boolean (rows, columns)
    mask, outside the stored band too) such that columns of one colour move no common row:
    greedy by the first stored row ``lo`` (the order of :func:`interval_colors`, which this
    is where each column's rows are one interval). A row that a column moves outside its
    stored range would otherwise be read as a change of another column of its colour."""
    order = np.argsort(lo, kind="stable")
    color = np.full(reach.shape[1], -1, np.int64)
    used: list[np.ndarray] = []  # the rows of each colour
    for j in order:
        c = next((c for c, u in enumerate(used) if not (u & reach[:, j]).any()), len(used))
        if c == len(used):
            used.append(np.zeros(reach.shape[0], bool))
        used[c] |= reach[:, j]
        color[j] = c
    return color


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def band_jacobian(y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws, kl, ku,
                  ab, scale, y_work, f_work):
    """:func:`colored_jacobian` with the full band's colouring (kl + ku + 1 right-hand sides)."""
    color, lo, hi = band_colors(y.shape[0], kl, ku)
    colored_jacobian(y, f0, prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, ext_hook, ws, kl, ku,
                     ab, scale, y_work, f_work, color, lo, hi)
