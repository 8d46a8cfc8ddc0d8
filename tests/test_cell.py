"""The whole swimming cell: a rigid body (sphere or prolate spheroid) free in 3D with the
motor on its surface (flagellum.hydro.body, the cell path of flagellum.rod.kernels.rhs)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flagellum.errors import ParameterError
from flagellum.hydro import body as Bd
from flagellum.hydro import rft
from flagellum.hydro.options import Hydrodynamics
from flagellum.motor import Boundary, Motor, MotorLaw
from flagellum.params import Params
from flagellum.rod.model import RodModel, positions, state_size
from flagellum.simulator import Simulator, SolverOptions

ETA = Params().fluid.viscosity


# -- resistance of the body -------------------------------------------------------------

def _perrin(a: float, c: float, eta: float):
    """Prolate spheroid (semi-axes c > a) in F. Perrin's form, J. Phys. Radium 5, 497 (1934)
    (translation) and the rotational coefficients as corrected by S. H. Koenig, Biopolymers
    14, 2421 (1975): with S = 2 (c² − a²)^(−1/2) ln((c + √(c² − a²))/a),
    f∥ = 16πη(c² − a²)/((2c² − a²) S − 2c), f⊥ = 32πη(c² − a²)/((2c² − 3a²) S + 2c),
    T∥ = 32πη(c² − a²) a²/(3 (2c − a² S)), T⊥ = 32πη(c⁴ − a⁴)/(3 ((2c² − a²) S − 2c))."""
    q = c * c - a * a
    S = 2 / math.sqrt(q) * math.log((c + math.sqrt(q)) / a)
    return (16 * math.pi * eta * q / ((2 * c * c - a * a) * S - 2 * c),
            32 * math.pi * eta * q / ((2 * c * c - 3 * a * a) * S + 2 * c),
            32 * math.pi * eta * q * a * a / (3 * (2 * c - a * a * S)),
            32 * math.pi * eta * (c ** 4 - a ** 4) / (3 * ((2 * c * c - a * a) * S - 2 * c)))


@pytest.mark.parametrize("aspect", [1.05, 2.0, 5.0, 20.0])
def test_spheroid_resistance_matches_perrin(aspect):
    """The Kim & Karrila (1991) form of the code against Perrin's (1934) closed forms, an
    independent way of writing the same exact Stokes solution."""
    r = Bd.body_resistance(0.5, aspect, ETA)
    np.testing.assert_allclose(r, _perrin(0.5, 0.5 * aspect, ETA), rtol=1e-10)


def test_sphere_limit():
    """p = 1: Stokes' 6πηa and the rotating sphere's 8πηa³ (Lamb, Hydrodynamics, §334), and
    the limit p → 1 is continuous (the series for small eccentricity, no cancellation)."""
    a = 0.7
    exact = (6 * math.pi * ETA * a,) * 2 + (8 * math.pi * ETA * a ** 3,) * 2
    np.testing.assert_allclose(Bd.body_resistance(a, 1.0, ETA), exact, rtol=1e-15)
    np.testing.assert_allclose(Bd.body_resistance(a, 1.0 + 1e-9, ETA), exact, rtol=1e-8)
    np.testing.assert_allclose(Bd.spheroid_coefficients(1.0 + 1e-12), 1.0, rtol=1e-10)


def test_slender_limit():
    """p → ∞: the slender-spheroid asymptotes (G. K. Batchelor, J. Fluid Mech. 44, 419
    (1970); the exact forms' expansion with L = 2 ln 2p): F∥ = 8πηc/(2 ln 2p − 1),
    F⊥ = 16πηc/(2 ln 2p + 1), T⊥ = (16/3)πηc³/(2 ln 2p − 1), T∥ = (16/3)πη a² c, up to
    O(ln p / p²)."""
    a, p = 1e-4, 1e4
    c, L = a * p, 2 * math.log(2 * p)
    r = Bd.body_resistance(a, p, ETA)
    pe = math.pi * ETA
    np.testing.assert_allclose(r, (8 * pe * c / (L - 1), 16 * pe * c / (L + 1),
                                   16 / 3 * pe * a * a * c, 16 / 3 * pe * c ** 3 / (L - 1)), rtol=1e-6)


def test_rotation_vector_helpers():
    """exp([φ]×) is a rotation, J⁻¹(φ) inverts the left Jacobian of SO(3) (checked by finite
    differences of exp: d/dt exp([φ + φ̇ dt]×) exp([φ]×)ᵀ = [ω]×), and wrapping keeps the
    rotation."""
    rng = np.random.default_rng(0)
    for _ in range(20):
        phi = rng.normal(size=3) * rng.uniform(0.0, 3.0)
        q = Bd.rotvec_matrix(phi)
        np.testing.assert_allclose(q @ q.T, np.eye(3), atol=1e-14)
        w = rng.normal(size=3)
        dphi = np.array(Bd.rotvec_rate(*phi, *w))
        dt = 1e-6
        dq = (Bd.rotvec_matrix(phi + dphi * dt) - Bd.rotvec_matrix(phi - dphi * dt)) / (2 * dt) @ q.T
        np.testing.assert_allclose([dq[2, 1], dq[0, 2], dq[1, 0]], w, rtol=1e-6, atol=1e-8)
        np.testing.assert_allclose(Bd.matrix_rotvec(q), phi if np.linalg.norm(phi) <= math.pi
                                   else phi * (1 - 2 * math.pi / np.linalg.norm(phi)), atol=1e-9)
    for t in (math.pi - 1e-4, math.pi - 1e-2, 1e-8):  # near π and near 0
        phi = rng.normal(size=3)
        phi *= t / np.linalg.norm(phi)
        np.testing.assert_allclose(Bd.matrix_rotvec(Bd.rotvec_matrix(phi)), phi, atol=1e-9)
    phi = np.array([0.0, 4.0, 0.0])
    q = Bd.rotvec_matrix(phi)
    assert Bd.wrap_rotvec(phi) and np.linalg.norm(phi) <= math.pi
    np.testing.assert_allclose(Bd.rotvec_matrix(phi), q, atol=1e-14)


def test_geometry_motor_on_the_surface_along_the_normal():
    for aspect, beta in ((1.0, 0.0), (2.0, 0.0), (2.0, 40.0), (1.0, 90.0)):
        g = Bd.body_geometry(0.5, aspect, beta)
        np.testing.assert_allclose(g.motor_axis, [0, 0, 1])
        # the motor point lies on the surface x²/a² + z²/c² = 1 in the body's axes
        e3 = g.axis
        z = g.offset @ e3
        rho = np.linalg.norm(g.offset - z * e3)
        assert rho ** 2 / 0.25 + z ** 2 / (0.5 * aspect) ** 2 == pytest.approx(1.0)
        # the motor axis is the inward normal: −∇(x²/a² + z²/c²) normalized
        grad = 2 * (g.offset - z * e3) / 0.25 + 2 * z * e3 / (0.5 * aspect) ** 2
        np.testing.assert_allclose(g.motor_axis, -grad / np.linalg.norm(grad), atol=1e-12)
    assert Bd.body_geometry(0.5, 2.0, 0.0).offset == pytest.approx([0, 0, -1.0])


# -- kernel: force and torque balance -----------------------------------------------------

BOUNDARIES = [Boundary(anchor="free", body_radius=0.5, body_aspect=2.0),
              Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, hook="clamped"),
              Boundary(anchor="free", body_radius=0.8, motor_offset=30.0, hook="elastic", hook_stiffness=2.0),
              Boundary(anchor="free", body_radius=0.4, body_aspect=3.0, motor_offset=60.0, hook="clamped")]
IDS = ["spheroid", "spheroid clamped", "sphere off-pole elastic", "spheroid off-pole clamped"]


def _state(model, rng):
    y = model.initial_state()
    y[3:-3] += rng.normal(0.0, 0.01, len(y) - 6)
    y[-3:] = rng.normal(0.0, 0.8, 3)
    if model.boundary.hook == "clamped":  # the hook along −m
        y[:3] = -Bd.rotvec_matrix(y[-3:])[:, 2] * np.linalg.norm(y[:3])
    return y


def _balance(model, y, t=0.0):
    """Total force and torque (about the origin) of the fluid on the cell, from the
    velocities of the right-hand side alone: bead drag w[γ∥tt + γ⊥(1 − tt)]v (bead 0 with
    the body), bond spins γR h ω3 t, the hook frame's rotational drag, the body's resistance.
    Lab frame (omega_frame = 0). Returns (force, torque, scale)."""
    gp, gn, gr = model.gammas
    h, n = model.h, model.n
    yd = model.rhs(t, y)
    bm = model.body_motion(t, y)
    fr = model.frames(y)
    pos = positions(y)
    vel = positions(yd)
    rb = Bd.body_resistance(model.boundary.body_radius, model.boundary.body_aspect, ETA)
    ax = bm["axis"]
    At = rb.translation_transverse * np.eye(3) + (rb.translation_axial - rb.translation_transverse) * np.outer(ax, ax)
    Br = rb.rotation_transverse * np.eye(3) + (rb.rotation_axial - rb.rotation_transverse) * np.outer(ax, ax)
    F = -At @ bm["velocity"]
    T = np.cross(bm["position"], F) - Br @ bm["angular_velocity"]
    if model.hydrodynamics.is_local:
        pts, tan, w = rft.bead_nodes(type("D", (), {"positions": pos, "tangents": fr.tangents[1:],
                                                    "segment_length": h})())
        for i in range(n + 1):
            tt = np.outer(tan[i], tan[i])
            f = -w[i] * (gp * tt + gn * (np.eye(3) - tt)) @ vel[i]
            F += f
            T += np.cross(pos[i], f)
    else:  # body + beads: the generalized forces R q of the coupled mobility, built here anew
        from flagellum.hydro.dynamics import CellBody, cell_mobility

        X = bm["position"]
        cell = CellBody(X, ax, model.boundary.body_radius, model.boundary.body_aspect)
        q = np.r_[bm["velocity"], vel[1:].ravel(), bm["angular_velocity"]]
        g = np.linalg.solve(cell_mobility(pos, model.params.fluid.filament_radius, ETA, cell), q).reshape(-1, 3)
        F = -(g[0] + g[1:-1].sum(0))
        T = -(g[-1] + np.cross(X, g[0]) + np.cross(pos[1:], g[1:-1]).sum(0))
    ang = y[3:3 + 4 * (n + 1)].reshape(-1, 4)[:, 3]
    dang = yd[3:3 + 4 * (n + 1)].reshape(-1, 4)[:, 3]
    for i in range(1, n + 1):
        tdot = (vel[i] - vel[i - 1]) / fr.lengths[i]
        tdot -= (tdot @ fr.tangents[i]) * fr.tangents[i]
        om3 = dang[i] + fr.spin[i] @ tdot
        T -= gr * h * om3 * fr.tangents[i]
    t0, u = fr.tangents[0], y[:3]
    udot = yd[:3] / np.linalg.norm(u)
    tdot0 = udot - (udot @ t0) * t0
    wh = np.cross(t0, tdot0) + (dang[0] + fr.spin[0] @ tdot0) * t0
    zt, zp = gr * h, 0.5 * gn * h ** 3
    T -= zt * (wh @ t0) * t0 + zp * (wh - (wh @ t0) * t0)
    del ang
    scale = np.abs(-At @ bm["velocity"]).max() + gn * h * np.abs(vel).max() * n
    return F, T, scale, bm, wh


DRIVES = {"torque": Motor(0.8), "speed": Motor(drive="speed", speed=600.0),
          "law": Motor(drive="law", law=MotorLaw.e_coli())}


def _check_balance(model, drive, tol):
    """Force and torque on the cell below ``tol`` of the single terms at a random state; the
    relative motor speed is (ω_hook − Ω)·m, the clamp holds it and the law's torque is on the
    law. Returns (state, body motion)."""
    y = _state(model, np.random.default_rng(7))
    F, T, scale, bm, wh = _balance(model, y)
    assert np.abs(F).max() < tol * scale
    assert np.abs(T).max() < tol * scale * 5.0
    assert bm["relative"] == pytest.approx((wh - bm["angular_velocity"]) @ bm["motor_axis"], rel=1e-6)
    if drive == "speed":
        assert bm["relative"] == pytest.approx(600.0, rel=1e-9)
    if drive == "law":
        assert bm["torque"] == pytest.approx(float(MotorLaw.e_coli()(bm["relative"])), abs=1e-9)
    return y, bm


@pytest.mark.parametrize("boundary", BOUNDARIES, ids=IDS)
@pytest.mark.parametrize("drive", list(DRIVES))
def test_cell_is_force_and_torque_free(boundary, drive):
    """The elastic forces and torques are internal and the motor's torque acts between the
    hook and the body: the fluid's total force and torque on the cell vanish to round-off,
    for random states (bent, twisted, the body turned), every hook and drive."""
    _check_balance(RodModel(Params(), DRIVES[drive], boundary), drive, 1e-11)


@pytest.mark.parametrize("boundary", BOUNDARIES, ids=IDS)
@pytest.mark.parametrize("drive", list(DRIVES))
def test_cell_with_sbt_is_force_and_torque_free(boundary, drive):
    """The same balance with the nonlocal mobility: the body's and the beads' velocities of the
    kernel (ΔM built at this state) imply, through the coupled mobility of beads + body built
    anew (hydro.dynamics.cell_mobility), a fluid force and torque on the cell that vanish to
    round-off; the clamp and the law stay exact."""
    m = RodModel(Params(), DRIVES[drive], boundary, hydrodynamics=Hydrodynamics("sbt", refresh=0.0))
    y, bm = _check_balance(m, drive, 1e-10)
    # the nonlocal flow does change the motion
    local = RodModel(Params(), DRIVES[drive], boundary)
    local.set_charts(*m.charts())
    loc = local.body_motion(0.0, y)
    assert np.linalg.norm(loc["velocity"] - bm["velocity"]) > 0.05 * np.linalg.norm(loc["velocity"])


@pytest.mark.parametrize("boundary", [BOUNDARIES[0], BOUNDARIES[1]], ids=IDS[:2])
def test_body_counter_rotation_balances_the_motor_torque(boundary):
    """Motor at the pole of a spheroid (m along the body's axis, d ∥ m): about its axis the
    body feels only the motor's reaction −M (the force at the motor point and the hook's
    constraint torque have no moment about it), so Ω·axis = −M/T∥ with the exact axial
    rotational resistance T∥ = 8πηc³ X_C, for any state and either hook."""
    m = RodModel(Params(), Motor(0.8), boundary)
    bm = m.body_motion(0.0, _state(m, np.random.default_rng(3)))
    r = Bd.body_resistance(0.5, 2.0, ETA)
    assert bm["angular_velocity"] @ bm["axis"] == pytest.approx(-0.8 / r.rotation_axial, rel=1e-10)


def test_anchored_paths_unchanged_and_state_layout():
    """The rod's other boundaries keep their state layout; the cell appends φ (3 values)."""
    p = Params()
    assert RodModel(p, boundary=Boundary()).initial_state().shape == (state_size(p.filament.n_segments),)
    m = RodModel(p, boundary=BOUNDARIES[0])
    y = m.initial_state()
    assert y.shape == (state_size(p.filament.n_segments, cell=True),) and not y[-3:].any()
    assert positions(y).shape == (p.filament.n_segments + 1, 3)


# -- rigid limit ---------------------------------------------------------------------------

def _rigid_cell(boundary, pos, tangents, params, torque):
    """(V, Ω, ω_r) of the rigid cell: body + rigid helix joined at the motor point, the
    helix turning relative to the body about m only (clamped hook), by virtual work over the
    generalized velocities q = (V, Ω, ω_r): K q = (0, …, 0, M) with K = Σ Pᵀ R P over the
    body (its resistance about its centre), the helix (RFT resistance of its beads 1…N about
    the motor point, hydro.rft.resistance_matrix, plus bond spins and the hook frame's
    rotational drag) and bead 0 (with the body). P maps q to each part's (velocity at its
    reference point, angular velocity)."""
    gp, gn, gr = params.gammas
    h = params.filament.segment_length
    g = Bd.body_geometry(boundary.body_radius, boundary.body_aspect, boundary.motor_offset)
    rb = Bd.body_resistance(boundary.body_radius, boundary.body_aspect, ETA)
    ax, d, m = g.axis, g.offset, g.motor_axis  # the body at the identity orientation
    centre = pos[0] - d
    Rb = np.zeros((6, 6))
    Rb[:3, :3] = rb.translation_transverse * np.eye(3) + (rb.translation_axial - rb.translation_transverse) * np.outer(ax, ax)
    Rb[3:, 3:] = rb.rotation_transverse * np.eye(3) + (rb.rotation_axial - rb.rotation_transverse) * np.outer(ax, ax)
    dh = type("D", (), {"positions": pos, "tangents": tangents, "segment_length": h})()
    pts, tan, w = rft.bead_nodes(dh)
    R0 = rft.resistance_matrix(pts[:1], tan[:1], w[:1], gp, gn, origin=centre)
    Rh = rft.resistance_matrix(pts[1:], tan[1:], w[1:], gp, gn, origin=pos[0])
    Rh[3:, 3:] += gr * h * np.einsum("ni,nj->ij", tangents, tangents)  # bond spins
    Rh[3:, 3:] += gr * h * np.outer(m, m) + 0.5 * gn * h ** 3 * (np.eye(3) - np.outer(m, m))  # hook frame
    dx = rft._skew(d)
    Pb = np.hstack([np.eye(6), np.zeros((6, 1))])
    Ph = np.zeros((6, 7))
    Ph[:3, :3], Ph[:3, 3:6], Ph[3:, 3:6], Ph[3:, 6] = np.eye(3), -dx, np.eye(3), m
    K = Pb.T @ (Rb + R0) @ Pb + Ph.T @ Rh @ Ph
    return np.linalg.solve(K, np.r_[np.zeros(6), torque])


@pytest.mark.parametrize("boundary", [Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, hook="clamped"),
                                      Boundary(anchor="free", body_radius=1.0, motor_offset=45.0, hook="clamped")],
                         ids=["spheroid at the pole", "sphere off-pole"])
