"""Linear stability of the steadily rotating filament (paper Sec. 3.1–3.2, Fig. 4(a), Fig. 5).

Below the buckling torque M_c1 the motor-driven filament rotates rigidly about the motor
axis e_z, aligned with the torque. In a frame co-rotating at its rate Ω (and, with a load
sphere, co-moving at its speed v) this *aligned state* is a fixed point of the discrete
rod dynamics (paper Eqs. (6)–(7) and the hook balance Eq. (12),
:class:`flagellum.rod.model.RodModel`)::

    0 = f(y; Ω) = f_lab(y) − Ω G(y),

with G the generator of rotations about e_z (the rhs is affine in Ω, so
G = f(y; 0) − f(y; 1)). Its linear stability replaces the paper's fit
|𝓕 − 𝓕0| ≈ δ𝓕0 exp(λt) sin(ωt) of a perturbed simulation (Eq. (13), Sec. 3.1.2, Fig. 4(a)) by the
spectrum of the Jacobian.

Method
------
* **Reduced coordinates.** The state y (see :mod:`flagellum.rod.kernels`) has exact
  non-physical zero directions, removed first: bead 0 is held at the origin (its
  coordinates are dropped), the hook tangent u0 moves on its sphere |u0| = const (two
  tangent-plane coordinates; none with a clamped hook, whose u0 is fixed), and with a load
  sphere the common translation along z is quotiented out by measuring every bead's ż
  relative to the sphere's, ż_i − ż_0 (the sphere speed v = ż_0 is an output); for a free
  swimmer (body sphere on bead 0) all three translations, ṙ_i − ṙ_0 (:data:`DRIFT`): its
  relative equilibrium is a fixed point in the frame moving with bead 0 and rotating about
  the e_z axis through it.
* **Cell body** (a body free in 3D with the motor on its surface, ``Boundary.body_radius``):
  its orientation φ joins the reduced coordinates; the whole cell may turn about any axis
  and its body spin about the motor axis m (a symmetry of a sphere, and of a spheroid with
  the motor at a pole; off the pole the steady swimmer is periodic: refused). The fixed
  point is one of f − σ S (S the spin generator, σ its rate, an extra Newton unknown with
  the phase condition Ŝ·δξ = 0), and the generators of the rotations about e_z, e_x, e_y
  and of the spin span an invariant subspace of J (eigenvalues 0, 0, ±iΩ) removed from the
  spectrum like the rotational zero mode (:func:`_symmetry_basis`).
* **Relative equilibrium.** Newton on (ξ, Ω) with the bordered Jacobian
  [[J, −G], [Ĝᵀ, 0]]: the phase condition Ĝ·δξ = 0 fixes the rotational symmetry and Ω is
  the extra unknown. J is a dense central finite-difference Jacobian (≈ 4N unknowns). The
  first guess is the rigid helix (turned onto its pinned rotation axis, rotating at M/b,
  App. B); larger torques follow by continuation in M. Elastic and clamped hooks start
  from the free-hook state and stiffen the hook by continuation in k (k → ∞: clamped).
* **Spectrum.** J G = 0 at a relative equilibrium, so in the orthonormal basis [Ĝ, W]
  (a Householder reflection) J is block upper triangular and eig J = {0} ∪ eig(Wᵀ J W):
  the rotational zero mode is removed exactly, without picking it out by size (genuinely
  slow tilt modes have |λ| down to 1e-5 /s). λ is the largest real part of eig(Wᵀ J W).
* **Critical torque.** M_c1 is the root of λ(M) (Brent's method on a sign-changing
  bracket), F_c1 the thrust there: the paper's F = −∂𝓕/∂r⁽⁰⁾·e_z, the elastic force on
  the first bead (with a load sphere, (6πηa + drag of bead 0)·v).
* **Drives.** A speed clamp or a torque–speed law (``motor``) selects the constant-torque
  state whose torque it needs (the kernel solves the same hook balance); the state is then
  linearized with that drive, whose solved torque responds to the perturbation
  (:func:`_on_drive`); :func:`critical_speed` is the critical rotation rate of a clamp.
* **Mobility.** The local RFT of the paper, or (``hydrodynamics``) the nonlocal mobility of
  :mod:`flagellum.hydro.dynamics`, then evaluated unfrozen: rebuilt at the state of every
  evaluation, so that f, its fixed point and J are those of the nonlocal dynamics itself.

Eigenvalues are in the co-rotating frame. A mode whose pattern turns at s|Im λ| (s = ±1)
about e_z in that frame turns at Ω + s|Im λ| in the lab (``lab_frequency``); for the Hopf
mode at M_c1 this is the precession rate χ of the buckled filament at onset (Fig. 4(b)).
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np
import scipy.linalg as sla
from scipy.optimize import brentq

from ..errors import ParameterError, SimulationError
from ..hydro.body import body_resistance, rotvec_matrix, rotvec_rate
from ..hydro.options import Hydrodynamics
from ..motor import Boundary, Motor
from ..params import Params, check_range, check_real
from ..rod.model import RodModel

FD_STEP = 1e-7  #: central-difference step [µm or rad]; λ is converged to ~1e-8 /s with it
MAX_TORQUE_STEP = 0.25  #: continuation step in M [pN·µm]
K_START, CLAMP_STIFFNESS = 1e-2, 1e4  #: hook stiffnesses [pN·µm] of the continuation in k
#: default bracket of :func:`critical_torque` [pN·µm] by mobility model. With the nonlocal
#: mobility the slow tilt mode of the anchored filament grows weakly at small torques
#: (λ = +0.009 /s at M = 0.5, −1.19 /s at M = 1; docs/hydrodynamics.md), so its bracket
#: starts at 1
BRACKETS = {"rft": (0.5, 2.0), "sbt": (1.0, 2.5)}
#: torques |M| [pN·µm] that the automatic bracket of :func:`critical_torque` may reach: it
#: starts from :data:`BRACKETS` and is widened by the factor :data:`WIDEN` per step (up while
#: λ < 0 at both ends, down while λ > 0 at both) until λ changes sign. 10 pN·µm is above every
#: threshold of the paper's model (Fig. 5: M_c1 ≤ 4.4 at a = 0.25 µm)
SEARCH_RANGE = (0.25, 10.0)
WIDEN = 1.25
#: components of bead 0's velocity that are a rigid translation of the whole filament, by
#: anchor: quotiented out of the reduced dynamics (a free swimmer's body, centred on bead 0,
#: translates in 3D; the motor axis stays e_z, so the rotation about e_z is the only other
#: continuous symmetry)
DRIFT = {"fixed": (), "sphere": (2,), "free": (0, 1, 2)}


def _relative_speed(params: Params, boundary: Boundary, torque: float, omega: float) -> float:
    """Motor speed relative to the body at filament rate Ω and torque M: Ω + M/(8πηa³) for a
    free swimmer with a body sphere (it counter-rotates, :meth:`Boundary.body_rotation_rate`),
    Ω otherwise."""
    body = boundary.body_rotation_rate(torque, params.fluid.viscosity)
    return omega - body if math.isfinite(body) else omega


# -- results -------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class RelativeEquilibrium:
    """The aligned, steadily rotating filament: a fixed point in the co-rotating frame.

    ``state`` is the rod state (bead 0 at the origin) whose material angles refer to
    ``charts`` = (ref_u, ref_e); ``hydrodynamics`` the bead mobility (a nonlocal one
    unfrozen, see :func:`_unfrozen`); ``omega`` = Ω the rotation rate [rad/s]; ``thrust`` the
    elastic force on bead 0 along e_z [pN]; ``velocity`` the speed of the load sphere or of
    the free swimmer's body along e_z [µm/s] (0 when anchored); ``residual`` the largest |ẏ|
    left in the reduced coordinates [µm/s or rad/s]; ``iterations`` the Newton iterations of
    the last solve. ``motor`` is the drive the state is linearized with (None: the constant
    torque ``torque``; a speed clamp or a law holds ``torque`` as its solved torque).
    """

    params: Params
    boundary: Boundary
    torque: float
    state: np.ndarray = field(repr=False)
    charts: tuple = field(repr=False)
    omega: float
    thrust: float
    velocity: float
    residual: float
    iterations: int
    hydrodynamics: Hydrodynamics = Hydrodynamics()
    motor: Motor | None = None
    #: a cell body's spin rate σ about its motor axis in the co-rotating frame [rad/s] (the
    #: body turns at Ω e_z + σ m in the lab); 0 without a cell body
    spin: float = 0.0
    #: a cell body's motor speed relative to the body [rad/s] (NaN without a cell body)
    cell_motor_speed: float = math.nan

    @property
    def motor_speed(self) -> float:
        """Motor speed relative to the body [rad/s]: Ω, plus M/(8πηa³) for a free swimmer
        whose body counter-rotates (docs/motor.md); a cell body's from the kernel."""
        if self.boundary.is_cell:
            return self.cell_motor_speed
        return _relative_speed(self.params, self.boundary, self.torque, self.omega)

    def model(self) -> RodModel:
        """A :class:`RodModel` in the co-rotating frame with this state's charts (and drive)."""
        m = RodModel(self.params, self.motor or Motor(self.torque), self.boundary,
                     omega_frame=self.omega, hydrodynamics=self.hydrodynamics)
        m.set_charts(*self.charts)
        return m


