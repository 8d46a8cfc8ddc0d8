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

import functools
import math
from typing import NamedTuple

import numpy as np
from numba import njit

from . import body as Bd
from . import local as L
from . import sbt
from .options import MODELS, REFRESH, Hydrodynamics

def bond_tangents(x: np.ndarray) -> np.ndarray:
    """The (n+1, 3) tangent table of :func:`flagellum.hydro.local.bead_node` (row i ≥ 1: the
    unit vector of bond i; row 0, the hook frame, is not used there)."""
    return _bond_tangents(np.ascontiguousarray(x, dtype=float))


@njit(cache=True)
def _bond_tangents(x):
    T = np.zeros_like(x)
    for j in range(1, x.shape[0]):
        d0, d1, d2 = x[j, 0] - x[j - 1, 0], x[j, 1] - x[j - 1, 1], x[j, 2] - x[j - 1, 2]
        ln = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        T[j, 0], T[j, 1], T[j, 2] = d0 / ln, d1 / ln, d2 / ln
    return T


def local_mobility(x, h, gpar, gperp, anchor, zeta) -> np.ndarray:
    """Block-diagonal mobility (3(n+1) square) of the local drag of :mod:`flagellum.hydro.local`
    at bead positions x: the operator of :func:`flagellum.rod.kernels.rhs` without ΔM."""
    n = len(x) - 1
    M = np.zeros((3 * (n + 1), 3 * (n + 1)))
    _fill_local(bond_tangents(x), n, h, gpar, gperp, anchor, zeta, M, 1.0)
    return M


@njit(cache=True)
def _fill_local(T, n, h, gpar, gperp, anchor, zeta, M, scale):
    """M += ``scale`` · the local mobility's diagonal blocks."""
    for i in range(n + 1):
        tx, ty, tz, zpar, zperp, mode = L.bead_friction(T, i, n, h, gpar, gperp, anchor, zeta)
        o = 3 * i
        if mode == L.AXIAL:
            M[o + 2, o + 2] += scale / zpar
        elif mode == L.FREE:
            t = (tx, ty, tz)
            for a in range(3):
                for b in range(a, 3):  # symmetric to the last bit
                    v = scale * ((1.0 / zpar - 1.0 / zperp) * t[a] * t[b]
                                 + (1.0 / zperp if a == b else 0.0))
                    M[o + a, o + b] += v
                    if b != a:
                        M[o + b, o + a] += v


def sphere_coupling(r: np.ndarray, a: float, viscosity: float) -> np.ndarray:
    """(m, 3, 3) blocks G(r) of a translating sphere of radius a at offsets r (m, 3): the flow
    at r per force on the sphere, and (Faxén's law) the sphere's velocity per point force at r.
    Outside: [(1 + r̂r̂)/r + a²/3 (1 − 3r̂r̂)/r³]/8πη; inside: rigid motion, 1/(6πηa)."""
    return body_flow(r, a, viscosity)[0]


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
    r = np.ascontiguousarray(r, dtype=float)
    gt, gr = np.empty((len(r), 3, 3)), np.empty((len(r), 3, 3))
    _body_flow_into(r, float(radius), float(viscosity), float(aspect), gt, gr)
    return gt, gr


@njit(cache=True)
def _body_flow_into(r, radius, viscosity, aspect, gt, gr):
    """:func:`body_flow` into gt and gr."""
    c8 = 8.0 * math.pi * viscosity
    for i in range(r.shape[0]):
        d = math.sqrt(r[i, 0] ** 2 + r[i, 1] ** 2 + r[i, 2] ** 2)
        de = max(d, radius)
        for a in range(3):
            for b in range(3):
                one = 1.0 if a == b else 0.0
                if aspect != 1.0:
                    gt[i, a, b] = (one + r[i, a] * r[i, b] / (de * de)) / (c8 * de)
                elif d < radius:
                    gt[i, a, b] = one / (6.0 * math.pi * viscosity * radius)
                else:
                    rr = r[i, a] * r[i, b] / (d * d)
                    gt[i, a, b] = ((one + rr) / d + radius * radius / 3.0 * (one - 3.0 * rr) / d ** 3) / c8
        s = 1.0 / (c8 * de ** 3)  # −[r]× / 8πη max(|r|, a)³
        gr[i, 0, 0], gr[i, 0, 1], gr[i, 0, 2] = 0.0, r[i, 2] * s, -r[i, 1] * s
        gr[i, 1, 0], gr[i, 1, 1], gr[i, 1, 2] = -r[i, 2] * s, 0.0, r[i, 0] * s
        gr[i, 2, 0], gr[i, 2, 1], gr[i, 2, 2] = r[i, 1] * s, -r[i, 0] * s, 0.0


