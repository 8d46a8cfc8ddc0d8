"""Rotation of a rigid helix under a constant torque (paper Sec. 3, App. B).

With the translation suppressed, M = B ω (Eq. (40)): the lab-frame angular
velocity is ω = R B⁻¹ Rᵀ M for the body orientation R (columns: body axes in the lab) and
the rotational resistance matrix B in body axes. Differentiating M_body = Rᵀ M = B ω_body
with ∂t R = [ω]× R gives, in the eigenframe of B (eigenvalues B₁, B₂, B₃),

    B₁ ∂t ω₁ = (B₂ − B₃) ω₂ ω₃,   and cyclic,

Euler's equations of a torque-free rigid body with inertia tensor B: the torque plays the
angular momentum and P = M·ω (the dissipated power) the kinetic energy. Both
M² = Σ Bᵢ² ωᵢ² and P = Σ Bᵢ ωᵢ² are conserved, so ω moves on the intersection of two
ellipsoids; for B₁ = B₂ the helix axis precesses about M at the rate |M|/B₁.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ..errors import ParameterError
from ..helix import Helix
from ..hydro.rft import helix_nodes, resistance_matrix
from ..integrate import ATOL_PER_RTOL
from ..params import Params, check_real


def _skew(w):
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def rotational_resistance(params: Params | None = None, origin: str = "center") -> np.ndarray:
    """3×3 rotational resistance matrix B of the rigid helix (RFT, App. A) in body axes.

    Body axes: the helix axis is e₃ (the filament runs along +z from the origin of
    :meth:`Helix.positions`). Torques about the helix ``origin``: "center" (midpoint of the
    axis, the natural pivot of a free helix) or "end" (the first point of the filament).
    """
    params = params or Params()
    helix = Helix.from_filament(params.filament)
    gp, gn, gr = params.gammas
    pts, tan, w = helix_nodes(helix)
    if origin == "center":
        o = np.array([0.0, 0.0, helix.axial_length / 2])
    elif origin == "end":
        o = pts[0]
    else:
        raise ParameterError("origin", origin, "'center' or 'end'")
    return resistance_matrix(pts, tan, w, gp, gn, gr, origin=o)[3:, 3:]


@dataclass(frozen=True)
class RigidRotation:
    """Trajectory of a rigid helix under a constant lab torque."""

    t: np.ndarray
    R: np.ndarray            #: (n, 3, 3) orientations, columns = body axes in the lab
    omega_lab: np.ndarray    #: (n, 3)
    omega_body: np.ndarray   #: (n, 3)
    B: np.ndarray            #: body-frame resistance matrix
    torque: np.ndarray       #: lab torque M

    @property
    def torque_squared(self) -> np.ndarray:
        """M² = |B ω_body|² at every time (conserved)."""
        return np.sum((self.omega_body @ self.B.T) ** 2, axis=1)

    @property
    def dissipation(self) -> np.ndarray:
        """P = M·ω = ω_bodyᵀ B ω_body at every time (conserved)."""
        return np.einsum("ni,ij,nj->n", self.omega_body, self.B, self.omega_body)

    @property
    def axis(self) -> np.ndarray:
        """Direction of body axis e₃ (the helix axis) in the lab, (n, 3)."""
        return self.R[:, :, 2]

    def precession_rate(self) -> float:
        """Mean angular rate at which the helix axis turns about the torque."""
        m = self.torque / np.linalg.norm(self.torque)
        a = self.axis - np.outer(self.axis @ m, m)
        if np.linalg.norm(a[0]) < 1e-12:  # axis along M: a fixed point, no precession
            return 0.0
        e1 = a[0] / np.linalg.norm(a[0])
        e2 = np.cross(m, e1)
        phi = np.unwrap(np.arctan2(a @ e2, a @ e1))
        return float(np.polyfit(self.t, phi, 1)[0])


def euler_rates(B_principal, omega) -> np.ndarray:
    """∂t ω in a right-handed eigenframe of B: Bᵢ ∂t ωᵢ = (Bⱼ − Bₖ) ωⱼ ωₖ (Euler, App. B)."""
    b1, b2, b3 = B_principal
    w1, w2, w3 = omega
    return np.array([(b2 - b3) * w2 * w3 / b1, (b3 - b1) * w3 * w1 / b2, (b1 - b2) * w1 * w2 / b3])


def rotate(B, torque, t_end: float, *, R0=None, n_out: int = 401, rtol: float = 1e-10) -> RigidRotation:
    """Integrate ∂t R = [ω]× R with ω = R B⁻¹ Rᵀ M for the rigid helix (App. B).

    ``B``: symmetric positive-definite 3×3 resistance matrix in body axes; ``torque``: the
    constant lab torque M; ``R0``: initial orientation (default: identity, i.e. helix axis
    along z). Returns the orientation and angular velocities at ``n_out`` times.
    """
    B = np.asarray(B, float)
    M = np.asarray(torque, float)
    if B.shape != (3, 3) or not np.allclose(B, B.T, rtol=1e-9, atol=0) \
            or np.any(np.linalg.eigvalsh(B) <= 0):
        raise ParameterError("B", B.tolist(), "a symmetric positive-definite 3×3 matrix")
    if M.shape != (3,) or not np.all(np.isfinite(M)):
        raise ParameterError("torque", M.tolist(), "a finite 3-vector")
    t_end = check_real("t_end", t_end)
    if t_end <= 0:
        raise ParameterError("t_end", t_end, "a positive time")
    R0 = np.eye(3) if R0 is None else np.asarray(R0, float)
    Binv = np.linalg.inv(B)

    def rhs(_, y):
        R = y.reshape(3, 3)
        w_body = Binv @ (R.T @ M)
        return (R @ _skew(w_body)).ravel()    # ∂t R = [ω]× R = R [ω_body]×

    t = np.linspace(0.0, t_end, n_out)
    sol = solve_ivp(rhs, (0.0, t_end), R0.ravel(), method="DOP853", t_eval=t,
                    rtol=rtol, atol=rtol * ATOL_PER_RTOL)
    R = sol.y.T.reshape(-1, 3, 3)
    u, _, vt = np.linalg.svd(R)   # remove the tiny drift off SO(3)
    R = u @ vt
    w_body = np.einsum("ij,njk,k->ni", Binv, np.transpose(R, (0, 2, 1)), M)
    w_lab = np.einsum("nij,nj->ni", R, w_body)
    return RigidRotation(t, R, w_lab, w_body, B, M)
