"""Fourth-order horizontal advection (Morinishi et al. 1998, fully conservative; advection.py) with
the projection of the same order (pressure.py): exact energy conservation under D4 = 0 and not under
D2 = 0, fourth-order convergence of the x and y parts, the stage kernels and the model honouring
the option."""
from __future__ import annotations

import numpy as np
import pytest

from solver_helpers import make_stepper, random_velocity, smoke_scene, stretched_grid
from solver_helpers import advection_tendencies, scalar_advection
from saltstudy.solver.grid import Grid
from saltstudy.solver.flow.pressure import PressureSolver, divergence, gradient, laplacian
from saltstudy.solver.state import FlowState


def _energy_rate(g, u, v, w, order):
    """sum_cv V phi A(phi) and the sum of its absolute terms (the round-off scale)."""
    au, av, aw = advection_tendencies(g, u, v, w, order)
    vu = g.dx * g.dy * g.dz_c
    vw = g.dx * g.dy * g.dz_f
    rate = (np.sum(vu * u * au) + np.sum(vu * v * av) + np.sum(vw[1:-1] * w[..., 1:-1] * aw[..., 1:-1]))
    scale = (np.sum(vu * np.abs(u * au)) + np.sum(vu * np.abs(v * av))
             + np.sum(vw[1:-1] * np.abs(w[..., 1:-1] * aw[..., 1:-1])))
    return rate, scale


def _kinetic_energy(g, s):
    vu = g.dx * g.dy * g.dz_c
    vw = g.dx * g.dy * g.dz_f
    return 0.5 * (np.sum(vu * (s.u**2 + s.v**2)) + np.sum(vw * s.w**2))


def test_fourth_order_advection_conserves_kinetic_energy_when_d4_vanishes():
    g = stretched_grid(nx=16, ny=12, nz=16, dz_bottom=0.01)
    u, v, w = random_velocity(g, seed=2, mean_u=3.0)
    rate, scale = _energy_rate(g, u, v, w, 4)
    assert abs(rate) > 1e-3 * scale                  # not solenoidal: not energy-neutral
    u2, v2, w2 = u.copy(), v.copy(), w.copy()
    PressureSolver(g, order=4).project(u, v, w)
    assert np.abs(divergence(g, u, v, w, order=4)).max() < 1e-12 * np.abs(u).max() / g.dz_c.min()
    rate, scale = _energy_rate(g, u, v, w, 4)
    assert abs(rate) < 1e-13 * scale
    # the second-order projection (D2 = 0) is not the condition: the rate is far from round-off
    PressureSolver(g, order=2).project(u2, v2, w2)
    rate, scale = _energy_rate(g, u2, v2, w2, 4)
    assert abs(rate) > 1e-5 * scale
    # and the second-order advection needs D2 = 0, not D4 = 0
    rate, scale = _energy_rate(g, u, v, w, 2)
    assert abs(rate) > 1e-5 * scale


def test_fourth_order_scalar_advection_conserves_e_and_e_squared_and_a_uniform_e():
    g = stretched_grid(nx=16, ny=12, nz=14)
    u, v, w = random_velocity(g, seed=5, mean_u=1.0)
    PressureSolver(g, order=4).project(u, v, w)
    s = np.random.default_rng(6).random(g.shape)
    vol = g.dx * g.dy * g.dz_c
    a = scalar_advection(g, s, u, v, w, order=4)
    assert abs(np.sum(vol * a)) < 1e-12 * np.sum(vol * np.abs(a))            # conservative
    assert abs(np.sum(vol * s * a)) < 1e-12 * np.sum(vol * np.abs(s * a))    # e^2 conserved
    ones = np.ones(g.shape)
    assert np.abs(scalar_advection(g, ones, u, v, w, order=4)).max() < 1e-11 * np.abs(u).max() / g.dx
    # the second-order flux in the same D4-free flow makes a uniform e non-uniform (-e D2 u)
    assert np.abs(scalar_advection(g, ones, u, v, w, order=2)).max() > 0.1 * np.abs(u).max() / g.dx


