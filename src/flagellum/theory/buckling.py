"""Linear buckling theory of a helical rod (paper Sec. 4.1, Eqs. (29)–(30)).

The rod of length L0 lies along z; its small deflection (X, Y) obeys Eq. (29) ::

    0 = −Y'''' + (m̂(1−z) X'')' − f̂∥(1−z) Y'' − f̂⊥ Y' + χ̂ X,
    0 =  X'''' + (m̂(1−z) Y'')' + f̂∥(1−z) X'' + f̂⊥ X' + χ̂ Y.

Rotation about z is a symmetry, so with the complex deflection V = X − iY both equations are
one complex fourth-order ODE, the rod equation (the second plus i times the first) ::

    V'''' + i (M(z) V'')' + N(z) V'' + f̂⊥ V' + i χ̂ V = 0,

with the axial torque M(z) = m̂(1−z) and compressive force N(z) = f̂∥(1−z) of the paper
(``torque_profile`` / ``force_profile`` = "linear"), or constant M = m̂, N = f̂∥ for loads
applied at the ends ("uniform": Greenhill's and Euler's problems). The boundary conditions
of Eq. (30) generalise to

* base z = 0: V = 0 and "hinged" V'' + iM V' = 0 (no bending moment, the torque stays along
  z) or "clamped" V' = 0;
* top z = 1: "free" V'' + iM V' = 0 and V''' + iM V'' + N V' = 0 (no moment, no transverse
  force); "hinged" V = 0, V'' + iM V' = 0; "clamped" V = V' = 0.

For the paper's problem M(1) = N(1) = 0, so the free end reads V'' = V''' = 0.

**Shooting.** The base conditions leave a two-dimensional space of solutions; integrating its
two basis solutions to z = 1 and imposing the two top conditions gives a complex 2×2 matrix S
whose determinant D = det S vanishes exactly when a non-trivial solution exists. Re D = Im D
= 0 are two real equations for two real unknowns (the paper's f̂⊥ and χ̂), solved by Newton's
method with the exact Jacobian from the parameter sensitivities. The ODE has coefficients
linear in z, so each step is a Taylor series to machine precision (recurrence below).

**Collocation** (independent check and global search). A Chebyshev collocation of the rod
equation is an affine matrix pencil in every parameter, K(p) = K₀ + Σ pₖ Kₖ, so for fixed
other parameters the critical values of one parameter are generalised eigenvalues. With χ̂
as eigenvalue the neutral modes are the real eigenvalues; an eigenvalue with Im χ̂ < 0 is an
unstable mode of the straight rod (its deflection grows as exp(−Im χ̂ · t), t in units of
a⊥L0⁴/A_eff), which locates the first instability along any scan.

**Trivial solution.** With a hinged base, free top, m̂ = 0 and f̂⊥ = χ̂ = 0 the rigid tilt
V = c z solves the problem for every f̂∥ (the torque-free rod can pivot freely about its
hinge). For m̂ ≠ 0 it does not: the base condition V'' = −i m̂ V' forbids it. This solution is
detected and excluded (:class:`TrivialSolutionError`, and skipped by :func:`find_critical`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np
import scipy.linalg
from numba import njit
from scipy.optimize import brentq

from .. import _jit  # noqa: F401  (the package's Numba cache, before the first cache=True kernel)
from ..errors import FlagellumError, ParameterError
from ..params import check_choice, check_real

NAMES = ("m_hat", "f_par", "f_perp", "chi")
LOAD_LIMIT = 1e6  #: largest |value| of a given dimensionless load: beyond, the shooting matrices overflow
BASES = ("hinged", "clamped")
TOPS = ("free", "hinged", "clamped")
PROFILES = ("linear", "uniform")

#: Default scan ranges (start, stop) of the global search, per unknown.
DEFAULT_SCAN = {"f_perp": (2000.0, -2000.0), "f_par": (0.0, 2000.0), "m_hat": (0.0, 80.0)}


class TrivialSolutionError(FlagellumError, ArithmeticError):
    """The solver found the rigid tilt V = c z (hinged base, m̂ = f̂⊥ = χ̂ = 0), not buckling."""


class NoConvergenceError(FlagellumError, ArithmeticError):
    """Newton's method or the global scan found no critical point."""


