"""The cell body: a rigid sphere or prolate spheroid, free in 3D, with the motor on its surface.

Geometry. The body has equatorial semi-axis a (``Boundary.body_radius``) and polar semi-axis
c = p·a along its symmetry axis (``Boundary.body_aspect`` p ≥ 1; p = 1: a sphere). The motor
sits on the surface at the point P = (a sin β, 0, −c cos β) of the body's natural frame
(``Boundary.motor_offset`` β, the eccentric angle from the rear pole; for a sphere the polar
angle), and the motor axis m is the local *inward* normal there (the filament leaves along
the outward normal, the motor torque M m acts on the hook, −M m on the body; m points from
the motor into the body, the swimming direction of a pusher). The body-fixed vectors are
stored turned so that m = e_z when the body orientation is the identity: a run starts with
the motor axis along e_z, as the anchored filament.

Orientation. The body's orientation is Q = exp([φ]×), a rotation vector φ carried as the last
three state components (:mod:`flagellum.rod.kernels`). It evolves as φ̇ = J⁻¹(φ) Ω with the
inverse left Jacobian of SO(3) (:func:`rotvec_rate`); J⁻¹ is singular only at |φ| = 2π, and
the simulator replaces φ by the same rotation φ (1 − 2π/|φ|) once |φ| > π
(:func:`wrap_rotvec`), so |φ| stays near or below π and the map well conditioned.

Resistance. Exact Stokes resistance of a prolate spheroid about its centre (no coupling
between translation and rotation there): with the eccentricity e = √(1 − 1/p²), ::

    F∥ = 6πηc X_A U∥,   F⊥ = 6πηc Y_A U⊥,   T∥ = 8πηc³ X_C Ω∥,   T⊥ = 8πηc³ Y_C Ω⊥,
    X_A = (8/3) e³ / (−2e + (1 + e²) L),     Y_A = (16/3) e³ / (2e + (3e² − 1) L),
    X_C = (4/3) e³ (1 − e²) / (2e − (1 − e²) L),   Y_C = (4/3) e³ (2 − e²) / (−2e + (1 + e²) L),

L = ln((1 + e)/(1 − e)) (Oberbeck 1876 for translation, Perrin 1934 and Edwardes 1892 for
rotation; in this form S. Kim & S. J. Karrila, *Microhydrodynamics* (1991), Table 3.4, and
A. T. Chwang & T. Y.-T. Wu, J. Fluid Mech. 67, 787 (1975)). p = 1 gives 6πηa and 8πηa³.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .._jit import FASTMATH


def _s(e: float) -> float:
    """(artanh e − e)/e³ = Σ_{k≥1} e^{2k−2}/(2k+1), without cancellation for small e."""
    if e < 0.5:
        total, term, k = 0.0, 1.0, 1
        while True:
            add = term / (2 * k + 1)
            total += add
            if add < 1e-18 * total:
                return total
            term *= e * e
            k += 1
    return (math.atanh(e) - e) / e ** 3


def spheroid_coefficients(aspect: float) -> tuple[float, float, float, float]:
    """(X_A, Y_A, X_C, Y_C) of a prolate spheroid of aspect ratio p = c/a ≥ 1 (Kim & Karrila
    1991, Table 3.4): the resistance along/across the axis in units of 6πηc (translation)
    and 8πηc³ (rotation); all 1 for a sphere. The denominators are written with
    s = (artanh e − e)/e³, exact and free of cancellation down to e = 0."""
    if aspect == 1.0:
        return 1.0, 1.0, 1.0, 1.0
    e2 = 1.0 - 1.0 / (aspect * aspect)
    s = _s(math.sqrt(e2))
    d1 = 2.0 + 2.0 * s * (1.0 + e2)  # (−2e + (1 + e²) L)/e³
    d2 = 6.0 + 2.0 * s * (3.0 * e2 - 1.0)  # (2e + (3e² − 1) L)/e³
    d3 = 2.0 - 2.0 * s * (1.0 - e2)  # (2e − (1 − e²) L)/e³
    return 8.0 / 3.0 / d1, 16.0 / 3.0 / d2, 4.0 / 3.0 * (1.0 - e2) / d3, 4.0 / 3.0 * (2.0 - e2) / d1


class BodyResistance(NamedTuple):
    """Stokes resistance of the body about its centre [pN·s/µm, pN·µm·s]."""

    translation_axial: float
    translation_transverse: float
    rotation_axial: float
    rotation_transverse: float


def body_resistance(radius: float, aspect: float, viscosity: float) -> BodyResistance:
    """Resistance of a prolate spheroid with equatorial semi-axis ``radius`` a [µm] and polar
    semi-axis c = ``aspect``·a in a fluid of ``viscosity`` η [pN·s/µm²]."""
    c = aspect * radius
    xa, ya, xc, yc = spheroid_coefficients(aspect)
    t, r = 6 * math.pi * viscosity * c, 8 * math.pi * viscosity * c ** 3
    return BodyResistance(t * xa, t * ya, r * xc, r * yc)


class BodyGeometry(NamedTuple):
    """Body-fixed vectors (turned so that the motor axis is e_z at the identity orientation)."""

    axis: np.ndarray  #: unit symmetry axis, from the rear (flagellar) pole to the front
    offset: np.ndarray  #: from the body's centre to the motor point on its surface [µm]
    motor_axis: np.ndarray  #: unit inward normal at the motor point (= e_z)


def body_geometry(radius: float, aspect: float, motor_offset_deg: float) -> BodyGeometry:
    """The body's vectors for the motor at eccentric angle β = ``motor_offset_deg`` from the
    rear pole (see the module docstring)."""
    from ..helix import rotation_between

    a, c, b = radius, aspect * radius, math.radians(motor_offset_deg)
    point = np.array([a * math.sin(b), 0.0, -c * math.cos(b)])
    normal = np.array([math.sin(b) / a, 0.0, -math.cos(b) / c])
    m = -normal / np.linalg.norm(normal)
    rot = rotation_between(m, np.array([0.0, 0.0, 1.0]))
    return BodyGeometry(rot @ np.array([0.0, 0.0, 1.0]), rot @ point, np.array([0.0, 0.0, 1.0]))


#: offset in the body's block of the rotation R (9 values, row by row, then a flag: 1 to
#: apply it) by which a frozen nonlocal ΔM is turned, R ΔM Rᵀ, onto the current points
#: (:meth:`flagellum.integrate.frozen.FrozenMobility.apply`; identity and 0 otherwise)
ROTATION = 13
#: length of the body's block in the kernels' parameter array: the four resistances, the
#: body-fixed axis, motor offset and motor axis (3 each), then the rotation of ΔM
BLOCK = ROTATION + 10


def kernel_block(radius: float, aspect: float, motor_offset_deg: float, viscosity: float) -> np.ndarray:
    """The body's parameters as the kernels read them (:data:`BLOCK` values)."""
    g = body_geometry(radius, aspect, motor_offset_deg)
    return np.concatenate([body_resistance(radius, aspect, viscosity), g.axis, g.offset, g.motor_axis,
                           np.eye(3).ravel(), [0.0]])


