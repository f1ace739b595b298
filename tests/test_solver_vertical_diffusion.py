"""The vertically implicit SGS diffusion (solver/flow/vertical_diffusion.py) against exact solutions:
1-D diffusion on the stretched grid at diffusion numbers 1, 10 and 100, the column budget of u
with the bed stress, the projection, and the implicit SGS dissipation."""
from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import make_stepper, random_velocity, stretched_grid
from saltstudy.solver.closures.closure import NoClosure
from saltstudy.solver.flow.pressure import divergence
from saltstudy.solver.closures.sgs import E_MIN
from saltstudy.solver.state import FlowState
from saltstudy.solver.flow.stepper import Boundaries, FlowNumerics, Stepper

NU0 = 2.0e-3     # [m^2 s^-1]
DZ1 = 0.01       # first level [m], the paper's


class ConstantViscosity(NoClosure):
    """A closure with a uniform eddy viscosity nu0 and no SGS TKE: the operator D is then linear
    and its exact solutions are known."""
    diffuses = True

    def __init__(self, grid, nu0):
        super().__init__(grid)
        self.nu0 = nu0

    def viscosity(self, u, v, w, e, nu):
        nu[...] = self.nu0


def column_grid(nz=24, Lz=2.0):
    return stretched_grid(nx=4, ny=4, nz=nz, Lx=0.4, Ly=0.4, Lz=Lz, dz_bottom=DZ1)


def diffusion_stepper(g, theta=0.5, scheme="implicit"):
    return Stepper(g, ConstantViscosity(g, NU0), Boundaries(wall=False),
                   FlowNumerics(vertical_diffusion=scheme, implicit_weight=theta, advection=False))


def operator_u(g):
    """The discrete vertical diffusion of a u column, du/dt = A u (zero flux at bed and lid)."""
    nz = g.nz
    A = np.zeros((nz, nz))
    for k in range(nz):
        if k > 0:
            a = NU0 / (g.dz_f[k] * g.dz_c[k])
            A[k, k - 1] += a
            A[k, k] -= a
        if k < nz - 1:
            c = NU0 / (g.dz_f[k + 1] * g.dz_c[k])
            A[k, k + 1] += c
            A[k, k] -= c
    return A


def smooth_mode(g):
    """The slowest decaying non-constant eigenvector of A and its rate (A is similar to a
    symmetric matrix: M^(1/2) A M^(-1/2) with M = diag(dz_c))."""
    A = operator_u(g)
    m = np.sqrt(g.dz_c)
    lam, V = np.linalg.eigh((m[:, None] * A) / m[None, :])
    order = np.argsort(-lam)          # 0 (constant), then the slowest decay
    return V[:, order[1]] / m, float(lam[order[1]])


def run_column(g, u0, dt, n, theta=0.5, scheme="implicit"):
    st = diffusion_stepper(g, theta, scheme)
    s = FlowState.zeros(g)
    s.u[...] = u0[None, None, :]
    for _ in range(n):
        st.step(s, dt)
    st.close()
    return s.u[0, 0].copy()


@pytest.mark.parametrize("D", [1.0, 10.0, 100.0])
def test_smooth_mode_decays_at_second_order(D):
    """A discrete eigenmode decays by (1 - dt|l|/2)/(1 + dt|l|/2) per step (Crank-Nicolson); the
    error against exp(-|l| t) falls 4x when dt halves, at every diffusion number nu dt / dz_1^2."""
    g = column_grid()
    phi, lam = smooth_mode(g)
    dt = D * DZ1 ** 2 / NU0
    t_end = 8 * dt
    errs = []
    for n in (8, 16, 32):
        got = run_column(g, phi, t_end / n, n)
        errs.append(np.abs(got - phi * math.exp(lam * t_end)).max())
    rate = -lam * dt
    amp = ((1 - rate / 2) / (1 + rate / 2)) ** 8
    assert run_column(g, phi, dt, 8) == pytest.approx(phi * amp, rel=1e-9, abs=1e-12)
    assert errs[0] / errs[1] == pytest.approx(4.0, rel=0.05)
    assert errs[1] / errs[2] == pytest.approx(4.0, rel=0.05)


