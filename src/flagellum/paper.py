"""The numbers that Vogel & Stark (2012) state, and the two reference helices.

Every entry of :data:`PAPER` is a :class:`Stated` value with its unit and where the paper
gives it, by the section, figure and equation numbers of the paper's source (equations
numbered continuously, (1)–(47), through the appendices; figures numbered with the
sketches: Fig. 5 is the thrust–torque figure that ``flagellum reproduce fig3`` redraws,
Fig. 6 ↔ fig4, Fig. 7 ↔ fig5, Fig. 8 ↔ fig6, Fig. 9 ↔ fig7, Fig. 11 ↔ fig8). The comparison
tables of ``flagellum reproduce`` and the bifurcation search quote them, and the defaults
of :mod:`flagellum.params` (helix, rigidities, friction) are taken from here.

Reference helices (spontaneous curvature κ0 and torsion τ0 of the filament, 1/µm):

* :data:`NORMAL_HELIX` (1.3, 2.1): the normal state of the flagellum of peritrichous
  bacteria used throughout the paper (Sec. 2.4);
* :data:`MONOTRICHOUS_HELIX` (2.2, 2.5): the flagellum of monotrichous bacteria, App. C
  (after Fujii et al. 2008), used for Fig. 11 and the estimate sin α ≈ 0.75 of Sec. 5.
"""

from __future__ import annotations

from typing import NamedTuple


class Stated(NamedTuple):
    """A number the paper states: value, unit ("" if none) and where it is stated."""

    value: float
    unit: str
    where: str


PAPER: dict[str, Stated] = {
    "M_c1": Stated(1.1, "pN·µm", "Sec. 3.1.1 and the caption of Fig. 5: first (supercritical "
                                 "Hopf) bifurcation, buckling"),
    "M_c2": Stated(4.2, "pN·µm", "Sec. 3.1.1 and the caption of Fig. 5: second bifurcation"),
    "sigma_equipartition": Stated(0.15, "", "Sec. 3.1.2: σ/σ0 below M_c1 from equipartition"),
    "sigma_simulated": Stated(0.18, "", "Sec. 3.1.2: σ/σ0 below M_c1, simulated with noise"),
    "persistence_length": Stated(1000.0, "µm", "Sec. 3.1.2: A/kT ≈ 1 mm"),
    "F_c1": Stated(1.0, "pN", "Sec. 5: simulated F_c1 ≈ 1 pN for real cell sizes (Fig. 7(b), "
                              "nearly constant for M_c1 between 1 and 2 pN·µm, Sec. 3.2)"),
    "linear_until_inv_a": Stated(2.5, "1/µm", "Sec. 3.2: M_c1 linear in 1/a up to 1/a ≈ 5/2"),
    "M_c1_quadratic": Stated(4.0, "pN·µm", "Sec. 3.2: at M_c1 ≈ 4 F_c1 falls to zero ∝ M_c1²"),
    "ridge_m_hat": Stated(15.0, "", "Sec. 4.2: shoulder of the buckling curves at m̂ ≈ 15 (Fig. 9)"),
    "compression": Stated(0.02, "", "Sec. 4.2: relative compression at F = 1 pN"),
    "sin_alpha_mono": Stated(0.75, "", "Sec. 5: sin α of the monotrichous flagellum"),
    "force_increase_mono": Stated(0.10, "", "Sec. 5: increase of F_c ∝ 1/sin α, monotrichous"),
    "gamma_par": Stated(1.6e-3, "pN·s/µm²", "Sec. 2.4: γ∥ from Lighthill's formulas (App. A)"),
    "gamma_perp": Stated(2.8e-3, "pN·s/µm²", "Sec. 2.4: γ⊥ from Lighthill's formulas (App. A)"),
    "gamma_rot": Stated(1.26e-6, "pN·s", "Sec. 2.4: γR from Lighthill's formulas (App. A)"),
    "turns": Stated(4.0, "", "Sec. 2.4: L = 10 µm is about four helical turns"),
    "strain": Stated(0.015, "", "Sec. 2.1: K keeps length changes below 1.5 %"),
    "bend_rigidity": Stated(3.5, "pN·µm²", "Sec. 2.4 and the caption of Fig. 11: A = A0 = C"),
}

#: (κ0, τ0) [1/µm] of the normal helix (peritrichous bacteria, Sec. 2.4)
NORMAL_HELIX = (1.3, 2.1)
#: (κ0, τ0) [1/µm] of the monotrichous helix (App. C)
MONOTRICHOUS_HELIX = (2.2, 2.5)
#: the reference helices by name
HELICES = {"normal": NORMAL_HELIX, "monotrichous": MONOTRICHOUS_HELIX}

__all__ = ["HELICES", "MONOTRICHOUS_HELIX", "NORMAL_HELIX", "PAPER", "Stated"]