@dataclass(frozen=True, eq=False)
class StabilityResult:
    """Spectrum of the aligned state at one torque.

    ``eigenvalues``: the leading ``n_eigs`` non-trivial eigenvalues [1/s] (co-rotating
    frame), sorted by real part, largest first; ``lambda_`` the largest real part (the
    paper's reorientation rate λ, Fig. 4(a)); ``frequency`` = |Im| of the leading one;
    ``lab_frequency`` the rotation rate of its pattern about e_z in the lab [rad/s];
    ``drive`` the drive linearized with (``"torque"``, ``"speed"``: clamp, ``"law"``) and
    ``motor_speed`` the motor speed relative to the body [rad/s].
    """

    torque: float
    omega: float
    thrust: float
    velocity: float
    lambda_: float
    frequency: float
    lab_frequency: float
    eigenvalues: np.ndarray
    equilibrium: RelativeEquilibrium = field(repr=False)
    drive: str = "torque"
    motor_speed: float = math.nan

    def to_dict(self) -> dict:
        return {"drive": self.drive, "torque": self.torque, "omega": self.omega,
                "motor_speed": self.motor_speed, "thrust": self.thrust,
                "velocity": self.velocity, "lambda": self.lambda_, "frequency": self.frequency,
                "lab_frequency": self.lab_frequency,
                "eigenvalues": [[float(e.real), float(e.imag)] for e in self.eigenvalues]}


@dataclass(frozen=True)
class CriticalTorque:
    """The buckling threshold M_c1 where λ(M) crosses zero, and the state there."""

    critical_torque: float  #: M_c1 [pN·µm]
    critical_force: float  #: F_c1 [pN], the thrust at M_c1
    omega: float  #: Ω at M_c1 [rad/s]
    velocity: float  #: load-sphere speed at M_c1 [µm/s]
    frequency: float  #: |Im λ| of the critical mode, co-rotating frame [rad/s]
    lab_frequency: float  #: its rotation rate in the lab (precession at onset) [rad/s]
    evaluations: int  #: number of λ(M) evaluations
    wall_seconds: float
    #: the drive of the threshold: "torque" (M_c1) or "speed" (a speed clamp: the critical
    #: rotation rate ω_c1 is ``motor_speed``, ``critical_torque`` the torque the clamp takes)
    drive: str = "torque"
    motor_speed: float = math.nan  #: motor speed relative to the body at the threshold [rad/s]

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True, eq=False)
class GrowthFit:
    """Rate from a perturbed simulation, fitted as |X − X0| ≈ δX0 exp(λt)."""

    rate: float  #: fitted λ [1/s]
    t: np.ndarray = field(repr=False)  #: sample times [s]
    deviation: np.ndarray = field(repr=False)  #: X(t) − X0 (thrust [pN] or tip radius [µm])
    peak_t: np.ndarray = field(repr=False)  #: times of the maxima of |X − X0| in the fit
    peaks: np.ndarray = field(repr=False)