@dataclass(frozen=True)
class BucklingProblem:
    """Parameters and boundary conditions of the rod equation (Eq. (29) for V = X − iY); all
    loads dimensionless (hats).

    ``m_hat`` = m L0²/A_eff, ``f_par`` = f∥ L0³/A_eff, ``f_perp`` = f⊥ L0³/A_eff and
    ``chi`` = χ a⊥ L0⁴/A_eff (paper Sec. 4.1). With a "uniform" profile ``m_hat`` = M L0/A and
    ``f_par`` = F L0²/A are the end torque and end force.
    """

    m_hat: float = 0.0
    f_par: float = 0.0
    f_perp: float = 0.0
    chi: float = 0.0
    base: str = "hinged"
    top: str = "free"
    force_profile: str = "linear"
    torque_profile: str = "linear"

    def __post_init__(self):
        for name in NAMES:
            object.__setattr__(self, name, check_real(name, getattr(self, name)))
        check_choice("base", self.base, BASES)
        check_choice("top", self.top, TOPS)
        check_choice("force_profile", self.force_profile, PROFILES)
        check_choice("torque_profile", self.torque_profile, PROFILES)

    @property
    def values(self) -> np.ndarray:
        """(m̂, f̂∥, f̂⊥, χ̂) as an array."""
        return np.array([self.m_hat, self.f_par, self.f_perp, self.chi])

    def with_values(self, values) -> "BucklingProblem":
        return replace(self, **dict(zip(NAMES, map(float, values))))

    @property
    def _flags(self) -> np.ndarray:
        return np.array([self.force_profile == "linear", self.torque_profile == "linear"],
                        dtype=np.int64)

    def profiles(self, z):
        """Axial torque M(z), its slope, compressive force N(z) and its slope (unit loads)."""
        lin_f, lin_m = self._flags
        return ((1 - z) if lin_m else 1.0, -1.0 if lin_m else 0.0,
                (1 - z) if lin_f else 1.0, -1.0 if lin_f else 0.0)

    def rigid_tilt_solves(self, tol: float = 0.0) -> bool:
        """True if V = z solves the problem (the trivial solution), within ``tol``."""
        n1 = self.f_par * self.profiles(1.0)[2]
        return (self.base == "hinged" and self.top == "free" and abs(self.m_hat) <= tol
                and abs(self.f_perp) <= tol and abs(self.chi) <= tol and abs(n1) <= tol)

    def scale(self) -> float:
        """Largest wavenumber of the rod equation: sets step size and collocation resolution."""
        return (1.0 + abs(self.chi) ** 0.25 + abs(self.f_perp) ** (1 / 3)
                + math.sqrt(abs(self.f_par)) + abs(self.m_hat))


# --------------------------------------------------------------------------------------------
# Shooting: Taylor-series propagation of the fundamental solutions and their sensitivities
# --------------------------------------------------------------------------------------------

@njit(cache=True)
def _coefficients(z, p, flags):
    """Last row r(z) of the companion matrix of the rod equation, its z-slope s, and both per
    parameter.

    V'''' = r·(V, V', V'', V''') with r = (−iχ, −f⊥, −i m M' − f∥ N, −i m M).
    """
    m, fpar, fperp, chi = p[0], p[1], p[2], p[3]
    mu, dmu = (1.0 - z, -1.0) if flags[1] else (1.0, 0.0)
    n, dn = (1.0 - z, -1.0) if flags[0] else (1.0, 0.0)
    r = np.array([-1j * chi, -fperp + 0j, -1j * m * dmu - fpar * n, -1j * m * mu])
    s = np.array([0j, 0j, -fpar * dn + 0j, -1j * m * dmu])
    dr = np.zeros((4, 4), np.complex128)
    ds = np.zeros((4, 4), np.complex128)
    dr[0, 2], dr[0, 3], ds[0, 3] = -1j * dmu, -1j * mu, -1j * dmu   # m̂
    dr[1, 2], ds[1, 2] = -n, -dn                                     # f̂∥
    dr[2, 1] = -1.0                                                  # f̂⊥
    dr[3, 0] = -1j                                                   # χ̂
    return r, s, dr, ds


@njit(cache=True)
def _propagate(Y, dY, p, flags, z0, z1, hmax, sens):
    """Advance solutions Y (4, ncol) and sensitivities dY (len(sens), 4, ncol) from z0 to z1.

    ``sens``: indices of the parameters (m̂, f̂∥, f̂⊥, χ̂) whose sensitivities are carried.

    Taylor series about each step start: with scaled coefficients e_k = c_k h^k and
    A(z0 + t) = A₀ + t A₁ (only the last row is non-trivial),
    e_{k+1} = (h A₀ e_k + h² A₁ e_{k−1})/(k + 1).
    """
    nsteps = max(1, int(math.ceil(abs(z1 - z0) / hmax)))
    h = (z1 - z0) / nsteps
    npar = len(sens)
    e = np.empty(4, np.complex128)
    ep = np.empty(4, np.complex128)
    en = np.empty(4, np.complex128)
    de = np.empty((4, 4), np.complex128)
    dep = np.empty((4, 4), np.complex128)
    den = np.empty((4, 4), np.complex128)
    for step in range(nsteps):
        r, s, dr, ds = _coefficients(z0 + step * h, p, flags)
        for col in range(Y.shape[1]):
            for i in range(4):
                e[i] = Y[i, col]
                ep[i] = 0.0
                for q in range(npar):
                    de[q, i] = dY[q, i, col]
                    dep[q, i] = 0.0
            small = 0
            for k in range(400):
                f = h / (k + 1)
                en[0], en[1], en[2] = f * e[1], f * e[2], f * e[3]
                en[3] = f * (r[0] * e[0] + r[1] * e[1] + r[2] * e[2] + r[3] * e[3]
                             + h * (s[2] * ep[2] + s[3] * ep[3]))
                size, norm = 0.0, 0.0
                for i in range(4):
                    Y[i, col] += en[i]
                    size = max(size, abs(en[i]))
                    norm = max(norm, abs(Y[i, col]))
                dsize, dnorm = 0.0, norm
                for q in range(npar):
                    den[q, 0], den[q, 1], den[q, 2] = f * de[q, 1], f * de[q, 2], f * de[q, 3]
                    acc = 0j
                    for l in range(4):
                        acc += (r[l] * de[q, l] + dr[sens[q], l] * e[l]
                                + h * (s[l] * dep[q, l] + ds[sens[q], l] * ep[l]))
                    den[q, 3] = f * acc
                    for i in range(4):
                        dY[q, i, col] += den[q, i]
                        dsize = max(dsize, abs(den[q, i]))
                        dnorm = max(dnorm, abs(dY[q, i, col]))
                for i in range(4):
                    ep[i] = e[i]
                    e[i] = en[i]
                    for q in range(npar):
                        dep[q, i] = de[q, i]
                        de[q, i] = den[q, i]
                if size <= 1e-18 * norm and dsize <= 1e-18 * dnorm:
                    small += 1
                    if small >= 2:
                        break
                else:
                    small = 0


