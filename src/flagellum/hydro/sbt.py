"""Nonlocal hydrodynamics of the discrete centreline: regularized Stokeslet segments
calibrated to slender-body theory (see docs/hydrodynamics.md).

The filament is the polyline through its beads, carrying a piecewise-linear force density
f(s) = Σ_k (F_k / w_k) φ_k(s) (φ_k the hat function of bead k, w_k = ∫ φ_k ds its length:
h, end beads h/2, as in :mod:`flagellum.hydro.local`). The velocity of bead i is the
integral of the regularized Stokeslet of Cortez, Fauci & Medovikov, Phys. Fluids 17,
031504 (2005), blob φ_ε = 15ε⁴ / (8π(r² + ε²)^{7/2}), ::

    8πη u(x) = ∫ [(|r|² + 2ε²) f + (r·f) r] / (|r|² + ε²)^{3/2} ds,   r = x − X(s),

done in closed form on every straight segment (the "regularized Stokeslet segments" of
Cortez, J. Comput. Phys. 375, 783 (2018)), so that ε may be far below the bead spacing h.

Calibration: for a uniform density on a straight line the integral at arc length s is
(1/8πη)[2 ln(4s(L−s)/ε²) tt + (ln(4s(L−s)/ε²) + 2)(1 − tt)] f + O(ε/s), while the
slender-body theory of a filament of radius r (Keller & Rubinow 1976; Johnson 1980) gives
(1/8πη)[ℒ(1 + tt) + (1 − 3tt)] f with ℒ = ln(4s(L−s)/r²). Both directions agree when
ε = √e · r (:data:`EPS_PER_RADIUS`); the nonlocal parts agree up to O(ε²/|r|²).

Neglected: the spin of the cross-section enters only locally (friction γR = 4πηr² per
length about the tangent, as in the local model); the rotlet it sends to other beads
(relative size r²/d²) and the fluid vorticity that other segments impose on it are dropped,
and so is the source doublet of SBT beyond what the blob carries (again O(r²/d²)).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..errors import ParameterError
from .local import bead_node

#: ε / r of the regularized Stokeslet line that reproduces slender-body theory of radius r
EPS_PER_RADIUS = math.exp(0.5)


def _check_positions(positions) -> np.ndarray:
    x = np.asarray(positions, float)
    if x.ndim != 2 or x.shape[1] != 3 or len(x) < 2:
        raise ParameterError("positions", f"shape {x.shape}", "an (n+1, 3) array with n ≥ 1")
    if not np.all(np.isfinite(x)):
        raise ParameterError("positions", "non-finite", "finite coordinates")
    lengths = np.linalg.norm(np.diff(x, axis=0), axis=1)
    if np.any(lengths <= 0):
        raise ParameterError("positions", "coincident beads", "distinct consecutive beads")
    return x


def _segment_radius(radius, n: int) -> np.ndarray:
    """Radius of each of the n segments: a scalar, or per bead (mean of the two ends)."""
    r = np.asarray(radius, float)
    if r.ndim == 0:
        if not (np.isfinite(r) and r > 0):
            raise ParameterError("radius", float(r), "> 0 (µm)")
        return np.full(n, float(r))
    if r.shape != (n + 1,):
        raise ParameterError("radius", f"an array of shape {r.shape}", f"a scalar or {n + 1} values")
    if not np.all(np.isfinite(r)) or np.any(r < 0):
        raise ParameterError("radius", float(np.min(r)), "≥ 0 at every bead")
    rs = 0.5 * (r[1:] + r[:-1])
    if np.any(rs <= 0):
        raise ParameterError("radius", 0.0, "> 0 on every segment (not zero at both its beads)")
    return rs


def centreline_nodes(positions):
    """(tangents, weights) of the beads of a polyline, as :func:`flagellum.hydro.rft.bead_nodes`
    gives them for a discrete helix: the averaged unit tangent of the adjacent bonds
    (:func:`flagellum.hydro.local.bead_node`) and the length (ℓ_{k−1} + ℓ_k)/2."""
    x = _check_positions(positions)
    d = np.diff(x, axis=0)
    lengths = np.linalg.norm(d, axis=1)
    bonds = np.vstack([d[:1], d]) / np.r_[lengths[:1], lengths][:, None]
    n = len(d)
    t = np.array([bead_node(bonds, i, n)[:3] for i in range(n + 1)])
    return t, _bead_lengths(lengths)


@njit(cache=True)
def _bead_lengths(lengths: np.ndarray) -> np.ndarray:
    """The bead lengths (ℓ_{k−1} + ℓ_k)/2 (the ends: half their one bond) from the bonds'."""
    n = len(lengths)
    w = np.zeros(n + 1)
    for j in range(n):
        w[j] += 0.5 * lengths[j]
        w[j + 1] += 0.5 * lengths[j]
    return w