def test_rigid_limit_matches_rigid_body_resistance(boundary):
    """A stiff filament (A = C = 100 × the paper's) on a clamped hook swims as a rigid body:
    after the twist has built up (2 ms), the body's velocity, angular velocity and the motor
    speed relative to the body equal the solution of the rigid-body resistance problem of
    body + helix (RFT of the foundation) for the instantaneous shape, to the filament's
    residual deformation rate (< 1 %)."""
    p = Params.from_flat({"bend_rigidity": 350.0, "twist_rigidity": 350.0})
    sim = Simulator(p, Motor(1.0), boundary, solver=SolverOptions(frame="lab", rtol=1e-8))
    sim.run(0.002, save_every=0.001, progress=False)
    y = sim.y
    bm = sim.model.body_motion(sim.t, y)
    fr = sim.model.frames(y)
    # the rigid problem in the body's frame (identity orientation): turn the shape back
    q = bm["orientation"]
    pos = (positions(y) - positions(y)[0]) @ q
    ref = _rigid_cell(boundary, pos, fr.tangents[1:] @ q, p, 1.0)
    v, om = q.T @ bm["velocity"], q.T @ bm["angular_velocity"]
    scale_v, scale_w = np.linalg.norm(ref[:3]), np.linalg.norm(ref[3:6])
    assert np.linalg.norm(v - ref[:3]) < 0.01 * scale_v
    assert np.linalg.norm(om - ref[3:6]) < 0.01 * scale_w
    assert bm["relative"] == pytest.approx(ref[6], rel=0.01)
    assert scale_v > 5.0  # it swims (µm/s)


