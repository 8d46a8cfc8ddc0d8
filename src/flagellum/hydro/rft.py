"""Resistive-force theory (RFT) of a rigid helix (paper App. A, Sec. 3.2, App. C).

Sign convention of the paper (Eq. (32)): the force and torque *applied to* a rigid body
moving with velocity v and angular velocity ω are ::

    (F, M) = [[A, C], [Cᵀ, B]] (v, ω),

with local force density f = (γ∥ t⊗t + γ⊥(1 − t⊗t))(v + ω×r) and torque density r×f
(+ γR (t·ω) t if spin friction is included). For a right-handed helix along +z, C∥ < 0.
The *thrust* is the paper's F of Sec. 3.1.1: the force the filament exerts on its anchor along
the motor axis, positive when it pushes (anchored helix: F/M = −C∥/B∥).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..helix import DiscreteHelix, Helix


def full_turn_coefficients(helix: Helix, gamma_par: float, gamma_perp: float) -> dict:
    """Friction coefficients of Eq. (38) for a helix of contour length ``helix.length``.

    Exact for whole turns; A∥ holds for any length. ``C_par`` carries the handedness::

        A⊥ = Lγ⊥(1 + δ cos²α/2),  A∥ = Lγ⊥(1 + δ sin²α),
        B∥ = Lγ⊥R²(1 + δ(1 − sin²α)),  C∥ = χ Lγ⊥ R δ sin α cos α,   δ = (γ∥ − γ⊥)/γ⊥.
    """
    L, R, a = helix.length, helix.radius, helix.pitch_angle
    d = (gamma_par - gamma_perp) / gamma_perp
    sa, ca = math.sin(a), math.cos(a)
    return {
        "A_perp": L * gamma_perp * (1 + d * ca**2 / 2),
        "A_par": L * gamma_perp * (1 + d * sa**2),
        "B_par": L * gamma_perp * R**2 * (1 + d * (1 - sa**2)),
        "C_par": helix.chirality * L * gamma_perp * R * d * sa * ca,
    }


def _skew(r: np.ndarray) -> np.ndarray:
    """Stack of cross-product matrices [r]× with [r]× w = r × w."""
    z = np.zeros(r.shape[:-1])
    return np.stack([np.stack([z, -r[..., 2], r[..., 1]], -1),
                     np.stack([r[..., 2], z, -r[..., 0]], -1),
                     np.stack([-r[..., 1], r[..., 0], z], -1)], -2)


def resistance_matrix(points, tangents, weights, gamma_par, gamma_perp, gamma_rot=0.0,
                      origin=(0.0, 0.0, 0.0)) -> np.ndarray:
    """6×6 resistance matrix [[A, C], [Cᵀ, B]] by quadrature over nodes (Eqs. (32)–(35)).

    ``points`` (n, 3), unit ``tangents`` (n, 3), ``weights`` (n,) are quadrature nodes along
    the filament (lengths for lumped beads). Torques are about ``origin``. ``gamma_rot``
    adds spin friction γR (t·ω) t per length (omitted in the paper's Eq. (38)).
    """
    r = np.asarray(points, float) - np.asarray(origin, float)
    t = np.asarray(tangents, float)
    w = np.asarray(weights, float)
    tt = t[:, :, None] * t[:, None, :]
    gam = w[:, None, None] * (gamma_par * tt + gamma_perp * (np.eye(3) - tt))
    rx = _skew(r)
    A = gam.sum(0)
    C = -(gam @ rx).sum(0)
    B = -(rx @ gam @ rx).sum(0) + gamma_rot * (w[:, None, None] * tt).sum(0)
    return np.block([[A, C], [C.T, B]])


def helix_nodes(helix: Helix, nodes_per_turn: int = 64):
    """Gauss–Legendre nodes along the continuum helix (spectrally accurate quadrature)."""
    n_int = max(1, int(math.ceil(helix.n_turns * 4)))
    x, wq = np.polynomial.legendre.leggauss(max(4, nodes_per_turn // 4))
    edges = np.linspace(0, helix.length, n_int + 1)
    mid, half = (edges[1:] + edges[:-1]) / 2, (edges[1:] - edges[:-1]) / 2
    s = (mid[:, None] + half[:, None] * x[None, :]).ravel()
    w = (half[:, None] * wq[None, :]).ravel()
    return helix.positions(s), helix.tangents(s), w


def bead_nodes(dh: DiscreteHelix):
    """The simulator's lumped drag nodes: beads with averaged tangents (paper Sec. 2.2).

    Bead i (1 ≤ i < N) carries length h with t = (e3⁽ⁱ⁾ + e3⁽ⁱ⁺¹⁾)/|…|; the end beads
    carry h/2 and the tangent of their one bond.
    """
    from .local import bead_node

    e3 = np.asarray(dh.tangents, float)
    n = len(e3)
    bonds = np.vstack([e3[:1], e3])  # the kernels' layout: row 0 the hook frame, then the bonds
    nodes = np.array([bead_node(bonds, i, n) for i in range(n + 1)])
    return dh.positions, nodes[:, :3], nodes[:, 3] * dh.segment_length


def anchored_helix(coeffs: dict) -> dict:
    """Rigid helix rotating about its own axis, held in place (Sec. 3.1): v = 0.

    ω/M = 1/B∥, thrust F/M = −C∥/B∥ (force on the anchor, > 0 when pushing).
    """
    return {"thrust_per_torque": -coeffs["C_par"] / coeffs["B_par"],
            "omega_per_torque": 1.0 / coeffs["B_par"]}


def load_sphere(coeffs: dict, torque: float, sphere_radius: float, viscosity: float) -> dict:
    """Rigid helix pushing a sphere of radius a (drag ζ = 6πηa) along its axis (Sec. 3.2).

    Solves (A∥ + ζ) v + C∥ ω = 0, M = C∥ v + B∥ ω; thrust F = ζ v on the sphere.
    """
    A, B, C = coeffs["A_par"], coeffs["B_par"], coeffs["C_par"]
    zeta = 6 * math.pi * viscosity * sphere_radius
    omega = torque / (B - C * C / (A + zeta))
    v = -C * omega / (A + zeta)
    return {"omega": omega, "velocity": v, "thrust": zeta * v}


def critical_torque_line(coeffs: dict, critical_force: float, viscosity: float) -> dict:
    """Eq. (16): M_c1 = −(B∥/C∥) F_c1 + (C∥ − A∥B∥/C∥) F_c1/(6πη) · (1/a).

    Returns ``intercept`` [pN·µm] and ``slope_per_inverse_radius`` [pN·µm²].
    """
    A, B, C = coeffs["A_par"], coeffs["B_par"], coeffs["C_par"]
    return {"intercept": -B / C * critical_force,
            "slope_per_inverse_radius": (C - A * B / C) * critical_force / (6 * math.pi * viscosity)}


def effective_bending_rigidity(helix: Helix | float | np.ndarray, bend_rigidity: float,
                               twist_rigidity: float):
    """Eq. (17) (derived in App. C, Eq. (47)): 1/A_eff = (1 + sin²α + (A/C) cos²α) / (2 A sin α).

    ``helix`` is a :class:`Helix` or its pitch angle α [rad]; an array of angles gives an
    array of A_eff.
    """
    a = helix.pitch_angle if isinstance(helix, Helix) else helix
    sin, cos = (np.sin, np.cos) if isinstance(a, np.ndarray) else (math.sin, math.cos)
    A, C = bend_rigidity, twist_rigidity
    return 2 * A * sin(a) / (1 + sin(a) ** 2 + A / C * cos(a) ** 2)


@dataclass(frozen=True)
class PinnedRotation:
    """Steady rotation of a rigid helix pinned at a point under a torque M along the motor axis.

    A rigid body whose pivot is fixed rotates steadily under a constant lab torque only when
    the torque lies along an eigenvector of its rotational resistance matrix about the pivot;
    the least-resistance eigen-axis (tilted slightly from the helix axis) is the one reached.
    """

    thrust_per_torque: float
    omega_per_torque: float
    axis_tilt_deg: float
    axis: np.ndarray  #: unit eigen-axis in the helix' coordinates, pointing from the pivot along the helix


def pinned_rotation(matrix: np.ndarray, helix_axis) -> PinnedRotation:
    """Thrust and rotation rate per torque of a helix pinned at the matrix' origin.

    ``matrix`` is the 6×6 resistance matrix about the pivot, ``helix_axis`` the direction
    from the pivot into the filament. The motor axis is m = −e (the filament trails behind
    the motor), ω = (M/b) m, and the thrust on the pivot along m is F = −mᵀC m M/b.
    """
    B, C = matrix[3:, 3:], matrix[:3, 3:]
    vals, vecs = np.linalg.eigh(B)
    e = vecs[:, 0]
    axis = np.asarray(helix_axis, float) / np.linalg.norm(helix_axis)
    if e @ axis < 0:
        e = -e
    m = -e
    b = vals[0]
    tilt = math.degrees(math.acos(min(1.0, abs(float(e @ axis)))))
    return PinnedRotation(-(m @ C @ m) / b, 1.0 / b, tilt, e)


def rft_summary(params, critical_force: float = 1.0) -> dict:
    """All RFT numbers of the foundation (used by ``flagellum rft``)."""
    from ..errors import ParameterError
    from ..params import lighthill_friction

    fil, fluid = params.filament, params.fluid
    if fil.kappa0 == 0:
        raise ParameterError("kappa0", 0.0, "> 0 for rigid-helix RFT (a straight rod is no helix)")
    if fil.tau0 == 0:
        raise ParameterError("tau0", 0.0, "> 0 for rigid-helix RFT (a flat ring gives no thrust)")
    helix = Helix.from_filament(fil)
    gp, gn, gr = params.gammas
    coeffs = full_turn_coefficients(helix, gp, gn)
    lh = lighthill_friction(fil, fluid)
    pts, tan, w = helix_nodes(helix)
    pinned = pinned_rotation(resistance_matrix(pts - pts[0], tan, w, gp, gn, gr),
                             helix_axis=(0.0, 0.0, 1.0))
    out = {**helix.summary(), "length": helix.length,
           "gamma_par": gp, "gamma_perp": gn, "gamma_rot": gr,
           "lighthill": {"gamma_par": lh[0], "gamma_perp": lh[1], "gamma_rot": lh[2]},
           **coeffs, **anchored_helix(coeffs),
           "A_eff": effective_bending_rigidity(helix, fil.bend_rigidity, fil.twist_rigidity),
           "pinned": {"thrust_per_torque": pinned.thrust_per_torque,
                      "omega_per_torque": pinned.omega_per_torque,
                      "axis_tilt_deg": pinned.axis_tilt_deg},
           "critical_torque_line": {"critical_force": critical_force,
                                    **critical_torque_line(coeffs, critical_force, fluid.viscosity)}}
    return out


def pinned_helix(params, boundary=None) -> DiscreteHelix:
    """The discrete helix of ``params`` turned so that its pinned rigid-body rotation axis
    is −e_z (unturned for a clamped hook of ``boundary``, which fixes the hook frame).

    A rigid helix pinned at bead 0 rotates steadily only about the least-resistance
    eigen-axis of its rotational resistance matrix (:func:`pinned_rotation`); starting there
    avoids a long precessing transient.
    """
    from ..helix import discrete_helix, rotation_between

    dh = discrete_helix(params.filament)
    if boundary is not None and boundary.hook == "clamped":
        return dh
    gp, gn, gr = params.gammas
    pin = pinned_rotation(resistance_matrix(*bead_nodes(dh), gp, gn, gr), dh.axis_direction)
    rot = rotation_between(pin.axis, np.array([0.0, 0.0, -1.0]))
    return DiscreteHelix(dh.positions @ rot.T, np.einsum("ij,njk->nik", rot, dh.frames),
                         rot @ dh.axis_point, rot @ dh.axis_direction, dh.radius, dh.pitch,
                         dh.segment_length)


def pinned_omega_per_torque(params) -> float:
    """ω/M [rad/(s·pN·µm)] of the rigid discrete helix of ``params`` pinned at bead 0."""
    from ..helix import discrete_helix

    dh = discrete_helix(params.filament)
    gp, gn, gr = params.gammas
    return pinned_rotation(resistance_matrix(*bead_nodes(dh), gp, gn, gr),
                           dh.axis_direction).omega_per_torque