def _step_bound(problem: BucklingProblem) -> float:
    return min(0.25, 1.5 / problem.scale())


def _base_solutions(problem: BucklingProblem, sens=()):
    """Basis (4, 2) of the solutions allowed by the base conditions, and d/d(params in sens)."""
    Y = np.zeros((4, 2), complex)
    dY = np.zeros((len(sens), 4, 2), complex)
    Y[3, 1] = 1.0
    if problem.base == "hinged":
        mu0 = problem.profiles(0.0)[0]
        Y[1, 0], Y[2, 0] = 1.0, -1j * problem.m_hat * mu0   # V'' = −iM(0) V'
        if 0 in sens:
            dY[list(sens).index(0), 2, 0] = -1j * mu0
    else:
        Y[2, 0] = 1.0                                         # V' = 0
    return Y, dY


def _top_rows(problem: BucklingProblem):
    """Top boundary functionals T (2, 4) acting on (V, V', V'', V''') and dT/d(params)."""
    mu1, _, n1, _ = problem.profiles(1.0)
    M1, N1 = problem.m_hat * mu1, problem.f_par * n1
    T = np.zeros((2, 4), complex)
    dT = np.zeros((4, 2, 4), complex)
    if problem.top == "free":
        T[0] = [0, 1j * M1, 1, 0]
        T[1] = [0, N1, 1j * M1, 1]
        dT[0, 0, 1] = dT[0, 1, 2] = 1j * mu1
        dT[1, 1, 1] = n1
    elif problem.top == "hinged":
        T[0] = [1, 0, 0, 0]
        T[1] = [0, 1j * M1, 1, 0]
        dT[0, 1, 1] = 1j * mu1
    else:
        T[0] = [1, 0, 0, 0]
        T[1] = [0, 1, 0, 0]
    return T, dT


def shooting_matrix(problem: BucklingProblem, sens=()):
    """S = T·Y(1) (2×2) of the two base solutions, and dS/dp (len(sens), 2, 2) for the
    parameters p with indices ``sens`` into (m̂, f̂∥, f̂⊥, χ̂)."""
    sens = np.asarray(sens, dtype=np.int64)
    Y, dY = _base_solutions(problem, tuple(sens))
    _propagate(Y, dY, problem.values, problem._flags, 0.0, 1.0, _step_bound(problem), sens)
    T, dT = _top_rows(problem)
    S = T @ Y
    dS = np.einsum("qij,jc->qic", dT[sens], Y) + np.einsum("ij,qjc->qic", T, dY)
    return S, dS


def characteristic(problem: BucklingProblem, with_gradient: bool = False, sens=(0, 1, 2, 3)):
    """Characteristic function D = det S of the shooting method (zero ⇔ buckling).

    Returns D, or (D, ∂D/∂(m̂, f̂∥, f̂⊥, χ̂), scale) with ``scale`` = |S₀|·|S₁| (product of
    the row norms, Hadamard's bound) so that |D|/scale ∈ [0, 1] is a relative residual.
    Only the derivatives with indices in ``sens`` are computed (the others are 0).
    """
    S, dS = shooting_matrix(problem, sens if with_gradient else ())
    D = S[0, 0] * S[1, 1] - S[0, 1] * S[1, 0]
    if not with_gradient:
        return D
    grad = np.zeros(4, complex)
    grad[list(sens)] = (S[0, 0] * dS[:, 1, 1] + dS[:, 0, 0] * S[1, 1]
                        - S[0, 1] * dS[:, 1, 0] - dS[:, 0, 1] * S[1, 0])
    return D, grad, float(np.prod(np.linalg.norm(S, axis=1)))   # Hadamard: |D| ≤ scale


# --------------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Mode:
    """Critical mode sampled on z ∈ [0, 1], normalised to max|X + iY| = 1."""

    z: np.ndarray
    X: np.ndarray
    Y: np.ndarray

    def as_dict(self) -> dict:
        return {"z": self.z.tolist(), "X": self.X.tolist(), "Y": self.Y.tolist()}