def _rigid_cell_sbt(model, y, torque):
    """(V, Ω, ω_r) of the rigid cell with the nonlocal mobility, solved independently of the
    kernel's splitting: the grand mobility of beads + body (hydro.dynamics.grand_mobility) in
    resistance form over the rigid motions q = (V, Ω, ω_r) — bead 0 at V + Ω × d, bead k at
    V + Ω × (x_k − X) + ω_r m × (x_k − x_0), the body at (V, Ω) — plus the local bond spins and
    the hook frame's drag on the helix' rotation Ω + ω_r m: K q = (0, …, 0, M)."""
    from flagellum.hydro.dynamics import grand_mobility

    p, b = model.params, model.boundary
    gp, gn, gr = p.gammas
    h = model.h
    bm = model.body_motion(0.0, y)
    x, X, ax, mm = positions(y), bm["position"], bm["axis"], bm["motor_axis"]
    big = grand_mobility(x, p.fluid.filament_radius, ETA, X, b.body_radius, b.body_aspect, ax)
    n1 = len(x)
    P = np.zeros((3 * n1 + 6, 7))
    for k in range(n1):
        P[3 * k:3 * k + 3, :3] = np.eye(3)
        P[3 * k:3 * k + 3, 3:6] = -rft._skew(x[k] - X)
        P[3 * k:3 * k + 3, 6] = np.cross(mm, x[k] - x[0])
    P[3 * n1:3 * n1 + 3, :3], P[3 * n1 + 3:, 3:6] = np.eye(3), np.eye(3)
    K = P.T @ np.linalg.solve(big, P)
    t = model.frames(y).tangents[1:]
    rot = gr * h * np.einsum("ni,nj->ij", t, t) + gr * h * np.outer(mm, mm) + 0.5 * gn * h ** 3 * (np.eye(3) - np.outer(mm, mm))
    Ph = np.hstack([np.zeros((3, 3)), np.eye(3), mm[:, None]])  # the helix' angular velocity
    K += Ph.T @ rot @ Ph
    return np.linalg.solve(K, np.r_[np.zeros(6), torque]), bm