@njit(cache=True)
def _bond_lengths(x: np.ndarray) -> np.ndarray:
    n = x.shape[0] - 1
    out = np.empty(n)
    for j in range(n):
        d0, d1, d2 = x[j + 1, 0] - x[j, 0], x[j + 1, 1] - x[j, 1], x[j + 1, 2] - x[j, 2]
        out[j] = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    return out


@njit(cache=True, error_model="numpy")  # no fastmath: the closed forms are checked to 1e-11
def _segment_kernel(x, eps, cutoff, K, scale):
    """K[3i + a, 3k + b] = scale_k ∫ S_ε(x_i − X(s))_ab φ_k(s) ds (3×3 blocks, without
    1/8πη) over the segments on either side of bead k: the hat function of segment j's first
    bead (weight 1 − s/ℓ_j) goes to k = j, that of its second (s/ℓ_j) to k = j + 1. ``cutoff``
    < 0: the whole filament; else only the part of each segment within that arc length of
    bead i. Every block is written once (no zeroing of K first).

    In the coordinate σ = s − b along the segment (b the projection of x_i − P_j on its
    direction e, p the perpendicular part, c² = |p|² + ε², ρ = √(σ² + c²)) the kernel is
    [(1 + ε²/ρ²) 1 + (p − σe)(p − σe)ᵀ/ρ²]/ρ, so all that is needed are the moments
    ∫ σᵏ/ρ (k = 0, 1) and ∫ σᵏ/ρ³ (k = 0…3), here in cancellation-free closed forms. A
    block is m0 p pᵀ − m1 (p eᵀ + e pᵀ) + m2 e eᵀ + iso·1 with the hat-weighted moments m;
    the first bead's is the whole segment's minus the second's (the weights sum to 1), and
    the second bead's is carried to the next segment's first: each block written once.

    For each target bead three passes over the segments: the geometry and the logarithm's
    argument, the logarithms, the blocks. A library call inside the arithmetic loop made
    the compiler save and reload its registers around every call: one loop took 135 µs at
    N = 50, the passes 80 µs (docs/hydrodynamics.md, "Cost").
    """
    n1 = x.shape[0]
    n = n1 - 1
    geo = np.empty((9, n))  # e (3), the segment's first point (3), ε², ℓ, 1/ℓ
    arc = np.zeros(n1)
    for j in range(n):
        d0, d1, d2 = x[j + 1, 0] - x[j, 0], x[j + 1, 1] - x[j, 1], x[j + 1, 2] - x[j, 2]
        ell = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        iv = 1.0 / ell
        geo[0, j], geo[1, j], geo[2, j] = d0 * iv, d1 * iv, d2 * iv
        geo[3, j], geo[4, j], geo[5, j] = x[j, 0], x[j, 1], x[j, 2]
        geo[6, j], geo[7, j], geo[8, j] = eps[j] * eps[j], ell, iv
        arc[j + 1] = arc[j] + ell
    span = np.empty((2, n))  # the part [lo, hi] of each segment integrated over
    work = np.empty((10, n))
    out = np.empty((12, n))  # per segment: the first bead's block, the second's
    for i in range(n1):
        if cutoff >= 0.0:  # the part of segment j within arc length `cutoff` of bead i
            for j in range(n):
                rel = arc[i] - arc[j]
                span[0, j] = min(max(rel - cutoff, 0.0), geo[7, j])
                span[1, j] = min(max(rel + cutoff, 0.0), geo[7, j])
        else:
            for j in range(n):
                span[0, j], span[1, j] = 0.0, geo[7, j]
        _segment_moments(x[i, 0], x[i, 1], x[i, 2], geo, span, work, n)
        for j in range(n):
            work[5, j] = math.log1p(work[5, j])
        _segment_blocks(geo, work, out, n)
        r = 3 * i
        for k in range(n1):
            a0 = a1 = a2 = a3 = a4 = a5 = 0.0
            if k < n:
                a0, a1, a2, a3, a4, a5 = out[0, k], out[1, k], out[2, k], out[3, k], out[4, k], out[5, k]
            if k > 0:
                a0 += out[6, k - 1]
                a1 += out[7, k - 1]
                a2 += out[8, k - 1]
                a3 += out[9, k - 1]
                a4 += out[10, k - 1]
                a5 += out[11, k - 1]
            sk = scale[k]
            _write_block(K, r, 3 * k, a0 * sk, a1 * sk, a2 * sk, a3 * sk, a4 * sk, a5 * sk)


