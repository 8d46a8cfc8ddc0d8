"""The pruned right-hand side and Jacobian kernels (rod.kernels.rod_rhs,
rod_colored_jacobian) against the general ones: the same source with the cell-body and
per-joint-shape paths removed at compile time, so every number must agree bit for bit (an
independent check of the pruning: any path it removed that mattered would change bits)."""

from __future__ import annotations

import numpy as np
import pytest

from flagellum.hydro.options import Hydrodynamics
from flagellum.motor import Boundary, Motor
from flagellum.params import EndLoad, Params
from flagellum.rod import kernels as K
from flagellum.simulator import Simulator

CASES = {
    "anchored": dict(),
    "elastic hook, end load": dict(boundary=Boundary(hook="elastic", hook_stiffness=2.0),
                                   end_load=EndLoad(force=0.5, trap_stiffness=1.0)),
    "clamped hook, speed clamp": dict(boundary=Boundary(hook="clamped"),
                                      motor=Motor(drive="speed", speed=300.0)),
    "load sphere": dict(boundary=Boundary(anchor="sphere", sphere_radius=1.0)),
    "free swimmer": dict(boundary=Boundary(anchor="free", sphere_radius=0.5)),
    "nonlocal (frozen ΔM)": dict(hydrodynamics=Hydrodynamics(model="sbt")),
}


@pytest.mark.parametrize("name", list(CASES))
def test_pruned_kernels_are_bit_identical(name):
    kw = dict(CASES[name])
    motor = kw.pop("motor", Motor(1.3))
    sim = Simulator(Params(), motor, **kw)
    m = sim.model
    assert m.rhs_kernel is K.rod_rhs and K.specialised(m.iprm)
    rng = np.random.default_rng(7)
    args = m.kernel_arrays
    kl, ku = m.jacobian_band
    for trial in range(3):
        y = sim.y.copy()
        y[3:] += rng.normal(0.0, 0.03, len(y) - 3)
        m.prm[K.P_OMEGA] = 200.0 * trial  # co-rotating frame on in later trials
        if trial == 2:  # thermal-like generalized forces, the Itô path (iprm[I_GEN] = 1)
            args[1][K.I_GEN] = 1  # (args: prm, iprm, ref_u, ref_e, ref_m, ext_f, ext_m, …)
            args[5][:] = rng.normal(0.0, 1.0, args[5].shape)
            args[6][:] = rng.normal(0.0, 1.0, args[6].shape)
        a, b = np.empty_like(y), np.empty_like(y)
        ra, rb = K.rod_rhs(y, a, *args), K.rhs(y, b, *args)
        assert np.array_equal(a, b)
        assert len(ra) == 7 and all(np.array_equal(u, v) for u, v in zip(ra, rb))
        ja, jb = (np.zeros((len(y), 2 * kl + ku + 1)) for _ in range(2))
        colors = m.jacobian_colors(kl, ku)
        for kernel, ab in ((K.rod_colored_jacobian, ja), (K.colored_jacobian, jb)):
            kernel(y, a, *args, kl, ku, ab, 1.0, np.zeros(len(y)), np.zeros(len(y)), *colors)
        assert np.array_equal(ja, jb)
    args[1][K.I_GEN] = 0
    args[5][:], args[6][:] = 0.0, 0.0


def test_general_kernel_where_pruning_would_be_wrong():
    """A cell body keeps the general kernels (the pruned ones lack its path)."""
    sim = Simulator(Params(), Motor(1.0), Boundary(anchor="free", body_radius=0.5))
    assert sim.model.rhs_kernel is K.rhs and not K.specialised(sim.model.iprm)


@pytest.mark.parametrize("hydro", ["rft", "sbt"])
@pytest.mark.parametrize("motor", [Motor(1.3), Motor(drive="speed", speed=900.0)])
def test_cell_scratch_in_the_workspace_carries_nothing_between_calls(hydro, motor):
    """`cell_motion` keeps its small arrays in the workspace (CW): filling that scratch with
    NaN or garbage between calls must leave the right-hand side unchanged bit for bit
    (every slot is reset or written before it is read), with local and nonlocal mobility
    and with the torque and the speed-clamp drives (clamped hook: the 7×7 problem)."""
    bd = Boundary(anchor="free", body_radius=0.5, motor_offset=30.0,
                  **({} if motor.drive == "torque" else {"hook": "clamped"}))
    sim = Simulator(Params(), motor, bd, hydrodynamics=Hydrodynamics(model=hydro))
    m = sim.model
    y = sim.y.copy()
    y[3:-3] += np.random.default_rng(3).normal(0.0, 0.02, len(y) - 6)
    m.refresh_mobility(y, force=True)
    cw = m.kernel_arrays[-1][10]
    assert cw.shape == (6, 6)
    a, b = m.rhs(0.0, y).copy(), None
    for fill in (np.nan, 1e30):
        cw[:] = fill
        b = m.rhs(0.0, y).copy()
        assert np.array_equal(a, b)