def grand_mobility(x, radius, viscosity, centre, body_radius, body_aspect=1.0, axis=(0.0, 0.0, 1.0),
                   body=None) -> np.ndarray:
    """Mobility (3(n+1) + 6 square) of the beads x (filament radius ``radius``) and a rigid
    body centred at ``centre``: (U_0 … U_n, V, Ω) = M (F_0 … F_n, F_B, T_B). Bead–bead:
    :func:`flagellum.hydro.sbt.mobility`; body–bead: :func:`body_flow` and its transpose;
    body–body: the inverse of its Stokes resistance (:func:`flagellum.hydro.body.body_resistance`,
    equatorial semi-axis ``body_radius``, polar ``body_aspect``·a along ``axis``; ``body``: a
    :class:`~flagellum.hydro.body.BodyResistance` instead)."""
    from .body import body_resistance

    x = sbt._check_positions(x)
    n1 = len(x)
    rb = body or body_resistance(body_radius, body_aspect, viscosity)
    e = np.asarray(axis, float)
    big = np.empty((3 * n1 + 6, 3 * n1 + 6))
    _grand_into(x, _blob_sizes(radius, n1 - 1), sbt._bead_lengths(sbt._bond_lengths(x)),
                float(viscosity), np.asarray(centre, float), float(body_radius),
                float(body_aspect), e / np.linalg.norm(e), np.asarray(rb, float), big)
    return big


def _blob_sizes(radius, n: int) -> np.ndarray:
    """The blob size ε of each of the n segments (:data:`flagellum.hydro.sbt.EPS_PER_RADIUS`)."""
    return sbt.EPS_PER_RADIUS * sbt._segment_radius(radius, n)


@njit(cache=True)
def _grand_into(x, eps, w, viscosity, centre, radius, aspect, axis, rb, big):
    """:func:`grand_mobility` into ``big``: ``w`` the bead lengths, ``axis`` a unit vector,
    ``rb`` the body's four resistances (:class:`~flagellum.hydro.body.BodyResistance`)."""
    n1 = x.shape[0]
    m = 3 * n1
    sbt._mobility_into(x, eps, w, viscosity, -1.0, big[:m, :m])
    r = np.empty((n1, 3))
    for i in range(n1):
        for a in range(3):
            r[i, a] = x[i, a] - centre[a]
    gt, gr = np.empty((n1, 3, 3)), np.empty((n1, 3, 3))
    _body_flow_into(r, radius, viscosity, aspect, gt, gr)
    for i in range(n1):
        for a in range(3):
            for b in range(3):
                big[3 * i + a, m + b] = gt[i, a, b]
                big[3 * i + a, m + 3 + b] = gr[i, a, b]
                big[m + b, 3 * i + a] = gt[i, a, b]
                big[m + 3 + b, 3 * i + a] = gr[i, a, b]
    for a in range(3):
        for b in range(3):
            ee = axis[a] * axis[b]
            one = 1.0 if a == b else 0.0
            big[m + a, m + b] = ee / rb[0] + (one - ee) / rb[1]
            big[m + 3 + a, m + 3 + b] = ee / rb[2] + (one - ee) / rb[3]
            big[m + a, m + 3 + b] = 0.0
            big[m + 3 + a, m + b] = 0.0


@njit(cache=True)
def sphere_centre(x: np.ndarray, sphere_radius: float) -> np.ndarray:
    """Centre of a load sphere or a free swimmer's sphere: x_0 + a e_z (the filament leaves its
    rear pole along −e_z)."""
    return np.array([x[0, 0], x[0, 1], x[0, 2] + sphere_radius])


def effective_mobility(x, radius, viscosity, anchor, sphere_radius=0.0) -> np.ndarray:
    """Nonlocal bead mobility (3(n+1) square) under the anchor's constraints: U = M_eff F with
    F the applied bead forces (see the module docstring). ``anchor`` a code of
    :mod:`flagellum.hydro.local` (FIXED, AXIAL, FREE). With a sphere (AXIAL, FREE and
    ``sphere_radius`` > 0) it translates with bead 0; on a load sphere (AXIAL) it does not
    turn (the paper's load sphere), a free swimmer's sphere turns freely (torque-free: its
    rotation from the filament's vorticity)."""
    x = sbt._check_positions(x)
    out = np.empty((3 * len(x), 3 * len(x)))
    _effective_into(x, _blob_sizes(radius, len(x) - 1), float(viscosity), anchor,
                    float(sphere_radius), _sphere_resistance(sphere_radius, viscosity), out)
    return out


@functools.lru_cache(maxsize=64)
def _sphere_resistance(sphere_radius, viscosity) -> np.ndarray:
    """The four resistances of a load or body sphere (zeros without one; read-only, cached:
    every build of ΔM asks)."""
    from .body import body_resistance

    out = np.zeros(4)
    if sphere_radius > 0:
        out[:] = body_resistance(sphere_radius, 1.0, viscosity)
    out.flags.writeable = False
    return out