@njit(cache=True, error_model="numpy")
def _segment_moments(xi0, xi1, xi2, geo, span, work, n):
    """The first pass of :func:`_segment_kernel` for the target (xi0, xi1, xi2): per segment
    p (rows 0–2), b, c², the argument of J0's log1p (row 5), J1, K0, K1 and
    s1/ρ1 − s0/ρ0 into ``work``."""
    for j in range(n):
        e0, e1, e2 = geo[0, j], geo[1, j], geo[2, j]
        r0, r1, r2 = xi0 - geo[3, j], xi1 - geo[4, j], xi2 - geo[5, j]
        b = r0 * e0 + r1 * e1 + r2 * e2
        p0, p1, p2 = r0 - b * e0, r1 - b * e1, r2 - b * e2
        c2 = p0 * p0 + p1 * p1 + p2 * p2 + geo[6, j]
        s0, s1 = span[0, j] - b, span[1, j] - b
        q0, q1 = math.sqrt(s0 * s0 + c2), math.sqrt(s1 * s1 + c2)
        t0, t1 = q0 + abs(s0), q1 + abs(s1)
        # two divisions for the seven reciprocals
        qq, qs, tt = q0 * q1, q0 + q1, t0 * t1
        ra, rb = 1.0 / (qq * qs), 1.0 / (tt * c2)
        iq = qs * ra  # 1/(ρ0 ρ1)
        iq0, iq1 = q1 * iq, q0 * iq
        it = c2 * rb  # 1/(t0 t1)
        it0, it1 = t1 * it, t0 * it
        J1 = (s1 - s0) * (s1 + s0) * (qq * ra)  # ρ1 − ρ0
        # J0 = asinh(s1/c) − asinh(s0/c) = log1p(arg), no cancellation: asinh(s/c)
        # = ±ln((|s| + ρ)/c), so for ends on one side arg is (s1 − s0 ± J1) over the nearer
        # end's |s| + ρ
        work[5, j] = ((s1 - s0 + J1) * it0 if s0 >= 0.0 else
                      ((s1 - s0 - J1) * it1 if s1 <= 0.0 else
                       (s1 + q1) * (q0 - s0) * (tt * rb) - 1.0))
        # σ/(c²ρ) = sgn σ (1/c² − 1/(ρ(ρ + |σ|))): no cancellation when both ends lie on one side
        g1 = 1.0 if s1 > 0.0 else (-1.0 if s1 < 0.0 else 0.0)
        g0 = 1.0 if s0 > 0.0 else (-1.0 if s0 < 0.0 else 0.0)
        work[7, j] = (g1 - g0) * (tt * rb) - (g1 * iq1 * it1 - g0 * iq0 * it0)  # K0
        work[8, j] = J1 * iq  # K1
        work[9, j] = s1 * iq1 - s0 * iq0
        work[6, j] = J1
        work[0, j], work[1, j], work[2, j], work[3, j], work[4, j] = p0, p1, p2, b, c2


