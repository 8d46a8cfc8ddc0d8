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

M_eff is the mobility of the beads under the anchor's constraints, from the resistance of the
filament plus (load sphere, free swimmer's body) a sphere of radius a centred on bead 0 and
moving with it: the sphere's flow at bead k is G(x_k − x_0) F_s and, by reciprocity (Faxén's
law), the filament's flow moves the sphere by Σ G F_k, with
G(r) = [(1 + rr/r²)/r + a²/3 (1 − 3rr/r²)/r³]/8πη for r ≥ a (the exact flow of a translating
sphere) and 1/(6πηa) inside it. Constrained bead-0 components (anchored: all three; load
sphere: x, y) are removed in the resistance form, i.e. their reaction forces do act on the
fluid.
"""

from __future__ import annotations

import math

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
    at r per force on the sphere, and (Faxén's law) the sphere's velocity per point force at r."""
    d = np.linalg.norm(r, axis=1)
    out = np.empty((len(r), 3, 3))
    inside = d < a
    out[inside] = np.eye(3) / (6 * math.pi * viscosity * a)
    o = ~inside
    ro, do = r[o], d[o][:, None, None]
    rr = ro[:, :, None] * ro[:, None, :] / do ** 2
    out[o] = ((np.eye(3) + rr) / do + a * a / 3 * (np.eye(3) - 3 * rr) / do ** 3) / (8 * math.pi * viscosity)
    return out


def effective_mobility(x, radius, viscosity, anchor, sphere_radius=0.0) -> np.ndarray:
    """Nonlocal bead mobility (3(n+1) square) under the anchor's constraints: U = M_eff F with
    F the applied bead forces (see the module docstring). ``anchor`` a code of
    :mod:`flagellum.hydro.local` (FIXED, AXIAL, FREE)."""
    n1 = len(x)
    M = sbt.mobility(x, radius, viscosity)
    if anchor != L.FIXED and sphere_radius > 0:  # add the sphere as node n1, moving with bead 0
        G = sphere_coupling(x - x[0], sphere_radius, viscosity).transpose(0, 2, 1).reshape(3 * n1, 3)
        big = np.zeros((3 * n1 + 3, 3 * n1 + 3))
        big[:3 * n1, :3 * n1] = M
        big[:3 * n1, 3 * n1:] = G
        big[3 * n1:, :3 * n1] = G.T
        big[3 * n1:, 3 * n1:] = np.eye(3) / (6 * math.pi * viscosity * sphere_radius)
        R = _attach(np.linalg.inv(big), n1)
        free = moving_components(anchor, n1)
        out = np.zeros((3 * n1, 3 * n1))
        out[np.ix_(free, free)] = np.linalg.inv(R[np.ix_(free, free)])
        return out
    # no sphere: ((M⁻¹)_ff)⁻¹ is the Schur complement M_ff − M_fc M_cc⁻¹ M_cf of the
    # constrained components c (O(N²) instead of two dense inverses)
    k = int(np.count_nonzero(~moving_components(anchor, n1)))  # the first k components
    if k == 0:
        return M
    out = np.zeros((3 * n1, 3 * n1))
    out[k:, k:] = M[k:, k:] - M[k:, :k] @ np.linalg.solve(M[:k, :k], M[:k, k:])
    return out


def _attach(R: np.ndarray, n1: int) -> np.ndarray:
    """Pᵀ R P for P the map of bead velocities to (bead velocities, sphere velocity = bead 0's)."""
    m = 3 * n1
    out = R[:m, :m].copy()
    out[:, :3] += R[:m, m:]
    out[:3, :] += R[m:, :m]
    out[:3, :3] += R[m:, m:]
    return out


def rigid_fit(x_ref, x, anchor):
    """(R, residual): the rotation R about bead 0 that best maps the beads x_ref onto x, among
    those under which the anchored problem (and so ΔM) is invariant — about e_z only on a load
    sphere (``AXIAL``), any for ``FIXED`` and ``FREE`` (Kabsch's least-squares fit) — and the
    largest bead distance left, |x − x_0 − R(x_ref − x_ref,0)| (``FREE``: relative to bead 0,
    which carries the body)."""
    a, b = x_ref - x_ref[0], x - x[0]
    if anchor == L.AXIAL:
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
    if anchor != L.FREE:
        resid = max(resid, float(np.max(np.abs(x[0] - x_ref[0]))))
    return R, resid


def rotate_correction(dm, R):
    """ΔM of the beads turned by R (about bead 0): each 3×3 block D_ij becomes R D_ij Rᵀ
    (the mobility of a rotated configuration, by the isotropy of Stokes flow)."""
    n1 = dm.shape[0] // 3
    d = dm.reshape(n1, 3, n1, 3)
    return np.einsum("ab,ibjc,dc->iajd", R, d, R, optimize=True).reshape(dm.shape)


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


__all__ = ["Hydrodynamics", "MODELS", "REFRESH", "correction", "effective_mobility",
           "local_mobility", "moving_components", "rigid_fit", "rotate_correction",
           "sphere_coupling"]
