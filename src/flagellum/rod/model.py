"""The rod model: parameters + boundary conditions → right-hand side of the ODE.

:class:`RodModel` wraps the Numba kernels of :mod:`flagellum.rod.kernels` with the state
layout, the reference-frame charts and the workspace arrays, and exposes ``rhs(t, y)``
(scipy convention), the energy and the gradients.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from ..errors import SimulationError
from ..helix import DiscreteHelix, discrete_helix
from ..hydro import body as body_model
from ..hydro.dynamics import (CellBody, bonds_within, build_arguments, cell_build_arguments,
                              cell_correction_points, cell_frame, cell_local_mobility, cell_points,
                              correction, limits_used, local_mobility, moving_components,
                              near_beads, renew_into, rotated_limits_used, turn_into, turn_limit)
from ..hydro.options import Hydrodynamics
from ..motor import Boundary, Motor
from ..params import EndLoad, Params
from . import kernels as K

#: (lower, upper) bandwidth of the right-hand side's Jacobian in the bead-by-bead state
#: ordering; tight for every boundary and hook (tests/test_rod.py)
JACOBIAN_BAND = (15, 11)
#: with a cell body: its orientation (the state's last three values) couples to the first
#: beads and the hook, outside any band; the stiff solvers keep this band as the
#: preconditioner of a Krylov solve (CVODE does so for any band but the rod's)
CELL_JACOBIAN_BAND = (16, 12)
#: the state entries per bead: a nonlocal mobility's near field (ΔM between beads at most
#: :func:`~flagellum.hydro.dynamics.near_beads` apart) widens either band by this per bead
STATE_PER_BEAD = 4


def nonlocal_band(band: tuple[int, int], near: int) -> tuple[int, int]:
    """The Jacobian band ``band`` widened by a near field of ``near`` beads each way."""
    return band[0] + STATE_PER_BEAD * near, band[1] + STATE_PER_BEAD * near


_HOOK = {"free": K.HOOK_FREE, "elastic": K.HOOK_ELASTIC, "clamped": K.HOOK_CLAMPED}
_ANCHOR = {"fixed": K.ANCHOR_FIXED, "sphere": K.ANCHOR_SPHERE, "free": K.ANCHOR_FREE}
#: a renewal of ΔM that a stepper asks for (``refresh_mobility(due=True)``) turns it only
#: where the best rotation of the frozen beads leaves at most this fraction of ``refresh``
DUE_TURN_RESIDUAL = 0.1
_DRIVE = {"torque": K.DRIVE_TORQUE, "speed": K.DRIVE_SPEED, "law": K.DRIVE_LAW}


def state_size(n: int, cell: bool = False) -> int:
    """Length of the state of n segments (+ 3: a cell body's orientation φ)."""
    return 3 + 4 * (n + 1) + (3 if cell else 0)


def _beads(y: np.ndarray) -> np.ndarray:
    """(..., n+1, 4): (x, y, z, θ) per bead (a cell body's orientation, the last three
    values, left out)."""
    y = np.asarray(y)
    k = (y.shape[-1] - 3) // 4
    return y[..., 3:3 + 4 * k].reshape(y.shape[:-1] + (k, 4))


def positions(y: np.ndarray) -> np.ndarray:
    """Bead positions (n+1, 3) of a state (or (..., n+1, 3) for a stack of states)."""
    return _beads(y)[..., :3]


def angles(y: np.ndarray) -> np.ndarray:
    return _beads(y)[..., 3]


class RodModel:
    """Discrete Kirchhoff rod driven by a motor, in a frame rotating at ``omega_frame``.

    Parameters
    ----------
    params, motor, boundary : the physics.
    omega_frame : angular velocity [rad/s] of the computational frame about e_z. Lab-frame
        positions are R_z(omega_frame·t) applied to the state. A frame co-rotating with the
        filament makes the aligned steady state a fixed point.
    hydrodynamics : the bead mobility (:class:`~flagellum.hydro.dynamics.Hydrodynamics`;
        default local RFT). A nonlocal one enters through the frozen correction ΔM that
        :meth:`refresh_mobility` builds (the first :meth:`rhs` call builds it if needed).
    end_load : a load on the free end (:class:`~flagellum.params.EndLoad`), default none.
    segments : give each joint its own intrinsic curvature and torsion
        (:meth:`set_intrinsic`; a polymorphic filament), initially the filament's.
    """

    def __init__(self, params: Params | None = None, motor: Motor | None = None,
                 boundary: Boundary | None = None, omega_frame: float = 0.0,
                 hydrodynamics: Hydrodynamics | None = None, end_load: EndLoad | None = None,
                 segments: bool = False):
        self.params = params or Params()
        self.motor = motor or Motor()
        self.boundary = boundary or Boundary()
        self.hydrodynamics = hydrodynamics or Hydrodynamics()
        self.omega_frame = float(omega_frame)
        f = self.params.filament
        self.n = f.n_segments
        self.h = f.segment_length
        self.gammas = self.params.gammas
        self.sphere_drag = self.boundary.sphere_drag(self.params.fluid.viscosity)
        self.cell = self.boundary.is_cell  #: a cell body free in 3D (:mod:`flagellum.hydro.body`)
        n1 = self.n + 1
        self.ref_u = np.zeros((n1, 3))
        self.ref_e = np.zeros((n1, 3))
        self.ref_m = np.zeros(n1)  #: last known reference twist of each joint (branch of ψ)
        self._nonlocal = not self.hydrodynamics.is_local
        self._solved_drive = self.motor.drive != "torque"  #: the kernel solves for the torque
        # ΔM over the beads, or a cell's slots (V, beads 1 … n, Ω) (hydro.dynamics.cell_correction)
        self._ws = K.workspace(self.n, 3 * (n1 + self.cell) if self._nonlocal else 0)
        #: scratch frames of :meth:`change_coordinates` (T, E1, E2, LEN, S, A1)
        self._scratch = tuple(np.zeros((n1, 3)) if k != 3 else np.zeros(n1) for k in range(6))
        self._frozen = None  #: bead positions the nonlocal correction ΔM was built at
        self._turn_limit = None  #: largest bond turn between builds of ΔM [rad] (turn_limit)
        #: build ΔM from the symmetric part of the nonlocal mobility (a thermal stepper sets it)
        self.symmetric_mobility = False
        self._zf = np.zeros((n1, 3))
        self._zm = np.zeros(n1)
        self._zh = np.zeros(3)
        self.last_force = np.zeros(3)  #: elastic force on bead 0 at the last rhs call
        self._colors = None  # (key, (color, lo, hi)) of jacobian_colors
        self._cell_geometry = None  # cell_geometry's, once
        gp, gn, gr = self.gammas
        ccw, cw = self.motor.law_table()
        b = self.boundary
        cell = (body_model.kernel_block(b.body_radius, b.body_aspect, b.motor_offset,
                                        self.params.fluid.viscosity) if self.cell else ())
        self._rotation = slice(K.P_LAW + len(ccw) + len(cw) + body_model.ROTATION,
                               K.P_LAW + len(ccw) + len(cw) + body_model.ROTATION + 10)
        self.prm = np.array([self.h, f.bend_rigidity, f.twist_rigidity, f.stretch_modulus,
                             f.kappa0, f.torsion, self.boundary.hook_stiffness,
                             self.sphere_drag, gp, gn, gr, self.motor(0.0), self.omega_frame, 1.0,
                             self.body_rotation_per_torque, 0.0, *ccw, *cw, *cell])
        anchor = K.ANCHOR_CELL if self.cell else _ANCHOR[self.boundary.anchor]
        self.iprm = np.array([self.n, _HOOK[self.boundary.hook], anchor, 0,
                              K.HYDRO_FROZEN if self._nonlocal else K.HYDRO_LOCAL,
                              _DRIVE[self.motor.drive], len(ccw) // 2, len(cw) // 2, 0, 0,
                              near_beads(self.h) if self._nonlocal else 0], dtype=np.int64)
        self.end_load = end_load if end_load is not None and end_load.active else None
        self.segments = bool(segments)
        self.trap_origin = 0.0  #: z [µm] of the trap's centre at t = 0 (the simulator's start)
        if self.end_load is not None or self.segments:  # the kernels' extra block (I_EXTRA)
            load = self.end_load or EndLoad()
            extra = [load.force, load.trap_stiffness, 0.0]
            if self.segments:
                extra += [f.kappa0] * self.n + [f.torsion] * self.n
            self.iprm[K.I_EXTRA], self.iprm[K.I_SEGMENTS] = len(self.prm), int(self.segments)
            self.prm = np.concatenate([self.prm, extra])
        # the kernels of this model: without a cell body or per-joint shapes the pruned ones
        # (the same numbers, less to compile; rod.kernels.rod_rhs)
        special = K.specialised(self.iprm)
        self.rhs_kernel = K.rod_rhs if special else K.rhs
        self.jacobian_kernel = K.rod_colored_jacobian if special else K.colored_jacobian
        self.last_torque = self.prm[K.P_TORQUE] if self.motor.drive == "torque" else 0.0
        self.last_relative_motor_speed = 0.0  #: motor speed relative to the body at the last rhs call

    @property
    def state_size(self) -> int:
        return state_size(self.n, self.cell)

    # -- state -----------------------------------------------------------------------
    def initial_state(self, helix: DiscreteHelix | None = None) -> np.ndarray:
        """State of the stress-free discrete helix (bead 0 at the origin, axis along −z).

        Sets the charts to the helix' own frames, so all material angles start at 0. With a
        clamped hook, the whole helix is turned so that its hook frame points along −z. A cell
        body starts at the identity orientation (its motor axis along e_z, the body on the
        +z side of the motor).
        """
        dh = helix or discrete_helix(self.params.filament)
        pos, frames = dh.positions.copy(), dh.frames.copy()
        if self.boundary.hook == "clamped":
            from ..helix import rotation_between

            rot = rotation_between(frames[0][:, 2], np.array([0.0, 0.0, -1.0]))
            pos = pos @ rot.T
            frames = np.einsum("ij,njk->nik", rot, frames)
        y = np.zeros(self.state_size)
        y[:3] = frames[0][:, 2]
        _beads(y)[:, :3] = pos
        self.ref_u[:] = frames[:, :, 2]
        self.ref_e[:] = frames[:, :, 0]
        self.update_reference_twists(y)
        return y

    # -- end load and per-joint intrinsic shape -----------------------------------------
    def trap_centre(self, t: float) -> float:
        """z [µm] of the trap's centre at time t: the initial free end, moving along −e_z at
        the pull rate."""
        return self.trap_origin - (self.end_load.pull_rate * t if self.end_load else 0.0)

    def end_force(self, t: float, y: np.ndarray) -> float:
        """The load pulling the free end along −e_z [pN] (:class:`~flagellum.params.EndLoad`;
        0 without one)."""
        if self.end_load is None:
            return 0.0
        return -K.end_load(y, self.n, self.end_load.force, self.end_load.trap_stiffness,
                           self.trap_centre(t))

    def set_intrinsic(self, kappa: np.ndarray, tau: np.ndarray) -> None:
        """Intrinsic curvature and signed torsion [1/µm] of each of the n joints (a model
        built with ``segments``)."""
        if not self.segments:
            raise ValueError("set_intrinsic needs a RodModel built with segments=True")
        o = self.iprm[K.I_EXTRA] + K.X_SEG
        self.prm[o:o + self.n] = kappa
        self.prm[o + self.n:o + 2 * self.n] = tau

    @property
    def intrinsic(self) -> tuple[np.ndarray, np.ndarray]:
        """(κ, τ) of the joints (copies): the filament's, or those of :meth:`set_intrinsic`."""
        if not self.segments:
            f = self.params.filament
            return np.full(self.n, f.kappa0), np.full(self.n, f.torsion)
        o = self.iprm[K.I_EXTRA] + K.X_SEG
        return self.prm[o:o + self.n].copy(), self.prm[o + self.n:o + 2 * self.n].copy()

    def joint_strains(self, y: np.ndarray) -> np.ndarray:
        """(n, 3) strains (Ω1, Ω2, Ω3) [1/µm] of the joints at state y (joint j: between
        frames j and j+1)."""
        w = _Workspace(*self._ws)
        out = np.zeros((self.n, 3))
        kap, tau = self.intrinsic
        K.elastic(y, *self._kernel_args(), self.ref_u, self.ref_e, self.ref_m,
                  w.T, w.E1, w.E2, w.LEN, w.S, w.GT, w.GTH, w.A1, kap, tau, out)
        return out

    def update_reference_twists(self, y: np.ndarray) -> None:
        """Follow the branch of each joint's reference twist (call between steps)."""
        w = self._fill_frames(y)
        raw = np.zeros(self.n + 1)
        K.reference_twists(self.n, w.T, w.A1, raw)
        self.ref_m[1:] = raw[1:] + 2 * np.pi * np.round((self.ref_m[1:] - raw[1:]) / (2 * np.pi))

    def rechart(self, y: np.ndarray, threshold: float = -0.5) -> bool:
        """Move chart poles that a tangent approaches the singularity of (t·u < threshold).

        The new pole is the current tangent and the new reference vector the current
        reference a1, so the material frames and the state are unchanged. A cell body's
        orientation φ is replaced (in ``y``) by the same rotation with |φ| ≤ π once |φ| > π
        (:func:`flagellum.hydro.body.wrap_rotvec`); that counts as a change too.
        """
        wrapped = self.cell and body_model.wrap_rotvec(y[-3:])
        self.update_reference_twists(y)
        w = self._fill_frames(y)
        bad = np.einsum("ij,ij->i", w.T, self.ref_u) < threshold
        if not bad.any():
            return bool(wrapped)
        self.ref_u[bad] = w.T[bad]
        self.ref_e[bad] = w.A1[bad]
        return True

    def change_coordinates(self, y: np.ndarray, charts, angle=0.0, only=None) -> np.ndarray:
        """The state ``y``, given in the charts ``charts`` = (poles, reference vectors), in
        the model's current charts and in coordinates turned by ``angle`` [rad] about e_z
        (positions and the hook tangent turned, the charts kept as they are in the new
        coordinates): the same material frames, so the same physical state. ``y`` may be a
        stack of states (k, size) with ``angle`` one per state. ``only``: the frames whose θ
        can change (a boolean (N+1,) mask; None: all). Not for a cell body (its orientation
        would turn too)."""
        if self.cell:
            raise ValueError("change_coordinates: not for a cell body")
        Y = np.atleast_2d(np.asarray(y, float))
        out = np.empty_like(Y)
        angles = np.broadcast_to(np.asarray(angle, float), (len(Y),)).copy()
        mask = np.ones(self.n + 1, np.bool_) if only is None else np.asarray(only, np.bool_)
        K.change_coordinates(Y, self.n, np.asarray(charts[0], float), np.asarray(charts[1], float),
                             self.ref_u, self.ref_e, angles, mask, out, *self._scratch)
        return out.reshape(np.shape(y))

    def charts(self):
        """(poles, reference vectors, reference twists): everything besides y that the
        right-hand side depends on."""
        return self.ref_u.copy(), self.ref_e.copy(), self.ref_m.copy()

    def set_charts(self, ref_u, ref_e, ref_m=None):
        self.ref_u[:] = ref_u
        self.ref_e[:] = ref_e
        if ref_m is not None:
            self.ref_m[:] = ref_m

    # -- physics ----------------------------------------------------------------------
    def _kernel_args(self):
        f = self.params.filament
        return (self.n, self.h, f.bend_rigidity, f.twist_rigidity, f.stretch_modulus,
                f.kappa0, f.torsion, self.boundary.hook_stiffness)

    def energy(self, y: np.ndarray) -> float:
        """Elastic energy [pN·µm] (bending, twist, stretching, hook)."""
        w = _Workspace(*self._ws)
        if self.segments:
            return K.elastic(y, *self._kernel_args(), self.ref_u, self.ref_e, self.ref_m,
                             w.T, w.E1, w.E2, w.LEN, w.S, w.GT, w.GTH, w.A1, *self.intrinsic)
        return K.elastic(y, *self._kernel_args(), self.ref_u, self.ref_e, self.ref_m,
                         w.T, w.E1, w.E2, w.LEN, w.S, w.GT, w.GTH, w.A1)

    def gradients(self, y: np.ndarray):
        """(E, ∂E/∂r (n+1,3), ∂E/∂θ (n+1), G_t (n+1,3)) with frames transported (gauge-free)."""
        w = _Workspace(*self._ws)
        e = self.energy(y)
        n, h, _, _, Kst = self._kernel_args()[:5]
        dr = np.zeros((self.n + 1, 3))
        K.bead_gradient(n, h, Kst, w.T, w.LEN, w.GT, dr)
        return e, dr, w.GTH.copy(), w.GT.copy()

    @property
    def jacobian_band(self) -> tuple[int, int]:
        """(lower, upper) bandwidth of the Jacobian the stiff solvers use for this model."""
        band = CELL_JACOBIAN_BAND if self.cell else JACOBIAN_BAND
        return nonlocal_band(band, int(self.iprm[K.I_NEAR])) if self._nonlocal else band

    def jacobian_colors(self, kl: int, ku: int):
        """(color, lo, hi) for :func:`~flagellum.rod.kernels.colored_jacobian`: the rows each
        column of the Jacobian can reach, found once from finite differences at two generic
        states (perturbed shape, charts off-centre, motor and frame rotation on; a structural
        zero gives an exactly zero difference), coloured with as few colours as possible."""
        key = (kl, ku)
        if self._colors is None or self._colors[0] != key:
            ny = self.state_size
            rng = np.random.default_rng(12345)
            prm = self.prm.copy()
            prm[K.P_TORQUE], prm[K.P_OMEGA], prm[K.P_SECANT] = 1.0, 300.0, 0.0
            charts = (self.ref_u.copy(), self.ref_e.copy(), self.ref_m.copy())
            frozen = (self._ws[-1].copy(), None if self._frozen is None else self._frozen.copy())
            nz = np.zeros((ny, 2 * kl + ku + 1), bool)
            reach = np.zeros((ny, ny), bool)  # a cell's: reach[i, j], row i moved by column j
            ab = np.zeros_like(nz, dtype=float)
            for _ in range(2):
                y = self.initial_state()
                y[3:] += rng.normal(0.0, 0.02, ny - 3)
                y[:3] += rng.normal(0.0, 0.1, 3)
                self.refresh_mobility(y, force=True)  # no-op for the local model
                f0 = np.zeros(ny)
                self.rhs_kernel(y, f0, prm, self.iprm, self.ref_u, self.ref_e, self.ref_m,
                                self._zf, self._zm, self._zh, self._ws)
                # the full band's colouring (numpy: no kernel of its own to compile)
                self.jacobian_kernel(y, f0, prm, self.iprm, self.ref_u, self.ref_e, self.ref_m,
                                     self._zf, self._zm, self._zh, self._ws, kl, ku, ab, 1.0,
                                     np.zeros(ny), np.zeros(ny), *K.band_colors.py_func(ny, kl, ku))
                nz |= ab != 0.0
                if self.cell:
                    reach |= self._reach(y, prm)
            self.set_charts(*charts)
            self._ws[-1][:], self._frozen = frozen
            rows = np.arange(ny)[:, None] + np.arange(-kl - ku, kl + 1)[None, :]
            rows = np.where(nz, rows, -1)
            hi = rows.max(axis=1)
            lo = np.where(nz, rows, ny).min(axis=1)
            lo, hi = np.minimum(lo, np.arange(ny)), np.maximum(hi, np.arange(ny))
            if self.cell:  # the orientation's rows and columns reach outside the band
                inside = np.arange(ny)[:, None]
                reach |= (inside >= lo[None, :]) & (inside <= hi[None, :])
                color = K.reach_colors(reach, lo)
            else:
                color = K.interval_colors(lo, hi)
            self._colors = (key, (color, lo.astype(np.int64), hi.astype(np.int64)))
        return self._colors[1]

    def _reach(self, y: np.ndarray, prm: np.ndarray) -> np.ndarray:
        """(ny, ny) mask of the rows each column of the colored Jacobian's operator moves at
        y (one column at a time), outside the band too: a cell body's orientation couples to
        the first beads and the hook (and, with a nonlocal near field, to the beads near
        bead 0), rows that a column of the same colour would otherwise read as its own."""
        ny = self.state_size
        ip = self.iprm.copy()
        if ip[K.I_HYDRO] == K.HYDRO_FROZEN:  # the operator colored_jacobian differentiates
            ip[K.I_HYDRO] = K.HYDRO_BANDED
        f0, f1 = np.zeros(ny), np.zeros(ny)
        args = (prm, ip, self.ref_u, self.ref_e, self.ref_m, self._zf, self._zm, self._zh, self._ws)
        self.rhs_kernel(y, f0, *args)
        out = np.zeros((ny, ny), bool)
        for j in range(ny):
            yj = y.copy()
            yj[j] += 1e-7 * max(1.0, abs(y[j]))
            self.rhs_kernel(yj, f1, *args)
            out[:, j] = f1 != f0
        return out

    def set_omega_frame(self, omega: float) -> None:
        self.omega_frame = float(omega)
        self.prm[K.P_OMEGA] = self.omega_frame

    def refresh_mobility(self, y: np.ndarray, force: bool = False, due: bool = False) -> bool:
        """Rebuild the frozen nonlocal correction ΔM at the beads of y if one has moved by more
        than ``hydrodynamics.refresh`` since the last build, or a bond has turned by more than
        :func:`~flagellum.hydro.dynamics.turn_limit` (always with ``force``), or turn it where
        the beads moved rigidly within those limits; returns whether it did. ``due``: renew it
        whatever the beads did, turned only where the rotation leaves at most
        :data:`DUE_TURN_RESIDUAL` of ``refresh`` (a renewal that a stepper's secant model
        continues from: a turn's residual error would be a kink in it). A no-op for the
        local model."""
        if not self._nonlocal:
            return False
        x = self._mobility_points(y)
        n1 = self.n + 1
        dm = self._ws[-1]
        if not force and self._frozen is not None:
            bond = self.turn_limit * self.h
            if (not due and np.max(np.abs(x - self._frozen)) <= self.hydrodynamics.refresh
                    and bonds_within(x[:n1], self._frozen[:n1], bond)):
                return False
            if not self.cell:
                renew_into(x, self._frozen, dm, dm, self.turn_arguments(due),
                           self.build_arguments())
                return True
            if turn_into(x, self._frozen, dm, dm, *self.turn_arguments(due)):
                self.unturn_mobility()
                return True
        if self._frozen is None:
            self._frozen = np.empty_like(x)
        self._correction(x, out=dm)
        self._frozen[:] = x
        self.unturn_mobility()
        return True

    def turn_arguments(self, due: bool = True) -> tuple:
        """The arguments of :func:`~flagellum.hydro.dynamics.turn_into` after ΔM: a rigid
        rotation of the frozen beads about bead 0 turns ΔM where it leaves at most
        ``refresh`` (``due``: :data:`DUE_TURN_RESIDUAL` of it) and turns no bond past the turn
        limit; about e_z only on a load sphere or with a free swimmer's sphere, which sits at
        x_0 + a e_z."""
        b = self.boundary
        anchor = _ANCHOR[b.anchor]
        about_z = anchor == K.ANCHOR_SPHERE or (b.anchor != "fixed" and bool(b.sphere_radius))
        within = self.hydrodynamics.refresh * (DUE_TURN_RESIDUAL if due else 1.0)
        return (float(within), float(self.turn_limit * self.h), bool(about_z),
                anchor == K.ANCHOR_FIXED, self.n + 1)

    def build_arguments(self) -> tuple:
        """The arguments of ΔM's compiled build after the positions
        (:func:`~flagellum.hydro.dynamics.build_arguments`; not for a cell body)."""
        fluid = self.params.fluid
        return build_arguments(self.n, self.h, self.gammas, _ANCHOR[self.boundary.anchor],
                               self.sphere_drag, fluid.filament_radius, fluid.viscosity,
                               self.boundary.sphere_radius or 0.0, self.symmetric_mobility)

    @property
    def frozen_beads(self) -> np.ndarray | None:
        """The bead positions ((n+1, 3)) at which ΔM was last built or turned (None before
        the first build)."""
        return None if self._frozen is None else self._frozen[:self.n + 1]

    @property
    def mobility_points(self) -> np.ndarray | None:
        """The mobility points (:meth:`_mobility_points`: the beads, and a cell body's centre
        and front pole) at which ΔM was last built or turned (None before the first build)."""
        return self._frozen

    def mobility_use(self, y: np.ndarray, rotated: bool = False) -> float:
        """The fraction of the limits of :meth:`refresh_mobility` that the beads of y have used
        since ΔM was last built or turned: the largest bead displacement over
        ``hydrodynamics.refresh`` or the largest bond change over the turn limit's length,
        whichever is larger (0 for the local model or before the first build). ``rotated``
        (a cell body): after the best rotation of the frozen points onto y's, which
        :meth:`turn_mobility` applies."""
        if not self._nonlocal or self._frozen is None:
            return 0.0
        x = np.ascontiguousarray(self._mobility_points(y))
        args = (self._frozen, self.n + 1, self.hydrodynamics.refresh, self.turn_limit * self.h)
        if rotated:
            return rotated_limits_used(x, *args, np.empty((3, 3)))
        return limits_used(x, *args)

    def turn_mobility(self, y: np.ndarray) -> float:
        """A cell body: let the kernel apply the frozen ΔM turned by the best rotation R of the
        frozen points onto y's, R ΔM Rᵀ (its forces turned by Rᵀ, its velocities by R: the
        mobility of the turned cell, by the isotropy of Stokes flow), until the next build;
        returns the part of the limits used after the turn (:meth:`mobility_use`)."""
        if self._frozen is None or self.hydrodynamics.refresh <= 0.0:  # (0: rebuilt at every
            return 0.0  # right-hand side, :meth:`rhs`)
        R = np.empty((3, 3))
        used = rotated_limits_used(np.ascontiguousarray(self._mobility_points(y)), self._frozen,
                                   self.n + 1, self.hydrodynamics.refresh,
                                   self.turn_limit * self.h, R)
        self.prm[self._rotation] = (*R.ravel(), 1.0)
        return used

    def unturn_mobility(self) -> None:
        """ΔM applied as built (a cell body's rotation of :meth:`turn_mobility` off)."""
        if self.cell:
            self.prm[self._rotation] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0)

    def correction_at_points(self, x: np.ndarray) -> np.ndarray:
        """ΔM built at the mobility points x (:meth:`_mobility_points`' layout)."""
        return self._correction(np.ascontiguousarray(x, dtype=float))

    def correction_at(self, y: np.ndarray) -> np.ndarray:
        """ΔM built at state y (returned, the frozen one left as it is; with
        :attr:`symmetric_mobility` from the symmetric mobility)."""
        return self._correction(self._mobility_points(y))

    def mobility_matrix(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(M, free): the bead mobility the right-hand side applies at y, the local operator
        at y plus the frozen ΔM, over the beads or a cell body's slots (V, beads 1 … n, Ω;
        :func:`~flagellum.hydro.dynamics.cell_mobility`), and the mask of the components the
        anchor leaves free (the others' rows and columns are zero). Spins and the hook frame
        keep their local friction and are not part of it."""
        if not self._nonlocal:
            raise ValueError("mobility_matrix: only for a nonlocal mobility")
        x = positions(y)
        h, (gpar, gperp, _) = self.h, self.gammas
        if self.cell:
            ml = cell_local_mobility(x, h, gpar, gperp, self.params.fluid.viscosity,
                                     self._cell_body(self._mobility_points(y)))
            return ml + self.applied_correction, np.ones(len(ml), bool)
        anchor, zeta = self.mobility_arguments()[2:4]
        return (local_mobility(x, h, gpar, gperp, anchor, zeta) + self.applied_correction,
                moving_components(anchor, len(x)))

    @property
    def applied_correction(self) -> np.ndarray:
        """The ΔM the kernel applies now: the workspace's DM plus prm[P_SECANT] times its DG
        (a secant model's slope, set by the BDF per right-hand side)."""
        w = float(self.prm[K.P_SECANT])
        return self._ws[-1] + w * self._ws[-2] if w else self._ws[-1].copy()

    def _correction(self, x: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """ΔM at the mobility points x (:meth:`_mobility_points`), into ``out`` if given."""
        if self.cell:
            if out is None:
                out = np.empty((3 * len(x) - 3, 3 * len(x) - 3))
            cell_correction_points(x, *self.cell_build_arguments(), out)
            return out
        return correction(x, *self.mobility_arguments(), symmetric=self.symmetric_mobility,
                          out=out)

    @property
    def turn_limit(self) -> float:
        """The largest bond turn [rad] between two builds of ΔM
        (:func:`~flagellum.hydro.dynamics.turn_limit`), from the initial state: a function of
        the parameters alone, so a resumed run rebuilds where the original did."""
        if self._turn_limit is None:
            charts = self.charts()  # (initial_state sets the charts)
            x = self._mobility_points(self.initial_state())
            self.set_charts(*charts)
            self._turn_limit = turn_limit(self._correction(x), x[:self.n + 1], self.h, self.gammas)
        return self._turn_limit

    def _mobility_points(self, y: np.ndarray) -> np.ndarray:
        """The points the nonlocal mobility depends on: the beads, and for a cell body its
        centre and its front pole (which fix its position and orientation)."""
        if not self.cell:
            return positions(y)
        out = np.empty((self.n + 3, 3))
        cell_points(np.ascontiguousarray(y, dtype=float), self.n + 1, *self.cell_geometry(), out)
        return out

    def cell_geometry(self) -> tuple:
        """(axis, motor offset) in the body frame and the polar semi-axis [µm]: the arguments
        of :func:`~flagellum.hydro.dynamics.cell_points` after the state and n + 1."""
        if self._cell_geometry is None:
            b = self.boundary
            g = body_model.body_geometry(b.body_radius, b.body_aspect, b.motor_offset)
            self._cell_geometry = (g.axis, g.offset, float(b.body_aspect * b.body_radius))
        return self._cell_geometry

    def cell_build_arguments(self) -> tuple:
        """The arguments of :func:`~flagellum.hydro.dynamics.cell_correction_points` after
        the points (with :attr:`symmetric_mobility`)."""
        fluid, b = self.params.fluid, self.boundary
        return cell_build_arguments(self.n, self.h, self.gammas, fluid.filament_radius,
                                    fluid.viscosity, b.body_radius, b.body_aspect,
                                    b.hook == "clamped", self.symmetric_mobility)

    def _cell_body(self, points: np.ndarray) -> CellBody:
        """The cell body of :meth:`_mobility_points` for :mod:`flagellum.hydro.dynamics`."""
        b = self.boundary
        centre, axis = cell_frame(np.ascontiguousarray(points, dtype=float))
        return CellBody(centre, axis, b.body_radius, b.body_aspect,
                        self.cell_build_arguments()[8])  # (a clamped hook's friction)

    def mobility_arguments(self) -> tuple:
        """The arguments of :func:`flagellum.hydro.dynamics.correction` after the positions:
        (h, gammas, anchor code, sphere drag, filament radius, viscosity, sphere radius)."""
        fluid = self.params.fluid
        return (self.h, self.gammas, _ANCHOR[self.boundary.anchor], self.sphere_drag,
                fluid.filament_radius, fluid.viscosity, self.boundary.sphere_radius or 0.0)

    def rhs(self, t: float, y: np.ndarray, noise_f=None, noise_m=None, out=None) -> np.ndarray:
        """dy/dt at time t (scipy's ``fun(t, y)``); optional thermal forces/torques."""
        if self._nonlocal and (self._frozen is None or self.hydrodynamics.refresh == 0.0):
            # refresh 0: rebuilt unless the beads are exactly where it was built (the same ΔM)
            self.refresh_mobility(y, force=self._frozen is None)
        ydot = np.empty_like(y) if out is None else out
        self.prm[K.P_TORQUE] = self.motor(t)
        if self.end_load is not None:
            self.prm[self.iprm[K.I_EXTRA] + K.X_TRAP_Z] = self.trap_centre(t)
        res = self.rhs_kernel(y, ydot, self.prm, self.iprm, self.ref_u, self.ref_e, self.ref_m,
                              self._zf if noise_f is None else noise_f,
                              self._zm if noise_m is None else noise_m, self._zh, self._ws)
        force = self.last_force
        force[0], force[1], force[2] = res[1], res[2], res[3]  # (a slice from a tuple: 1 µs)
        self.last_energy, self.last_motor_speed, self.last_torque = res[0], res[4], res[5]
        self.last_relative_motor_speed = res[6]
        if self.cell:
            self.last_cell = res[7]
        if self._solved_drive and not math.isfinite(self.last_torque):
            raise SimulationError(f"motor drive {self.motor.drive!r}: no operating point at "
                                  f"t = {t:.6g} s (the hook cannot turn about the motor axis)")
        return ydot

    @property
    def body_rotation_per_torque(self) -> float:
        """−(body rotation rate)/M [rad/(s·pN·µm)]: 1/(8πηa³) for a free swimmer with a
        body sphere, else 0 (the body does not turn)."""
        b = self.boundary
        if b.anchor != "free" or not b.sphere_radius:
            return 0.0
        return 1.0 / (8 * math.pi * self.params.fluid.viscosity * b.sphere_radius ** 3)

    def body_motion(self, t: float, y: np.ndarray) -> dict:
        """A cell body's state and motion at time t, state ``y`` (computational frame; lab
        velocities):
        ``position`` of its centre [µm], unit ``axis``, ``motor_axis`` m and ``offset`` d
        (centre → motor point, bead 0) [µm], ``orientation`` Q (3, 3), ``angular_velocity``
        Ω [rad/s], ``velocity`` of the centre [µm/s], the hook frame's ``hook_rate`` ω_hook·m
        and the motor speed ``relative`` to the body [rad/s], the motor ``torque`` [pN·µm]."""
        if not self.cell:
            raise ValueError("body_motion needs a cell body")
        self.rhs(t, y)
        cm = self.last_cell
        b = self.boundary
        g = body_model.body_geometry(b.body_radius, b.body_aspect, b.motor_offset)
        q = body_model.rotvec_matrix(y[-3:])
        d = q @ g.offset
        return {"position": positions(y)[0] - d, "axis": q @ g.axis, "motor_axis": q @ g.motor_axis,
                "offset": d, "orientation": q, "angular_velocity": cm[4:7].copy(),
                "velocity": cm[7:10].copy(), "hook_rate": float(cm[16]),
                "relative": float(cm[17]), "torque": float(cm[0])}

    def bead_force(self, t: float, y: np.ndarray) -> np.ndarray:
        """Elastic force on bead 0 (the anchor) at state y."""
        self.rhs(t, y)
        return self.last_force.copy()

    def to_lab(self, t, pos: np.ndarray) -> np.ndarray:
        """Rotate computational-frame positions (..., 3) at time(s) t into the lab frame."""
        ang = self.omega_frame * np.asarray(t, float)
        c, s = np.cos(ang), np.sin(ang)
        out = np.array(pos, float, copy=True)
        x, yy = pos[..., 0], pos[..., 1]
        if np.ndim(ang):
            shape = (-1,) + (1,) * (pos.ndim - 2)
            c, s = c.reshape(shape), s.reshape(shape)
        out[..., 0] = c * x - s * yy
        out[..., 1] = s * x + c * yy
        return out

    # -- frames -----------------------------------------------------------------------
    @property
    def kernel_arrays(self) -> tuple:
        """The arrays the kernels take after the state, in their order: (prm, iprm, ref_u,
        ref_e, ref_m, ext_f, ext_m, ext_hook, workspace), for integrators that call
        :func:`~flagellum.rod.kernels.rhs` or :func:`~flagellum.rod.kernels.colored_jacobian`
        themselves (the extra forces are zero; the arrays are the model's, not copies)."""
        return (self.prm, self.iprm, self.ref_u, self.ref_e, self.ref_m, self._zf, self._zm,
                self._zh, self._ws)

    def frames(self, y: np.ndarray | None = None) -> "Frames":
        """The frames of state ``y`` in the current charts (copies); without ``y``, those of
        the last :meth:`rhs`, :meth:`energy` or :meth:`frames` call. Row 0 is the hook frame."""
        w = _Workspace(*self._ws) if y is None else self._fill_frames(y)
        return Frames(w.T.copy(), w.E1.copy(), w.E2.copy(), w.LEN.copy(), w.S.copy(), w.A1.copy())

    def _fill_frames(self, y: np.ndarray) -> "_Workspace":
        w = _Workspace(*self._ws)
        K.frames(y, self.n, self.ref_u, self.ref_e, w.T, w.E1, w.E2, w.LEN, w.S, w.A1)
        return w


class Frames(NamedTuple):
    """Frames of a rod state (:meth:`RodModel.frames`): row i belongs to frame i (0: the hook
    frame, i ≥ 1: bond i from bead i−1 to bead i), computational frame."""

    tangents: np.ndarray  #: (N+1, 3) unit tangents t_i (row 0: u0/|u0|)
    e1: np.ndarray  #: (N+1, 3) first material vectors, cos θ a1 + sin θ t × a1
    e2: np.ndarray  #: (N+1, 3) second material vectors, t × e1
    lengths: np.ndarray  #: (N+1,) bond lengths [µm] (row 0: |u0|)
    spin: np.ndarray  #: (N+1, 3) spin connection −(u × t)/(1 + u·t) of the charts
    reference: np.ndarray  #: (N+1, 3) reference vectors a1 = P(u→t) e of the charts


class _Workspace(NamedTuple):
    """The arrays of :func:`flagellum.rod.kernels.workspace`, by name."""

    T: np.ndarray
    E1: np.ndarray
    E2: np.ndarray
    LEN: np.ndarray
    S: np.ndarray
    GT: np.ndarray
    GTH: np.ndarray
    DR: np.ndarray
    V: np.ndarray
    A1: np.ndarray
    CW: np.ndarray
    DG: np.ndarray
    DM: np.ndarray