# -- reduced coordinates -------------------------------------------------------------------
class _Reduced:
    """Reduced coordinates ξ around a base state y: y(ξ) = y + Q ξ, ẏ_red = R ẏ.

    Q keeps θ0 and beads 1..N (and two tangent directions of u0 unless the hook is
    clamped); R also subtracts bead 0's velocity from the beads' along the directions in
    which bead 0 moves (:data:`DRIFT`: none anchored, ż_0 on a load sphere, all three for a
    free swimmer): the rigid translations are quotiented out.
    """

    def __init__(self, model: RodModel, y: np.ndarray, spin: float = 0.0):
        self.model = model
        n = model.n
        self.spin = float(spin)  #: σ: the body's spin about its motor axis (cell, :func:`_cell_symmetric`)
        idx = [6] + [3 + 4 * i + k for i in range(1, n + 1) for k in range(4)]
        if model.cell:  # the body's orientation φ: the state's last three values
            idx += [model.state_size - 3 + k for k in range(3)]
        self.idx = np.array(idx)
        comp = np.where(self.idx < 3 + 4 * (n + 1), (self.idx - 3) % 4, 3)  # 0–2: x, y, z of a bead
        # (entry of idx, component of bead 0's velocity subtracted from it)
        self.drift = [(j, int(c)) for j, c in enumerate(comp) if c in DRIFT[model.boundary.anchor]]
        self.n_u = 0 if model.boundary.hook == "clamped" else 2
        self.size = self.n_u + len(self.idx)
        self.rebase(y)

    def rebase(self, y: np.ndarray) -> None:
        self.y = np.array(y, float)
        u = self.y[:3] / np.linalg.norm(self.y[:3])
        a = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
        a /= np.linalg.norm(a)
        self.basis = np.stack([a, np.cross(u, a)])[: self.n_u]  # (n_u, 3)

    def embed(self, xi: np.ndarray) -> np.ndarray:
        y = self.y.copy()
        y[:3] += xi[: self.n_u] @ self.basis
        y[self.idx] += xi[self.n_u:]
        return y

    def reduce(self, f: np.ndarray) -> np.ndarray:
        out = np.empty(self.size)
        out[: self.n_u] = self.basis @ f[:3]
        r = f[self.idx]
        for j, c in self.drift:
            r[j] -= f[3 + c]
        out[self.n_u:] = r
        return out

    def field(self, y: np.ndarray, omega: float) -> np.ndarray:
        self.model.set_omega_frame(omega)
        f = self.reduce(self.model.rhs(0.0, y))
        if self.spin:
            f -= self.spin * self.spin_generator(y)
        return f

    def generator(self, y: np.ndarray) -> np.ndarray:
        """Reduced G(y) = f(y; 0) − f(y; 1): rotation of the whole state about e_z."""
        return self.field(y, 0.0) - self.field(y, 1.0)

    def rotation(self, y: np.ndarray, axis) -> np.ndarray:
        """Reduced generator of a rigid rotation of the whole state about ``axis`` (unit):
        δr_i = e × r_i, δu0 = e × u0, δθ_i = e·t_i − s_i·(e × t_i) (the material frames turn
        with the rod; s the charts' spin connection, as in the kernels' θ̇), δφ = J⁻¹(φ) e."""
        e = np.asarray(axis, float)
        fr = self.model.frames(y)
        g = np.zeros_like(y)
        g[:3] = np.cross(e, y[:3])
        beads = y[3: 3 + 4 * (self.model.n + 1)].reshape(-1, 4)
        gb = g[3: 3 + 4 * (self.model.n + 1)].reshape(-1, 4)
        gb[:, :3] = np.cross(e, beads[:, :3])
        gb[:, 3] = fr.tangents @ e - np.einsum("ij,ij->i", fr.spin, np.cross(e, fr.tangents))
        gb[0, 3] = 0.0
        g[6] = gb[0, 3] = fr.tangents[0] @ e - fr.spin[0] @ np.cross(e, fr.tangents[0])
        if self.model.cell:
            g[-3:] = rotvec_rate(*y[-3:], *e)
        return self.reduce(g)

    def spin_generator(self, y: np.ndarray) -> np.ndarray:
        """Reduced generator of the cell body's spin about its motor axis m through the motor
        point: only φ changes (δφ = J⁻¹(φ) m), which is a symmetry of a sphere (any motor
        position) or of a spheroid with the motor at a pole (:func:`_cell_symmetric`)."""
        g = np.zeros_like(y)
        g[-3:] = rotvec_rate(*y[-3:], *self.motor_axis(y))
        return self.reduce(g)

    @staticmethod
    def motor_axis(y: np.ndarray) -> np.ndarray:
        """The cell body's motor axis m = Q e_z (body-fixed m is e_z, :mod:`flagellum.hydro.body`)."""
        return rotvec_matrix(y[-3:])[:, 2]

    def symmetries(self, y: np.ndarray) -> np.ndarray:
        """(k, size) reduced generators of the continuous symmetries left after the
        translations: the rotation about e_z; for a cell body also its spin about the motor
        axis and the rotations about e_x and e_y (the whole cell turns freely in 3D)."""
        gens = [self.generator(y)]
        if self.model.cell:
            gens += [self.spin_generator(y), self.rotation(y, (1.0, 0.0, 0.0)),
                     self.rotation(y, (0.0, 1.0, 0.0))]
        return np.array(gens)

    def jacobian(self, omega: float, step: float = FD_STEP) -> np.ndarray:
        """Central-difference ∂(reduced f)/∂ξ at the base state."""
        J = np.empty((self.size, self.size))
        xi = np.zeros(self.size)
        for j in range(self.size):
            xi[j] = step
            fp = self.field(self.embed(xi), omega)
            xi[j] = -step
            J[:, j] = (fp - self.field(self.embed(xi), omega)) / (2 * step)
            xi[j] = 0.0
        return J

    def tip_xy(self) -> tuple[int, int]:
        """Reduced indices of the free end's x and y."""
        k = self.n_u + int(np.nonzero(self.idx == 3 + 4 * self.model.n)[0][0])
        return k, k + 1


# -- relative equilibrium ------------------------------------------------------------------
def _cell_symmetric(boundary: Boundary) -> None:
    """A cell body's steady swimming is a relative equilibrium (the analysis here) when the
    body's spin about the motor axis is a symmetry: a sphere (any motor position) or a
    spheroid with the motor at a pole. Off the pole the body's shape turns against the
    filament once per motor turn: a periodic orbit (refused)."""
    if boundary.is_cell and boundary.body_aspect != 1.0 and boundary.motor_offset not in (0.0, 180.0):
        raise ParameterError("motor_offset", boundary.motor_offset,
                             "0 or 180 for a spheroid body in the stability analysis (off the "
                             "pole its steady swimming is periodic, no relative equilibrium)")