@njit(cache=True)
def _effective_into(x, eps, viscosity, anchor, sphere_radius, rb, out):
    """:func:`effective_mobility` into ``out``; ``rb`` the sphere's resistances."""
    n1 = x.shape[0]
    m = 3 * n1
    w = sbt._bead_lengths(sbt._bond_lengths(x))
    # constraints C u = 0, row r: coef[r, 0] u[idx[r, 0]] + coef[r, 1] u[idx[r, 1]]
    # (idx −1: no second term)
    idx = np.full((8, 2), -1, np.int64)
    coef = np.zeros((8, 2))
    k = 0
    if anchor != L.FIXED and sphere_radius > 0:
        big = np.empty((m + 6, m + 6))
        _grand_into(x, eps, w, viscosity, sphere_centre(x, sphere_radius), sphere_radius, 1.0,
                    np.array([0.0, 0.0, 1.0]), rb, big)
        # the sphere moves with bead 0 (V = U_0); on a load sphere (AXIAL) it does not turn
        # (Ω = 0: its reaction torque acts on the fluid), a free swimmer's sphere is
        # torque-free (Ω unconstrained)
        for a in range(3):
            idx[k, 0], coef[k, 0], idx[k, 1], coef[k, 1] = m + a, 1.0, a, -1.0
            k += 1
        if anchor != L.FREE:
            for a in range(3):
                idx[k, 0], coef[k, 0] = m + 3 + a, 1.0
                k += 1
    else:  # constrained in place
        big = out
        sbt._mobility_into(x, eps, w, viscosity, -1.0, big)
    for a in range(fixed_components(anchor)):  # bead 0's
        idx[k, 0], coef[k, 0] = a, 1.0
        k += 1
    _constrained_into(big, m, idx[:k], coef[:k], out)


@njit(cache=True)
def _constrained_into(big, m, idx, coef, out):
    """The first m rows and columns of the mobility ``big`` under the constraints C u = 0
    (row r: Σ_t coef[r, t] u[idx[r, t]], idx −1 for no term), the constraint forces Cᵀλ
    acting on the fluid: M − M Cᵀ (C M Cᵀ)⁻¹ C M, into ``out``. This is the resistance form
    P (Pᵀ M⁻¹ P)⁻¹ Pᵀ for any P whose range is the null space of C (both vanish on Cᵀ and
    reproduce P on M⁻¹P), in O(N²) instead of dense inverses; for a constraint that only
    fixes components it is the Schur complement M_ff − M_fc M_cc⁻¹ M_cf. The bead components
    that a constraint fixes alone get zero rows and columns. ``big`` may be ``out`` (m
    square): the update is then done in place, with no copy of the matrix."""
    k = idx.shape[0]
    size = big.shape[0]
    mc = np.zeros((size, k))  # M Cᵀ
    cm = np.zeros((k, m))  # C M (bead columns)
    terms = idx.shape[1]
    for r in range(k):
        for t in range(terms):
            j = idx[r, t]
            if j < 0:
                continue
            c = coef[r, t]
            for i in range(size):
                mc[i, r] += c * big[i, j]
            for i in range(m):
                cm[r, i] += c * big[j, i]
    cmc = np.zeros((k, k))
    for r in range(k):
        for t in range(terms):
            j = idx[r, t]
            if j >= 0:
                for q in range(k):
                    cmc[r, q] += coef[r, t] * mc[j, q]
    z = _solve_small(cmc, cm)
    for i in range(m):  # out = big − (M Cᵀ) z, row by row (``big`` may be ``out``)
        row = out[i]
        for j in range(m):
            row[j] = big[i, j]
        for r in range(k):
            a = mc[i, r]
            zr = z[r]
            for j in range(m):
                row[j] -= a * zr[j]
    for r in range(k):
        j = idx[r, 0]
        alone = True
        for t in range(1, terms):
            alone = alone and idx[r, t] < 0
        if alone and j < m:  # exactly zero (roundoff of the product otherwise)
            out[j, :] = 0.0
            out[:, j] = 0.0


@njit(cache=True)
def _solve_small(a, b):
    """a⁻¹ b for a small k×k matrix a (the constraints', k ≤ 8) and k×m b, by Gaussian
    elimination with partial pivoting, overwriting both (returns b): LAPACK's wrapper
    cost 7.6 µs for k = 3, m = 153, most of it not arithmetic."""
    k, m = b.shape
    for c in range(k):
        p = c
        for r in range(c + 1, k):
            if abs(a[r, c]) > abs(a[p, c]):
                p = r
        if a[p, c] == 0.0:
            raise np.linalg.LinAlgError("singular constraint matrix")
        if p != c:
            for q in range(k):
                a[c, q], a[p, q] = a[p, q], a[c, q]
            for j in range(m):
                b[c, j], b[p, j] = b[p, j], b[c, j]
        for r in range(c + 1, k):
            f = a[r, c] / a[c, c]
            if f != 0.0:
                for q in range(c, k):
                    a[r, q] -= f * a[c, q]
                for j in range(m):
                    b[r, j] -= f * b[c, j]
    for c in range(k - 1, -1, -1):
        inv = 1.0 / a[c, c]
        for j in range(m):
            b[c, j] *= inv
        for r in range(c):
            f = a[r, c]
            if f != 0.0:
                for j in range(m):
                    b[r, j] -= f * b[c, j]
    return b


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
        return _motor_axis(np.asarray(point, float), np.asarray(self.centre, float),
                           np.asarray(self.axis, float), float(self.radius), float(self.aspect))

    def arguments(self, viscosity: float) -> tuple:
        """(centre, axis, a, p, the body's four resistances, hook friction): the body's
        arguments of the compiled routines :func:`_cell_mobility_into` and
        :func:`_cell_local_into`."""
        return (np.asarray(self.centre, float), np.asarray(self.axis, float), float(self.radius),
                float(self.aspect), _body_resistance(self.radius, self.aspect, viscosity),
                float(self.hook_friction))


