"""Helix geometry: the continuum helix of the paper and the discrete helix of the rod model.

Continuum (paper Sec. 2.1, Eq. (37)): curvature κ, torsion τ (sign = handedness χ), ::

    R = κ/(κ² + τ²),   p = 2π|τ|/(κ² + τ²),   tan α = p/(2πR) = |τ|/κ,
    r(s) = (R cos ks, χ R sin ks, s sin α),    k = cos α / R = √(κ² + τ²),
    L0 = L sin α (axial length),   Λ = 2πR/cos α (contour length of one turn).

Discrete (paper Sec. 2.2): frame j+1 follows from frame j by a twist τh about e3, then a bend
κh about the new e2, i.e. D_{j+1} = D_j R_z(τh) R_y(κh) (columns of D are e1, e2, e3); this
helix has exactly the strains (0, κ0, τ0) of the discrete energy and is stress free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .params import Filament


def rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1.0, 0], [-s, 0, c]])


def rot_z(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])


def rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The minimal rotation (parallel transport) taking unit vector ``a`` to unit vector ``b``."""
    a = np.asarray(a, float) / np.linalg.norm(a)
    b = np.asarray(b, float) / np.linalg.norm(b)
    c = np.cross(a, b)
    d = float(a @ b)
    if d < -1 + 1e-12:
        perp = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
        perp /= np.linalg.norm(perp)
        return 2 * np.outer(perp, perp) - np.eye(3)
    cx = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
    return np.eye(3) + cx + cx @ cx / (1 + d)


def axis_angle(rot: np.ndarray) -> tuple[np.ndarray, float]:
    """Unit axis and angle in [0, π] of a rotation matrix."""
    angle = math.acos(max(-1.0, min(1.0, (np.trace(rot) - 1) / 2)))
    w = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
    n = np.linalg.norm(w)
    if n < 1e-14:
        return np.array([0.0, 0.0, 1.0]), angle
    return w / n, angle


@dataclass(frozen=True)
class Helix:
    """Continuum helix of contour length ``length`` (paper Sec. 2.1, App. A)."""

    curvature: float
    torsion: float  #: signed: > 0 right-handed
    length: float

    @classmethod
    def from_filament(cls, filament: Filament) -> "Helix":
        return cls(filament.kappa0, filament.torsion, filament.length)

    @property
    def chirality(self) -> int:
        return 1 if self.torsion >= 0 else -1

    @property
    def wavenumber(self) -> float:
        """k = √(κ² + τ²) = cos α / R: phase advance per contour length."""
        return math.hypot(self.curvature, self.torsion)

    @property
    def radius(self) -> float:
        return self.curvature / self.wavenumber**2 if self.curvature else 0.0

    @property
    def pitch(self) -> float:
        return 2 * math.pi * abs(self.torsion) / self.wavenumber**2 if self.curvature else math.inf

    @property
    def pitch_angle(self) -> float:
        """α in radians, tan α = |τ|/κ (α = π/2 for a straight rod)."""
        return math.atan2(abs(self.torsion), self.curvature) if self.curvature else math.pi / 2

    @property
    def axial_length(self) -> float:
        """L0 = L sin α."""
        return self.length * math.sin(self.pitch_angle)

    @property
    def turn_length(self) -> float:
        """Λ = 2πR/cos α: contour length of one turn (∞ for a straight rod)."""
        return 2 * math.pi / self.wavenumber if self.curvature else math.inf

    @property
    def n_turns(self) -> float:
        return self.length / self.turn_length

    def positions(self, s) -> np.ndarray:
        """r(s) of Eq. (37), axis along +z through the origin."""
        s = np.asarray(s, float)
        k, R, a = self.wavenumber, self.radius, self.pitch_angle
        return np.stack([R * np.cos(k * s), self.chirality * R * np.sin(k * s),
                         math.sin(a) * s], axis=-1)

    def tangents(self, s) -> np.ndarray:
        s = np.asarray(s, float)
        k, a = self.wavenumber, self.pitch_angle
        ca = math.cos(a)
        return np.stack([-ca * np.sin(k * s), self.chirality * ca * np.cos(k * s),
                         np.full_like(s, math.sin(a))], axis=-1)

    def summary(self) -> dict:
        return {"radius": self.radius, "pitch": self.pitch,
                "pitch_angle_deg": math.degrees(self.pitch_angle),
                "axial_length": self.axial_length, "n_turns": self.n_turns,
                "turn_length": self.turn_length}