@njit(cache=True, error_model="numpy")
def _segment_blocks(geo, work, out, n):
    """The last pass of :func:`_segment_kernel`: from the moments (``work``, J0 in row 5) the
    six distinct entries of each segment's first-bead block (rows 0–5 of ``out``) and its
    second-bead block (rows 6–11)."""
    for j in range(n):
        e0, e1, e2 = geo[0, j], geo[1, j], geo[2, j]
        p0, p1, p2 = work[0, j], work[1, j], work[2, j]
        J0, J1, K0, K1 = work[5, j], work[6, j], work[7, j], work[8, j]
        eps2 = geo[6, j]
        K2 = J0 - work[9, j]
        K3 = J1 - work[4, j] * K1
        # the second bead's hat weight (b + σ)/ℓ_j
        inv = geo[8, j]
        be0 = work[3, j] * inv
        m0, m1, m2 = be0 * K0 + inv * K1, be0 * K1 + inv * K2, be0 * K2 + inv * K3
        iso = be0 * J0 + inv * J1 + eps2 * m0
        f0, f1, f2 = m0 * p0 - m1 * e0, m0 * p1 - m1 * e1, m0 * p2 - m1 * e2
        h0, h1, h2 = m2 * e0 - m1 * p0, m2 * e1 - m1 * p1, m2 * e2 - m1 * p2
        n00, n01, n02 = f0 * p0 + h0 * e0 + iso, f0 * p1 + h0 * e1, f0 * p2 + h0 * e2
        n11, n12, n22 = f1 * p1 + h1 * e1 + iso, f1 * p2 + h1 * e2, f2 * p2 + h2 * e2 + iso
        # the whole segment (weight 1) minus the second bead's: the first bead's
        isot = J0 + eps2 * K0
        f0, f1, f2 = K0 * p0 - K1 * e0, K0 * p1 - K1 * e1, K0 * p2 - K1 * e2
        h0, h1, h2 = K2 * e0 - K1 * p0, K2 * e1 - K1 * p1, K2 * e2 - K1 * p2
        out[0, j] = f0 * p0 + h0 * e0 + isot - n00
        out[1, j] = f0 * p1 + h0 * e1 - n01
        out[2, j] = f0 * p2 + h0 * e2 - n02
        out[3, j] = f1 * p1 + h1 * e1 + isot - n11
        out[4, j] = f1 * p2 + h1 * e2 - n12
        out[5, j] = f2 * p2 + h2 * e2 + isot - n22
        out[6, j], out[7, j], out[8, j] = n00, n01, n02
        out[9, j], out[10, j], out[11, j] = n11, n12, n22


@njit(cache=True, inline="always")
def _write_block(K, r, c, v00, v01, v02, v11, v12, v22):
    """The symmetric 3×3 block at (r, c) of K from its six distinct entries."""
    K[r, c], K[r, c + 1], K[r, c + 2] = v00, v01, v02
    K[r + 1, c], K[r + 1, c + 1], K[r + 1, c + 2] = v01, v11, v12
    K[r + 2, c], K[r + 2, c + 1], K[r + 2, c + 2] = v02, v12, v22


def mobility(positions, radius, viscosity, weights=None, cutoff=None) -> np.ndarray:
    """Dense mobility M (3(n+1) × 3(n+1)): bead velocities U = M F from bead forces F.

    ``positions`` (n+1, 3) beads of the centreline; ``radius`` the filament radius r (scalar
    or one per bead; the blob size is ε = √e r on each segment); ``viscosity`` η;
    ``weights`` the bead lengths w_k that turn bead forces into line densities F_k / w_k
    (default: (ℓ_{k−1} + ℓ_k)/2, the hat-function lengths). ``cutoff`` keeps only the part of
    the filament within that arc length of each bead: the local (RFT-like) limit.
    Row/column index 3k + a is component a of bead k. Self terms included; spin not (it is
    local, see :class:`SlenderBody`).
    """
    x = _check_positions(positions)
    n = len(x) - 1
    if isinstance(viscosity, bool) or not np.isfinite(viscosity) or viscosity <= 0:
        raise ParameterError("viscosity", viscosity, "> 0")
    if cutoff is not None and not cutoff > 0:
        raise ParameterError("cutoff", cutoff, "> 0 (an arc length) or None")
    eps = EPS_PER_RADIUS * _segment_radius(radius, n)
    if weights is None:
        w = _bead_lengths(np.linalg.norm(np.diff(x, axis=0), axis=1))
    else:
        w = np.asarray(weights, float)
        if w.shape != (n + 1,) or np.any(~(w > 0)):
            raise ParameterError("weights", f"shape {w.shape}", "n+1 lengths > 0")
    M = np.empty((3 * (n + 1), 3 * (n + 1)))
    _mobility_into(x, eps, w, float(viscosity), -1.0 if cutoff is None else float(cutoff), M)
    return M


@njit(cache=True)
def _mobility_into(x, eps, w, viscosity, cutoff, M):
    """:func:`mobility` into M (3(n+1) square) without the checks: the kernel's integrals per
    unit line density, each column k divided by 8πη w_k."""
    n1 = x.shape[0]
    s = np.empty(n1)
    for k in range(n1):
        s[k] = 1.0 / (8.0 * math.pi * viscosity * w[k])
    _segment_kernel(x, eps, cutoff, M, s)