def test_fourth_order_projection_is_exact_and_does_no_work():
    g = stretched_grid(nx=20, ny=12, nz=18)
    rng = np.random.default_rng(3)
    x, y, z = np.meshgrid(g.x_c, g.y_c, g.z_c, indexing="ij")
    phi = (np.cos(2 * np.pi * x / g.Lx) * np.sin(4 * np.pi * y / g.Ly) * np.cos(np.pi * z / g.Lz)
           + 0.3 * z**2 + 0.1 * rng.standard_normal(g.shape))
    ps = PressureSolver(g, order=4)
    rhs = laplacian(g, phi, order=4)
    sol = ps.solve(rhs)
    assert np.abs((sol - sol.mean()) - (phi - phi.mean())).max() < 1e-10 * np.abs(phi).max()
    # the second-order operator's inverse does not solve it (the test can tell them apart)
    sol2 = PressureSolver(g, order=2).solve(rhs)
    assert np.abs((sol2 - sol2.mean()) - (phi - phi.mean())).max() > 1e-3 * np.abs(phi).max()
    # G4 = -D4^T with the control-volume weights: the projection does no work
    u, v, w = random_velocity(g, seed=4)
    vc = g.dx * g.dy * g.dz_c
    gx, gy, gz = gradient(g, phi, order=4)
    lhs = np.sum(vc * phi * divergence(g, u, v, w, order=4))
    rhs_ = -(np.sum(vc * (u * gx + v * gy)) + np.sum(g.dx * g.dy * g.dz_f * w * gz))
    assert lhs == pytest.approx(rhs_, rel=1e-12)
    u0, v0, w0 = u.copy(), v.copy(), w.copy()
    ps.project(u, v, w)
    assert np.all(w[..., 0] == 0) and np.all(w[..., -1] == 0)
    assert np.abs(divergence(g, u, v, w, order=4)).max() < 1e-12 * np.abs(u0).max() / g.dz_c.min()
    assert np.abs(divergence(g, u, v, w, order=2)).max() > 0.01 * np.abs(u0).max() / g.dx
    # orthogonal: |u0|^2 = |u|^2 + |u0 - u|^2 in the control-volume norm
    def norm2(a, b, c):
        return np.sum(vc * (a**2 + b**2)) + np.sum(g.dx * g.dy * g.dz_f * c**2)
    assert norm2(u0, v0, w0) == pytest.approx(norm2(u, v, w) + norm2(u0 - u, v0 - v, w0 - w),
                                              rel=1e-12)


def _horizontal_errors(order, nx, ny, kxm, kym, Lx=2.0, Ly=1.5, nz=5):
    """Max errors of A_u, A_v, A_w against -d(u_j u_i)/dx_j for fields smooth in x and y (kxm,
    kym wavelengths per domain) and uniform in z (w uniform on the interior faces), on the levels
    where the discrete vertical fluxes cancel, so only the x and y parts are measured."""
    g = Grid.uniform(nx, ny, nz, Lx, Ly, 1.0)
    kx, ky = 2 * np.pi * kxm / Lx, 2 * np.pi * kym / Ly

    def fu(x, y):                      # value, d/dx, d/dy
        X, Y = kx * x + 0.6, ky * y + 0.5
        return 1 + 0.5 * np.sin(X) * np.cos(Y), 0.5 * kx * np.cos(X) * np.cos(Y), \
            -0.5 * ky * np.sin(X) * np.sin(Y)

    def fv(x, y):
        X, Y = kx * x + 0.4, ky * y + 0.7
        return 0.2 + 0.3 * np.cos(X) * np.sin(Y), -0.3 * kx * np.sin(X) * np.sin(Y), \
            0.3 * ky * np.cos(X) * np.cos(Y)

    def fw(x, y):
        X, Y = kx * x + 0.1, ky * y + 0.3
        return 0.4 * np.sin(X) * np.sin(Y), 0.4 * kx * np.cos(X) * np.sin(Y), \
            0.4 * ky * np.sin(X) * np.cos(Y)

    xf, xc, yf, yc = g.x_f[:, None], g.x_c[:, None], g.y_f[None, :], g.y_c[None, :]
    u = np.ascontiguousarray(np.repeat(fu(xf, yc)[0][:, :, None], nz, axis=2))
    v = np.ascontiguousarray(np.repeat(fv(xc, yf)[0][:, :, None], nz, axis=2))
    w = np.zeros((nx, ny, nz + 1))
    w[..., 1:-1] = fw(xc, yc)[0][:, :, None]
    au, av, aw = advection_tendencies(g, u, v, w, order)
    (uu, ux, uy), (vv, vx, vy) = fu(xf, yc), fv(xf, yc)
    exact_u = -(2 * uu * ux + uy * vv + uu * vy)
    (uu, ux, uy), (vv, vx, vy) = fu(xc, yf), fv(xc, yf)
    exact_v = -(ux * vv + uu * vx + 2 * vv * vy)
    (uu, ux, uy), (vv, vx, vy), (ww, wx, wy) = fu(xc, yc), fv(xc, yc), fw(xc, yc)
    exact_w = -(ux * ww + uu * wx + vy * ww + vv * wy)
    return np.array([np.abs(au[..., 1:-1] - exact_u[..., None]).max(),
                     np.abs(av[..., 1:-1] - exact_v[..., None]).max(),
                     np.abs(aw[..., 2:-2] - exact_w[..., None]).max()])