@pytest.mark.slow
@pytest.mark.ci
@pytest.mark.parametrize("boundary", [Boundary(anchor="free", body_radius=0.5, body_aspect=2.0, hook="clamped"),
                                      Boundary(anchor="free", body_radius=1.0, motor_offset=45.0, hook="clamped")],
                         ids=["spheroid at the pole", "sphere off-pole"])
def test_rigid_limit_with_sbt_matches_the_coupled_rigid_body(boundary):
    """The stiff filament of the RFT test on a clamped hook with the nonlocal mobility: after
    2 ms the body's velocity, angular velocity and the motor speed relative to the body equal
    the rigid-body solution of body + helix with the same coupled mobility (built anew, not
    through the kernel's ΔM splitting) to the filament's residual deformation rate, and differ
    from RFT at that state by far more."""
    p = Params.from_flat({"bend_rigidity": 350.0, "twist_rigidity": 350.0})
    sim = Simulator(p, Motor(1.0), boundary, solver=SolverOptions(frame="lab", rtol=1e-8),
                    hydrodynamics=Hydrodynamics("sbt"))
    sim.run(0.002, save_every=0.001, progress=False)
    sim.model.refresh_mobility(sim.y, force=True)  # ΔM at this very shape
    ref, bm = _rigid_cell_sbt(sim.model, sim.y, 1.0)
    scale_v, scale_w = np.linalg.norm(ref[:3]), np.linalg.norm(ref[3:6])
    # measured: V 0.82 % (spheroid) and 0.18 % (sphere), Ω and ω_r ≤ 6e-4; the stiff
    # filament's slowest bending mode relaxes in γ⊥L⁴/(12.4 A) ≈ 6 ms, longer than the run
    assert np.linalg.norm(bm["velocity"] - ref[:3]) < 0.015 * scale_v
    assert np.linalg.norm(bm["angular_velocity"] - ref[3:6]) < 0.01 * scale_w
    assert bm["relative"] == pytest.approx(ref[6], rel=0.01)
    local = RodModel(p, Motor(1.0), boundary)
    local.set_charts(*sim.model.charts())
    loc = local.body_motion(0.0, sim.y)  # RFT at the same state: 21.7 and 8.4 against 14.0 and 7.7 µm/s
    assert np.linalg.norm(loc["velocity"] - ref[:3]) > 0.05 * scale_v