# -- orientation ------------------------------------------------------------------------

@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def rotation_matrix(p0, p1, p2, out):
    """``out`` (3, 3) = exp([φ]×) (Rodrigues), with series near φ = 0."""
    t2 = p0 * p0 + p1 * p1 + p2 * p2
    if t2 < 1e-8:
        a, b = 1.0 - t2 / 6.0, 0.5 - t2 / 24.0
    else:
        t = math.sqrt(t2)
        a, b = math.sin(t) / t, (1.0 - math.cos(t)) / t2
    out[0, 0] = 1.0 - b * (p1 * p1 + p2 * p2)
    out[1, 1] = 1.0 - b * (p0 * p0 + p2 * p2)
    out[2, 2] = 1.0 - b * (p0 * p0 + p1 * p1)
    out[0, 1], out[1, 0] = b * p0 * p1 - a * p2, b * p0 * p1 + a * p2
    out[0, 2], out[2, 0] = b * p0 * p2 + a * p1, b * p0 * p2 - a * p1
    out[1, 2], out[2, 1] = b * p1 * p2 - a * p0, b * p1 * p2 + a * p0


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def rotvec_rate(p0, p1, p2, w0, w1, w2):
    """φ̇ = J⁻¹(φ) ω for Q = exp([φ]×) turning at the (space-frame) angular velocity ω:
    J⁻¹ = 1 − ½[φ]× + c(θ)[φ]×², c = (1 − θ sin θ / (2(1 − cos θ)))/θ² (θ = |φ|)."""
    t2 = p0 * p0 + p1 * p1 + p2 * p2
    if t2 < 1e-6:
        c = 1.0 / 12.0 + t2 / 720.0
    else:
        t = math.sqrt(t2)
        c = (1.0 - t * math.sin(t) / (2.0 * (1.0 - math.cos(t)))) / t2
    x0, x1, x2 = p1 * w2 - p2 * w1, p2 * w0 - p0 * w2, p0 * w1 - p1 * w0  # φ × ω
    y0, y1, y2 = p1 * x2 - p2 * x1, p2 * x0 - p0 * x2, p0 * x1 - p1 * x0  # φ × (φ × ω)
    return w0 - 0.5 * x0 + c * y0, w1 - 0.5 * x1 + c * y1, w2 - 0.5 * x2 + c * y2


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def rotvec_torque(p0, p1, p2, f0, f1, f2):
    """The torque J⁻ᵀ(φ) f of the generalized force f conjugate to φ (virtual work
    T·δΘ = f·δφ with δΘ = J δφ, :func:`rotvec_rate`): J⁻ᵀ(φ) = J⁻¹(−φ)."""
    return rotvec_rate(-p0, -p1, -p2, f0, f1, f2)