@pytest.mark.parametrize("direction", ["x", "y", "xy"])
def test_horizontal_advection_converges_at_the_scheme_order(direction):
    """The error of each of A_u, A_v, A_w falls ~16x per halving of dx (dy) at order 4 (measured
    15.5-15.8 from 32 to 64 points per wavelength) and ~4x at order 2."""
    kxm, kym = {"x": (1, 0), "y": (0, 1), "xy": (1, 1)}[direction]
    ratios = {}
    for order in (2, 4):
        e32, e64 = (_horizontal_errors(order, n if kxm else 4, n if kym else 4, kxm, kym)
                    for n in (32, 64))
        assert np.all(e64 > 0)
        ratios[order] = e32 / e64
    assert np.all(ratios[4] > 14.0), ratios
    assert np.all((ratios[2] > 3.5) & (ratios[2] < 4.5)), ratios


@pytest.mark.parametrize("implicit", [False, True])
def test_stage_kernels_advect_at_the_chosen_order(implicit):
    """One stage of each momentum kernel with no diffusion, damping or pressure, from a zero base
    and cdt = 1 s, is the whole-grid advection operator of that order (order 2 by default, as
    the callers that do not name it)."""
    from saltstudy.solver.flow.stepper import _momentum_stage
    from saltstudy.solver.flow.vertical_diffusion import momentum_stage_implicit
    g = stretched_grid(nx=12, ny=10, nz=8)
    u, v, w = random_velocity(g, seed=9, mean_u=1.0)
    PressureSolver(g, order=4).project(u, v, w)
    zc, zf, tau0 = np.zeros(g.nz), np.zeros(g.nz + 1), np.zeros(g.shape[:2])
    for order in (2, 4):
        ou, ov, ow = np.zeros_like(u), np.zeros_like(v), np.zeros_like(w)
        base = (np.zeros_like(u), np.zeros_like(v), np.zeros_like(w))
        if implicit:
            momentum_stage_implicit(u, v, w, np.zeros(g.shape), np.ones(g.nz), tau0, tau0, *base, ou,
                                    ov, ow, np.zeros(g.shape), 1.0, 0.5, 1.0 / g.dx, 1.0 / g.dy,
                                    g.dz_c, g.dz_f, zc, zc, zf, 0.0, 0.0, True, order)
        else:
            _momentum_stage(u, v, w, np.zeros(g.shape), np.ones(g.nz), tau0, tau0, *base, ou, ov,
                            ow, 1.0, 1.0 / g.dx, 1.0 / g.dy, g.dz_c, g.dz_f, zc, zc, zf, 0.0, 0.0,
                            True, False, order)
        for got, want in zip((ou, ov, ow), advection_tendencies(g, u, v, w, order)):
            assert np.abs(got - want).max() < 1e-12 * np.abs(want).max()
        other = advection_tendencies(g, u, v, w, 6 - order)
        assert np.abs(ou - other[0]).max() > 1e-3 * np.abs(other[0]).max()


