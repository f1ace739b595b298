"""Advection: discrete energy conservation of the centred scheme on the stretched grid."""
from __future__ import annotations

import numpy as np

from solver_helpers import (advection_tendencies, make_stepper, random_velocity, scalar_advection,
                            stretched_grid)
from saltstudy.solver.flow.pressure import PressureSolver


def _energy_rate(g, u, v, w):
    au, av, aw = advection_tendencies(g, u, v, w)
    vu = g.dx * g.dy * g.dz_c
    vw = g.dx * g.dy * g.dz_f
    rate = (np.sum(vu * u * au) + np.sum(vu * v * av) + np.sum(vw[1:-1] * w[..., 1:-1] * aw[..., 1:-1]))
    scale = (np.sum(vu * np.abs(u * au)) + np.sum(vu * np.abs(v * av))
             + np.sum(vw[1:-1] * np.abs(w[..., 1:-1] * aw[..., 1:-1])))
    return rate, scale


def test_advection_conserves_kinetic_energy_exactly_for_solenoidal_flow():
    g = stretched_grid(nx=16, ny=12, nz=16, dz_bottom=0.01)
    u, v, w = random_velocity(g, seed=2, mean_u=3.0)
    # not solenoidal: the operator is not energy-neutral (so the test below can fail)
    rate, scale = _energy_rate(g, u, v, w)
    assert abs(rate) > 1e-3 * scale
    PressureSolver(g).project(u, v, w)
    rate, scale = _energy_rate(g, u, v, w)
    assert abs(rate) < 1e-13 * scale


def test_uniform_flow_is_not_advected_and_scalar_is_conserved():
    g = stretched_grid()
    u = np.full(g.shape, 2.5)
    v = np.full(g.shape, -1.0)
    w = np.zeros(g.shape[:2] + (g.nz + 1,))
    au, av, aw = advection_tendencies(g, u, v, w)
    assert np.abs(au).max() < 1e-12 and np.abs(av).max() < 1e-12 and np.abs(aw).max() < 1e-12
    u, v, w = random_velocity(g, seed=5)
    PressureSolver(g).project(u, v, w)
    s = np.random.default_rng(6).random(g.shape)
    a = scalar_advection(g, s, u, v, w)
    vol = g.dx * g.dy * g.dz_c
    assert abs(np.sum(vol * a)) < 1e-12 * np.sum(vol * np.abs(a))            # conservative
    assert abs(np.sum(vol * s * a)) < 1e-12 * np.sum(vol * np.abs(s * a))    # s^2 conserved


def test_inviscid_rk3_keeps_kinetic_energy():
    """No SGS, no wall, no damping: RK3 + centred advection loses energy only at O(dt^4)."""
    from saltstudy.solver.state import FlowState
    g = stretched_grid(nx=16, ny=12, nz=12, dz_bottom=0.05)
    st = make_stepper(g, nu_mol=0.0, sgs=False, wall=False)
    s = FlowState.zeros(g)
    s.u[...], s.v[...], s.w[...] = random_velocity(g, seed=7, mean_u=1.0)
    st.pressure.project(s.u, s.v, s.w)

    def ke():
        vu = g.dx * g.dy * g.dz_c
        vw = g.dx * g.dy * g.dz_f
        return 0.5 * (np.sum(vu * (s.u**2 + s.v**2)) + np.sum(vw * s.w**2))

    k0 = ke()
    rate = 4.0 / min(g.dx, g.dy, g.dz_c.min())
    dt = 0.1 / rate          # Courant ~ 0.1
    for _ in range(5):
        st.step(s, dt)
    assert abs(ke() - k0) / k0 < 1e-5
    # and the flow did change (the test is not trivially satisfied)
    assert np.abs(s.v).max() > 0.1