def _check_torque(torque) -> float:
    m = check_range("torque", torque, -1e3, 1e3, lo_open=False)
    if m == 0:
        raise ParameterError("torque", torque, "nonzero (at M = 0 every orientation is an equilibrium)")
    return m


def _unfrozen(hydrodynamics: Hydrodynamics | None) -> Hydrodynamics:
    """The mobility the linearization sees: a nonlocal one rebuilt at every evaluation
    (``refresh=0``), so that the Jacobian carries the change of the mobility with the bead
    positions, (∂M/∂x) F, which the simulator's frozen correction ΔM leaves out within a
    refresh interval."""
    h = hydrodynamics or Hydrodynamics()
    return h if h.is_local else replace(h, refresh=0.0)


def _rigid_start(params: Params, boundary: Boundary, torque: float, hydrodynamics: Hydrodynamics):
    """Rigid-helix guess for a free hook: model, state and Ω = M/b.

    The stress-free helix is turned onto its pinned rotation axis and rotates at M/b, b the
    least eigenvalue of its rotational resistance about bead 0 (App. B,
    :func:`flagellum.hydro.rft.pinned_rotation`; the local value is a close guess for a
    nonlocal mobility too: ω/M differs by about 1 %, docs/hydrodynamics.md).
    """
    from ..hydro.rft import pinned_helix, pinned_omega_per_torque

    m = RodModel(params, Motor(torque), boundary, hydrodynamics=hydrodynamics)
    return m, m.initial_state(pinned_helix(params, boundary)), torque * pinned_omega_per_torque(params)


def _newton(red: _Reduced, omega: float, tol: float, max_iter: int):
    """Newton on (ξ, Ω) with the phase condition Ĝ·δξ = 0; for a cell body also on its spin
    rate σ (``red.spin``, updated) with Ŝ·δξ = 0 (Ŝ the spin generator). Returns
    (Ω, iterations, residual)."""
    n = red.size
    k = 2 if red.model.cell else 1  # extra unknowns: Ω (and σ)
    A = np.zeros((n + k, n + k))
    scale_u = np.linalg.norm(red.y[:3])
    for it in range(1, max_iter + 1):
        f = red.field(red.y, omega)
        gens = [red.generator(red.y)] + ([red.spin_generator(red.y)] if k == 2 else [])
        A[:n, :n] = red.jacobian(omega)
        for c, g in enumerate(gens):
            A[:n, n + c] = -g
            A[n + c, :n] = g / np.linalg.norm(g)
        try:
            d = np.linalg.solve(A, np.r_[-f, np.zeros(k)])
        except np.linalg.LinAlgError:
            break
        r0, s, spin0 = np.linalg.norm(f), 1.0, red.spin
        while True:  # backtracking on |f|, unless the step is already tiny (roundoff)
            y = red.embed(s * d[:n])
            y[:3] *= scale_u / np.linalg.norm(y[:3])
            red.spin = spin0 + (s * d[n + 1] if k == 2 else 0.0)
            if np.abs(d[:n]).max() < 1e-6:
                break
            r1 = np.linalg.norm(red.field(y, omega + s * d[n]))
            if np.isfinite(r1) and r1 < r0:
                break
            s *= 0.5
            if s < 1e-3:
                red.spin = spin0
                return omega, it, math.inf
        red.rebase(y)
        omega += s * d[n]
        if s == 1.0 and np.abs(d[:n]).max() < tol and all(
                abs(d[n + c]) < tol * max(1.0, abs(v)) for c, v in enumerate((omega, red.spin)[:k])):
            return omega, it, float(np.abs(red.field(red.y, omega)).max())
    return omega, max_iter, math.inf


class _Branch:
    """Continuation of the aligned state in M for fixed params and boundary (cached)."""

    def __init__(self, params: Params, boundary: Boundary, tol: float = 1e-10, max_iter: int = 25,
                 hydrodynamics: Hydrodynamics | None = None):
        _cell_symmetric(boundary)
        self.params, self.boundary = params, boundary
        self.tol, self.max_iter = tol, max_iter
        self.hydrodynamics = _unfrozen(hydrodynamics)
        self.solutions: list[RelativeEquilibrium] = []

    def _solve(self, torque, y, charts, omega, spin=None) -> RelativeEquilibrium | None:
        m = RodModel(self.params, Motor(torque), self.boundary, hydrodynamics=self.hydrodynamics)
        m.set_charts(*charts)
        if m.cell and spin is None:  # the body counter-rotates at −M/R∥ about m in the lab
            b = self.boundary
            spin = -torque / body_resistance(b.body_radius, b.body_aspect,
                                             self.params.fluid.viscosity).rotation_axial - omega
        red = _Reduced(m, y, spin or 0.0)
        omega, it, res = _newton(red, omega, self.tol, self.max_iter)
        if not math.isfinite(res):
            return None
        m.rechart(red.y)
        m.set_omega_frame(omega)
        f = m.rhs(0.0, red.y)
        return RelativeEquilibrium(self.params, self.boundary, torque, red.y.copy(), m.charts(),
                                   float(omega), float(m.last_force[2]), float(f[5]), res, it,
                                   self.hydrodynamics, spin=red.spin,
                                   cell_motor_speed=float(m.last_relative_motor_speed)
                                   if m.cell else math.nan)

    def _start(self, torque: float, max_step: float) -> RelativeEquilibrium:
        """First solution on the branch, at a torque of the sign of ``torque``."""
        if self.boundary.hook == "free":  # the rigid helix at a small torque
            m0 = math.copysign(min(abs(torque), max_step), torque)
            while abs(m0) >= 1e-3:
                model, y, om = _rigid_start(self.params, self.boundary, m0, self.hydrodynamics)
                eq = self._solve(m0, y, model.charts(), om)
                if eq is not None:
                    return eq
                m0 /= 4
            raise SimulationError("no aligned rotating state found near the rigid helix")
        # stiffer hooks: the free-hook state, then continuation in log k (k → ∞: clamped)
        m0 = math.copysign(min(abs(torque), 1.0), torque)
        eq = _Branch(self.params, replace(self.boundary, hook="free"), self.tol, self.max_iter,
                     self.hydrodynamics).at(m0, max_step)
        k_end = self.boundary.hook_stiffness if self.boundary.hook == "elastic" else CLAMP_STIFFNESS
        logk, dlog = math.log(min(K_START, k_end)), 0.25
        while True:
            b = replace(self.boundary, hook="elastic", hook_stiffness=math.exp(logk))
            nxt = _Branch(self.params, b, self.tol, self.max_iter,
                          self.hydrodynamics)._solve(m0, eq.state, eq.charts, eq.omega, eq.spin)
            if nxt is None:
                logk -= dlog
                dlog /= 2
                if dlog < 1e-3:
                    raise SimulationError(f"stiffening the hook failed at k = {math.exp(logk):g} pN·µm")
            else:
                eq = nxt
                if logk >= math.log(k_end) - 1e-12:
                    break
                dlog = min(2 * dlog, 0.6)
            logk = min(logk + dlog, math.log(k_end))
        if self.boundary.hook == "elastic":
            return replace(eq, boundary=self.boundary)
        y = eq.state.copy()
        # the clamped hook points along −m (−e_z, or a cell body's turned motor axis)
        m_axis = _Reduced.motor_axis(y) if self.boundary.is_cell else np.array([0.0, 0.0, 1.0])
        y[:3] = -np.linalg.norm(y[:3]) * m_axis
        eq = self._solve(m0, y, eq.charts, eq.omega, eq.spin)
        if eq is None:
            raise SimulationError("no aligned rotating state found with a clamped hook")
        return eq

    def at(self, torque: float, max_step: float = MAX_TORQUE_STEP) -> RelativeEquilibrium:
        """The aligned state at ``torque`` by continuation from the nearest solved one."""
        same = [s for s in self.solutions if s.torque * torque > 0]
        if same:
            cur = min(same, key=lambda s: abs(s.torque - torque))
        else:
            cur = self._start(torque, max_step)
            self.solutions.append(cur)
        step = max_step
        while cur.torque != torque:
            gap = torque - cur.torque
            m_new = torque if abs(gap) <= step else cur.torque + math.copysign(step, gap)
            nxt = self._solve(m_new, cur.state, cur.charts, cur.omega * m_new / cur.torque,
                              cur.spin * m_new / cur.torque)
            if nxt is None:
                step /= 2
                if step < 1e-3:
                    raise SimulationError(f"continuation of the aligned state failed near "
                                          f"M = {cur.torque:g} pN·µm")
                continue
            cur = nxt
            self.solutions.append(cur)
        return cur


