"""Polymorphism of the filament: the order parameter of each joint and its dynamics.

Each joint j of the discrete rod (between frames j and j+1) carries an order parameter φ_j;
its integer values 0, 1, … are the polymorphic forms of
:class:`flagellum.params.Polymorphism` in order (normal, semicoiled, curly-1: Calladine's
sequence, in which each next form has one more protofilament in the R state; Calladine,
J. Mol. Biol. 118, 457 (1978)). The joint's intrinsic curvature and torsion are those of
its form, linear in φ between neighbouring forms, so every form is a stress-free helix of
the rod energy (:func:`flagellum.rod.kernels.elastic` with per-joint κ, τ).

Energy besides the rod's (per length v [pN], continuum D [pN·µm²]), discretized as::

    E_φ = Σ_j h v(φ_j) + Σ_j D/(2h) (φ_{j+1} − φ_j)²,

v between forms m, m+1 (x = φ − m) the quartic of the Nagumo (Zeldovich) equation,
v = ε_m + k [x⁴/4 − (1 + a) x³/3 + a x²/2], v' = k x (x − 1)(x − a): minima at both forms,
a = 1/2 + 6 Δε/k (k = 64 × the pair's barrier, one per neighbouring pair:
:func:`pair_landscape`); outside the first and last form the parabola of its well, although
the dynamics keeps φ within the forms (:func:`advance`). An overdamped
dynamics, as for the order parameter of Srigiriraju & Powers, Phys. Rev. E 73, 011902
(2006) (time-dependent Ginzburg–Landau), ::

    ζ h dφ_j/dt = −∂(E_rod + E_φ)/∂φ_j + √(2 kT ζ h) ξ_j,

with ∂E_rod/∂φ_j = −h [A (Ω2 − κ_j) κ'(φ_j) + C (Ω3 − τ_j) τ'(φ_j)] at the rod's strains:
stress tilts the landscape (torque- and force-driven transformations). With equal minima
a wall stays; otherwise it moves towards the higher-energy form at the speed of the
Nagumo front, c = √(Dk/2)(1 − 2a)/ζ (:func:`front_speed`), for walls much wider than h.
The noise (a thermal run) samples the Boltzmann weight of E_φ (detailed balance).

The simulator advances φ between the rod's integration chunks with the rod's strains
frozen (operator splitting, :func:`advance`), chunks shorter than the wells' relaxation
time ζ/k.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .._jit import FASTMATH


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def pair_landscape(phi, eps, kk):
    """(v, dv/dφ) of the landscape with well energies ``eps`` (forms 0 … M−1) and the well
    stiffness kk[m] = 64 × barrier of each neighbouring pair (m, m+1) (at least one entry)
    (:mod:`module docstring <flagellum.rod.polymorph>`); the end wells' parabolas take the
    stiffness of their pair."""
    m_last = eps.shape[0] - 1
    if m_last == 0 or phi <= 0.0:  # the first well's parabola (one form: a single well)
        k = kk[0]
        a = 0.5 + 6.0 * (eps[1] - eps[0]) / k if m_last > 0 else 0.5
        return eps[0] + 0.5 * k * a * phi * phi, k * a * phi
    if phi >= m_last:
        k = kk[m_last - 1]
        a = 0.5 + 6.0 * (eps[m_last] - eps[m_last - 1]) / k
        d = phi - m_last
        return eps[m_last] + 0.5 * k * (1.0 - a) * d * d, k * (1.0 - a) * d
    m = int(math.floor(phi))
    x = phi - m
    k = kk[m]
    a = 0.5 + 6.0 * (eps[m + 1] - eps[m]) / k
    v = eps[m] + k * (x ** 4 / 4.0 - (1.0 + a) * x ** 3 / 3.0 + a * x * x / 2.0)
    return v, k * x * (x - 1.0) * (x - a)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def landscape(phi, eps, k):
    """(v, dv/dφ) of the landscape with well energies ``eps`` and one well stiffness k for
    every pair (:func:`pair_landscape`)."""
    return pair_landscape(phi, eps, np.full(max(eps.shape[0] - 1, 1), k))


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def form_strains(phi, kap, tau):
    """(κ, τ, dκ/dφ, dτ/dφ) at order parameter φ: linear between the forms (held beyond)."""
    m_last = kap.shape[0] - 1
    if m_last == 0:
        return kap[0], tau[0], 0.0, 0.0
    if phi < 0.0:
        return kap[0], tau[0], 0.0, 0.0
    if phi > m_last:
        return kap[m_last], tau[m_last], 0.0, 0.0
    # at a form itself the slope towards the next form (the last: from the one before), so
    # that stress acts on a joint sitting exactly in its well
    m = min(int(math.floor(phi)), m_last - 1)
    x = phi - m
    dk, dt = kap[m + 1] - kap[m], tau[m + 1] - tau[m]
    return kap[m] + x * dk, tau[m] + x * dt, dk, dt


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def phi_rate(phi, h, eps, kk, D, zeta, A, C, strains, kap, tau, coupled, out):
    """out_j = −(1/ζh) ∂E/∂φ_j, the deterministic rate of every joint (``coupled``: with the
    rod's energy at its frozen ``strains`` (n, 3)); ``kk`` the pairs' well stiffnesses
    (:func:`pair_landscape`)."""
    n = phi.shape[0]
    for j in range(n):
        _, dv = pair_landscape(phi[j], eps, kk)
        g = h * dv
        if j > 0:
            g += D / h * (phi[j] - phi[j - 1])
        if j < n - 1:
            g += D / h * (phi[j] - phi[j + 1])
        if coupled:
            kj, tj, dk, dt = form_strains(phi[j], kap, tau)
            g -= h * (A * (strains[j, 1] - kj) * dk + C * (strains[j, 2] - tj) * dt)
        out[j] = -g / (zeta * h)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def advance(phi, dt, n_sub, h, eps, kk, D, zeta, A, C, strains, kap, tau, coupled, kT, normals):
    """Advance φ by ``dt`` in ``n_sub`` Euler(–Maruyama) steps; ``kk`` the pairs' well
    stiffnesses (:func:`pair_landscape`); ``normals`` (n_sub, n) unit Gaussians for kT > 0.

    φ stays within the forms, [0, M−1]: beyond the last form the strains are held
    (:func:`form_strains`), so the rod exerts no drive there and a joint pushed past it by
    the stress would relax back only from outside and never cross into the next well; the
    sequence of forms ends there (projection for the deterministic flow, reflection for
    the noise)."""
    n = phi.shape[0]
    rate = np.empty(n)
    s = dt / n_sub
    amp = math.sqrt(2.0 * kT * s / (zeta * h)) if kT > 0.0 else 0.0
    top = float(kap.shape[0] - 1)
    for i in range(n_sub):
        phi_rate(phi, h, eps, kk, D, zeta, A, C, strains, kap, tau, coupled, rate)
        for j in range(n):
            phi[j] += s * rate[j]
            if amp > 0.0:
                # reflecting walls at the end forms: Euler–Maruyama of the reflected
                # diffusion, whose stationary law is the Boltzmann weight on [0, top]
                phi[j] += amp * normals[i, j]
                if phi[j] < 0.0:
                    phi[j] = -phi[j]
                if phi[j] > top:
                    phi[j] = 2.0 * top - phi[j]
            # the projection onto [0, top]: the deterministic flow's boundary (and the
            # rare noise kick wider than the whole range)
            phi[j] = min(max(phi[j], 0.0), top)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def intrinsic(phi, kap, tau, out_k, out_t):
    """The joints' intrinsic curvature and torsion at order parameters φ."""
    for j in range(phi.shape[0]):
        out_k[j], out_t[j], _, _ = form_strains(phi[j], kap, tau)


def stable_substep(h: float, k: float, D: float, zeta: float, kap, tau, A: float, C: float) -> float:
    """Largest stable explicit step [s]: ζ/(stiffest curvature of the energy in φ), the
    landscape (≤ k; the largest of the pairs' stiffnesses if k is a sequence), the walls
    (4D/h²) and the rod (A κ'² + C τ'²), with a margin of 2."""
    k = float(np.max(k))
    dk = np.max(np.abs(np.diff(kap))) if len(kap) > 1 else 0.0
    dt = np.max(np.abs(np.diff(tau))) if len(tau) > 1 else 0.0
    stiff = 2.0 * k + 4.0 * D / h ** 2 + A * dk ** 2 + C * dt ** 2
    return 0.5 * zeta / stiff


def front_speed(barrier: float, wall_stiffness: float, friction: float, de: float) -> float:
    """Speed [µm/s] of a straight wall between forms m and m+1 of energies differing by
    ``de`` = ε_{m+1} − ε_m (continuum Nagumo front, c = √(Dk/2)(1 − 2a)/ζ with k = 64·barrier,
    a = 1/2 + 6 de/k), counted positive into form m+1: form m grows when de > 0."""
    k = 64.0 * barrier
    a = 0.5 + 6.0 * de / k
    return math.sqrt(wall_stiffness * k / 2.0) * (2.0 * a - 1.0) / friction


def spinodal_drive(barrier: float, de: float = 0.0) -> float:
    """The largest stress drive g [pN] (−∂E_rod/∂φ per length) that a joint in form m
    withstands without a wall or noise: past it the well of form m has no minimum left.
    With k = 64·barrier and a = 1/2 + 6 de/k (de = ε_{m+1} − ε_m), v'(x) = k x(x − 1)(x − a),
    so g* = k max_{0≤x≤a} x(1 − x)(a − x), at x* = [(1 + a) − √(1 − a + a²)]/3
    (3.08·barrier for equal wells)."""
    k = 64.0 * barrier
    a = 0.5 + 6.0 * de / k
    x = ((1.0 + a) - math.sqrt(1.0 - a + a * a)) / 3.0
    return k * x * (1.0 - x) * (a - x)


def tension_drive(kappa: float, tau: float, dkappa: float, dtau: float,
                  bend_rigidity: float | None = None) -> float:
    """Drive g = −∂E_rod/∂φ per length [pN] that an axial pull F on the free end exerts on a
    joint of a long, stress-free helix (κ, signed τ) towards the form whose intrinsic strains
    differ by (κ', τ') = (``dkappa``, ``dtau``), per pN of load; positive: the pull drives the
    joint towards that form.

    g = m·Δ with m the moment of the load about the joint (statics: independent of A and C).
    Small loads (Love, *Mathematical Theory of Elasticity*, §270): the moment F R splits into
    a twist F R²/ρ and a bend −F R b/ρ (R = κ/ω², b = τ/ω², ρ = 1/ω, ω² = κ² + τ²), so
    g/F = κ (κ τ' − τ κ')/ω³. With ``bend_rigidity`` A: the limit of large loads instead,
    where the helix is pulled straight and the joint carries the whole bending moment −A κ,
    g = −A κ κ' (a finite drive, not per pN): pulling drives towards the less curved form."""
    if bend_rigidity is not None:
        return -bend_rigidity * kappa * dkappa
    w = math.hypot(kappa, tau)
    return kappa * (kappa * dtau - tau * dkappa) / w ** 3


def wall_width(barrier: float, wall_stiffness: float) -> float:
    """Width √(2D/k) [µm] of a wall's tanh profile (k = 64·barrier)."""
    return math.sqrt(2.0 * wall_stiffness / (64.0 * barrier))


def forms_of(phi) -> np.ndarray:
    """The form index of each joint: φ rounded (clipped at 0)."""
    return np.maximum(np.rint(np.asarray(phi)), 0).astype(int)


def domain_walls(phi) -> np.ndarray:
    """The number of walls (neighbouring joints of different forms) of each record (…, n)."""
    f = forms_of(phi)
    return np.count_nonzero(np.diff(f, axis=-1), axis=-1)


def fractions(phi, n_forms: int) -> np.ndarray:
    """(…, n_forms) fraction of the joints in each form."""
    f = np.minimum(forms_of(phi), n_forms - 1)
    return np.stack([np.mean(f == m, axis=-1) for m in range(n_forms)], axis=-1)


def transformed_length(phi, phi0, h: float) -> np.ndarray:
    """Length [µm] of filament that has left its starting form: h Σ_j min(|φ_j − φ0_j|, 1)
    for each record (…, n); continuous in φ, so a moving wall changes it smoothly."""
    return h * np.sum(np.minimum(np.abs(np.asarray(phi) - np.asarray(phi0)), 1.0), axis=-1)


def transformation_events(t, phi, h: float, t_from: float | None = None) -> dict:
    """Nucleation and growth of the domains that leave the starting form.

    ``t`` (T,) [s], ``phi`` (T, n) the joints' order parameters, ``h`` [µm] the segment
    length; the starting forms are those of the first record at t ≥ ``t_from`` (default:
    the first record), and times are counted from that record. Joint j sits at the bead
    between segments j and j+1, (j + 1) h from the hook.

    Returns ``nucleation_site`` [µm from the hook] and ``nucleation_time`` [s] of the first
    joint whose form changes (NaN if none does), ``transformation_time`` [s] (the number of
    joints out of their starting form first reaching 90 % of its largest value),
    ``transformed_final`` (their fraction at the end) and ``wall_speed`` [µm/s] (the slope
    of the transformed length ℓ(t), :func:`transformed_length`, between nucleation and 90 %, divided by the number of moving fronts: the edges of the
    changed region that are not walls of the start; 1 for a domain at an end or a wall that
    moves, 2 for a domain inside).
    """
    t, phi = np.asarray(t, float), np.asarray(phi, float)
    i0 = 0 if t_from is None else int(np.searchsorted(t, t_from))
    i0 = min(i0, len(t) - 1)
    t, phi = t[i0:] - t[i0], phi[i0:]
    n = phi.shape[1]
    nan = float("nan")
    out = {"nucleation_site": nan, "nucleation_time": nan, "transformation_time": nan,
           "transformed_final": 0.0, "wall_speed": nan}
    f0 = forms_of(phi[0])
    changed = forms_of(phi) != f0
    hit = np.nonzero(changed.any(axis=1))[0]
    if not hit.size:
        return out
    i_nuc = int(hit[0])
    j_nuc = np.nonzero(changed[i_nuc])[0]
    # the joint that has gone farthest at nucleation (the nearest to the hook on a tie)
    j = int(j_nuc[np.argmax(np.abs(phi[i_nuc, j_nuc] - phi[0, j_nuc]))])
    count = changed.sum(axis=1)
    i90 = int(np.nonzero(count >= 0.9 * count.max())[0][0])
    ell = transformed_length(phi, phi[0], h)
    out.update(nucleation_site=(j + 1) * h, nucleation_time=float(t[i_nuc]),
               transformation_time=float(t[i90]), transformed_final=float(count[-1] / n))
    grow = slice(i_nuc, max(i90, i_nuc) + 1)
    if i90 - i_nuc >= 1:
        mid = changed[(i_nuc + i90) // 2]
        # the moving fronts: edges of the changed region that are no wall of the start
        edges = np.nonzero(np.diff(mid.astype(int)))[0]
        fronts = int(np.count_nonzero(f0[edges] == f0[edges + 1]))
        out["wall_speed"] = float(np.polyfit(t[grow], ell[grow], 1)[0] / max(fronts, 1))
    return out