def test_inviscid_rk3_keeps_kinetic_energy_with_fourth_order():
    """No SGS, no wall, no damping: RK3 + the fourth-order advection and projection lose energy
    only through the time scheme (the loss falls with dt); with the second-order projection the
    fourth-order advection drifts by a spatial error that does not fall with dt (measured:
    -1.5e-8 against -5.0e-5 over the same 5 steps; -3.0e-9 against -5.0e-5 over 10 steps of
    half the size)."""
    g = stretched_grid(nx=16, ny=12, nz=12, dz_bottom=0.05)

    def run(nsteps, courant, projection_order=4):
        st = make_stepper(g, nu_mol=0.0, sgs=False, wall=False, advection_order=4)
        if projection_order != 4:
            st.pressure = PressureSolver(g, order=projection_order)
        s = FlowState.zeros(g)
        s.u[...], s.v[...], s.w[...] = random_velocity(g, seed=7, mean_u=1.0)
        st.pressure.project(s.u, s.v, s.w)
        v0 = s.v.copy()
        k0 = _kinetic_energy(g, s)
        dt = courant / (4.0 / min(g.dx, g.dy, g.dz_c.min()))
        for _ in range(nsteps):
            st.step(s, dt)
        return (_kinetic_energy(g, s) - k0) / k0, np.abs(s.v - v0).max()

    loss, change = run(5, 0.1)
    assert abs(loss) < 1e-6
    assert change > 0.1                    # the flow did change
    loss_half, _ = run(10, 0.05)
    assert abs(loss_half) < abs(loss) / 3.0
    drift, _ = run(5, 0.1, projection_order=2)
    drift_half, _ = run(10, 0.05, projection_order=2)
    assert abs(drift) > 1e3 * abs(loss) and abs(drift_half) > 0.5 * abs(drift)


def test_implicit_and_explicit_agree_at_small_steps_with_fourth_order():
    """As test_solver_vertical_diffusion's test at order 2: the implicit stages carry the
    fourth-order gradient G4 of the last pressure (the projection's), so one step of each
    scheme differs by O(dt^3) in u and w (a carried G2 would leave an O(dt^2) difference)."""
    g = stretched_grid(nx=12, ny=10, nz=16, dz_bottom=0.01)
    diffs = []
    for dt in (4e-4, 2e-4, 1e-4):
        s = FlowState.zeros(g)
        s.u[...], s.v[...], s.w[...] = random_velocity(g, seed=4, mean_u=2.0)
        s.e[...] = np.random.default_rng(8).uniform(0.05, 0.5, g.shape)
        st = make_stepper(g, vertical_diffusion="explicit", advection_order=4)
        st.pressure.project(s.u, s.v, s.w)
        for _ in range(3):
            st.step(s, dt)
        st.close()
        out = {}
        for scheme in ("explicit", "implicit"):
            s2 = FlowState.zeros(g)
            for f in "uvwep":
                getattr(s2, f)[...] = getattr(s, f)
            st = make_stepper(g, vertical_diffusion=scheme, advection_order=4)
            st.step(s2, dt)
            d4 = divergence(g, s2.u, s2.v, s2.w, order=4)
            assert np.abs(d4).max() < 1e-10 * np.abs(s2.u).max() / g.dz_c.min()
            st.close()
            out[scheme] = s2
        diffs.append([np.abs(getattr(out["explicit"], f) - getattr(out["implicit"], f)).max()
                      for f in "uw"])
    d = np.array(diffs)
    assert np.all(d > 0)
    assert np.all(d[:-1] / d[1:] > 6.5)


def test_flow_numerics_carries_the_order_from_the_fidelity():
    from pydantic import ValidationError

    from saltstudy.config import TimeStepping
    from saltstudy.solver.flow.stepper import FlowNumerics
    assert TimeStepping().advection_order == 2
    assert FlowNumerics.from_time(TimeStepping(advection_order=4)).advection_order == 4
    with pytest.raises(ValidationError):
        TimeStepping(advection_order=3)
    with pytest.raises(ValueError, match="advection_order"):
        FlowNumerics(advection_order=6)


@pytest.mark.parametrize("vertical_diffusion", ["explicit", "implicit"])
def test_smoke_model_with_fourth_order_is_finite_and_differs(vertical_diffusion):
    from saltstudy.solver.model import Model
    states = {}
    for order in (2, 4):
        sc = smoke_scene()
        ts = sc.fidelity.time.model_copy(update={"advection_order": order,
                                                 "vertical_diffusion": vertical_diffusion})
        sc = sc.model_copy(update={"fidelity": sc.fidelity.model_copy(update={"time": ts})})
        m = Model.from_scene(sc)
        assert m.stepper.order == order and m.stepper.pressure.order == order
        for _ in range(3):
            m.step(m.next_dt())
        s = m.state
        assert all(np.isfinite(getattr(s, f)).all() for f in "uvwep")
        umax = np.abs(s.u).max()
        assert np.abs(divergence(m.grid, s.u, s.v, s.w, order=order)).max() * m.grid.dx / umax < 1e-10
        states[order] = {f: getattr(s, f).copy() for f in "uvwe"}
        m.close()
    for f in "uvwe":
        scale = np.abs(states[2][f]).max()
        assert np.abs(states[4][f] - states[2][f]).max() > 1e-6 * scale, f