@njit(cache=True, fastmath=FASTMATH, error_model="numpy")
def haar_gradient(p0, p1, p2):
    """∇_φ ln det J(φ) = (cot(θ/2) − 2/θ) φ/θ, with det J = 2(1 − cos θ)/θ² the density of
    the invariant (Haar) measure of SO(3) in the coordinates φ (θ = |φ|): kT times it is
    the generalized force that makes a flat-space Brownian scheme in φ sample orientations
    uniformly (series −φ/6 − θ²φ/360 near φ = 0)."""
    t2 = p0 * p0 + p1 * p1 + p2 * p2
    if t2 < 1e-4:
        c = -1.0 / 6.0 - t2 / 360.0
    else:
        t = math.sqrt(t2)
        c = (1.0 / math.tan(0.5 * t) - 2.0 / t) / t
    return c * p0, c * p1, c * p2


def rotvec_matrix(phi) -> np.ndarray:
    """exp([φ]×) of one rotation vector (numpy)."""
    out = np.zeros((3, 3))
    rotation_matrix(float(phi[0]), float(phi[1]), float(phi[2]), out)
    return out


def matrix_rotvec(rot: np.ndarray) -> np.ndarray:
    """The rotation vector φ with |φ| ≤ π of a rotation matrix (near π from the symmetric
    part, where the antisymmetric one vanishes)."""
    r = np.asarray(rot, float)
    angle = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1) / 2)))
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    if angle < 1e-6:
        return 0.5 * w
    if angle < math.pi - 1e-3:
        return w * (angle / (2 * math.sin(angle)))
    s = 0.5 * (r + r.T) - math.cos(angle) * np.eye(3)  # (1 − cos θ) n nᵀ
    k = int(np.argmax(np.diag(s)))
    n = s[:, k] / math.sqrt(s[k, k] * (1.0 - math.cos(angle)))
    if n @ w < 0:
        n = -n
    return n * angle


def wrap_rotvec(phi: np.ndarray) -> bool:
    """Replace φ (in place) by the same rotation φ (1 − 2π/|φ|) when |φ| > π; whether it did."""
    t = float(np.linalg.norm(phi))
    if t <= math.pi:
        return False
    phi *= 1.0 - 2.0 * math.pi / t
    return True


__all__ = ["BLOCK", "BodyGeometry", "BodyResistance", "body_geometry", "body_resistance",
           "haar_gradient", "kernel_block", "matrix_rotvec", "rotation_matrix", "rotvec_matrix",
           "rotvec_rate", "rotvec_torque",
           "spheroid_coefficients", "wrap_rotvec"]
