"""Grain equation of motion (paper eqs. 3-4): terminal velocity, relaxation, periodic wrap."""
from __future__ import annotations


import numpy as np
import pytest

from test_particles_helpers import (component, exact_slip, scene, synthetic_flow,
                                    terminal_velocity)
from saltstudy.solver.grains.layout import _TOL, DRAG_TOL
from saltstudy.solver.grains.interp import wrap_periodic


def _fall(d, dt, steps, z0=2.5):
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc)
    s.add_parcels([1.0], [0.5], [z0], d=d)
    ws = []
    for _ in range(steps):
        s.dynamics(st, dt)
        ws.append(-s.w[0])
    air = sc.case.air
    wt = terminal_velocity(d, sc.case.soil.rho_p, air.rho, air.nu, air.g)
    tp = sc.case.soil.rho_p * d * d / (18 * air.rho * air.nu)
    return np.array(ws), wt, tp, s


def test_terminal_velocity_200um():
    ws, wt, tp, s = _fall(200e-6, 0.01, 150)
    assert s.n == 1 and s.z[0] > 0.2  # still airborne
    assert abs(ws[-1] - wt) / wt < 5e-3
    assert abs(ws[-1] - wt) / wt < 1e-5  # in fact converged to the root itself
    assert np.all(np.diff(ws) >= -1e-12)  # monotone approach


def test_terminal_velocity_stiff_10um_no_overshoot():
    d = 10e-6
    sc_tp = 2650 * d * d / (18 * 1.2 * 1.5e-5)
    ws, wt, tp, s = _fall(d, 100 * sc_tp, 40, z0=2.0)
    assert abs(tp - sc_tp) < 1e-15
    assert np.all(np.isfinite(ws))
    assert abs(ws[0] - wt) / wt < 1e-6        # on the terminal velocity after one step
    # never above it, beyond the drag-rate iteration's error (~DRAG_TOL^2 on k)
    assert ws.max() <= wt * (1 + 1e-7)
    assert abs(ws[-1] - wt) / wt < 1e-7


@pytest.mark.parametrize("d", [20e-6, 200e-6])
def test_relaxation_in_uniform_wind_matches_exact(d):
    """No gravity, uniform wind U: the slip follows the closed-form solution with f(Re)."""
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc, gravity=False)
    U = 5.0
    st.u[...] = U
    s.add_parcels([1.0], [0.5], [1.5], d=d)
    air = sc.case.air
    tp = 2650 * d * d / (18 * air.rho * air.nu)
    dt = tp / 50
    t = 0.0
    err = 0.0
    for _ in range(200):
        s.dynamics(st, dt)
        t += dt
        r_exact = exact_slip(t, U, d, tp, air.nu)
        err = max(err, abs((U - s.u[0]) - r_exact) / U)
    # Stokes-like (20 um: Re <= 7, f up to 1.5) and nonlinear (200 um, Re up to 67) alike
    assert err < 5e-4
    # and refining the step reduces the error
    s2, st2 = component(sc, gravity=False)
    st2.u[...] = U
    s2.add_parcels([1.0], [0.5], [1.5], d=d)
    t = 0.0
    err2 = 0.0
    for _ in range(800):
        s2.dynamics(st2, dt / 4)
        t += dt / 4
        err2 = max(err2, abs((U - s2.u[0]) - exact_slip(t, U, d, tp, air.nu)) / U)
    assert err2 < err / 8  # second order in dt (ratio 16 expected)


def test_wrap_more_than_a_domain_length():
    assert wrap_periodic(-1e-18, 2.4) < 2.4
    assert abs(wrap_periodic(7 * 2.4 + 0.1, 2.4) - 0.1) < 1e-12
    assert abs(wrap_periodic(-3 * 2.4 - 0.3, 2.4) - (2.4 - 0.3)) < 1e-12
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc, gravity=False)
    Lx, Ly = s.grid.Lx, s.grid.Ly
    s.add_parcels([0.3], [0.2], [1.0], u=13.7 * Lx, v=-5.3 * Ly, d=200e-6)
    st.u[...] = 13.7 * Lx
    st.v[...] = -5.3 * Ly
    s.dynamics(st, 1.0)  # grain moving with the air: no slip, exact displacement
    assert abs(s.x[0] - ((0.3 + 13.7 * Lx) % Lx)) < 1e-9
    assert abs(s.y[0] - ((0.2 - 5.3 * Ly) % Ly)) < 1e-9
    assert 0 <= s.x[0] < Lx and 0 <= s.y[0] < Ly


def test_log_law_below_first_level():
    sc = scene(2, physics={"two_way_coupling": False, "tke_particle_sink": False})
    s, st = component(sc)
    g = s.grid
    st.u[...] = np.arange(g.nz)[None, None, :] + 1.0  # level 1 holds 2.0
    st.w[..., 1] = 0.4
    z = np.array([0.001, 0.003, 0.5 * (g.z_c[0] + g.z_c[1])])
    s.add_parcels(np.full(3, 0.5), np.full(3, 0.5), z)
    uf, vf, wf = s.fluid_at_parcels(st)
    z0 = sc.case.surface.z0
    L = np.log(z[:2] / z0) / np.log(g.z_c[1] / z0)
    assert np.allclose(uf[:2], 2.0 * L, rtol=1e-12)
    assert abs(uf[2] - 1.5) < 1e-12                         # trilinear above the first level
    assert np.allclose(wf[:2], 0.4 * z[:2] / g.z_f[1], rtol=1e-12)  # w linear to 0 at the bed


def _saltating(tol, steps, n=3000):
    """A two-way coupled cloud of parcels in a frozen perturbed log-law wind (they splash)."""
    sc = scene(2)
    s, st = component(sc)
    s.prm[_TOL] = tol
    synthetic_flow(st, sc.case.forcing.u_star_s, sc.case.surface.z0)
    rng = np.random.default_rng(3)
    g = s.grid
    s.add_parcels(rng.uniform(0, g.Lx, n), rng.uniform(0, g.Ly, n), rng.uniform(1e-3, 0.3, n),
                  u=rng.uniform(0, 4, n), w=rng.normal(0, 1, n),
                  d=rng.choice([90e-6, 200e-6, 400e-6], n))
    for _ in range(steps):
        s.dynamics(st, 0.005)
    return s


def test_drag_rate_iteration_error_far_below_its_tolerance():
    """DRAG_TOL stops the iteration before its last Newton update, so the accepted drag rate is
    ~DRAG_TOL^2 off: the cold first step (k from rest) agrees with a 1e-13 tolerance to round-off,
    and so does a warm one."""
    for steps in (1, 3):
        a = _saltating(DRAG_TOL, steps)
        b = _saltating(1e-13, steps)
        assert a.n == b.n
        for f in ("u", "v", "w", "z"):
            assert np.max(np.abs(getattr(a, f) - getattr(b, f))) < 1e-10, f
        kd_a, kd_b = a._kd[:a.n], b._kd[:b.n]
        live = kd_b > 0
        assert np.max(np.abs(kd_a[live] / kd_b[live] - 1.0)) < 1e-9

