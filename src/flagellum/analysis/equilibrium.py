"""Equilibrium reference for the thermal fluctuations of the unloaded filament (M = 0).

Without motor torque the anchored filament (bead 0 fixed, free hook = universal joint) is in
thermal equilibrium, so its statistics are Boltzmann in the discrete rod energy of paper
Eqs. (3)–(5) (:meth:`flagellum.rod.model.RodModel.energy`), whatever the dynamics (Eqs. (6)–(10)).
This module samples that distribution directly and gives the end-to-end distance
r = |r(L) − r(0)| of Eqs. (14)–(15) (paper Sec. 3.1.2, Fig. 4(d): σ/σ0 with σ0 = R/√2) as a reference
for Brownian runs.

Sampling (:class:`EquilibriumSampler`). The energy and the measure (Lebesgue in the beads,
Haar in the material frames) are invariant under rotations about bead 0, so the shape
distribution is that with the hook frame clamped. Then the units (relative rotation of
consecutive frames, bond length) are independent and identically distributed, and whole
configurations are drawn exactly (independence Metropolis–Hastings on the full energy).

Analytic estimate (:func:`end_to_end_estimate`): linear response of r to a pair of forces
on the end beads = axial spring (Love, paper ref. Vogel 2010) + bending of the helix axis by
the moment of those forces about the axis (the end beads sit a distance R off the axis)
+ the second-order shortening of r by bending of the axis (App. C rigidity A_eff).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..helix import Helix, discrete_helix
from ..hydro.rft import effective_bending_rigidity
from ..params import Params
from ..rod.model import RodModel

def sigma0(params: Params | None = None) -> float:
    """σ0 = R/√2 [µm], the paper's unit of σ (Sec. 3.1.2)."""
    return Helix.from_filament((params or Params()).filament).radius / math.sqrt(2.0)


def end_to_end_estimate(params: Params | None = None, kT: float | None = None) -> dict:
    """Continuum estimate of the thermal spread of r for the unloaded helix [µm].

    * ``axial``: compression of the helix as a coil spring, 1/k = L R² (cos²α/C + sin²α/A)
      (Love; = R²L/A for A = C, the paper's spring constant A/(R²L)); σ² = kT/k.
    * ``moment``: a force pair F along r acts on the end beads, which lie a distance R off
      the axis, so the axis carries a bending moment F·d(s), d interpolating linearly from
      R n̂(0) to R n̂(L) (n̂ radial unit vectors, azimuths kL apart). With the beam rigidity
      A_eff of Eq. (17): compliance R² L0 (2 + cos kL)/(3 A_eff). Equipartition of the
      linear part of r: σ_lin² = kT (1/k + that).
    * ``bend2``: second order in the bending of the axis, Δr = −½ Σ_⊥ ∫ (θ − θ̄)² ds with
      θ(s) the slope of the axis (rigid tilt, free at the universal joint, drops out).
      Free ends of the slope field (hinged–free and free–free beams give the same, they
      differ only by rigid motions, which leave r unchanged): Neumann modes cos(nπs/L0),
      ⟨Δr⟩ = −kT L0²/(6 A_eff), std = kT L0²/(A_eff √90).
    * ``total``: √(σ_lin² + bend2²) (the quadratic term is uncorrelated with the linear one
      at this order).
    """
    params = params or Params()
    f = params.filament
    kT = params.fluid.kT if kT is None else kT
    hx = Helix.from_filament(f)
    a, R, L, L0 = hx.pitch_angle, hx.radius, hx.length, hx.axial_length
    A, C = f.bend_rigidity, f.twist_rigidity
    a_eff = effective_bending_rigidity(hx, A, C)
    c_axial = L * R**2 * (math.cos(a) ** 2 / C + math.sin(a) ** 2 / A)
    c_moment = R**2 * L0 * (2.0 + math.cos(hx.wavenumber * L)) / (3.0 * a_eff)
    s_axial = math.sqrt(kT * c_axial)
    s_moment = math.sqrt(kT * c_moment)
    s_lin = math.hypot(s_axial, s_moment)
    s_bend2 = kT * L0**2 / (a_eff * math.sqrt(90.0))
    return {"sigma0": sigma0(params), "A_eff": a_eff, "spring_constant": 1.0 / c_axial,
            "axial": s_axial, "moment": s_moment, "linear": s_lin, "bend2": s_bend2,
            "mean_shift_bend2": -kT * L0**2 / (6.0 * a_eff),
            "total": math.hypot(s_lin, s_bend2)}