@pytest.mark.parametrize("D", [1.0, 10.0, 100.0])
def test_cosine_profile_against_the_continuous_solution(D):
    """u(z, 0) = cos(pi z / Lz) under zero-flux bed and lid decays as exp(-nu (pi/Lz)^2 t): the
    implicit scheme at D = nu dt / dz_1^2 of 1, 10 and 100 follows it within the grid's spatial
    error plus the scheme's O(dt^2) time error, and stays bounded (the explicit scheme would be
    unstable beyond D ~ 0.6)."""
    Lz = 2.0
    g = column_grid(nz=40, Lz=Lz)
    dt = D * DZ1 ** 2 / NU0
    k2 = (math.pi / Lz) ** 2
    n = max(4, int(round(0.25 / (NU0 * k2 * dt))))    # to exp(-0.25) of the start
    got = run_column(g, np.cos(math.pi * g.z_c / Lz), dt, n)
    want = np.cos(math.pi * g.z_c / Lz) * math.exp(-NU0 * k2 * n * dt)
    # time error of CN: (|l| dt)^3 / 12 per step on the mode
    tol = 2e-3 + n * (NU0 * k2 * dt) ** 3 / 12
    assert np.abs(got - want).max() < tol
    assert np.all(np.isfinite(got))


def test_backward_euler_weight_damps_the_stiff_modes():
    """theta = 1: the grid-scale mode of the first levels (the stiffest) is damped at once; theta
    = 1/2 keeps it ringing at amplitude (1 - z/2)/(1 + z/2) per step."""
    g = column_grid()
    A = operator_u(g)
    m = np.sqrt(g.dz_c)
    lam, V = np.linalg.eigh((m[:, None] * A) / m[None, :])
    stiff = V[:, np.argmin(lam)] / m
    dt = 100 * DZ1 ** 2 / NU0
    z = -lam.min() * dt
    cn = run_column(g, stiff, dt, 1, theta=0.5)
    be = run_column(g, stiff, dt, 1, theta=1.0)
    assert cn == pytest.approx(stiff * (1 - z / 2) / (1 + z / 2), rel=1e-8, abs=1e-12)
    assert be == pytest.approx(stiff / (1 + z), rel=1e-8, abs=1e-12)
    assert np.abs(be).max() < 0.05 * np.abs(cn).max()


def test_column_integral_changes_by_the_bed_stress_only():
    """Deardorff closure with a varying e, advection on, at a step 20x the explicit diffusion
    limit: the domain integral of u changes by dt times the bed stress of the last stage's input
    (the implicit fluxes telescope; advection and the pressure gradient sum to zero), to
    round-off."""
    from saltstudy.solver.diagnostics.checks import health
    g = stretched_grid(nx=12, ny=10, nz=16, dz_bottom=DZ1)
    st = make_stepper(g, vertical_diffusion="implicit")
    s = FlowState.zeros(g)
    u, v, w = random_velocity(g, seed=5)
    s.u[...], s.v[...], s.w[...] = 0.05 * u, 0.05 * v, 0.01 * w
    s.u += 0.3 * np.log1p(g.z_c / 0.01)[None, None, :]
    st.pressure.project(s.u, s.v, s.w)
    s.e[...] = np.random.default_rng(6).uniform(10.0, 60.0, g.shape)
    clo = st.closure
    courant, drate, _ = health(g, s, clo.cml, clo.cml_v, clo.nu_mol)
    dt = 20 * 0.5 / drate
    assert courant * dt < 0.8
    vol = g.dx * g.dy * g.dz_c
    for _ in range(3):
        before = float(np.sum(vol * s.u))
        st.step(s, dt)
        change = float(np.sum(vol * s.u)) - before
        bed = dt * float(np.sum(st.taux)) * g.dx * g.dy
        assert abs(bed) > 1e-6 * abs(before)
        assert change == pytest.approx(bed, rel=1e-9, abs=1e-13 * abs(before))
    assert np.abs(divergence(g, s.u, s.v, s.w)).max() < 1e-10 * np.abs(s.u).max() / g.dz_c.min()
    st.close()


