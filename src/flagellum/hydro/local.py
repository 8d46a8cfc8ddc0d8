"""Local resistive-force drag of the discrete filament (paper Sec. 2.2, Eqs. (6)–(7)).

The one place that says which friction each bead, each bond spin and the hook frame carry.
The deterministic right-hand side (:func:`flagellum.rod.kernels.rhs`), the thermal forces of
the Brownian scheme (:func:`flagellum.integrate.brownian.thermal_forces`, whose covariance
2kT R/Δt must be built from the same friction R) and the rigid-helix quadrature over the
simulator's beads (:func:`flagellum.hydro.rft.bead_nodes`) all call these kernels.

* Bead i carries the length w = h (end beads h/2) and the friction
  w [γ∥ t t + γ⊥ (1 − t t)] with t the average of its two bond tangents (end beads: the
  tangent of their one bond).
* Bead 0 moves according to its anchor: not at all (``FIXED``), along z only on a load
  sphere of drag ζ = 6πηa that adds to the bead's own axial friction (``AXIAL``, Sec. 3.3),
  or freely with the isotropic drag ζ of a body sphere added (``FREE``); on a cell body
  (``CELL``) it is a point of the rigid body, which the rod kernels move as a whole
  (:mod:`flagellum.hydro.body`), and its own friction is part of the body's.
* A bond spins about its tangent with friction γR h; the hook frame turns with
  γR h t0 t0 + ½ γ⊥ h³ (1 − t0 t0) (rotation of a bond of length h about its end), and a
  clamped hook only about its tangent.

A nonlocal hydrodynamic model replaces these kernels by a mobility of the whole centreline;
see docs/architecture.md.
"""

from __future__ import annotations

import math

from numba import njit

from .._jit import FASTMATH

#: how bead 0 may move: with the filament (a free swimmer's body), along z only (load
#: sphere), or not at all (anchored), or with a cell body; the rod kernels use the same
#: codes for the anchor
FIXED, AXIAL, FREE, CELL = 0, 1, 2, 3


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def bead_node(T, i, n):
    """(tx, ty, tz, weight factor) of bead i: the averaged unit tangent of its bonds (rows
    1…n of ``T``; row 0 is the hook frame) and its share of a bond length (1/2 at the ends)."""
    if i == 0:
        return T[1, 0], T[1, 1], T[1, 2], 0.5
    if i == n:
        return T[n, 0], T[n, 1], T[n, 2], 0.5
    tx, ty, tz = T[i, 0] + T[i + 1, 0], T[i, 1] + T[i + 1, 1], T[i, 2] + T[i + 1, 2]
    nn = math.sqrt(tx * tx + ty * ty + tz * tz)
    return tx / nn, ty / nn, tz / nn, 1.0


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def bead_friction(T, i, n, h, gpar, gperp, anchor, zeta):
    """(tx, ty, tz, ζ∥, ζ⊥, mode) of bead i: friction ζ∥ along the unit tangent t and ζ⊥
    across it, and how the bead moves (``FREE``, ``AXIAL``, ``FIXED``, ``CELL``; beads i ≥ 1
    are free). For ``AXIAL`` (load sphere) ζ∥ is the friction along z: w (γ∥ t_z² + γ⊥ (1 − t_z²)) + ζ;
    for ``CELL`` the bead's own friction, which the cell body's motion takes up."""
    tx, ty, tz, wf = bead_node(T, i, n)
    w = wf * h
    if i > 0:
        return tx, ty, tz, w * gpar, w * gperp, FREE
    if anchor == FIXED:
        return tx, ty, tz, 0.0, 0.0, FIXED
    if anchor == AXIAL:
        return tx, ty, tz, w * (gpar * tz * tz + gperp * (1.0 - tz * tz)) + zeta, 0.0, AXIAL
    if anchor == CELL:
        return tx, ty, tz, w * gpar, w * gperp, CELL
    return tx, ty, tz, w * gpar + zeta, w * gperp + zeta, FREE


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def bead_velocity(fx, fy, fz, tx, ty, tz, zpar, zperp, mode):
    """Velocity of a bead under the force f, for the friction of :func:`bead_friction` (0 on
    a cell body: the body's motion sets it)."""
    if mode == FIXED or mode == CELL:
        return 0.0, 0.0, 0.0
    if mode == AXIAL:
        return 0.0, 0.0, fz / zpar
    ft = fx * tx + fy * ty + fz * tz
    ip, iq = 1.0 / zpar, 1.0 / zperp
    return iq * fx + (ip - iq) * ft * tx, iq * fy + (ip - iq) * ft * ty, iq * fz + (ip - iq) * ft * tz


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def bead_noise(c, gx, gy, gz, tx, ty, tz, zpar, zperp, mode):
    """Thermal force c R^{1/2} g of a bead with friction R (:func:`bead_friction`) from unit
    normals g; c = √(2kT/Δt) gives the covariance 2kT R/Δt (fluctuation–dissipation)."""
    if mode == FIXED:
        return 0.0, 0.0, 0.0
    if mode == AXIAL:
        return 0.0, 0.0, c * math.sqrt(zpar) * gz
    gt = gx * tx + gy * ty + gz * tz
    a, b = c * math.sqrt(zpar), c * math.sqrt(zperp)
    return a * gt * tx + b * (gx - gt * tx), a * gt * ty + b * (gy - gt * ty), a * gt * tz + b * (gz - gt * tz)


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def bead_directions(mode, vx, vy, vz):
    """The part of v along which a bead with this ``mode`` can move (directions of the
    random finite difference of the Itô drift)."""
    if mode == FIXED:
        return 0.0, 0.0, 0.0
    if mode == AXIAL:
        return 0.0, 0.0, vz
    return vx, vy, vz


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def spin_friction(h, grot):
    """Rotational friction γR h of a bond spinning about its tangent."""
    return grot * h


@njit(cache=True, inline="always", fastmath=FASTMATH, error_model="numpy")
def hook_friction(h, gperp, grot, clamped):
    """(about the tangent, across it) rotational friction of the hook frame; a clamped hook
    turns only about its tangent (friction across it 0 here means: no such rotation)."""
    return grot * h, 0.0 if clamped else 0.5 * gperp * h * h * h