@dataclass(frozen=True)
class CriticalPoint:
    """A critical parameter set (non-trivial solution of the rod equation) and how it was found."""

    problem: BucklingProblem
    unknowns: tuple
    method: str
    residual: float  #: |D|/scale (shooting) or |Im χ̂|-type residual (collocation)
    iterations: int
    extra: dict = field(default_factory=dict, compare=False)

    def __getattr__(self, name):  # m_hat, f_par, f_perp, chi straight from the problem
        if name in NAMES:
            return getattr(self.problem, name)
        raise AttributeError(name)

    def as_dict(self) -> dict:
        return {**{n: getattr(self.problem, n) for n in NAMES}, "base": self.problem.base,
                "top": self.problem.top, "force_profile": self.problem.force_profile,
                "torque_profile": self.problem.torque_profile, "unknowns": list(self.unknowns),
                "method": self.method, "residual": self.residual, "iterations": self.iterations}

    def mode(self, n: int = 101) -> Mode:
        return critical_mode(self.problem, n)


def critical_mode(problem: BucklingProblem, n: int = 101) -> Mode:
    """Null vector of S propagated to n points: the buckling mode X(z), Y(z)."""
    S, _ = shooting_matrix(problem)
    row = S[0] if np.abs(S[0]).sum() >= np.abs(S[1]).sum() else S[1]
    coef = np.array([row[1], -row[0]])
    z = np.linspace(0.0, 1.0, n)
    Y0, _ = _base_solutions(problem)
    Y = Y0 @ coef[:, None]
    dummy = np.zeros((0, 4, 1), complex)
    none = np.zeros(0, dtype=np.int64)
    V = np.empty(n, complex)
    V[0] = Y[0, 0]
    hmax = _step_bound(problem)
    for i in range(1, n):
        _propagate(Y, dummy, problem.values, problem._flags, z[i - 1], z[i], hmax, none)
        V[i] = Y[0, 0]
    V = V / V[np.argmax(np.abs(V))]   # real and positive where |V| is largest
    return Mode(z, V.real.copy(), -V.imag.copy())   # V = X − iY


# --------------------------------------------------------------------------------------------
# Newton's method on the shooting determinant
# --------------------------------------------------------------------------------------------

def _check_unknowns(unknowns) -> tuple:
    if isinstance(unknowns, str):
        unknowns = tuple(u.strip() for u in unknowns.split(",") if u.strip())
    unknowns = tuple(unknowns)
    if not 1 <= len(unknowns) <= 2 or len(set(unknowns)) != len(unknowns) \
            or any(u not in NAMES for u in unknowns):
        raise ParameterError("unknowns", ",".join(map(str, unknowns)),
                             "one or two distinct names among " + ", ".join(NAMES))
    return unknowns


def _is_real_problem(problem: BucklingProblem, unknowns) -> bool:
    """D is real when neither torque nor precession enters (m̂ = χ̂ = 0, both given)."""
    return "m_hat" not in unknowns and "chi" not in unknowns \
        and problem.m_hat == 0 and problem.chi == 0


def newton(param_map, u0, problem: BucklingProblem, *, tol: float = 1e-11, maxiter: int = 60):
    """Solve Re D = Im D = 0 (or Re D = 0 for one unknown) by damped Newton iteration.

    ``param_map(u)`` returns the parameter vector p (4,) and dp/du (4, k) for the k unknowns
    u. Returns (u, p, relative residual, iterations).
    """
    u = np.array(u0, float)
    k = len(u)

    def evaluate(u):
        p, J = param_map(u)
        with np.errstate(all="ignore"):
            D, g, sc = characteristic(problem.with_values(p), True, np.flatnonzero(np.any(J, axis=1)))
        dDu = g @ J
        F = np.array([D.real, D.imag])[:k]
        Jr = np.vstack([dDu.real, dDu.imag])[:k]
        return F, Jr, abs(D) / sc if sc > 0 else abs(D), p

    F, Jr, res, p = evaluate(u)
    for it in range(1, maxiter + 1):
        try:
            du = np.linalg.solve(Jr, -F)
        except np.linalg.LinAlgError:
            du = np.linalg.lstsq(Jr, -F, rcond=None)[0]
        if not np.all(np.isfinite(du)):
            break
        small = np.all(np.abs(du) <= tol * (1 + np.abs(u)))
        lam = min(1.0, float(np.min((np.abs(u) + 10.0) / (np.abs(du) + 1e-300))))  # trust region
        for _ in range(30):   # backtrack until |D| decreases (or the step is at roundoff)
            Fn, Jn, resn, pn = evaluate(u + lam * du)
            if np.all(np.isfinite(Fn)) and (small or np.linalg.norm(Fn) < np.linalg.norm(F)):
                break
            lam /= 2
        else:
            if res < 1e-12:   # converged to roundoff: no step can reduce |D| further
                return u, p, res, it
            break
        u = u + lam * du
        F, Jr, res, p = Fn, Jn, resn, pn
        if small or res < 1e-15:
            return u, p, res, it
    raise NoConvergenceError(f"Newton's method did not converge from {list(u0)} "
                             f"(residual {res:.2e} after {it} iterations)")


def _named_map(problem: BucklingProblem, unknowns):
    idx = [NAMES.index(n) for n in unknowns]
    base = problem.values
    E = np.eye(4)[:, idx]

    def param_map(u):
        p = base.copy()
        p[idx] = u
        return p, E
    return param_map


