"""Closed-form references used by several test files (independent of the package's code)."""

import math


def app_a_thrust_per_torque(kappa: float, tau: float, gamma_par: float, gamma_perp: float) -> float:
    """F/M of the rigid helix held on its axis, App. A Eqs. (38)–(39) for full turns:
    −C∥/B∥ = −δ sin α cos α / (R (1 + δ cos²α)), with δ = (γ∥ − γ⊥)/γ⊥,
    R = κ/(κ² + τ²), sin α = τ/√(κ² + τ²), cos α = κ/√(κ² + τ²)."""
    k = math.hypot(kappa, tau)
    R, sin_a, cos_a = kappa / k**2, tau / k, kappa / k
    delta = (gamma_par - gamma_perp) / gamma_perp
    return -delta * sin_a * cos_a / (R * (1 + delta * cos_a**2))