def relative_equilibrium(params: Params | None = None, torque: float = 1.0,
                         boundary: Boundary | None = None, *, tol: float = 1e-10,
                         max_step: float = MAX_TORQUE_STEP,
                         hydrodynamics: Hydrodynamics | None = None) -> RelativeEquilibrium:
    """The aligned, steadily rotating (and, with a load sphere, translating) filament.

    Solves f(y; Ω) = 0 in the co-rotating frame by Newton with a phase condition, reached
    by continuation in M from the rigid-helix limit (steps ≤ ``max_step``).

    Parameters
    ----------
    params : filament, fluid and friction (default: the paper's, Sec. 2.4).
    torque : motor torque M [pN·µm], nonzero (M > 0 pushes, paper Sec. 3.1).
    boundary : anchor and hook (default: fixed anchor, free hook, paper Sec. 2.3).
    tol : Newton tolerance on the update [µm, rad] (relative for Ω).
    max_step : largest continuation step in M [pN·µm].
    hydrodynamics : the bead mobility (default local RFT); a nonlocal one is evaluated
        unfrozen, at the state itself.

    Returns
    -------
    RelativeEquilibrium
    """
    torque = _check_torque(torque)
    tol = check_range("tol", tol, 0.0, 1e-3)
    max_step = check_range("max_step", max_step, 0.0, 10.0)
    return _Branch(params or Params(), boundary or Boundary(), tol,
                   hydrodynamics=hydrodynamics).at(torque, max_step)


# -- drives --------------------------------------------------------------------------------
def steady_drive(motor: Motor | None, torque: float | None = None) -> Motor:
    """The drive of a stability analysis: ``motor``, or the constant ``torque``; refused
    (:class:`ParameterError`) when it is not steady: reversals, a schedule or a ramp."""
    if motor is None:
        return Motor(_check_torque(1.0 if torque is None else torque))
    if not isinstance(motor, Motor):
        raise ParameterError("motor", motor, "a Motor")
    for name in ("reversals", "reversal_rates", "schedule"):
        if getattr(motor, name) is not None:
            raise ParameterError(name, getattr(motor, name), "none for the stability analysis "
                                 "(it linearizes a steadily rotating state)")
    if motor.ramp_time:
        raise ParameterError("ramp_time", motor.ramp_time, "0 for the stability analysis "
                             "(the steady state does not depend on how the motor started)")
    if motor.drive == "torque":
        _check_torque(motor.torque)
    return motor


def _drive_gap(motor: Motor, eq: RelativeEquilibrium) -> float:
    """How far the constant-torque state ``eq`` is from the drive's operating point: the
    clamp's speed error [rad/s], or the law's torque error [pN·µm]."""
    if motor.drive == "speed":
        return eq.motor_speed - motor.speed
    return eq.torque - float(motor.law(eq.motor_speed))


def _on_drive(branch: "_Branch", motor: Motor, max_iter: int = 40) -> RelativeEquilibrium:
    """The aligned state the drive selects, linearized with that drive.

    A speed clamp ω_c or a law f keeps the steady state of the constant torque M it needs
    (the kernel solves the same hook balance Eq. (12) for M, docs/motor.md): the state on the
    constant-torque branch where the motor speed relative to the body s(M) equals ω_c, or
    where M = f(s(M)). M is found by a secant iteration along the branch (s(M) is smooth and
    increasing through M_c1). The returned state carries the drive, so that its Jacobian is
    that of the clamped (or law-driven) dynamics: a perturbation then changes the torque
    instead of the hook's rate (the hook row of the Jacobian changes).
    """
    if motor.drive == "torque":
        return branch.at(motor.torque)
    from ..hydro.rft import pinned_omega_per_torque

    m_a = motor.expected_torque(pinned_omega_per_torque(branch.params))
    if motor.drive == "law":
        m_a = min(m_a, motor.law.stall_torque)
    m_a = _check_torque(m_a)
    scale = abs(motor.speed) if motor.drive == "speed" else motor.law.stall_torque
    eq_a = branch.at(m_a)
    g_a = _drive_gap(motor, eq_a)
    m_b = m_a * (0.98 if g_a > 0 else 1.02)
    for _ in range(max_iter):
        eq_b = branch.at(m_b)
        g_b = _drive_gap(motor, eq_b)
        if abs(g_b) <= 1e-11 * scale:
            return replace(eq_b, motor=motor)
        if g_b == g_a:
            break
        step = -g_b * (m_b - m_a) / (g_b - g_a)
        step = max(-0.2 * abs(m_b), min(0.2 * abs(m_b), step))  # s(M) bends near M_c1
        m_a, g_a, m_b = m_b, g_b, m_b + step
        if m_b * m_a <= 0:
            break
    what = f"motor speed {motor.speed:g} rad/s" if motor.drive == "speed" else "this law"
    raise SimulationError(f"no aligned rotating state found for {what} "
                          f"(the torque iteration stopped near M = {m_b:g} pN·µm)")