def solve(problem: BucklingProblem, unknowns=("f_perp", "chi"), guess=None, *,
          method: str = "shooting", collocation_n: int | None = None) -> CriticalPoint:
    """Critical values of one or two ``unknowns`` among (m̂, f̂∥, f̂⊥, χ̂) of Eq. (29).

    ``method="shooting"``: Newton's method on D = det S from ``guess`` (values of the
    unknowns); without a guess the global search of :func:`find_critical` is used.
    ``method="collocation"``: the Chebyshev-collocation eigenvalue formulation, refined from
    ``guess`` (or from the shooting result). One unknown is allowed only when the problem is
    real (m̂ = χ̂ = 0), otherwise Re D = Im D = 0 needs two.

    Raises :class:`TrivialSolutionError` for the rigid tilt of a torque-free hinged rod.
    """
    unknowns = _check_unknowns(unknowns)
    check_choice("method", method, ("shooting", "collocation"))
    if len(unknowns) == 1 and not _is_real_problem(problem, unknowns):
        raise ParameterError("unknowns", unknowns[0],
                             "two names (Re D = Im D = 0) unless m_hat = chi = 0 are given")
    if guess is None:
        if "chi" not in unknowns:
            raise ParameterError("guess", None, "given when 'chi' is not among the unknowns")
        found = find_critical(problem, unknowns)
        if method == "shooting":
            return found
        guess = [getattr(found, n) for n in unknowns]
    guess = [check_real("guess", g) for g in np.atleast_1d(guess)]
    if len(guess) != len(unknowns):
        raise ParameterError("guess", guess, f"{len(unknowns)} value(s), one per unknown")
    if method == "collocation":
        return solve_collocation(problem, unknowns, guess, n=collocation_n)
    u, p, res, it = newton(_named_map(problem, unknowns), guess, problem)
    solved = problem.with_values(p)
    _reject_trivial(solved)
    return CriticalPoint(solved, unknowns, "shooting", float(res), it)


def _reject_trivial(problem: BucklingProblem) -> None:
    if problem.rigid_tilt_solves(tol=1e-6 * problem.scale()):
        raise TrivialSolutionError("the solution is the rigid tilt X = c z of the torque-free "
                                   "hinged rod (f_perp = chi = 0), not a buckling mode")


# --------------------------------------------------------------------------------------------
# Chebyshev collocation: pencil K(p) = K0 + Σ p_k K_k
# --------------------------------------------------------------------------------------------

@lru_cache(maxsize=32)
def _chebyshev(n: int):
    """Nodes z ∈ [0, 1] (z[0] = 0) and derivative matrices D1..D4 (Trefethen's cheb)."""
    x = np.cos(np.pi * np.arange(n + 1) / n)
    c = np.hstack([2.0, np.ones(n - 1), 2.0]) * (-1.0) ** np.arange(n + 1)
    dx = x[:, None] - x[None, :]
    D = np.outer(c, 1 / c) / (dx + np.eye(n + 1))
    D -= np.diag(D.sum(axis=1))
    D1 = -2.0 * D   # z = (1 − x)/2
    D2 = D1 @ D1
    D3 = D2 @ D1
    return (1 - x) / 2, D1, D2, D3, D2 @ D2


def collocation_pencil(problem: BucklingProblem, n: int):
    """Matrices (K0, [K_m, K_fpar, K_fperp, K_chi]) of the collocated Eq. (29) with
    its boundary conditions.

    Rows 0, 1 (z = 0) and n−1, n (z = 1) are replaced by the boundary conditions. The
    matrices depend only on the boundary conditions and profiles (cached; do not modify).
    """
    return _pencil(replace(problem, m_hat=0.0, f_par=0.0, f_perp=0.0, chi=0.0), n)


@lru_cache(maxsize=64)
def _pencil(problem: BucklingProblem, n: int):
    z, D1, D2, D3, D4 = _chebyshev(n)
    mu, dmu, nn, _ = problem.profiles(z)
    mu, nn = np.broadcast_to(mu, z.shape), np.broadcast_to(nn, z.shape)
    I = np.eye(n + 1)
    K0 = D4.astype(complex)   # a copy
    Ks = [1j * (dmu * D2 + mu[:, None] * D3), nn[:, None] * D2 + 0j, D1 + 0j, 1j * I]
    bc = {0: {}, 1: {}, n - 1: {}, n: {}}   # row -> {param index or None: row vector}
    mu0, mu1, n1 = mu[0], mu[-1], nn[-1]
    bc[0][None] = I[0]
    if problem.base == "hinged":
        bc[1][None], bc[1][0] = D2[0], 1j * mu0 * D1[0]
    else:
        bc[1][None] = D1[0]
    if problem.top == "free":
        bc[n - 1][None], bc[n - 1][0] = D2[n], 1j * mu1 * D1[n]
        bc[n][None], bc[n][0], bc[n][1] = D3[n], 1j * mu1 * D2[n], n1 * D1[n]
    elif problem.top == "hinged":
        bc[n - 1][None] = I[n]
        bc[n][None], bc[n][0] = D2[n], 1j * mu1 * D1[n]
    else:
        bc[n - 1][None], bc[n][None] = I[n], D1[n]
    for row, parts in bc.items():
        K0[row] = parts[None]
        for q in range(4):
            Ks[q][row] = parts.get(q, 0.0)
    return K0, Ks