def rigid_motion_matrix(positions, origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """J (3(n+1) × 6): bead velocities v + ω × (x_i − origin) of the rigid motion (v, ω)."""
    r = np.asarray(positions, float) - np.asarray(origin, float)
    m = len(r)
    J = np.zeros((m, 3, 6))
    J[:, :, :3] = np.eye(3)
    z = np.zeros(m)
    J[:, :, 3:] = -np.stack([np.stack([z, -r[:, 2], r[:, 1]], -1),
                             np.stack([r[:, 2], z, -r[:, 0]], -1),
                             np.stack([-r[:, 1], r[:, 0], z], -1)], -2)
    return J.reshape(3 * m, 6)


def rigid_resistance(mobility_matrix, positions, origin=(0.0, 0.0, 0.0), tangents=None,
                     weights=None, gamma_rot=0.0) -> np.ndarray:
    """6×6 [[A, C], [Cᵀ, B]] of a rigid filament from any bead mobility (forces and torques
    applied to the body, torques about ``origin``; the convention of
    :func:`flagellum.hydro.rft.resistance_matrix`): Jᵀ M⁻¹ J, plus the local spin friction
    γR Σ w t tᵀ in B when ``gamma_rot`` > 0 (needs ``tangents`` and ``weights``)."""
    J = rigid_motion_matrix(positions, origin)
    R = J.T @ np.linalg.solve(np.asarray(mobility_matrix, float), J)
    if gamma_rot:
        t, w = np.asarray(tangents, float), np.asarray(weights, float)
        R[3:, 3:] += gamma_rot * np.einsum("k,ki,kj->ij", w, t, t)
    return R


def resistance_matrix(positions, radius, viscosity, gamma_rot=0.0, origin=(0.0, 0.0, 0.0),
                      tangents=None, weights=None, cutoff=None) -> np.ndarray:
    """6×6 resistance matrix of the rigid filament through ``positions`` with the nonlocal
    mobility of :func:`mobility` (same arguments); tangents and weights default to
    :func:`centreline_nodes`."""
    t, w = centreline_nodes(positions)
    t = t if tangents is None else tangents
    w = w if weights is None else weights
    M = mobility(positions, radius, viscosity, weights=w, cutoff=cutoff)
    return rigid_resistance(M, positions, origin, t, w, gamma_rot)


def local_friction(cutoff, radius, viscosity) -> tuple[float, float]:
    """(γ∥, γ⊥) of the kernel kept within arc length ``cutoff`` on a straight filament:
    8πη u = [2 asinh(q/ε)(1 + tt) + 2 q/√(q² + ε²) (1 − tt)] f  (q = cutoff, ε = √e r),
    i.e. γ∥ ≈ 2πη/(ln(2q/r) − ½), γ⊥ ≈ 4πη/(ln(2q/r) + ½)."""
    eps = EPS_PER_RADIUS * radius
    a, b = math.asinh(cutoff / eps), cutoff / math.hypot(cutoff, eps)
    return 8 * math.pi * viscosity / (4 * a), 8 * math.pi * viscosity / (2 * a + 2 * b)


@dataclass(frozen=True)
class SlenderBody:
    """Nonlocal hydrodynamic model of the filament (the interface a time stepper calls).

    ``mobility(positions)`` is the translational bead mobility (nonlocal, dense);
    ``spin_friction(h)`` the local friction of a bond spinning about its tangent, as
    :func:`flagellum.hydro.local.spin_friction` gives it for the local model.
    """

    radius: float  #: filament radius r [µm]
    viscosity: float  #: η [pN·s/µm²]

    def __post_init__(self):
        for name in ("radius", "viscosity"):
            v = getattr(self, name)
            if isinstance(v, bool) or not np.isfinite(v) or v <= 0:
                raise ParameterError(name, v, "> 0")

    @property
    def gamma_rot(self) -> float:
        """γR = 4πηr²: torque per length and angular velocity of a spinning cylinder."""
        return 4 * math.pi * self.viscosity * self.radius ** 2

    def spin_friction(self, h: float) -> float:
        return self.gamma_rot * h

    def mobility(self, positions, weights=None) -> np.ndarray:
        return mobility(positions, self.radius, self.viscosity, weights=weights)

    def resistance_matrix(self, positions, origin=(0.0, 0.0, 0.0), spin=True) -> np.ndarray:
        return resistance_matrix(positions, self.radius, self.viscosity,
                                 self.gamma_rot if spin else 0.0, origin)
