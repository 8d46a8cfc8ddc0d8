"""The hydrodynamic model of the time stepper: local drag (RFT) or the nonlocal mobility of
:mod:`flagellum.hydro.sbt`, and the frozen correction that carries the latter into the rod's
right-hand side (see docs/hydrodynamics.md, "Integration").

With ``model="sbt"`` the bead velocities are U = M_loc(y) F + ΔM F, where M_loc is the local
drag of :mod:`flagellum.hydro.local` (block diagonal, evaluated at the current state, so the
banded Jacobian and its stiffness treatment stay as they are) and ΔM = M_eff(x*) − M_loc(x*)
the dense difference to the nonlocal mobility, built from frozen bead positions x* and
rebuilt when a bead has moved by more than ``refresh`` from them (in the splitting of
Tornberg & Shelley, J. Comput. Phys. 196, 8 (2004)). The bond spins and the hook frame keep
their local friction.

M_eff is the mobility of the beads under the anchor's constraints, from the grand mobility
of the filament's beads plus (load sphere, free swimmer, cell body) a rigid body whose force
and torque are unknowns too (:func:`grand_mobility`). The filament leaves the body at its
surface: a load sphere or a free swimmer's sphere of radius a is centred at x_0 + a e_z
(bead 0 the motor point on its rear pole), a cell body at x_0 − d (d its centre → motor
offset, :mod:`flagellum.hydro.body`). The body's flow at a bead r from its centre is
G_t(r) F + G_r(r) T: for a sphere the exact flow of a translating sphere,
G_t = [(1 + r̂r̂)/r + a²/3 (1 − 3r̂r̂)/r³]/8πη (the Stokeslet with its finite-size term
(1 + a²/6 ∇²)), and of a rotating one, G_r T = T × r/8πηr³ (rigid-body motion inside); for a
prolate spheroid its Stokeslet and rotlet. By reciprocity the beads' flow moves the body by
the transposed blocks: Faxén's laws, translation from the mean flow (1 + a²/6 ∇²)u and
rotation from half the vorticity. Constrained components (anchored: bead 0; load sphere:
bead 0's x, y and the sphere's rotation) are removed in the resistance form, i.e. their
reaction forces and torques do act on the fluid. Neglected: the filament's finite radius in
the body's flow (r² against the body's a²), the spheroid's finite-size (quadrupole) terms and
its stresslet, and the strain part of Faxén's law for a spheroid.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from . import local as L
from . import sbt
from .options import MODELS, REFRESH, Hydrodynamics

def bond_tangents(x: np.ndarray) -> np.ndarray:
    """The (n+1, 3) tangent table of :func:`flagellum.hydro.local.bead_node` (row i ≥ 1: the
    unit vector of bond i; row 0, the hook frame, is not used there)."""
    d = np.diff(x, axis=0)
    T = np.zeros_like(x)
    T[1:] = d / np.linalg.norm(d, axis=1)[:, None]
    return T


def local_mobility(x, h, gpar, gperp, anchor, zeta) -> np.ndarray:
    """Block-diagonal mobility (3(n+1) square) of the local drag of :mod:`flagellum.hydro.local`
    at bead positions x: the operator of :func:`flagellum.rod.kernels.rhs` without ΔM."""
    n = len(x) - 1
    M = np.zeros((3 * (n + 1), 3 * (n + 1)))
    _fill_local(bond_tangents(x), n, h, gpar, gperp, anchor, zeta, M)
    return M


@njit(cache=True)
def _fill_local(T, n, h, gpar, gperp, anchor, zeta, M):
    for i in range(n + 1):
        tx, ty, tz, zpar, zperp, mode = L.bead_friction(T, i, n, h, gpar, gperp, anchor, zeta)
        o = 3 * i
        if mode == L.AXIAL:
            M[o + 2, o + 2] = 1.0 / zpar
        elif mode == L.FREE:
            t = (tx, ty, tz)
            for a in range(3):
                for b in range(a, 3):  # symmetric to the last bit
                    v = (1.0 / zpar - 1.0 / zperp) * t[a] * t[b] + (1.0 / zperp if a == b else 0.0)
                    M[o + a, o + b] = v
                    M[o + b, o + a] = v


def sphere_coupling(r: np.ndarray, a: float, viscosity: float) -> np.ndarray:
    """(m, 3, 3) blocks G(r) of a translating sphere of radius a at offsets r (m, 3): the flow
    at r per force on the sphere, and (Faxén's law) the sphere's velocity per point force at r.
    Outside: [(1 + r̂r̂)/r + a²/3 (1 − 3r̂r̂)/r³]/8πη; inside: rigid motion, 1/(6πηa)."""
    d = np.linalg.norm(r, axis=1)
    out = np.empty((len(r), 3, 3))
    inside = d < a
    out[inside] = np.eye(3) / (6 * math.pi * viscosity * a)
    o = ~inside
    ro, do = r[o], d[o][:, None, None]
    rr = ro[:, :, None] * ro[:, None, :] / do ** 2
    out[o] = ((np.eye(3) + rr) / do + a * a / 3 * (np.eye(3) - 3 * rr) / do ** 3) / (8 * math.pi * viscosity)
    return out


def _skew(r: np.ndarray) -> np.ndarray:
    """(m, 3, 3) matrices [r]× (so that [r]× v = r × v)."""
    z = np.zeros(len(r))
    return np.stack([np.stack([z, -r[:, 2], r[:, 1]], -1), np.stack([r[:, 2], z, -r[:, 0]], -1),
                     np.stack([-r[:, 1], r[:, 0], z], -1)], -2)


def body_flow(r: np.ndarray, radius: float, viscosity: float, aspect: float = 1.0):
    """(G_t, G_r), each (m, 3, 3): the flow at offsets r (m, 3) from a body's centre per unit
    force (G_t) and per unit torque (G_r, u = T × r / 8πη|r|³) on the body. Sphere
    (``aspect`` 1): the exact flows of a translating and a rotating sphere of ``radius`` a
    (:func:`sphere_coupling`; rigid-body motion inside). Prolate spheroid: its Stokeslet and
    rotlet at the centre, with |r| bounded below by the equatorial radius (no finite-size
    terms). By reciprocity, G_tᵀ and G_rᵀ give the body's velocity and angular velocity per
    point force at r (Faxén: the mean flow, half the vorticity)."""
    r = np.asarray(r, float)
    d = np.linalg.norm(r, axis=1)
    c8 = 8 * math.pi * viscosity
    if aspect == 1.0:
        gt = sphere_coupling(r, radius, viscosity)
    else:
        de = np.maximum(d, radius)[:, None, None]
        rr = r[:, :, None] * r[:, None, :] / (de * de)
        gt = (np.eye(3) + rr) / (c8 * de)
    gr = -_skew(r) / (c8 * np.maximum(d, radius)[:, None, None] ** 3)
    return gt, gr


def grand_mobility(x, radius, viscosity, centre, body_radius, body_aspect=1.0, axis=(0.0, 0.0, 1.0),
                   body=None) -> np.ndarray:
    """Mobility (3(n+1) + 6 square) of the beads x (filament radius ``radius``) and a rigid
    body centred at ``centre``: (U_0 … U_n, V, Ω) = M (F_0 … F_n, F_B, T_B). Bead–bead:
    :func:`flagellum.hydro.sbt.mobility`; body–bead: :func:`body_flow` and its transpose;
    body–body: the inverse of its Stokes resistance (:func:`flagellum.hydro.body.body_resistance`,
    equatorial semi-axis ``body_radius``, polar ``body_aspect``·a along ``axis``; ``body``: a
    :class:`~flagellum.hydro.body.BodyResistance` instead)."""
    from .body import body_resistance

    n1 = len(x)
    m = 3 * n1
    gt, gr = body_flow(np.asarray(x, float) - np.asarray(centre, float), body_radius, viscosity,
                       body_aspect)
    rb = body or body_resistance(body_radius, body_aspect, viscosity)
    e = np.asarray(axis, float)
    ee = np.outer(e, e) / (e @ e)
    big = np.zeros((m + 6, m + 6))
    big[:m, :m] = sbt.mobility(x, radius, viscosity)
    big[:m, m:m + 3], big[:m, m + 3:] = gt.reshape(m, 3), gr.reshape(m, 3)
    big[m:m + 3, :m], big[m + 3:, :m] = gt.reshape(m, 3).T, gr.reshape(m, 3).T
    big[m:m + 3, m:m + 3] = ee / rb.translation_axial + (np.eye(3) - ee) / rb.translation_transverse
    big[m + 3:, m + 3:] = ee / rb.rotation_axial + (np.eye(3) - ee) / rb.rotation_transverse
    return big


def sphere_centre(x: np.ndarray, sphere_radius: float) -> np.ndarray:
    """Centre of a load sphere or a free swimmer's sphere: x_0 + a e_z (the filament leaves its
    rear pole along −e_z)."""
    return np.asarray(x[0], float) + np.array([0.0, 0.0, sphere_radius])


def effective_mobility(x, radius, viscosity, anchor, sphere_radius=0.0) -> np.ndarray:
    """Nonlocal bead mobility (3(n+1) square) under the anchor's constraints: U = M_eff F with
    F the applied bead forces (see the module docstring). ``anchor`` a code of
    :mod:`flagellum.hydro.local` (FIXED, AXIAL, FREE). With a sphere (AXIAL, FREE and
    ``sphere_radius`` > 0) it translates with bead 0; on a load sphere (AXIAL) it does not
    turn (the paper's load sphere), a free swimmer's sphere turns freely (torque-free: its
    rotation from the filament's vorticity)."""
    n1 = len(x)
    m = 3 * n1
    free = moving_components(anchor, n1)
    if anchor != L.FIXED and sphere_radius > 0:
        big = grand_mobility(x, radius, viscosity, sphere_centre(x, sphere_radius), sphere_radius)
        # constraints C u = 0 on (U_0 … U_n, V, Ω): the sphere moves with bead 0 (V = U_0),
        # bead 0's fixed components, and on a load sphere Ω = 0 (its reaction torque acts on
        # the fluid); a free swimmer's sphere is torque-free (Ω unconstrained)
        rows = [np.eye(3, m + 6, m) - np.eye(3, m + 6, 0)]
        if anchor != L.FREE:
            rows.append(np.eye(3, m + 6, m + 3))
        fixed = np.flatnonzero(~free)
        if len(fixed):
            rows.append(np.eye(m + 6)[fixed])
        return _constrained(big, np.vstack(rows), m, fixed)
    M = sbt.mobility(x, radius, viscosity)
    # no sphere: the constraints fix the first k components, and _constrained is the Schur
    # complement M_ff − M_fc M_cc⁻¹ M_cf, here from the blocks directly
    k = int(np.count_nonzero(~free))
    if k == 0:
        return M
    out = np.zeros((m, m))
    out[k:, k:] = M[k:, k:] - M[k:, :k] @ np.linalg.solve(M[:k, :k], M[:k, k:])
    return out


def _constrained(big: np.ndarray, C: np.ndarray, m: int, fixed: np.ndarray) -> np.ndarray:
    """The first m rows and columns of the mobility under the constraints C u = 0, the
    constraint forces Cᵀλ acting on the fluid: M − M Cᵀ (C M Cᵀ)⁻¹ C M. This is the
    resistance form P (Pᵀ M⁻¹ P)⁻¹ Pᵀ for any P whose range is the null space of C (both
    vanish on Cᵀ and reproduce P on M⁻¹P), in O(N²) instead of dense inverses; for a
    constraint that only fixes components it is the Schur complement M_ff − M_fc M_cc⁻¹ M_cf.
    ``fixed``: the bead components C fixes, whose rows and columns are set to zero."""
    mc = big[:m] @ C.T  # (m, k)
    cm = C @ big[:, :m]  # (k, m)
    out = big[:m, :m] - mc @ np.linalg.solve(C @ big @ C.T, cm)
    out[fixed, :] = 0.0  # exactly zero (roundoff of the product otherwise)
    out[:, fixed] = 0.0
    return out


class CellBody(NamedTuple):
    """A cell body for the coupled mobility: its centre and unit symmetry axis, equatorial
    semi-axis a, aspect p = c/a, and the local rotational friction ``hook_friction`` across the
    motor axis that a clamped hook adds to the body (½γ⊥h³, 0 for a free or elastic hook)."""

    centre: np.ndarray
    axis: np.ndarray
    radius: float
    aspect: float
    hook_friction: float = 0.0

    def motor_axis(self, point) -> np.ndarray:
        """The inward unit normal m of the body's surface at ``point`` (the motor point)."""
        d = np.asarray(point, float) - self.centre
        z = d @ self.axis
        nrm = (d - z * self.axis) / self.radius ** 2 + z * self.axis / (self.aspect * self.radius) ** 2
        return -nrm / np.linalg.norm(nrm)


def cell_mobility(x, radius, viscosity, cell: CellBody) -> np.ndarray:
    """Mobility (3(n+2) square) of a free cell: its generalized velocities q = (V, U_1 … U_n,
    Ω) (3×3 blocks; the body's velocity V and angular velocity Ω first and last) per
    generalized force (F_0 + F_B, F_1 … F_n, T_B + d × F_0): the grand mobility
    (:func:`grand_mobility`) in resistance form, Pᵀ M⁻¹ P with P the map of q to
    (U_0 … U_n, V, Ω) (U_0 = V + Ω × d, bead 0 the motor point), plus a clamped
    hook's local friction across the motor axis, inverted."""
    big = grand_mobility(x, radius, viscosity, cell.centre, cell.radius, cell.aspect, cell.axis)
    n1 = len(x)
    m = 3 * n1
    # Pᵀ M⁻¹ P inverted without dense inverses (:func:`_constrained`): P(Pᵀ M⁻¹ P)⁻¹Pᵀ is the
    # mobility under the constraint C u = U_0 − V − Ω × d = 0, and its rows of V, U_1 … U_n,
    # Ω (where P is the identity) are the slots' mobility
    C = np.zeros((3, m + 6))
    C[:, :3], C[:, m:m + 3] = np.eye(3), -np.eye(3)
    C[:, m + 3:] = _skew((np.asarray(x[0], float) - cell.centre)[None])[0]
    bc = big @ C.T
    w = big - bc @ np.linalg.solve(C @ bc, C @ big)
    slots = np.r_[m:m + 3, 3:m, m + 3:m + 6]
    out = w[np.ix_(slots, slots)]
    if cell.hook_friction:  # + H on Ω's resistance: push-through, (R + SᵀH S)⁻¹ = M − M Sᵀ(1 + H S M Sᵀ)⁻¹ H S M
        a = cell.motor_axis(x[0])
        h = cell.hook_friction * (np.eye(3) - np.outer(a, a))
        out = out - out[:, -3:] @ np.linalg.solve(np.eye(3) + h @ out[-3:, -3:], h @ out[-3:])
    return out


def cell_local_mobility(x, h, gpar, gperp, viscosity, cell: CellBody) -> np.ndarray:
    """The local counterpart of :func:`cell_mobility`, block for block the operator of
    :func:`flagellum.rod.kernels.cell_motion` and :func:`flagellum.hydro.local.bead_friction`:
    beads 1 … n their local drag, (V, Ω) the inverse of the body's resistance plus bead 0's
    friction at the motor point (and a clamped hook's friction across m)."""
    from .body import body_resistance

    n1 = len(x)
    out = local_mobility(x, h, gpar, gperp, L.CELL, 0.0)
    out = np.pad(out, ((0, 3), (0, 3)))
    rb = body_resistance(cell.radius, cell.aspect, viscosity)
    ee = np.outer(cell.axis, cell.axis)
    t = (x[1] - x[0]) / np.linalg.norm(x[1] - x[0])
    z0 = 0.5 * h * (gpar * np.outer(t, t) + gperp * (np.eye(3) - np.outer(t, t)))
    dx = _skew((np.asarray(x[0], float) - cell.centre)[None])[0]
    G = np.zeros((6, 6))
    G[:3, :3] = rb.translation_transverse * np.eye(3) + (rb.translation_axial - rb.translation_transverse) * ee + z0
    G[:3, 3:] = -z0 @ dx
    G[3:, :3] = dx @ z0
    G[3:, 3:] = rb.rotation_transverse * np.eye(3) + (rb.rotation_axial - rb.rotation_transverse) * ee - dx @ z0 @ dx
    if cell.hook_friction:
        m = cell.motor_axis(x[0])
        G[3:, 3:] += cell.hook_friction * (np.eye(3) - np.outer(m, m))
    Gi = np.linalg.inv(G)
    s = [0, 1, 2, 3 * n1, 3 * n1 + 1, 3 * n1 + 2]
    out[np.ix_(s, s)] = Gi
    return out


def _attach(R: np.ndarray, n1: int) -> np.ndarray:
    """Pᵀ R P for P the map of bead velocities to (bead velocities, sphere velocity = bead 0's)."""
    m = 3 * n1
    out = R[:m, :m].copy()
    out[:, :3] += R[:m, m:]
    out[:3, :] += R[m:, :m]
    out[:3, :3] += R[m:, m:]
    return out


def rigid_fit(x_ref, x, anchor, axial=None):
    """(R, residual): the rotation R about bead 0 that best maps the beads x_ref onto x, among
    those under which the anchored problem (and so ΔM) is invariant — about e_z only on a load
    sphere (``AXIAL``) or with ``axial`` (a free swimmer's sphere, which sits at x_0 + a e_z),
    any for ``FIXED`` and ``FREE`` (Kabsch's least-squares fit; a cell body's points are part
    of x) — and the largest bead distance left, |x − x_0 − R(x_ref − x_ref,0)|: relative to
    bead 0, since the problem is invariant under its translation too where bead 0 moves (a
    free swimmer's body, a load sphere along z; ``FIXED``: also its own displacement)."""
    a, b = x_ref - x_ref[0], x - x[0]
    if anchor == L.AXIAL if axial is None else axial:
        s = np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
        c = np.sum(a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1])
        phi = math.atan2(s, c)
        R = np.array([[math.cos(phi), -math.sin(phi), 0.0], [math.sin(phi), math.cos(phi), 0.0],
                      [0.0, 0.0, 1.0]])
    else:
        u, _, vt = np.linalg.svd(b.T @ a)
        d = np.sign(np.linalg.det(u @ vt))
        R = u @ np.diag([1.0, 1.0, d]) @ vt
    resid = np.max(np.abs(b - a @ R.T))
    if anchor == L.FIXED:
        resid = max(resid, float(np.max(np.abs(x[0] - x_ref[0]))))
    return R, resid


#: the arc length [µm] of ΔM's near field in the stiff solvers' banded Newton matrix
#: (preconditioner), and its least width in beads (:func:`near_beads`)
NEAR_ARC = 0.2
NEAR_MIN_BEADS = 2


def near_beads(h: float) -> int:
    """Width in beads of ΔM's near field in the banded Newton matrix: the blocks between
    beads within :data:`NEAR_ARC` of arc length, at least :data:`NEAR_MIN_BEADS` (2 up to
    N = 100 on the paper's filament, 4 at N = 200, 8 at N = 400). A width fixed in beads
    shrinks the near field in length as N grows, and at N = 400 (2 beads: 0.05 µm) GMRES no
    longer converged in CVODE's Newton steps: the run took 2.8 times the steps and its thrust
    had spikes 13 % off the unfrozen splitting's."""
    return max(NEAR_MIN_BEADS, int(round(NEAR_ARC / h)))


#: the largest turn [rad] of a bond allowed between two builds of ΔM, as a multiple of
#: λ_min(M_eff) / λ_max(M_loc) (:func:`turn_limit`). The turn at which M_loc(y) + ΔM(x*)
#: loses positive definiteness was measured at 4–8 times that ratio (smooth bends of the
#: paper's helix and of thicker, thinner and shorter ones, h/ε = 1.5–12:
#: tests/test_sbt_fine.py, docs/hydrodynamics.md), so this leaves a margin of 2–4.
TURN_SAFETY = 2.0


def turn_limit(dm: np.ndarray, x: np.ndarray, h: float, gammas) -> float:
    """The largest bond turn [rad] between builds of ΔM that keeps the applied mobility
    M_loc(y) + ΔM(x*) positive definite: :data:`TURN_SAFETY` · λ_min / λ_max, λ_min the
    smallest eigenvalue of the symmetric part of M_eff = M_loc + ΔM over beads 1 … n (the
    first 3 + 3n slots: a cell's V, the beads' for the others) and λ_max a bound on the
    local mobility's largest (Gershgorin). The local part follows the current tangents while
    ΔM is frozen, so a turn θ moves M_loc by about θ·λ_max; where SBT's zig-zag modes have a
    mobility far below the local one (beads spaced by a few blob sizes: λ_min/λ_max is 0.14
    at N = 50, 0.011 at N = 400 on the paper's 10-µm filament) a small turn is enough to
    make the sum indefinite and a bond-scale mode grow until the next build."""
    n1 = len(x)
    loc = local_mobility(np.asarray(x, float)[:n1], h, gammas[0], gammas[1], L.FREE, 0.0)[3:, 3:]
    m = loc.shape[0]
    me = dm[3:3 + m, 3:3 + m] + loc
    lam = float(np.linalg.eigvalsh(0.5 * (me + me.T))[0])
    return TURN_SAFETY * max(lam, 0.0) / float(np.abs(loc).sum(axis=1).max())


def bond_change(dx: np.ndarray) -> float:
    """The largest change of a bond vector for bead displacements (or velocities) dx:
    max |dx_{i+1} − dx_i|."""
    return float(np.max(np.abs(np.diff(dx, axis=0))))


def bonds_within(x: np.ndarray, x_ref: np.ndarray, limit: float) -> bool:
    """Whether no bond of the beads x has changed by more than ``limit`` (a length) against
    x_ref: |(x_{i+1} − x_i) − (x_ref,i+1 − x_ref,i)| ≤ limit."""
    return bond_change(x - x_ref) <= limit


def rotate_correction(dm, R):
    """ΔM of the beads turned by R (about bead 0): each 3×3 block D_ij becomes R D_ij Rᵀ
    (the mobility of a rotated configuration, by the isotropy of Stokes flow)."""
    out = np.empty_like(dm)
    _rotate_blocks(np.ascontiguousarray(dm, dtype=float), np.asarray(R, float), out)
    return out


@njit(cache=True)
def _rotate_blocks(dm, R, out):
    m = dm.shape[0]
    tmp = np.empty((3, 3))
    for i in range(0, m, 3):
        for j in range(0, m, 3):
            for a in range(3):  # tmp = R D_ij
                for c in range(3):
                    tmp[a, c] = R[a, 0] * dm[i, j + c] + R[a, 1] * dm[i + 1, j + c] + R[a, 2] * dm[i + 2, j + c]
            for a in range(3):  # out_ij = tmp Rᵀ
                for d in range(3):
                    out[i + a, j + d] = tmp[a, 0] * R[d, 0] + tmp[a, 1] * R[d, 1] + tmp[a, 2] * R[d, 2]


def correction(x, h, gammas, anchor, zeta, radius, viscosity, sphere_radius=0.0,
               symmetric=False) -> np.ndarray:
    """ΔM = M_eff − M_loc at frozen bead positions x (:func:`effective_mobility`,
    :func:`local_mobility`); ``gammas`` (γ∥, γ⊥, γR) of the local drag. ``symmetric``: M_eff
    replaced by its symmetric part (M_eff + M_effᵀ)/2, the mobility of a thermal run (the
    collocation matrix is not exactly symmetric, and fluctuation–dissipation needs the noise
    covariance 2kT M to be the symmetric mobility that also moves the filament)."""
    me = effective_mobility(x, radius, viscosity, anchor, sphere_radius)
    if symmetric:
        me = 0.5 * (me + me.T)
    return me - local_mobility(x, h, gammas[0], gammas[1], anchor, zeta)


def cell_correction(x, h, gammas, radius, viscosity, cell: CellBody, symmetric=False) -> np.ndarray:
    """ΔM = M_cell − M_cell,loc (3(n+2) square, :func:`cell_mobility`,
    :func:`cell_local_mobility`) at frozen bead positions x and body ``cell``: what
    :func:`flagellum.rod.kernels.cell_motion` adds to the body's and the beads' local motion."""
    me = cell_mobility(x, radius, viscosity, cell)
    if symmetric:
        me = 0.5 * (me + me.T)
    return me - cell_local_mobility(x, h, gammas[0], gammas[1], viscosity, cell)


def moving_components(anchor, n1: int) -> np.ndarray:
    """Mask of the 3·n1 bead velocity components the anchor leaves free (bead 0: none when
    ``FIXED``, z only on a load sphere ``AXIAL``, all for ``FREE``); the mobility's rows and
    columns of the others are zero."""
    free = np.ones(3 * n1, bool)
    if anchor == L.FIXED:
        free[:3] = False
    elif anchor == L.AXIAL:
        free[:2] = False
    return free


__all__ = ["CellBody", "Hydrodynamics", "MODELS", "REFRESH", "body_flow", "cell_correction",
           "cell_local_mobility", "cell_mobility", "correction", "effective_mobility",
           "grand_mobility", "local_mobility", "moving_components", "rigid_fit",
           "rotate_correction", "sphere_centre", "sphere_coupling", "turn_limit", "bonds_within", "near_beads"]