def _resolution(problem: BucklingProblem) -> int:
    """Collocation order: resolves the modes, yet keeps the roundoff of D⁴ (∝ n⁸) small."""
    return int(min(48, max(28, 20 + 0.6 * problem.scale())))


def pencil_eigenvalues(problem: BucklingProblem, which: str = "chi", n: int | None = None,
                       vectors: bool = False):
    """Critical values of parameter ``which`` with the others fixed: eigenvalues of the pencil.

    Returns the finite, resolved eigenvalues (complex; real ones are critical), and with
    ``vectors`` also the nodal eigenvectors and nodes.
    """
    n = n or _resolution(problem)
    K0, Ks = collocation_pencil(problem, n)
    q = NAMES.index(which)
    p = problem.values
    A = K0 + sum(p[k] * Ks[k] for k in range(4) if k != q)
    if which == "chi" and not vectors:
        # K_chi = i·I on the interior rows: eliminate the 4 boundary values and solve the
        # standard eigenproblem (A_ii − A_ib A_bb⁻¹ A_bi) v = −iχ v of the interior.
        b = [0, 1, n - 1, n]
        i = slice(2, n - 1)
        schur = A[i, i] - A[i][:, b] @ np.linalg.solve(A[b][:, b], A[b][:, i])
        lam = 1j * np.linalg.eigvals(schur)
        return lam[np.abs(lam) < (math.pi * n / 4) ** 4]   # drop unresolved high modes
    out = scipy.linalg.eig(A, -Ks[q], right=vectors)
    lam, vec = (out if vectors else (out, None))
    ok = np.isfinite(lam)
    if which == "chi":
        ok &= np.abs(lam) < (math.pi * n / 4) ** 4
    if vectors:
        return lam[ok], vec[:, ok], _chebyshev(n)[0]
    return lam[ok]


def spectrum(problem: BucklingProblem, n: int | None = None) -> np.ndarray:
    """Relaxation rates μ of the straight rod: V ∝ exp(−μ t) (μ = −iχ̂), sorted by Re μ.

    Re μ < 0 is an unstable mode; Re μ = 0 a critical one with χ̂ = −Im μ. The exact zero
    rate of the rigid tilt (when it solves the problem) is removed.
    """
    lam = pencil_eigenvalues(replace(problem, chi=0.0), "chi", n)
    mu = -1j * lam
    if replace(problem, chi=0.0).rigid_tilt_solves():
        mu = np.delete(mu, np.argmin(np.abs(mu)))
    return mu[np.argsort(mu.real)]


def solve_collocation(problem: BucklingProblem, unknowns, guess, *, n: int | None = None,
                      tol: float = 1e-13, maxiter: int = 30) -> CriticalPoint:
    """Second, independent method: eigenvalue of the collocation pencil + 1-D secant search.

    One unknown (real problem): its eigenvalue nearest the guess. Two unknowns: the one named
    ``chi`` (else the second) is the eigenvalue; the other is varied until that eigenvalue is
    real.
    """
    unknowns = _check_unknowns(unknowns)
    values = dict(zip(unknowns, map(float, guess)))
    eig_name = "chi" if "chi" in unknowns else unknowns[-1]
    other = [u for u in unknowns if u != eig_name]
    target = values[eig_name]

    def nearest(t):
        prob = problem.with_values([values.get(nm, getattr(problem, nm)) for nm in NAMES])
        if other:
            prob = replace(prob, **{other[0]: t})
        lam = pencil_eigenvalues(prob, eig_name, n)
        return lam[np.argmin(np.abs(lam - target))], prob

    if not other:
        lam, prob = nearest(None)
        it, res, solved = 1, abs(lam.imag) / (1 + abs(lam)), replace(prob, **{eig_name: lam.real})
    else:   # secant on Im λ(t) = 0, tracking the eigenvalue; stops at the roundoff floor
        t0 = values[other[0]]
        t1 = t0 + 1e-6 * (1 + abs(t0))
        lam0 = nearest(t0)[0]
        best = (abs(lam0.imag) / (1 + abs(lam0)), t0)
        for it in range(1, maxiter + 1):
            lam1 = nearest(t1)[0]
            target = lam1.real
            best = min(best, (abs(lam1.imag) / (1 + abs(lam1)), t1))
            if lam1.imag == lam0.imag or abs(t1 - t0) <= tol * (1 + abs(t1)):
                break
            t0, t1, lam0 = t1, t1 - lam1.imag * (t1 - t0) / (lam1.imag - lam0.imag), lam1
        res, t = best
        if not res < 1e-6:
            raise NoConvergenceError(f"collocation search did not converge from {list(guess)}")
        lam, prob = nearest(t)
        solved = replace(prob, **{eig_name: lam.real})
    _reject_trivial(solved)
    return CriticalPoint(solved, unknowns, "collocation", float(res), it,
                         {"collocation_n": n or _resolution(solved)})