@functools.lru_cache(maxsize=64)
def _body_resistance(radius, aspect, viscosity) -> np.ndarray:
    """The four resistances of a cell body (read-only, cached: every build of ΔM asks)."""
    from .body import body_resistance

    out = np.array(body_resistance(radius, aspect, viscosity), float)
    out.flags.writeable = False
    return out


@njit(cache=True)
def _motor_axis(point, centre, axis, radius, aspect):
    """:meth:`CellBody.motor_axis`: minus the normalized gradient of the spheroid's surface
    function at ``point``."""
    z = 0.0
    for a in range(3):
        z += (point[a] - centre[a]) * axis[a]
    out = np.empty(3)
    for a in range(3):
        d = point[a] - centre[a]
        out[a] = (d - z * axis[a]) / radius ** 2 + z * axis[a] / (aspect * radius) ** 2
    nrm = math.sqrt(out[0] ** 2 + out[1] ** 2 + out[2] ** 2)
    for a in range(3):
        out[a] = -out[a] / nrm
    return out


def cell_mobility(x, radius, viscosity, cell: CellBody) -> np.ndarray:
    """Mobility (3(n+2) square) of a free cell: its generalized velocities q = (V, U_1 … U_n,
    Ω) (3×3 blocks; the body's velocity V and angular velocity Ω first and last) per
    generalized force (F_0 + F_B, F_1 … F_n, T_B + d × F_0): the grand mobility
    (:func:`grand_mobility`) in resistance form, Pᵀ M⁻¹ P with P the map of q to
    (U_0 … U_n, V, Ω) (U_0 = V + Ω × d, bead 0 the motor point), plus a clamped
    hook's local friction across the motor axis, inverted."""
    x = sbt._check_positions(x)
    out = np.empty((3 * len(x) + 3, 3 * len(x) + 3))
    _cell_mobility_into(x, _blob_sizes(radius, len(x) - 1), float(viscosity),
                        *cell.arguments(viscosity), out)
    return out


@njit(cache=True)
def _cell_mobility_into(x, eps, viscosity, centre, axis, radius, aspect, rb, hook_friction, out):
    """:func:`cell_mobility` into ``out``."""
    n1 = x.shape[0]
    m = 3 * n1
    big = np.empty((m + 6, m + 6))
    _grand_into(x, eps, sbt._bead_lengths(sbt._bond_lengths(x)), viscosity, centre, radius,
                aspect, axis, rb, big)
    # Pᵀ M⁻¹ P inverted without dense inverses (:func:`_constrained_into`): P(Pᵀ M⁻¹ P)⁻¹Pᵀ is
    # the mobility under the constraint C u = U_0 − V − Ω × d = 0 (row a: U_0,a − V_a +
    # ([d]×Ω)_a), and its rows of V, U_1 … U_n, Ω (where P is the identity) are the slots'
    d0, d1, d2 = x[0, 0] - centre[0], x[0, 1] - centre[1], x[0, 2] - centre[2]
    skew = np.array([[0.0, -d2, d1], [d2, 0.0, -d0], [-d1, d0, 0.0]])
    idx = np.full((3, 4), -1, np.int64)
    coef = np.zeros((3, 4))
    for a in range(3):
        idx[a, 0], coef[a, 0], idx[a, 1], coef[a, 1] = a, 1.0, m + a, -1.0
        t = 2
        for b in range(3):
            if skew[a, b] != 0.0:
                idx[a, t], coef[a, t] = m + 3 + b, skew[a, b]
                t += 1
    w = np.empty((m + 6, m + 6))
    _constrained_into(big, m + 6, idx, coef, w)
    k = m + 3
    slots = np.empty(k, np.int64)  # V, beads 1 … n, Ω
    for a in range(3):
        slots[a], slots[m + a] = m + a, m + 3 + a
    for i in range(3, m):
        slots[i] = i
    for p in range(k):
        for q in range(k):
            out[p, q] = w[slots[p], slots[q]]
    if hook_friction != 0.0:  # + H on Ω's resistance: push-through,
        # (R + SᵀH S)⁻¹ = M − M Sᵀ(1 + H S M Sᵀ)⁻¹ H S M
        mm = _motor_axis(x[0], centre, axis, radius, aspect)
        hm = np.empty((3, 3))
        for a in range(3):
            for b in range(3):
                hm[a, b] = hook_friction * ((1.0 if a == b else 0.0) - mm[a] * mm[b])
        lhs = np.empty((3, 3))
        rhs = np.zeros((3, k))
        for a in range(3):
            for b in range(3):
                acc = 1.0 if a == b else 0.0
                for c in range(3):
                    acc += hm[a, c] * out[m + c, m + b]
                lhs[a, b] = acc
            for j in range(k):
                acc = 0.0
                for c in range(3):
                    acc += hm[a, c] * out[m + c, j]
                rhs[a, j] = acc
        z = _solve_small(lhs, rhs)
        col = out[:, m:].copy()
        for i in range(k):
            for j in range(k):
                out[i, j] -= col[i, 0] * z[0, j] + col[i, 1] * z[1, j] + col[i, 2] * z[2, j]