# -- boundary, CLI, API -------------------------------------------------------------------

@pytest.mark.parametrize("kw, name", [
    (dict(anchor="fixed", body_radius=1.0), "body_radius"),
    (dict(anchor="sphere", sphere_radius=1.0, body_radius=1.0), "body_radius"),
    (dict(anchor="free", sphere_radius=1.0, body_radius=1.0), "sphere_radius"),
    (dict(anchor="free", body_radius=-1.0), "body_radius"),
    (dict(anchor="free", body_radius=1.0, body_aspect=0.5), "body_aspect"),
    (dict(anchor="free", body_aspect=2.0), "body_aspect"),
    (dict(anchor="free", body_radius=1.0, motor_offset=200.0), "motor_offset"),
    (dict(anchor="free", sphere_radius=1.0, motor_offset=10.0), "motor_offset"),
])
def test_bad_body_parameters(kw, name):
    with pytest.raises(ParameterError, match=name):
        Boundary(**kw)


def test_from_flags_body_radius_means_a_free_cell():
    b = Boundary.from_flags(body_radius=1.0, body_aspect=2.0)
    assert b.anchor == "free" and b.is_cell and b.body_aspect == 2.0
    assert Boundary.from_flags(anchor="free", sphere_radius=0.5) == Boundary(anchor="free", sphere_radius=0.5)
    assert not Boundary(anchor="free", sphere_radius=0.5).is_cell