# --------------------------------------------------------------------------------------------
# Global search: first instability along a scan
# --------------------------------------------------------------------------------------------

def _ladder(start: float, stop: float) -> np.ndarray:
    """Scan points from start to stop: geometric in |t| (ratio ≈ 1.15) about 0, plus 41 even."""
    lo, hi = sorted((start, stop))
    top = max(abs(lo), abs(hi), 1.0)
    mags = np.concatenate([[0.0], np.geomspace(0.25, top, int(np.log(4 * top) / np.log(1.15)) + 2)])
    pts = np.unique(np.concatenate([[lo, hi], mags, -mags, np.linspace(lo, hi, 41)]))
    pts = pts[(pts >= lo) & (pts <= hi)]
    return pts if start <= stop else pts[::-1]


def _chi_eigenvalues(prob: BucklingProblem):
    """Sorted Im χ̂ (negative = unstable mode) and the χ̂-eigenvalues, trivial tilt removed."""
    lam = pencil_eigenvalues(prob, "chi")
    if replace(prob, chi=0.0).rigid_tilt_solves():
        lam = np.delete(lam, np.argmin(np.abs(lam)))
    return np.sort(lam.imag), lam


def is_tilt_mode(prob: BucklingProblem) -> bool:
    """Heuristic: a precessing, nearly rigid tilt rather than a buckling mode.

    The rigid tilt of the hinged rod turns, for m̂ ≠ 0, into a slowly precessing mode with
    χ̂ ≈ 3m̂ (exactly 3m̂ for f̂∥ → 0, small m̂); buckling modes precess an order of
    magnitude faster. Over the manifold of Fig. 7 the ratio |χ̂/m̂| has a gap between
    17 and 27, so modes with |χ̂| < 20|m̂| count as tilt modes.
    """
    return prob.base == "hinged" and abs(prob.chi) < 20 * abs(prob.m_hat)


def unstable_count(prob: BucklingProblem) -> int:
    """Number of unstable modes of the straight rod (Im χ̂ < 0; rigid tilt excluded)."""
    return int(np.sum(_chi_eigenvalues(prob)[0] < 0))


def line_path(problem: BucklingProblem, name: str):
    """Path t ↦ problem with parameter ``name`` = t (for :func:`scan_path`)."""
    q = NAMES.index(name)
    dp = np.eye(4)[q]

    def path(t):
        p = problem.values
        p[q] = t
        return p, dp
    return path


def find_critical(problem: BucklingProblem, unknowns=("f_perp", "chi"), *,
                  scan=None) -> CriticalPoint:
    """First instability of the straight rod while one unknown is scanned; χ̂ follows.

    The unknown other than ``chi`` runs from ``scan[0]`` to ``scan[1]`` (default
    :data:`DEFAULT_SCAN`: f̂⊥ downwards from +2000, f̂∥ and m̂ upwards from 0); see
    :func:`scan_path`.
    """
    unknowns = _check_unknowns(unknowns)
    if "chi" not in unknowns or len(unknowns) != 2:
        raise ParameterError("unknowns", ",".join(unknowns), "'chi' and one other name")
    name = [u for u in unknowns if u != "chi"][0]
    start, stop = scan if scan is not None else DEFAULT_SCAN[name]
    cp = scan_path(problem, line_path(problem, name), check_real("scan start", start),
                   check_real("scan stop", stop))
    return replace(cp, unknowns=unknowns)


def scan_path(problem: BucklingProblem, path, start: float, stop: float, *,
              skip=None) -> CriticalPoint:
    """First point along ``path`` (t from start to stop) where one more mode turns unstable.

    ``path(t)`` returns the parameters (4,) (χ̂ ignored: it is the eigenvalue) and their
    t-derivative. At each scan point the collocation pencil gives all modes; the first
    interval where the number of unstable modes (Im χ̂ < 0) grows is bracketed, the
    crossing located by Brent's method on the next-to-turn eigenvalue, the rigid tilt
    skipped (and any crossing for which ``skip(problem)`` is true, e.g.
    :func:`is_tilt_mode`), and the result polished by Newton's method on the shooting
    determinant.
    """
    at = lambda t: problem.with_values(path(t)[0])
    pts = _ladder(start, stop)
    prev_t, nu_prev = pts[0], unstable_count(at(pts[0]))
    for t in pts[1:]:
        nu = unstable_count(at(t))
        if nu > nu_prev:
            found = _locate(at, prev_t, t, nu_prev, depth=0)
            if found is not None and not (skip and skip(found[1])):
                cp = _polish(problem, path, *found)
                if not (skip and skip(cp.problem)):
                    return cp
        prev_t, nu_prev = t, nu
    raise NoConvergenceError(f"no instability of the straight rod from t = {start:g} to "
                             f"{stop:g} ({problem.base} base, {problem.top} top)")


def is_onset(problem: BucklingProblem, path, t: float, direction: float = 1.0):
    """True if exactly one more mode is unstable just after t than just before (along t)."""
    d = direction * 1e-5 * (1 + abs(t))
    at = lambda x: problem.with_values(path(x)[0])
    before = unstable_count(at(t - d))
    return unstable_count(at(t + d)) == before + 1, before