def cell_local_mobility(x, h, gpar, gperp, viscosity, cell: CellBody) -> np.ndarray:
    """The local counterpart of :func:`cell_mobility`, block for block the operator of
    :func:`flagellum.rod.kernels.cell_motion` and :func:`flagellum.hydro.local.bead_friction`:
    beads 1 … n their local drag, (V, Ω) the inverse of the body's resistance plus bead 0's
    friction at the motor point (and a clamped hook's friction across m)."""
    x = np.ascontiguousarray(x, dtype=float)
    out = np.zeros((3 * len(x) + 3, 3 * len(x) + 3))
    _cell_local_into(x, float(h), float(gpar), float(gperp), *cell.arguments(viscosity), 1.0, out)
    return out


@njit(cache=True)
def _body_block(x, h, gpar, gperp, centre, axis, rb, hook_friction, radius, aspect):
    """The 6×6 local mobility of the body's slots (V, Ω) in :func:`cell_local_mobility`:
    the inverse of the body's resistance about its centre plus bead 0's friction ζ0 at the
    motor point d (and a clamped hook's across the motor axis)."""
    t = np.empty(3)
    dx = np.zeros((3, 3))  # [d]×
    for a in range(3):
        t[a] = x[1, a] - x[0, a]
    ln = math.sqrt(t[0] ** 2 + t[1] ** 2 + t[2] ** 2)
    for a in range(3):
        t[a] /= ln
    d0, d1, d2 = x[0, 0] - centre[0], x[0, 1] - centre[1], x[0, 2] - centre[2]
    dx[0, 1], dx[0, 2], dx[1, 2] = -d2, d1, -d0
    dx[1, 0], dx[2, 0], dx[2, 1] = d2, -d1, d0
    z0 = np.empty((3, 3))
    ee = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            one = 1.0 if a == b else 0.0
            z0[a, b] = 0.5 * h * (gpar * t[a] * t[b] + gperp * (one - t[a] * t[b]))
            ee[a, b] = axis[a] * axis[b]
    dz = dx @ z0
    zd = z0 @ dx
    dzd = dz @ dx
    g = np.empty((6, 6))
    for a in range(3):
        for b in range(3):
            one = 1.0 if a == b else 0.0
            g[a, b] = rb[1] * one + (rb[0] - rb[1]) * ee[a, b] + z0[a, b]
            g[a, 3 + b] = -zd[a, b]
            g[3 + a, b] = dz[a, b]
            g[3 + a, 3 + b] = rb[3] * one + (rb[2] - rb[3]) * ee[a, b] - dzd[a, b]
    if hook_friction != 0.0:
        mm = _motor_axis(x[0], centre, axis, radius, aspect)
        for a in range(3):
            for b in range(3):
                g[3 + a, 3 + b] += hook_friction * ((1.0 if a == b else 0.0) - mm[a] * mm[b])
    return np.linalg.inv(g)


@njit(cache=True)
def _cell_local_into(x, h, gpar, gperp, centre, axis, radius, aspect, rb, hook_friction, scale, out):
    """out += ``scale`` · :func:`cell_local_mobility` (3(n+2) square)."""
    n1 = x.shape[0]
    # beads 1 … n (bead 0's CELL friction adds nothing here: it is the body block's)
    _fill_local(_bond_tangents(x), n1 - 1, h, gpar, gperp, L.CELL, 0.0, out, scale)
    gi = _body_block(x, h, gpar, gperp, centre, axis, rb, hook_friction, radius, aspect)
    m = 3 * n1
    for p in range(6):
        for q in range(6):
            out[p if p < 3 else m + p - 3, q if q < 3 else m + q - 3] += scale * gi[p, q]