# -- spectrum ------------------------------------------------------------------------------
def _householder(v: np.ndarray) -> np.ndarray:
    """Symmetric orthogonal H with H v̂ = ±e_0 (its columns 1.. span v̂⊥)."""
    v = v / np.linalg.norm(v)
    w = v.copy()
    w[0] += math.copysign(1.0, v[0])
    return np.eye(len(v)) - 2.0 * np.outer(w, w) / (w @ w)


def _symmetry_basis(gens: np.ndarray) -> np.ndarray:
    """Orthogonal H whose first k columns span the k symmetry generators ``gens`` (k, n)
    (one generator: a Householder reflection, H v̂ = ±e_0; more: a complete QR)."""
    if len(gens) == 1:
        return _householder(gens[0])
    return np.linalg.qr(gens.T, mode="complete")[0]


def _spectrum(eq: RelativeEquilibrium) -> tuple[np.ndarray, float]:
    """Non-trivial eigenvalues (largest real part first) and the leading mode's lab rate.

    The symmetry generators span an invariant subspace of J (J Ĝ = 0 for the rotation about
    e_z and a cell body's spin; a cell's tilts about e_x, e_y turn into each other at ±iΩ),
    so in the basis H = [generators, complement] HᵀJH is block upper triangular and the
    complement block holds the non-trivial spectrum."""
    red = _Reduced(eq.model(), eq.state, eq.spin)
    gens = red.symmetries(eq.state)
    k = len(gens)
    H = _symmetry_basis(gens)
    JH = H.T @ red.jacobian(eq.omega) @ H  # first k columns ≈ J-invariant subspace
    w, vr = sla.eig(JH[k:, k:])
    order = np.lexsort((-w.imag, -w.real))
    w, vr = w[order], vr[:, order]
    lam, u = w[0], vr[:, 0]
    if lam.imag == 0.0:
        return w, eq.omega
    # sense of rotation of the free end's displacement X + iY in the co-rotating frame:
    # X = Re(a e^{iσt}), Y = Re(b e^{iσt}) gives X Ẏ − Y Ẋ = −σ Im(ā b)
    top = np.linalg.solve(lam * np.eye(k) - JH[:k, :k], JH[:k, k:] @ u)  # symmetry components
    v = H @ np.r_[top, u]
    kx, ky = red.tip_xy()
    sense = math.copysign(1.0, -lam.imag * float(np.imag(np.conj(v[kx]) * v[ky])))
    return w, eq.omega + sense * abs(lam.imag)


def linear_stability(params: Params | None = None, torque: float = 1.0,
                     boundary: Boundary | None = None, n_eigs: int = 6, *,
                     equilibrium: RelativeEquilibrium | None = None,
                     hydrodynamics: Hydrodynamics | None = None,
                     motor: Motor | None = None) -> StabilityResult:
    """Eigenvalues of the aligned state's Jacobian, trivial modes removed.

    Parameters
    ----------
    params, torque, boundary, hydrodynamics : as for :func:`relative_equilibrium`.
    n_eigs : how many leading eigenvalues to return.
    equilibrium : reuse a computed :class:`RelativeEquilibrium` (params, torque and
        boundary and hydrodynamics are then taken from it).
    motor : the drive instead of ``torque`` (:func:`steady_drive`): a constant torque, a
        speed clamp (``Motor(drive="speed", speed=ω)``: the aligned state rotating with the
        motor at ω relative to the body, linearized with the clamp: the torque is an output)
        or a torque–speed law (at its operating point, linearized with the law).

    Returns
    -------
    StabilityResult
        λ = largest real part of the spectrum: λ < 0 the aligned state is stable (Fig. 4(a)).
    """
    if isinstance(n_eigs, bool) or not isinstance(n_eigs, (int, np.integer)) or n_eigs < 1:
        raise ParameterError("n_eigs", n_eigs, "an integer ≥ 1")
    if equilibrium is None:
        motor = steady_drive(motor, torque)
        branch = _Branch(params or Params(), boundary or Boundary(), hydrodynamics=hydrodynamics)
        equilibrium = _on_drive(branch, motor)
    eq = equilibrium
    w, lab = _spectrum(eq)
    return StabilityResult(eq.torque, eq.omega, eq.thrust, eq.velocity, float(w[0].real),
                           float(abs(w[0].imag)), float(lab), w[:n_eigs], eq,
                           (eq.motor or Motor(eq.torque)).drive, eq.motor_speed)


def stability_curve(params: Params | None = None, torques=(), boundary: Boundary | None = None,
                    n_eigs: int = 6, *, hydrodynamics: Hydrodynamics | None = None,
                    errors: str = "raise") -> list:
    """:func:`linear_stability` at each of ``torques`` along one continuation branch.

    The torques are solved in order of increasing |M| on each side of M = 0, so that each
    Newton solve starts from the nearest torque already solved instead of from the rigid
    helix at small M: the same aligned states as separate :func:`linear_stability` calls
    (to the Newton tolerance), with a fraction of the solves. Returns the results in the
    order of ``torques``; with ``errors="return"`` a torque whose solve failed gives its
    exception in its place (the other torques go on), with ``"raise"`` it is raised.
    """
    if errors not in ("raise", "return"):
        raise ParameterError("errors", errors, "'raise' or 'return'")
    ms = [_check_torque(m) for m in torques]
    branch = _Branch(params or Params(), boundary or Boundary(), hydrodynamics=hydrodynamics)
    out: list = [None] * len(ms)
    for k in sorted(range(len(ms)), key=lambda k: (ms[k] < 0, abs(ms[k]))):
        try:
            out[k] = linear_stability(n_eigs=n_eigs, equilibrium=branch.at(ms[k]))
        except (SimulationError, ParameterError, ArithmeticError, np.linalg.LinAlgError) as exc:
            if errors == "raise":
                raise
            out[k] = exc
    return out