def test_projection_keeps_w_divergence_free_at_a_stiff_step():
    g = stretched_grid(nx=12, ny=10, nz=16, dz_bottom=DZ1)
    st = make_stepper(g, vertical_diffusion="implicit")
    s = FlowState.zeros(g)
    s.u[...], s.v[...], s.w[...] = random_velocity(g, seed=2, mean_u=1.0)
    s.e[...] = 0.3
    st.step(s, 0.05)
    assert np.abs(s.w[..., 0]).max() == 0.0 and np.abs(s.w[..., -1]).max() == 0.0
    assert np.abs(divergence(g, s.u, s.v, s.w)).max() < 1e-10 * np.abs(s.u).max() / g.dz_c.min()
    assert np.abs(s.w[..., 1:-1]).max() > 1e-3   # w was not zeroed
    st.close()


def test_implicit_and_explicit_agree_at_small_steps():
    """From the same state (after a few steps, so that it carries the pressure its projection
    increments), one step of each scheme well inside the explicit limits: u and w differ by
    O(dt^3), the local error of a second-order scheme (the difference falls ~8x when dt halves;
    without the incremental projection it fell 4x), e by O(dt^2) (its dissipation is backward
    Euler: first order, positive, with exact equilibria)."""
    g = stretched_grid(nx=12, ny=10, nz=16, dz_bottom=DZ1)
    diffs = []
    for dt in (4e-4, 2e-4, 1e-4):
        s = FlowState.zeros(g)
        s.u[...], s.v[...], s.w[...] = random_velocity(g, seed=4, mean_u=2.0)
        s.e[...] = np.random.default_rng(8).uniform(0.05, 0.5, g.shape)
        st = make_stepper(g, vertical_diffusion="explicit")
        st.pressure.project(s.u, s.v, s.w)
        for _ in range(3):
            st.step(s, dt)
        st.close()
        out = {}
        for scheme in ("explicit", "implicit"):
            s2 = FlowState.zeros(g)
            for f in "uvwep":
                getattr(s2, f)[...] = getattr(s, f)
            st = make_stepper(g, vertical_diffusion=scheme)
            st.step(s2, dt)
            st.close()
            out[scheme] = s2
        diffs.append([np.abs(getattr(out["explicit"], f) - getattr(out["implicit"], f)).max()
                      for f in "uwe"])
    d = np.array(diffs)
    assert np.all(d > 0)
    assert np.all(d[:-1, :2] / d[1:, :2] > 6.5)                       # u, w: third order locally
    assert np.all((d[:-1, 2] / d[1:, 2] > 3.5) & (d[:-1, 2] / d[1:, 2] < 5.0))   # e: second


def test_sgs_dissipation_is_implicit_and_keeps_e_positive():
    """A uniform e at rest: de/dt = -c_eps e^{3/2} / l only. At r dt = c_eps e^{1/2} dt / l up to
    ~100 near the bed e stays above zero and decays monotonically; at small r dt it follows the
    exact e(t) = (e0^{-1/2} + r0 t / (2 e0^{1/2}))^{-2} to first order in dt."""
    g = stretched_grid(nx=4, ny=4, nz=16, dz_bottom=DZ1)
    st = make_stepper(g, vertical_diffusion="implicit", wall=False, advection=False)
    ceps_l = st.closure.ceps_l
    e0 = 1.0
    for dt, tol in ((2.0, None), (1e-4, 0.02)):
        s = FlowState.zeros(g)
        s.e[...] = e0
        prev = s.e[0, 0].copy()
        n = 10
        for _ in range(n):
            st.step(s, dt)
            col = s.e[0, 0]
            assert np.all(col >= E_MIN) and np.all(col <= prev + 1e-15)
            prev = col.copy()
        assert ceps_l[0] * math.sqrt(e0) * dt > 50 or tol is not None
        if tol is not None:
            t = n * dt
            exact = (e0 ** -0.5 + 0.5 * ceps_l * t) ** -2.0
            assert np.allclose(s.e[0, 0], exact, rtol=tol)
            assert not np.allclose(s.e[0, 0], e0, rtol=1e-3)
    st.close()