def rigid_fit(x_ref, x, anchor, axial=None):
    """(R, residual): the rotation R about bead 0 that best maps the beads x_ref onto x, among
    those under which the anchored problem (and so ΔM) is invariant — about e_z only on a load
    sphere (``AXIAL``) or with ``axial`` (a free swimmer's sphere, which sits at x_0 + a e_z),
    any for ``FIXED`` and ``FREE`` (Kabsch's least-squares fit; a cell body's points are part
    of x) — and the largest bead distance left, |x − x_0 − R(x_ref − x_ref,0)|: relative to
    bead 0, since the problem is invariant under its translation too where bead 0 moves (a
    free swimmer's body, a load sphere along z; ``FIXED``: also its own displacement)."""
    about_z = anchor == L.AXIAL if axial is None else bool(axial)
    R = np.empty((3, 3))
    resid = _rigid_fit(np.ascontiguousarray(x_ref, dtype=float),
                       np.ascontiguousarray(x, dtype=float), about_z, anchor == L.FIXED, R)
    return R, resid


@njit(cache=True)
def _rigid_fit(x_ref, x, about_z, fixed, R):
    """:func:`rigid_fit` (compiled: it runs at every renewal of ΔM): R written, the residual
    returned."""
    n = x.shape[0]
    a = np.empty((n, 3))
    b = np.empty((n, 3))
    for i in range(n):
        for c in range(3):
            a[i, c] = x_ref[i, c] - x_ref[0, c]
            b[i, c] = x[i, c] - x[0, c]
    if about_z:
        s, c = 0.0, 0.0
        for i in range(n):
            s += a[i, 0] * b[i, 1] - a[i, 1] * b[i, 0]
            c += a[i, 0] * b[i, 0] + a[i, 1] * b[i, 1]
        phi = math.atan2(s, c)
        R[:] = 0.0
        R[0, 0], R[0, 1], R[1, 0], R[1, 1] = math.cos(phi), -math.sin(phi), math.sin(phi), math.cos(phi)
        R[2, 2] = 1.0
    else:
        u, _, vt = np.linalg.svd(np.dot(b.T, a))
        d = 1.0 if np.linalg.det(np.dot(u, vt)) >= 0.0 else -1.0
        for i in range(3):
            for j in range(3):
                R[i, j] = u[i, 0] * vt[0, j] + u[i, 1] * vt[1, j] + d * u[i, 2] * vt[2, j]
    resid = 0.0
    for i in range(n):
        for c in range(3):
            v = b[i, c] - (a[i, 0] * R[c, 0] + a[i, 1] * R[c, 1] + a[i, 2] * R[c, 2])
            resid = max(resid, abs(v))
    if fixed:
        for c in range(3):
            resid = max(resid, abs(x[0, c] - x_ref[0, c]))
    return resid


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


@njit(cache=True)
def limits_used(x, x_ref, n1, refresh, bond):
    """max(largest |x − x_ref| / ``refresh``, largest bond change of the first n1 points over
    ``bond``): the part of the renewal limits that the points x have used since x_ref (the
    measure of :meth:`flagellum.rod.model.RodModel.mobility_use`)."""
    move, turn = 0.0, 0.0
    for i in range(x.shape[0]):
        for c in range(3):
            d = x[i, c] - x_ref[i, c]
            move = max(move, abs(d))
            if 0 < i < n1:
                turn = max(turn, abs(d - (x[i - 1, c] - x_ref[i - 1, c])))
    return max(move / refresh, turn / bond)


@njit(cache=True)
def rotated_limits_used(x, x_ref, n1, refresh, bond, R):
    """:func:`limits_used` after the best rotation R (written) of the points ``x_ref`` about
    their point 0 onto x (:func:`rigid_fit`, any rotation): the part of the renewal limits
    that a ΔM turned by R (R ΔM Rᵀ, a free cell's: its mobility depends on relative
    positions only) has used, the largest residual over ``refresh`` or bond change over
    ``bond``, whichever is larger."""
    move = _rigid_fit(x_ref, x, False, False, R)
    turn = 0.0
    for i in range(1, n1):
        for c in range(3):
            d = x_ref[i, 0] - x_ref[i - 1, 0], x_ref[i, 1] - x_ref[i - 1, 1], x_ref[i, 2] - x_ref[i - 1, 2]
            rd = R[c, 0] * d[0] + R[c, 1] * d[1] + R[c, 2] * d[2]
            turn = max(turn, abs(x[i, c] - x[i - 1, c] - rd))
    return max(move / refresh, turn / bond)


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


@njit(cache=True)
def turn_into(x, frozen, src, dm, within, bond, about_z, fixed, n1):
    """Turn ΔM ``src`` (built at the points ``frozen``) onto the points x, into ``dm`` (which
    may be ``src``), where they moved rigidly: where the best rotation R of ``frozen`` about
    its point 0 (:func:`rigid_fit`, about e_z with ``about_z``; ``fixed``: bead 0's own
    displacement counts too) leaves at most ``within`` and turns none of the first ``n1``
    points' bonds by more than ``bond`` (lengths), each block becomes R D_ij Rᵀ
    (:func:`rotate_correction`) and ``frozen`` the turned points. Returns whether it turned
    (never with ``within`` < 0)."""
    if within < 0.0:
        return False
    R = np.empty((3, 3))
    if _rigid_fit(frozen, x, about_z, fixed, R) > within:
        return False
    n = x.shape[0]
    turned = np.empty((n, 3))
    for i in range(n):
        for a in range(3):
            turned[i, a] = x[0, a] + (R[a, 0] * (frozen[i, 0] - frozen[0, 0])
                                      + R[a, 1] * (frozen[i, 1] - frozen[0, 1])
                                      + R[a, 2] * (frozen[i, 2] - frozen[0, 2]))
    for i in range(1, n1):  # bonds_within
        for a in range(3):
            if abs((x[i, a] - turned[i, a]) - (x[i - 1, a] - turned[i - 1, a])) > bond:
                return False
    _rotate_blocks(src, R, dm)  # block by block: ``dm`` may be ``src``
    for i in range(n):
        for a in range(3):
            frozen[i, a] = turned[i, a]
    return True