def _sign_change(lam, lo: float, hi: float) -> tuple[float, float]:
    """A bracket (M_lo, M_hi) with λ(M_lo) < 0 < λ(M_hi), widened from the positive torques
    (``lo``, ``hi``) by :data:`WIDEN` per step within :data:`SEARCH_RANGE`: upwards while λ < 0
    at both ends (the threshold lies higher: small load spheres and cell bodies, stiff hooks),
    downwards while λ > 0 at both. Each step keeps the end already on the right side, so the
    root found is the first sign change met from the starting bracket (a coarser step could
    jump over a pair of close crossings, docs/stability.md). :class:`ParameterError` (one
    line, ``bracket``) when no sign change lies within the range."""
    m_min, m_max = SEARCH_RANGE
    l_lo, l_hi = lam(lo), lam(hi)
    while l_lo < 0 and l_hi < 0 and hi < m_max:
        lo, l_lo = hi, l_hi
        hi = min(WIDEN * hi, m_max)
        l_hi = lam(hi)
    while l_lo > 0 and l_hi > 0 and lo > m_min:
        hi, l_hi = lo, l_lo
        lo = max(lo / WIDEN, m_min)
        l_lo = lam(lo)
    if not (l_lo < 0 < l_hi):
        what = ("λ > 0: the aligned state is unstable" if l_lo > 0 and l_hi > 0 else
                "λ < 0: the aligned state is stable" if l_lo < 0 and l_hi < 0 else
                "λ falls through zero instead of rising")
        raise ParameterError("bracket", (lo, hi),
                             f"a sign change of λ(M) from < 0 to > 0 within M = {m_min:g}…{m_max:g} "
                             f"pN·µm; found none ({what} at every end tried, λ = {l_lo:.3g} and "
                             f"{l_hi:.3g} /s at the last; give --bracket M_lo M_hi)")
    return lo, hi


def critical_torque(params: Params | None = None, boundary: Boundary | None = None,
                    bracket: tuple[float, float] | None = None, xtol: float = 1e-4,
                    hydrodynamics: Hydrodynamics | None = None) -> CriticalTorque:
    """Buckling threshold M_c1: the root of λ(M) in ``bracket`` (paper Sec. 3.1, Sec. 3.2).
    Without ``bracket`` the search starts from :data:`BRACKETS` of the mobility model and
    widens it until λ changes sign (:func:`_sign_change`, within :data:`SEARCH_RANGE`).

    All λ(M) evaluations share one continuation branch, so each Newton solve starts from the
    nearest torque already solved (``hydrodynamics`` as for :func:`relative_equilibrium`).
    Raises :class:`ParameterError` unless λ(M_lo) < 0 < λ(M_hi) for a given ``bracket``, or
    when the automatic search finds no sign change.
    """
    t0 = time.perf_counter()
    automatic = bracket is None
    if automatic:
        bracket = BRACKETS[(hydrodynamics or Hydrodynamics()).model]
    try:
        lo, hi = (check_real("bracket", float(b)) for b in bracket)
    except (TypeError, ValueError):
        raise ParameterError("bracket", bracket, "two torques (M_lo, M_hi)")
    if not (lo < hi and lo * hi > 0):
        raise ParameterError("bracket", tuple(bracket), "M_lo < M_hi, both nonzero and of one sign")
    for m in (lo, hi):
        _check_torque(m)
    xtol = check_range("xtol", xtol, 0.0, 1.0)
    branch = _Branch(params or Params(), boundary or Boundary(), hydrodynamics=hydrodynamics)
    results: dict[float, StabilityResult] = {}

    def lam(M: float) -> float:  # memoized: brentq evaluates the bracket's ends again
        if M not in results:
            results[M] = linear_stability(equilibrium=branch.at(M))
        return results[M].lambda_

    if automatic:  # BRACKETS are positive torques
        lo, hi = _sign_change(lam, lo, hi)
    else:
        l_lo, l_hi = lam(lo), lam(hi)
        if not (l_lo < 0 < l_hi):
            raise ParameterError("bracket", tuple(bracket), "torques with λ(M_lo) < 0 < λ(M_hi) "
                                 f"(here λ = {l_lo:.3g} and {l_hi:.3g} /s)")
    mc = brentq(lam, lo, hi, xtol=xtol)
    r = results[mc] if mc in results else linear_stability(equilibrium=branch.at(mc))
    return CriticalTorque(float(mc), r.thrust, r.omega, r.velocity, r.frequency, r.lab_frequency,
                          len(results), time.perf_counter() - t0, "torque", r.motor_speed)