def _locate(at, a, b, k, depth):
    """Crossing of the (k+1)-th smallest Im χ̂ between a and b (bisecting multiple ones)."""
    def g(t):
        im = _chi_eigenvalues(at(t))[0]
        return im[k] if len(im) > k else 1.0

    tilt_at_a = at(a).rigid_tilt_solves()
    if tilt_at_a and g(a + 1e-3 * (b - a)) < 0:
        return None   # the rigid tilt itself turns unstable at a: trivial crossing
    if not g(a) >= 0 > g(b):   # several crossings in [a, b]: bisect
        if depth > 12:
            return None
        mid = (a + b) / 2
        nmid = unstable_count(at(mid))
        if nmid > k:
            found = _locate(at, a, mid, k, depth + 1)
            if found is not None:
                return found
        return _locate(at, mid, b, nmid, depth + 1) if unstable_count(at(b)) > nmid else None
    t = brentq(g, a, b, xtol=1e-12 * (1 + abs(a) + abs(b)), rtol=1e-14, maxiter=200)
    if tilt_at_a and abs(t - a) < 1e-3 * abs(b - a):
        return None
    lam = _chi_eigenvalues(at(t))[1]
    prob = replace(at(t), chi=lam[np.argsort(lam.imag)[k]].real)
    if prob.rigid_tilt_solves(tol=1e-6 * prob.scale()):
        return None
    return t, prob, k


def _polish(problem, path, t, prob, count_before):
    u, p, res, it = newton(_path_map(path), [t, prob.chi], problem)
    solved = problem.with_values(p)
    _reject_trivial(solved)
    return CriticalPoint(solved, ("path", "chi"), "shooting", float(res), it,
                         {"scan_value": float(u[0]), "count_before": count_before,
                          "collocation_guess": [float(t), float(prob.chi)]})


def _path_map(path):
    """Newton parameter map for u = (t, χ̂) along ``path(t) -> (p, dp/dt)``."""
    def param_map(u):
        p, dp = path(u[0])
        p = np.array(p, float)
        p[3] = u[1]
        J = np.zeros((4, 2))
        J[:, 0] = dp
        J[3] = [0.0, 1.0]
        return p, J
    return param_map


def solve_path(problem: BucklingProblem, path, t_guess: float, chi_guess: float) -> CriticalPoint:
    """Newton's method for (t, χ̂) with the other parameters on ``path(t) -> (p, dp/dt)``."""
    u, p, res, it = newton(_path_map(path), [t_guess, chi_guess], problem)
    solved = problem.with_values(p)
    _reject_trivial(solved)
    return CriticalPoint(solved, ("path", "chi"), "shooting", float(res), it,
                         {"scan_value": float(u[0])})


def follow(problem: BucklingProblem, make_path, s_values, start: float, stop: float, *,
           stable_start: bool = False, end_on_start_change: bool = False, skip=None):
    """First instability along ``make_path(s)`` for each s, by continuation in s.

    For each s Newton's method starts from the previous critical point; the result is
    accepted when the number of unstable modes at the scan start and just before the point
    are those of the previous point, one more mode is unstable just after it, and it moved
    by less than half its size. Otherwise (and for the first s) :func:`scan_path` runs.
    ``stable_start``: report nothing (``None``) where the rod is already unstable at the
    scan start (the critical value lies beyond the scanned range). ``end_on_start_change``:
    stop (``None`` from there on) once the number of unstable modes at the scan start
    differs from that at the first s: the followed curve has left through the start.
    ``skip`` is passed on to :func:`scan_path` (and rejects continued points too).
    Returns one :class:`CriticalPoint` or ``None`` per s.
    """
    out, prev, first_n0 = [], None, None
    direction = 1.0 if stop >= start else -1.0
    for s in s_values:
        path = make_path(s)
        n0 = unstable_count(problem.with_values(path(start)[0]))
        first_n0 = n0 if first_n0 is None else first_n0
        cp = None
        if (stable_start and n0) or (end_on_start_change and n0 != first_n0):
            out.append(None)
            prev = None
            first_n0 = -1 if end_on_start_change else first_n0   # ended for good
            continue
        if prev is not None and prev.extra["start_count"] == n0:
            try:
                t_prev = prev.extra["scan_value"]
                cp = solve_path(problem, path, t_prev, prev.chi)
                t = cp.extra["scan_value"]
                onset, before = is_onset(problem, path, t, direction)
                ok = ((t - start) * direction >= 0 and (stop - t) * direction >= 0
                      and abs(t - t_prev) <= 0.5 * (1 + abs(t_prev))
                      and before == prev.extra["count_before"] and onset
                      and not (skip and skip(cp.problem)))
                cp = replace(cp, extra={**cp.extra, "count_before": before}) if ok else None
            except (NoConvergenceError, TrivialSolutionError):
                cp = None
        if cp is None:
            try:
                cp = scan_path(problem, path, start, stop, skip=skip)
            except (NoConvergenceError, TrivialSolutionError):
                cp = None
        if cp is not None:
            cp = replace(cp, extra={**cp.extra, "start_count": n0})
        out.append(cp)
        prev = cp
    return out