def test_cli_cell_run_and_errors(cli, tmp_path):
    out = tmp_path / "cell.h5"
    code, stdout, err = cli("simulate", "--body-radius", "0.5", "--body-aspect", "2", "--time",
                            "0.004", "--save-every", "0.0005", "--json", "-o", str(out))
    assert code == 0, err
    import json

    d = json.loads(stdout)
    for k in ("body_velocity", "body_speed", "body_rotation_rate", "wobble_angle_deg", "motor_speed_mean"):
        assert math.isfinite(d[k]), k
    assert d["body_rotation_rate"] < 0  # counter-rotating
    from flagellum.trajectory import open_trajectory

    ds = open_trajectory(out)
    assert ds["body_position"].attrs["units"] == "um" and ds["body_position"].dims == ("time", "xyz")
    assert ds["body_angular_velocity"].attrs["units"] == "rad/s"
    assert ds["relative_motor_speed"].attrs["units"] == "rad/s"
    for args, name in ((("--anchor", "fixed", "--body-radius", "1"), "body_radius"),
                       (("--body-aspect", "2"), "body_aspect"),
                       (("--body-radius", "1", "--hydrodynamics", "sbt", "--thermal", "--method", "cvode"),
                        "method")):
        code, stdout, err = cli("simulate", *args, "--time", "0.001")
        assert code == 2 and name in err and "Traceback" not in err and len(err.strip().splitlines()) == 1, err