@dataclass(frozen=True)
class DiscreteHelix:
    """The stress-free discrete helix of the rod model.

    ``positions``: (N+1, 3) beads; ``frames``: (N+1, 3, 3) with columns (e1, e2, e3);
    ``frames[0]`` is the hook frame (paper Sec. 2.3), ``frames[j]`` belongs to bond j
    (from bead j−1 to bead j) for j = 1..N.
    """

    positions: np.ndarray
    frames: np.ndarray
    axis_point: np.ndarray
    axis_direction: np.ndarray
    radius: float
    pitch: float
    segment_length: float

    @property
    def n_segments(self) -> int:
        return len(self.positions) - 1

    @property
    def tangents(self) -> np.ndarray:
        """Unit bond tangents e3 of bonds 1..N, shape (N, 3)."""
        return self.frames[1:, :, 2]

    @property
    def axial_length(self) -> float:
        return float((self.positions[-1] - self.positions[0]) @ self.axis_direction)


def discrete_helix(filament: Filament, axis=(0.0, 0.0, -1.0), origin: str = "bead",
                   phase: float = 0.0) -> DiscreteHelix:
    """Build the discrete helix of ``filament`` with its axis along ``axis``.

    ``origin="bead"``: bead 0 (on the filament) sits at the origin, the helix axis is the
    line through ``axis_point`` (a distance ≈ R away) along ``axis``.
    ``origin="axis"``: the helix axis passes through the origin; bead 0 lies ≈ R off it.
    ``phase`` rotates the helix about its own axis.

    The default axis −z is the simulator's: with the motor at the origin and M > 0 along
    +z, a right-handed filament then pushes towards the motor (paper's sign convention).
    """
    if origin not in ("bead", "axis"):
        from .errors import ParameterError

        raise ParameterError("origin", origin, "'bead' or 'axis'")
    n, h = filament.n_segments, filament.segment_length
    step = rot_z(filament.torsion * h) @ rot_y(filament.kappa0 * h)
    n_body, dpsi = axis_angle(step)
    if n_body[2] < 0:  # orient the axis along the direction of progress
        n_body, dpsi = -n_body, -dpsi
    axis = np.asarray(axis, float)
    axis = axis / np.linalg.norm(axis)
    d0 = rotation_between(n_body, axis) @ _rot_about(n_body, phase)
    frames = np.empty((n + 1, 3, 3))
    frames[0] = d0
    for j in range(1, n + 1):
        frames[j] = frames[j - 1] @ step
    pos = np.zeros((n + 1, 3))
    pos[1:] = np.cumsum(h * frames[1:, :, 2], axis=0)
    # axis point: r_{j+1} - c = Rot(dpsi)(r_j - c) + rise·axis in the plane ⟂ axis
    d = pos[1] - pos[0]
    d_perp = d - (d @ axis) * axis
    u = np.cross(axis, d_perp)
    # For a rotation by dpsi about axis: (Rot − 1) x = d_perp, x ⟂ axis, solved in closed form.
    c, s = math.cos(dpsi), math.sin(dpsi)
    x = -0.5 * d_perp - s / (2 * (1 - c)) * u if abs(1 - c) > 1e-15 else np.zeros(3)
    axis_point = pos[0] - x
    radius = float(np.linalg.norm(x))
    pitch = abs(2 * math.pi * float(d @ axis) / dpsi) if dpsi else math.inf
    if origin == "axis":
        pos = pos - axis_point
        axis_point = np.zeros(3)
    return DiscreteHelix(pos, frames, axis_point, axis, radius, pitch, h)


def _rot_about(n: np.ndarray, angle: float) -> np.ndarray:
    n = n / np.linalg.norm(n)
    k = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def discrete_rod(frame0: np.ndarray, kappa, tau, h: float, origin=(0.0, 0.0, 0.0)):
    """(positions (N+1, 3), frames (N+1, 3, 3)) of the stress-free discrete rod whose joint j
    has intrinsic curvature ``kappa[j]`` and torsion ``tau[j]``: D_{j+1} = D_j R_z(τ_j h)
    R_y(κ_j h) from the hook frame ``frame0`` (the construction of :func:`discrete_helix`,
    joint by joint), bead 0 at ``origin``."""
    n = len(kappa)
    frames = np.empty((n + 1, 3, 3))
    frames[0] = frame0
    for j in range(n):
        frames[j + 1] = frames[j] @ rot_z(tau[j] * h) @ rot_y(kappa[j] * h)
    pos = np.zeros((n + 1, 3))
    pos[0] = origin
    pos[1:] = np.asarray(origin) + np.cumsum(h * frames[1:, :, 2], axis=0)
    return pos, frames