@njit(cache=True)
def renew_into(x, frozen, src, dm, turn, build):
    """Renew ΔM into ``dm`` at the bead positions x and set ``frozen`` to them: ``src`` (the
    ΔM built at ``frozen``; may be ``dm``) turned (:func:`turn_into`, ``turn`` its arguments
    after ``dm``) where the beads moved rigidly, else rebuilt (:func:`correction`; ``build``
    the arguments of its compiled routine after x, without ``out``). The renewal of an
    anchored filament, a load sphere or a free swimmer's sphere in one compiled call (a cell
    body's build is not compiled)."""
    if turn_into(x, frozen, src, dm, *turn):
        return
    _correction_into(x, *build, dm)
    for i in range(x.shape[0]):
        for a in range(3):
            frozen[i, a] = x[i, a]


def correction(x, h, gammas, anchor, zeta, radius, viscosity, sphere_radius=0.0,
               symmetric=False, out=None) -> np.ndarray:
    """ΔM = M_eff − M_loc at frozen bead positions x (:func:`effective_mobility`,
    :func:`local_mobility`); ``gammas`` (γ∥, γ⊥, γR) of the local drag. ``symmetric``: M_eff
    replaced by its symmetric part (M_eff + M_effᵀ)/2, the mobility of a thermal run (the
    collocation matrix is not exactly symmetric, and fluctuation–dissipation needs the noise
    covariance 2kT M to be the symmetric mobility that also moves the filament). ``out``: a
    3(n+1)-square array to write it into (the stepper's ΔM; no allocation of the result).

    Compiled end to end (kernel, constraints, local part): the simulator renews ΔM every few
    steps, and the numpy around the kernel was 40 % of a build (docs/hydrodynamics.md,
    "Cost")."""
    x = np.ascontiguousarray(x, dtype=float)
    if out is None:
        out = np.empty((3 * len(x), 3 * len(x)))
    _correction_into(x, *build_arguments(len(x) - 1, h, gammas, anchor, zeta, radius,
                                         viscosity, sphere_radius, symmetric), out)
    return out


def build_arguments(n, h, gammas, anchor, zeta, radius, viscosity, sphere_radius=0.0,
                    symmetric=False) -> tuple:
    """The arguments of :func:`correction`'s compiled routine after the positions and before
    ``out``, for n segments (those of :func:`renew_into`'s build)."""
    return (_blob_sizes(radius, n), float(h), float(gammas[0]), float(gammas[1]), int(anchor),
            float(zeta), float(viscosity), float(sphere_radius),
            _sphere_resistance(sphere_radius, viscosity), bool(symmetric))


@njit(cache=True)
def _correction_into(x, eps, h, gpar, gperp, anchor, zeta, viscosity, sphere_radius, rb,
                     symmetric, out):
    _effective_into(x, eps, viscosity, anchor, sphere_radius, rb, out)
    if symmetric:
        _symmetrize(out)
    _fill_local(_bond_tangents(x), x.shape[0] - 1, h, gpar, gperp, anchor, zeta, out, -1.0)


@njit(cache=True)
def _symmetrize(out):
    """out := (out + outᵀ)/2 in place (the thermal runs' symmetric mobility)."""
    m = out.shape[0]
    for i in range(m):
        for j in range(i + 1, m):
            v = 0.5 * (out[i, j] + out[j, i])
            out[i, j] = v
            out[j, i] = v


def cell_correction(x, h, gammas, radius, viscosity, cell: CellBody, symmetric=False,
                    out=None) -> np.ndarray:
    """ΔM = M_cell − M_cell,loc (3(n+2) square, :func:`cell_mobility`,
    :func:`cell_local_mobility`) at frozen bead positions x and body ``cell``: what
    :func:`flagellum.rod.kernels.cell_motion` adds to the body's and the beads' local motion.
    Compiled end to end, as :func:`correction` (``out``: the array to write it into)."""
    x = sbt._check_positions(x)
    if out is None:
        out = np.empty((3 * len(x) + 3, 3 * len(x) + 3))
    _cell_correction_into(x, _blob_sizes(radius, len(x) - 1), float(h), float(gammas[0]),
                          float(gammas[1]), float(viscosity), *cell.arguments(viscosity),
                          bool(symmetric), out)
    return out