def critical_speed(params: Params | None = None, boundary: Boundary | None = None,
                   bracket: tuple[float, float] | None = None, xtol: float = 0.1,
                   hydrodynamics: Hydrodynamics | None = None, *,
                   torque_bracket: tuple[float, float] | None = None) -> CriticalTorque:
    """Critical rotation rate ω_c1 of a speed clamp: the motor speed (relative to the body)
    above which the clamped aligned state is unstable, the root of λ_clamp(ω) in
    ``bracket`` [rad/s] (default: the speeds of the torques :data:`BRACKETS`, widened as in
    :func:`critical_torque`), to ``xtol``
    [rad/s]; or ``torque_bracket`` (M_lo, M_hi): the speeds of the torque-driven states
    there.

    The clamped state at ω is the constant-torque state whose speed is ω
    (:func:`_on_drive`); only its linearization differs: the clamp fixes the hook's rate
    about e_z, so a perturbation changes the torque instead. The root is searched in the
    torque M along one continuation branch (ω = s(M) increases through the threshold), so
    the result's ``critical_torque`` is the torque the clamp takes at ω_c1.
    """
    t0 = time.perf_counter()
    branch = _Branch(params or Params(), boundary or Boundary(), hydrodynamics=hydrodynamics)
    xtol = check_range("xtol", xtol, 0.0, 1e4)
    results: dict[float, StabilityResult] = {}

    def lam(M: float) -> float:  # memoized: brentq evaluates the bracket's ends again
        if M not in results:
            eq = branch.at(M)
            eq = replace(eq, motor=Motor(drive="speed", speed=eq.motor_speed))
            results[M] = linear_stability(equilibrium=eq)
        return results[M].lambda_

    if bracket is None:
        lo, hi = torque_bracket or BRACKETS[branch.hydrodynamics.model]
        for m in (lo, hi):
            _check_torque(m)
        if torque_bracket is None:  # widened as for critical_torque
            lo, hi = _sign_change(lam, lo, hi)
        s_lo, s_hi = branch.at(lo).motor_speed, branch.at(hi).motor_speed
    else:
        try:
            s_lo, s_hi = (check_real("bracket", float(b)) for b in bracket)
        except (TypeError, ValueError):
            raise ParameterError("bracket", bracket, "two motor speeds (ω_lo, ω_hi) [rad/s]")
        if not (s_lo < s_hi and s_lo * s_hi > 0):
            raise ParameterError("bracket", tuple(bracket), "ω_lo < ω_hi, both nonzero and of one sign")
        lo, hi = (_on_drive(branch, Motor(drive="speed", speed=w)).torque for w in (s_lo, s_hi))

    l_lo, l_hi = lam(lo), lam(hi)
    if not (l_lo < 0 < l_hi):
        raise ParameterError("bracket", (s_lo, s_hi), "motor speeds with λ(ω_lo) < 0 < λ(ω_hi) "
                             f"(here λ = {l_lo:.3g} and {l_hi:.3g} /s)")
    mc = brentq(lam, lo, hi, xtol=xtol * (hi - lo) / (s_hi - s_lo))
    r = results[mc] if mc in results else (lam(mc), results[mc])[1]
    return CriticalTorque(float(mc), r.thrust, r.omega, r.velocity, r.frequency, r.lab_frequency,
                          len(results), time.perf_counter() - t0, "speed", r.motor_speed)


# -- cross-check by simulation -------------------------------------------------------------
def simulated_growth_rate(equilibrium: RelativeEquilibrium, t_end: float, *,
                          observable: str = "thrust", amplitude: float = 1e-6,
                          fit_from: float = 0.0, seed: int = 0, method: str = "Radau",
                          rtol: float = 1e-8, atol: float = 1e-12, samples: int = 20000) -> GrowthFit:
    """λ the paper's way (Sec. 3.1.2): perturb, simulate, fit |X − X0| ≈ δX0 exp(λt).

    The aligned state is displaced along a random direction of the reduced coordinates
    (norm ``amplitude``) and integrated in the co-rotating frame with scipy's ``method``;
    the log of the local maxima of |X(t) − X0| for t ≥ ``fit_from`` is fitted by a line.
    The perturbation oscillates at ≈ Ω in this frame, and implicit integrators damp it
    numerically: at M = 1 BDF shifts λ by ≈ −0.09 /s (rtol = 1e-9), the 5th-order Radau IIA
    by ≈ −0.005 /s (rtol = 1e-8); for the slow tilt modes use rtol ≈ 1e-10.
    X is the thrust F (``"thrust"``), or the distance of the free end from the motor axis
    (``"tip_radius"``), which — unlike F — changes at first order under the tilt modes
    that lead below M ≈ 0.9. Both are invariant under the rotational zero mode. A cell
    body turns freely in 3D: a tilt of the whole cell is neutral (±iΩ) and changes both, so
    for a cell X is the elastic energy (``"energy"``), invariant under every rigid motion;
    its body spin σ is integrated along (the field f − σ S, which keeps φ bounded; the spin
    is a symmetry).
    """
    from scipy.integrate import solve_ivp
    from scipy.sparse import diags

    if observable not in ("thrust", "tip_radius", "energy"):
        raise ParameterError("observable", observable, "'thrust', 'tip_radius' or 'energy'")
    m = equilibrium.model()
    if m.cell and observable != "energy":
        raise ParameterError("observable", observable, "'energy' for a cell body (a tilt of "
                             "the whole cell changes the thrust and the tip radius)")

    def measure(y):
        if observable == "thrust":
            return m.bead_force(0.0, y)[2]
        if observable == "energy":  # as the rhs has it: with a cell's hook term k(1 + t0·m)
            m.rhs(0.0, y)
            return m.last_energy
        return math.hypot(y[3 + 4 * m.n], y[4 + 4 * m.n])

    red = _Reduced(m, equilibrium.state, equilibrium.spin)

    def fun(t, y):
        f = m.rhs(t, y)
        if m.cell:
            f[-3:] -= equilibrium.spin * np.array(rotvec_rate(*y[-3:], *_Reduced.motor_axis(y)))
        return f

    xi = np.random.default_rng(seed).normal(size=red.size)
    y0 = red.embed(amplitude * xi / np.linalg.norm(xi))
    n, (kl, ku) = len(y0), m.jacobian_band
    # the unfrozen nonlocal mobility couples every bead: a dense Jacobian
    sparsity = diags([np.ones(n - abs(k)) for k in range(-kl, ku + 1)], list(range(-kl, ku + 1))) \
        if m.hydrodynamics.is_local and not m.cell else None
    t = np.linspace(0.0, t_end, samples)
    sol = solve_ivp(fun, (0.0, t_end), y0, method=method, t_eval=t, rtol=rtol, atol=atol,
                    jac_sparsity=sparsity)
    if not sol.success:
        raise SimulationError(f"integration failed: {sol.message}")
    dev = np.array([measure(y) for y in sol.y.T]) - measure(equilibrium.state)
    a = np.abs(dev)
    k = np.nonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:]) & (t[1:-1] >= fit_from))[0] + 1
    if len(k) < 3:
        raise SimulationError(f"too few maxima of |X − X0| after t = {fit_from:g} s to fit a rate")
    rate = np.polyfit(t[k], np.log(a[k]), 1)[0]
    return GrowthFit(float(rate), t, dev, t[k], a[k])


__all__ = ["BRACKETS", "SEARCH_RANGE", "WIDEN", "DRIFT", "RelativeEquilibrium", "StabilityResult", "CriticalTorque",
           "GrowthFit", "relative_equilibrium", "linear_stability", "critical_torque",
           "critical_speed", "stability_curve", "steady_drive", "simulated_growth_rate"]