def test_api_takes_the_body():
    import flagellum as fl

    tr = fl.simulate(1.0, 0.003, body_radius=0.5, save_every=0.001)
    assert tr.meta and np.all(np.isfinite(tr.body_position))
    assert np.all(tr.body_rotation_rate[1:] < 0)


def test_cell_run_wraps_its_orientation_and_resumes_bit_identically(tmp_path, monkeypatch):
    """The body turns by more than π within the run (−197 rad/s for this spheroid, 0.03 s):
    its rotation vector is wrapped (|φ| stays ≤ π plus one chunk's turn) and the body axis
    stays continuous; a run interrupted after its first checkpoint and resumed from it gives
    the same file (the orientation is part of the checkpointed state)."""
    from flagellum.io import read_trajectory

    def make():
        return Simulator(Params(), Motor(1.0), BOUNDARIES[0])

    run = dict(t_end=0.03, save_every=0.001, checkpoint_every=0.01, progress=False)
    ref = make().run(output=tmp_path / "ref.h5", **run)
    assert np.abs(np.diff(ref.body_axis, axis=0)).max() < 0.1
    sim = make()
    calls = [0]
    orig = Simulator._record

    def record(self, buf):
        calls[0] += 1
        if calls[0] == 15:
            raise KeyboardInterrupt
        return orig(self, buf)

    monkeypatch.setattr(Simulator, "_record", record)
    with pytest.raises(KeyboardInterrupt):
        sim.run(output=tmp_path / "run.h5", **run)
    monkeypatch.undo()
    resumed, tr = Simulator.resume(tmp_path / "run.h5", progress=False)
    assert np.linalg.norm(resumed.y[-3:]) <= math.pi + 0.5
    a, b = read_trajectory(tmp_path / "ref.h5"), read_trajectory(tmp_path / "run.h5")
    for k in ("positions", "body_position", "body_axis", "body_angular_velocity", "relative_motor_speed"):
        np.testing.assert_array_equal(a[k], b[k])