@njit(cache=True)
def _cell_correction_into(x, eps, h, gpar, gperp, viscosity, centre, axis, radius, aspect, rb,
                          hook_friction, symmetric, out):
    """:func:`cell_correction` into ``out``."""
    _cell_mobility_into(x, eps, viscosity, centre, axis, radius, aspect, rb, hook_friction, out)
    if symmetric:
        _symmetrize(out)
    _cell_local_into(x, h, gpar, gperp, centre, axis, radius, aspect, rb, hook_friction, -1.0, out)


def cell_build_arguments(n, h, gammas, radius, viscosity, body_radius, body_aspect, clamped,
                         symmetric=False) -> tuple:
    """The arguments of :func:`cell_correction_points` after the points and before ``out``
    (n segments, filament ``radius``; a clamped hook's friction across the motor axis,
    ½γ⊥h³, on the body)."""
    return (_blob_sizes(radius, n), float(h), float(gammas[0]), float(gammas[1]),
            float(viscosity), float(body_radius), float(body_aspect),
            _body_resistance(body_radius, body_aspect, viscosity),
            0.5 * gammas[1] * h ** 3 if clamped else 0.0, bool(symmetric))


@njit(cache=True)
def cell_correction_points(points, eps, h, gpar, gperp, viscosity, radius, aspect, rb,
                           hook_friction, symmetric, out):
    """:func:`cell_correction` at a cell's mobility points (the beads, the body's centre and
    front pole, :func:`cell_points`) into ``out``; the arguments after them from
    :func:`cell_build_arguments`."""
    centre, axis = cell_frame(points)
    _cell_correction_into(points[:points.shape[0] - 2], eps, h, gpar, gperp, viscosity, centre,
                          axis, radius, aspect, rb, hook_friction, symmetric, out)


@njit(cache=True)
def cell_local_points(points, h, gpar, gperp, radius, aspect, rb, hook_friction, scale, out):
    """out += ``scale`` · :func:`cell_local_mobility` at a cell's mobility points."""
    centre, axis = cell_frame(points)
    _cell_local_into(points[:points.shape[0] - 2], h, gpar, gperp, centre, axis, radius, aspect,
                     rb, hook_friction, scale, out)


@njit(cache=True)
def cell_points(y, n1, axis_b, offset_b, polar, out):
    """A cell's mobility points from its state y into ``out`` (n1 + 2, 3): the n1 beads, the
    body's centre x_0 − Q d_b and its front pole, centre + ``polar`` Q e_b (Q = exp([φ]×) of
    the state's last three values; d_b, e_b the motor offset and the axis in the body frame)."""
    ny = y.shape[0]
    q = np.empty((3, 3))
    Bd.rotation_matrix(y[ny - 3], y[ny - 2], y[ny - 1], q)
    for i in range(n1):
        for a in range(3):
            out[i, a] = y[3 + 4 * i + a]
    for a in range(3):
        c = out[0, a] - (q[a, 0] * offset_b[0] + q[a, 1] * offset_b[1] + q[a, 2] * offset_b[2])
        out[n1, a] = c
        out[n1 + 1, a] = c + polar * (q[a, 0] * axis_b[0] + q[a, 1] * axis_b[1] + q[a, 2] * axis_b[2])


@njit(cache=True)
def cell_frame(points):
    """(centre, unit axis) of a cell body from its mobility points (the beads, then the
    body's centre and front pole: :meth:`flagellum.rod.model.RodModel._mobility_points`)."""
    k = points.shape[0]
    centre = points[k - 2].copy()
    axis = points[k - 1] - centre
    nrm = math.sqrt(axis[0] ** 2 + axis[1] ** 2 + axis[2] ** 2)
    return centre, axis / nrm


def moving_components(anchor, n1: int) -> np.ndarray:
    """Mask of the 3·n1 bead velocity components the anchor leaves free (bead 0: none when
    ``FIXED``, z only on a load sphere ``AXIAL``, all for ``FREE``); the mobility's rows and
    columns of the others are zero."""
    free = np.ones(3 * n1, bool)
    free[:fixed_components(anchor)] = False
    return free


@njit(cache=True)
def fixed_components(anchor) -> int:
    """How many of bead 0's velocity components (x, y, z in that order) the anchor fixes."""
    return 3 if anchor == L.FIXED else (2 if anchor == L.AXIAL else 0)


__all__ = ["CellBody", "Hydrodynamics", "MODELS", "REFRESH", "body_flow", "bonds_within",
           "cell_build_arguments", "cell_correction", "cell_correction_points", "cell_frame",
           "cell_local_mobility", "cell_local_points", "cell_mobility", "cell_points",
           "correction", "effective_mobility", "grand_mobility", "local_mobility",
           "moving_components", "near_beads", "renew_into", "rigid_fit", "rotate_correction",
           "rotated_limits_used",
           "sphere_centre", "sphere_coupling", "turn_into", "turn_limit"]
