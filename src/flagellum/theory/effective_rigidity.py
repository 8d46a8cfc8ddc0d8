"""Effective bending rigidity of the helix (paper App. C, Eq. (47) = Eq. (17)), checked
mechanically.

App. C applies a constant moment M ⟂ to the helix axis, writes Kirchhoff's energy in terms
of the moment, f_cl = ½ (M₁²/A + M₂²/A + M₃²/C) (Eq. (45)), integrates it over the
undeformed helix and compares with a rod of length L0 = L sin α, 𝓕 = M² L0/(2 A_eff)
(Eq. (44))::

    1/A_eff = (1 + sin²α + (A/C) cos²α) / (2 A sin α).

:func:`continuum_compliance` evaluates that integral exactly for a finite helix and one
moment direction (the paper drops the O(sin 2kL / 2kL) term; the mean over two orthogonal
directions ⟂ to the axis has none). :func:`measured_bending_rigidity` measures the same
quantity directly on the discrete rod of the simulator (:class:`flagellum.rod.model.RodModel`
energy): the first frame and bead are clamped, a moment M ê acts on the last material frame
(no forces, so the internal moment is M ê everywhere), and the equilibrium energy
𝓕 = ½ M² gᵀ H⁻¹ g (H the Hessian of the energy, g = ∂(ê·Θ_N)/∂y with Θ_N the rotation of the
last frame) gives A_eff = M² L0 / (2𝓕).
"""

from __future__ import annotations

import numpy as np

from ..helix import Helix
from ..hydro.rft import effective_bending_rigidity
from ..params import Params

#: finite-difference step of the Hessian [µm, rad]
FD_STEP = 1e-4


def formula(params: Params | None = None) -> float:
    """A_eff of Eq. (17) [pN·µm²] for the filament of ``params``."""
    f = (params or Params()).filament
    return effective_bending_rigidity(Helix.from_filament(f), f.bend_rigidity, f.twist_rigidity)


def continuum_compliance(params: Params | None = None, direction=(1.0, 0.0, 0.0),
                         n: int = 20001) -> float:
    """∫₀ᴸ Σᵢ (ê·eᵢ)²/Aᵢ ds [µm/(pN·µm²)] over the helix of Eq. (37) (Frenet frame, axis z).

    2𝓕/M² for a moment M ê; equals L0/A_eff of Eq. (47) up to the O(sin 2kL/2kL) term of Eq. (46).
    """
    f = (params or Params()).filament
    helix = Helix.from_filament(f)
    e = np.asarray(direction, float) / np.linalg.norm(direction)
    s = np.linspace(0.0, helix.length, n)
    t = helix.tangents(s)
    k = helix.wavenumber
    nrm = -np.stack([np.cos(k * s), helix.chirality * np.sin(k * s), 0 * s], axis=-1)
    b = np.cross(t, nrm)
    y = ((nrm @ e) ** 2 + (b @ e) ** 2) / f.bend_rigidity + (t @ e) ** 2 / f.twist_rigidity
    return float(np.sum((y[1:] + y[:-1]) / 2) * (s[1] - s[0]))


def _frame_rotation(model, y, rot0) -> np.ndarray:
    """Small-rotation vector of the last material frame of state y relative to rot0
    (exact to O(|Θ|³))."""
    fr = model.frames(y)
    a = np.stack([fr.e1[-1], fr.e2[-1], fr.tangents[-1]], axis=1) @ rot0.T
    a = (a - a.T) / 2
    return np.array([a[2, 1], a[0, 2], a[1, 0]])


def bending_compliance(params: Params | None = None, directions=((1.0, 0, 0), (0, 1.0, 0)),
                       step: float = FD_STEP) -> np.ndarray:
    """Compliance gᵀH⁻¹g [1/(pN·µm)] of the discrete stress-free helix for end moments along
    ``directions`` (lab vectors; the helix axis is −z, :func:`flagellum.helix.discrete_helix`).

    The hook frame (u0, θ0) and bead 0 are clamped; H is the central-difference Hessian of
    the elastic energy in the remaining coordinates (beads 1..N and their angles).
    """
    from ..rod.model import RodModel

    model = RodModel(params or Params())
    y0 = model.initial_state()
    free = np.arange(7, len(y0))
    n = len(free)
    energy = model.energy
    H = np.empty((n, n))
    y = y0.copy()
    for a in range(n):
        i = free[a]
        for b in range(a, n):
            j = free[b]
            e = 0.0
            for si, sj, w in ((1, 1, 1), (1, -1, -1), (-1, 1, -1), (-1, -1, 1)):
                y[i] += si * step
                y[j] += sj * step
                e += w * energy(y)
                y[i] -= si * step
                y[j] -= sj * step
            H[a, b] = H[b, a] = e / (4 * step * step)
    fr = model.frames(y0)
    rot0 = np.stack([fr.e1[-1], fr.e2[-1], fr.tangents[-1]], axis=1)
    G = np.empty((n, 3))
    for a, i in enumerate(free):
        y[i] += step
        tp = _frame_rotation(model, y, rot0)
        y[i] -= 2 * step
        G[a] = (tp - _frame_rotation(model, y, rot0)) / (2 * step)
        y[i] += step
    E = np.array([np.asarray(d, float) / np.linalg.norm(d) for d in directions])
    g = G @ E.T                      # (n, k) generalised forces of unit moments
    return np.einsum("ak,ak->k", g, np.linalg.solve(H, g))


def measured_bending_rigidity(params: Params | None = None) -> float:
    """A_eff measured on the discrete rod: 2 L0 / (c_x + c_y), c the compliances of end
    moments along two orthogonal directions ⟂ to the axis (L0 = L sin α, as in Eq. (47))."""
    params = params or Params()
    c = bending_compliance(params)
    return 2 * Helix.from_filament(params.filament).axial_length / float(np.sum(c))


__all__ = ["formula", "continuum_compliance", "bending_compliance", "measured_bending_rigidity"]