def windowed_sigma(t: np.ndarray, r: np.ndarray, window: float | None = None) -> float:
    """σ of r over the whole series (``window=None``) or the mean of the σ's of contiguous
    windows of length ``window`` [s] (what a short averaging time sees)."""
    r = np.asarray(r, float)
    if window is None:
        return float(r.std())
    t = np.asarray(t, float)
    idx = np.floor((t - t[0]) / window).astype(int)
    n_full = int((t[-1] - t[0]) // window)
    sig = [r[idx == k].std() for k in range(n_full) if np.count_nonzero(idx == k) > 1]
    return float(np.mean(sig)) if sig else math.nan


def _block_sigma(x: np.ndarray, n_blocks: int) -> tuple[float, float]:
    """σ of x and its standard error from the σ's of ``n_blocks`` contiguous blocks."""
    s = np.array([b.std() for b in np.array_split(np.asarray(x, float), n_blocks)])
    return float(np.asarray(x).std()), float(s.std(ddof=1) / math.sqrt(n_blocks))


def rotations(eta: np.ndarray) -> np.ndarray:
    """exp([η]×) for rotation vectors η of shape (..., 3) (Rodrigues)."""
    eta = np.asarray(eta, float)
    a = np.linalg.norm(eta, axis=-1)[..., None, None]
    k = np.zeros(eta.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -eta[..., 2], eta[..., 1], -eta[..., 0]
    k = k - np.swapaxes(k, -1, -2)
    small = a < 1e-8
    s1 = np.where(small, 1.0, np.sin(a) / np.where(small, 1.0, a))
    s2 = np.where(small, 0.5, (1 - np.cos(a)) / np.where(small, 1.0, a * a))
    return np.eye(3) + s1 * k + s2 * (k @ k)


def log_haar(eta: np.ndarray) -> np.ndarray:
    """log of the Haar density of SO(3) in exponential coordinates, 2(1 − cos|η|)/|η|²."""
    a = np.linalg.norm(eta, axis=-1)
    dens = 2 * (1 - np.cos(a)) / np.maximum(a, 1e-6) ** 2
    return np.log(np.where(a < 1e-6, 1.0 - a * a / 12.0, dens))


@dataclass
class EquilibriumSamples:
    """Independent Boltzmann samples of the unloaded filament (hook frame fixed; r and the
    shape do not depend on its orientation).

    ``r``: end-to-end distances; ``r_axial``: the end-to-end vector's component along the
    helix axis after best-fit (Kabsch) alignment of the filament with the stress-free helix;
    ``energy``: elastic energy; ``tangent_dot``: t_0·t_k (hook frame with bond k, (n, N)).
    """

    r: np.ndarray
    r_axial: np.ndarray
    energy: np.ndarray
    tangent_dot: np.ndarray
    acceptance: float
    sigma0: float
    kT: float

    def sigma(self, which: str = "r", n_blocks: int = 20) -> tuple[float, float]:
        """(σ, standard error) of ``r`` or ``r_axial`` [µm] from block σ's."""
        return _block_sigma(getattr(self, which), n_blocks)

    def summary(self, n_blocks: int = 20) -> dict:
        s, e = self.sigma("r", n_blocks)
        sa, ea = self.sigma("r_axial", n_blocks)
        return {"kT": self.kT, "n": len(self.r), "acceptance": self.acceptance,
                "r_mean": float(self.r.mean()), "sigma": s, "sigma_err": e,
                "sigma_over_sigma0": s / self.sigma0, "sigma_over_sigma0_err": e / self.sigma0,
                "sigma_axial_over_sigma0": sa / self.sigma0,
                "sigma_axial_over_sigma0_err": ea / self.sigma0,
                "energy_per_kT": float(self.energy.mean() / self.kT)}


class EquilibriumSampler:
    """Exact sampler of exp(−E/kT) for the discrete rod of :class:`RodModel` (no motor).

    With the hook frame D_0 fixed, write each bond frame as D_i = D_{i−1} S exp([η_i]×)
    (S = the stress-free step between frames) and bond i's length as ℓ_i. The energy of joint
    i depends only on D_{i−1}ᵀD_i, i.e. on η_i, and the stretching only on ℓ_i; the measure
    (Lebesgue in the bond vectors, Haar in the frames) is Π ℓ_i² dℓ_i Haar(dη_i) by the
    invariance of the Haar measure. So the units (η_i, ℓ_i) are independent and identically
    distributed: p ∝ exp(−e(η, ℓ)/kT) ℓ² Haar(η). We draw whole configurations from the
    Gaussian of the unit Hessian and accept them with an independence Metropolis–Hastings
    test on the full :meth:`RodModel.energy` (exact; acceptance ≈ 1 at room temperature).

    Parameters
    ----------
    params : filament (its ``fluid.kT`` is the default temperature).
    kT : temperature [pN·µm].
    """

    def __init__(self, params: Params | None = None, kT: float | None = None,
                 fd_step: float = 1e-4):
        self.params = params or Params()
        self.kT = float(self.params.fluid.kT if kT is None else kT)
        self.model = RodModel(self.params)
        self.y0 = self.model.initial_state()
        dh = discrete_helix(self.params.filament)
        self.frames0 = dh.frames
        self.step = dh.frames[0].T @ dh.frames[1]
        self.n, self.h = self.model.n, self.model.h
        self.hessian = self._unit_hessian(fd_step)
        self.cov = self.kT * np.linalg.inv(self.hessian)
        self._chol = np.linalg.cholesky(self.cov)
        pos0 = dh.positions
        self._ref = pos0 - pos0.mean(0)
        self._axis = dh.axis_direction

    # -- configurations ----------------------------------------------------------------------
    def frames(self, eta: np.ndarray) -> np.ndarray:
        """Bond frames (..., N, 3, 3) from the unit rotations η (..., N, 3)."""
        q = self.step @ rotations(eta)
        d = np.empty_like(q)
        cur = np.broadcast_to(self.frames0[0], q.shape[:-3] + (3, 3))
        for i in range(self.n):
            cur = cur @ q[..., i, :, :]
            d[..., i, :, :] = cur
        return d

    def positions(self, eta: np.ndarray, ell: np.ndarray) -> np.ndarray:
        """Beads (..., N+1, 3), bead 0 at the origin."""
        t = self.frames(eta)[..., 2] * np.asarray(ell)[..., None]
        z = np.zeros(t.shape[:-2] + (1, 3))
        return np.concatenate([z, np.cumsum(t, axis=-2)], axis=-2)

    def state(self, eta: np.ndarray, ell: np.ndarray) -> np.ndarray:
        """Model states y (..., len y) (material angles in the model's charts)."""
        d = self.frames(eta)
        t, e1 = d[..., 2], d[..., 0]
        u, e = self.model.ref_u[1:], self.model.ref_e[1:]
        c = np.cross(u, t)
        dd = np.einsum("...j,...j->...", u, t)[..., None]
        a1 = dd * e + np.cross(c, e) + np.einsum("...j,...j->...", c, e)[..., None] / (1 + dd) * c
        a2 = np.cross(t, a1)
        y = np.broadcast_to(self.y0, t.shape[:-2] + self.y0.shape).copy()
        body = y[..., 3:].reshape(t.shape[:-2] + (-1, 4))
        body[..., 1:, :3] = self.positions(eta, ell)[..., 1:, :]
        body[..., 1:, 3] = np.arctan2(np.einsum("...j,...j->...", e1, a2),
                                      np.einsum("...j,...j->...", e1, a1))
        return y

    def _unit_hessian(self, step: float) -> np.ndarray:
        """4×4 Hessian of the energy of one unit (η, ℓ) at rest (first unit, rest at rest)."""
        def e(v):
            eta = np.zeros((self.n, 3))
            ell = np.full(self.n, self.h)
            eta[0], ell[0] = v[:3], self.h + v[3]
            return self.model.energy(self.state(eta, ell))

        H = np.empty((4, 4))
        d = np.eye(4) * step
        for i in range(4):
            for j in range(i, 4):
                H[i, j] = H[j, i] = (e(d[i] + d[j]) - e(d[i] - d[j]) - e(d[j] - d[i])
                                     + e(-d[i] - d[j])) / (4 * step**2)
        return H

    # -- sampling ----------------------------------------------------------------------------
    def _batch(self, rng, size: int):
        """``size`` proposals: (log target − log proposal, energy, r, r_axial, t_0·t_k)."""
        z = rng.standard_normal((size, self.n, 4))
        v = z @ self._chol.T
        eta, ell = v[..., :3], self.h + v[..., 3]
        ys = self.state(eta, ell)
        energy = np.array([self.model.energy(y) for y in ys])
        logw = (-energy / self.kT + np.sum(2 * np.log(np.abs(ell)) + log_haar(eta), axis=1)
                + 0.5 * np.sum(z * z, axis=(1, 2)))
        logw[np.any(ell <= 0, axis=1) | ~np.isfinite(energy)] = -math.inf
        pos = ys[:, 3:].reshape(size, -1, 4)[:, :, :3]
        rv = pos[:, -1] - pos[:, 0]
        u, _, vt = np.linalg.svd(np.swapaxes(pos - pos.mean(1)[:, None], 1, 2) @ self._ref)
        rot = np.swapaxes(u @ vt, 1, 2)  # Kabsch: the best rotation onto the stress-free helix
        ra = np.einsum("bij,bj,i->b", rot, rv, self._axis)
        tan = np.diff(pos, axis=1)
        tan /= np.linalg.norm(tan, axis=2)[..., None]
        return logw, energy, np.linalg.norm(rv, axis=1), ra, tan @ self.frames0[0][:, 2]

    def run(self, n_samples: int, seed: int = 0, batch: int = 500) -> EquilibriumSamples:
        """``n_samples`` states of an independence Metropolis–Hastings chain started from
        one proposal (proposals are drawn and evaluated in batches)."""
        rng = np.random.default_rng(seed)
        cur, acc = None, 0
        out = []
        while len(out) < n_samples:
            logw, *obs = self._batch(rng, batch)
            for k in range(batch):
                if cur is None:
                    cur = (logw[k],) + tuple(o[k] for o in obs)
                    continue
                if len(out) == n_samples:
                    break
                if math.log(rng.uniform()) < logw[k] - cur[0]:
                    cur = (logw[k],) + tuple(o[k] for o in obs)
                    acc += 1
                out.append(cur[1:])
        energy, r, ra, td = (np.array(x) for x in zip(*out))
        return EquilibriumSamples(r, ra, energy, td, acc / max(n_samples, 1),
                                  sigma0(self.params), self.kT)

    def linear_sigma(self) -> tuple[float, float]:
        """Equipartition for the linearised r and its axial component, kT gᵀH⁻¹g with H the
        (block-diagonal) Hessian in the unit coordinates: (σ_r, σ_axial) [µm]. Exact for the
        discrete model as kT → 0; the rest of σ is second order (bending shortens r)."""
        zero_eta, ell0 = np.zeros((self.n, 3)), np.full(self.n, self.h)
        pos0 = self.positions(zero_eta, ell0)
        rv = pos0[-1] - pos0[0]
        eps = 1e-6
        g = np.empty((self.n, 4, 3))  # ∂(r_N − r_0)/∂(unit i, coordinate a)
        for i in range(self.n):
            for a in range(4):
                eta, ell = zero_eta.copy(), ell0.copy()
                if a < 3:
                    eta[i, a] = eps
                else:
                    ell[i] += eps
                p = self.positions(eta, ell)
                g[i, a] = (p[-1] - p[0] - rv) / eps
        out = []
        for d in (rv / np.linalg.norm(rv), self._axis):
            gd = g @ d
            out.append(math.sqrt(float(np.einsum("ia,ab,ib->", gd, self.cov, gd))))
        return out[0], out[1]


__all__ = ["EquilibriumSampler", "EquilibriumSamples", "end_to_end_estimate", "sigma0",
           "windowed_sigma", "rotations", "log_haar"]