def test_lab_state_of_a_cell_turns_its_orientation_with_the_frame():
    """A co-rotating run's state turned into the lab: the body's centre and axis computed
    from the lab state are those recorded (lab frame)."""
    sim = Simulator(Params(), Motor(1.0), BOUNDARIES[2])
    tr = sim.run(0.005, save_every=0.001, progress=False)
    assert sim.frame_angle != 0.0
    lab = sim.lab_state()
    m = RodModel(Params(), Motor(1.0), BOUNDARIES[2])
    m.set_charts(*lab.charts)
    bm = m.body_motion(sim.t, lab.y)
    np.testing.assert_allclose(bm["position"], tr.body_position[-1], atol=1e-9)
    np.testing.assert_allclose(bm["axis"], tr.body_axis[-1], atol=1e-9)


@pytest.mark.slow
@pytest.mark.ci
def test_e_coli_like_cell_swims_as_measured():
    """Literature comparison, stated and not tuned (docs/motor.md, "Whole cell"): the paper's
    filament on an elastic hook (k = 5 pN·µm) driven by the E. coli motor law, on a
    2.5 × 0.88 µm spheroid (the cell size of Darnton et al., J. Bacteriol. 189, 1756 (2007)),
    swims at tens of µm/s (measured 29 ± 6), its body turning at tens of Hz (measured
    23 ± 8; ours ≈ 2× faster: the motor runs at the stall torque) and the motor at
    100–300 Hz relative to the body (measured ≈ 154). Here 0.4 s, averages over 0.2–0.4 s."""
    b = Boundary(anchor="free", body_radius=0.44, body_aspect=2.5 / 0.88, hook="elastic", hook_stiffness=5.0)
    s = Simulator(Params(), Motor(drive="law", law=MotorLaw.e_coli()), b).run(
        0.4, save_every=1e-3, progress=False).summary(t_from=0.2)
    assert 15.0 < s.body_velocity < 60.0
    assert 10.0 < -s.body_rotation_rate / (2 * math.pi) < 100.0
    assert 100.0 < s.motor_speed_mean / (2 * math.pi) < 300.0
    assert s.wobble_angle_deg < 20.0


def test_centred_swimmer_records_its_body_as_before():
    """The centred body sphere (--anchor free --sphere-radius a) keeps its model: its body
    record spins at −M/(8πηa³) about e_z, and the relative motor speed is motor_speed +
    M/(8πηa³) (docs/motor.md, "Motor speed relative to the body")."""
    tr = Simulator(Params(), Motor(0.6), Boundary(anchor="free", sphere_radius=0.5)).run(
        0.002, save_every=0.001, progress=False)
    rate = 0.6 / (8 * math.pi * ETA * 0.5 ** 3)
    np.testing.assert_allclose(tr.body_rotation_rate, -rate, rtol=1e-12)
    np.testing.assert_allclose(tr.relative_motor_speed, tr.motor_speed + rate, rtol=1e-12)
    np.testing.assert_array_equal(tr.body_position, tr.positions[:, 0])
    assert not tr.body_orientation.any()


def test_body_orientation_record_is_the_body_axis_turned():
    tr = Simulator(Params(), Motor(1.0), BOUNDARIES[2]).run(0.01, save_every=0.001, progress=False)
    g = Bd.body_geometry(0.8, 1.0, 30.0)
    for phi, axis in zip(tr.body_orientation, tr.body_axis):
        np.testing.assert_allclose(Bd.rotvec_matrix(phi) @ g.axis, axis, atol=1e-9)
