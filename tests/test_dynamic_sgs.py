"""The plane-averaged scale-dependent dynamic Smagorinsky closure (solver/closures/dynamic.py).

An a-priori test on a field with a Kolmogorov inertial range and a real cascade (it must give the
Smagorinsky-Lilly coefficient and beta ~ 1), the same procedure on a field with the same spectrum but
no cascade (it must give none), the test filters' widths, the coefficient's clipping, the diagnosed
SGS TKE's equilibrium with the grain sink, momentum conservation of the SGS stress, a bit-for-bit
restart, and the configuration's errors.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from solver_helpers import make_stepper, random_velocity, smoke_scene, stretched_grid, with_closure
from turbulence_field import KOLMOGOROV_C, evolved_field, staggered_sample
from saltstudy.solver.closures import dynamic as dyn
from saltstudy.solver.closures import sgs
from saltstudy.solver.grid import Grid
from saltstudy.solver.flow.stepper import _momentum_stage

#: Lilly (1967): C_s = (1/pi) (3 C_K / 2)^(-3/4) for a sharp cut-off in a k^-5/3 range
C_S_LILLY = (1.0 / math.pi) * (1.5 * KOLMOGOROV_C) ** -0.75


def _volume_coefficients(u, v, w, m):
    """(C_s(2 Delta), C_s(4 Delta), beta, C_s) from the sums of the interior levels of an
    isotropic periodic m^3 box (the first and last levels use the bed and lid rules)."""
    dx = 2.0 * np.pi / m
    g = Grid(m, m, m, 2.0 * np.pi, 2.0 * np.pi, np.arange(m + 1) * dx)
    out = np.zeros((m, 4))
    a2, a4 = dyn.TEST_ALPHA_SQ
    dyn.germano_sums(u, v, w, 1.0 / dx, 1.0 / dx, g.rdz_c, g.rdz_f, 0.0, a2, a4, out)
    s = out[1:-1].sum(axis=0)
    c2, c4 = s[0] / s[1], s[2] / s[3]
    delta = dx                                    # (dx dy dz)^(1/3) on a cubic grid
    beta = c4 / c2
    return (math.sqrt(max(c2, 0.0)) / delta, math.sqrt(max(c4, 0.0)) / delta, beta,
            math.sqrt(max(c2 / beta, 0.0)) / delta if c2 > 0 else 0.0)


@pytest.fixture(scope="module")
def cascade_field():
    return evolved_field(64, turnovers=0.15)


def test_a_priori_coefficient_is_lilly_value_and_scale_invariant(cascade_field):
    uh, skew = cascade_field
    assert skew < -0.3                      # the field carries a cascade (Gaussian: 0)
    u, v, w = staggered_sample(uh, 24)
    cs2, cs4, beta, cs = _volume_coefficients(u, v, w, 24)
    assert C_S_LILLY == pytest.approx(0.165, abs=0.002)
    # within 20 % of the 0.16-0.18 band of the Smagorinsky-Lilly value
    assert 0.8 * 0.16 <= cs <= 1.2 * 0.18, cs
    # an inertial range has no scale dependence
    assert 0.85 <= beta <= 1.2, beta
    assert cs2 == pytest.approx(cs4, rel=0.15)


def test_a_field_without_a_cascade_gives_no_coefficient():
    """Same spectrum, Gaussian phases: no mean energy transfer, nothing for the procedure to
    measure (what makes the first test a test of the procedure, not of the spectrum)."""
    uh, skew = evolved_field(64, turnovers=0.0)
    assert abs(skew) < 0.05
    u, v, w = staggered_sample(uh, 24)
    _, _, _, cs = _volume_coefficients(u, v, w, 24)
    assert cs < 0.06, cs


@pytest.mark.parametrize("filt, variance", [(dyn.filter_plane_2, 4.0 / 12.0),
                                            (dyn.filter_plane_4, 16.0 / 12.0)])
def test_test_filters_have_the_box_widths(filt, variance):
    nx, ny = 12, 10
    src = np.zeros((nx, ny))
    src[5, 4] = 1.0
    dst, tmp = np.empty_like(src), np.empty_like(src)
    filt(src, dst, tmp)
    x = np.arange(nx)[:, None] - 5
    y = np.arange(ny)[None, :] - 4
    assert dst.sum() == pytest.approx(1.0, rel=1e-14)
    assert (dst * x).sum() == pytest.approx(0.0, abs=1e-14)
    assert (dst * x * x).sum() == pytest.approx(variance, rel=1e-13)   # that of a box of 2 or 4 cells
    assert (dst * y * y).sum() == pytest.approx(variance, rel=1e-13)
    const = np.full((nx, ny), 3.5)
    filt(const, dst, tmp)
    assert np.allclose(dst, 3.5, rtol=1e-15)



@pytest.mark.parametrize("ny", [5, 6, 11])
@pytest.mark.parametrize("filt, weights", [(dyn.filter_plane_2, {-1: 1 / 6, 0: 4 / 6, 1: 1 / 6}),
                                           (dyn.filter_plane_4, {-2: 1 / 12, -1: 4 / 12, 0: 2 / 12,
                                                                 1: 4 / 12, 2: 1 / 12})])
def test_test_filters_equal_a_periodic_convolution(filt, weights, ny):
    """The peeled end points of the y pass wrap like the interior (np.roll reference)."""
    src = np.random.default_rng(ny).standard_normal((7, ny))
    ref = sum(wx * np.roll(src, -sx, axis=0) for sx, wx in weights.items())
    ref = sum(wy * np.roll(ref, -sy, axis=1) for sy, wy in weights.items())
    dst, tmp = np.empty_like(src), np.empty_like(src)
    filt(src, dst, tmp)
    np.testing.assert_allclose(dst, ref, rtol=0, atol=1e-14)

def test_coefficient_profile_clips_and_bounds():
    delta = np.full(5, 0.1)
    sums = np.array([[-1.0, 1.0, 1.0, 1.0],       # backscatter at 2 Delta: zero
                     [1e-4, 1.0, 1e-4, 1.0],      # scale-invariant: beta = 1
                     [1e-4, 1.0, 5e-5, 1.0],      # beta = 0.5: C^2(Delta) = 2 C^2(2 Delta)
                     [1e-4, 1.0, -1.0, 1.0],      # beta floored at BETA_MIN
                     [1.0, 1.0, 1.0, 1.0]])       # beyond CS_MAX: capped
    cs2d2, beta, cs = dyn.coefficient_profile(sums, delta)
    assert cs2d2[0] == 0.0 and np.isnan(beta[0])
    assert cs2d2[1] == pytest.approx(1e-4) and beta[1] == pytest.approx(1.0)
    assert cs2d2[2] == pytest.approx(2e-4) and beta[2] == pytest.approx(0.5)
    assert beta[3] == dyn.BETA_MIN and cs2d2[3] == pytest.approx(1e-4 / dyn.BETA_MIN)
    assert cs[4] == pytest.approx(dyn.CS_MAX)
    assert np.all(cs <= dyn.CS_MAX + 1e-15)


def _strain_norm_numpy(g, u, v, w, rlog):
    """|S| at the centres (nx, ny, nz) with the edge averages of closures.dynamic.strain_at_centre,
    written with numpy rolls."""
    rx, ry = 1.0 / g.dx, 1.0 / g.dy
    s11 = (np.roll(u, -1, 0) - u) * rx
    s22 = (np.roll(v, -1, 1) - v) * ry
    s33 = (w[..., 1:] - w[..., :-1]) / g.dz_c
    e = (u - np.roll(u, 1, 1)) * ry + (v - np.roll(v, 1, 0)) * rx       # 2 S12 on (x_f, y_f)
    s12 = 0.125 * (e + np.roll(e, -1, 0) + np.roll(e, -1, 1) + np.roll(np.roll(e, -1, 0), -1, 1))
    nx, ny, nz = u.shape
    a = np.zeros((nx, ny, nz + 1))
    b = np.zeros((nx, ny, nz + 1))
    a[..., 1:nz] = ((u[..., 1:] - u[..., :-1]) / g.dz_f[1:nz]
                    + (w[..., 1:nz] - np.roll(w, 1, 0)[..., 1:nz]) * rx)
    b[..., 1:nz] = ((v[..., 1:] - v[..., :-1]) / g.dz_f[1:nz]
                    + (w[..., 1:nz] - np.roll(w, 1, 1)[..., 1:nz]) * ry)
    a[..., 0] = u[..., 0] * rlog
    b[..., 0] = v[..., 0] * rlog
    s13 = 0.125 * (a[..., :-1] + a[..., 1:] + np.roll(a, -1, 0)[..., :-1] + np.roll(a, -1, 0)[..., 1:])
    s23 = 0.125 * (b[..., :-1] + b[..., 1:] + np.roll(b, -1, 1)[..., :-1] + np.roll(b, -1, 1)[..., 1:])
    return np.sqrt(2 * (s11**2 + s22**2 + s33**2) + 4 * (s12**2 + s13**2 + s23**2))


def test_viscosity_and_diagnosed_tke_with_and_without_the_grain_sink():
    g = stretched_grid()
    u, v, w = random_velocity(g, seed=11, mean_u=3.0)
    rlog = 1.0 / (g.z_c[0] * math.log(g.z_c[0] / 1e-5))
    d = dyn.DynamicSmagorinsky(g, 0.4, rlog)
    d.cs2d2[...] = (0.17 * d.delta) ** 2
    d.cs2d2[-1] = 0.0                            # a level without SGS
    d._derived()
    nu, e = np.zeros(g.shape), np.zeros(g.shape)
    nu_mol = 1.5e-5
    d.viscosity(u, v, w, None, nu_mol, nu, e)
    sn = _strain_norm_numpy(g, u, v, w, rlog)
    want = d.cs2d2[None, None, :] * sn
    assert np.allclose(nu - nu_mol, want, rtol=1e-12, atol=1e-18)
    assert np.all(nu[..., -1] == nu_mol) and np.all(e[..., -1] == sgs.E_MIN)
    # the paper's nu_t = C_K l sqrt(e): every reader of (cml, e) gets the acting viscosity
    assert np.allclose(d.ckl[None, None, :-1] * np.sqrt(e[..., :-1]), want[..., :-1], rtol=1e-12)
    # eq. A1 in equilibrium: production = dissipation (+ grain sink)
    prod = (nu - nu_mol) * sn ** 2
    eps = d.ceps_l[None, None, :] * e ** 1.5
    assert np.allclose(prod[..., :-1], eps[..., :-1], rtol=1e-10)
    rate = np.random.default_rng(2).uniform(0.0, 50.0, g.shape)
    nu_s, e_s = np.zeros(g.shape), np.zeros(g.shape)
    d.viscosity(u, v, w, rate, nu_mol, nu_s, e_s)
    nt = nu_s - nu_mol
    prod = nt * sn ** 2
    eps = d.ceps_l[None, None, :] * e_s ** 1.5
    assert np.allclose(prod[..., :-1], (eps + rate * e_s)[..., :-1], rtol=1e-9)
    assert np.all(nt[..., :-1] < nu[..., :-1] - nu_mol)       # the grains lower it
    assert np.allclose(d.ckl[None, None, :-1] * np.sqrt(e_s[..., :-1]), nt[..., :-1], rtol=1e-12)
    # T_L = 4 e / (3 C0 eps) through the component's coefficient tlc / sqrt(e)
    k = 3
    tl = d.tlc[k] / np.sqrt(e[..., k])
    assert np.allclose(tl, 4 * e[..., k] / (3 * d.c0 * d.ceps_l[k] * e[..., k] ** 1.5), rtol=1e-12)


def test_sgs_stress_divergence_conserves_momentum():
    """Horizontal mean of the SGS momentum tendency = -d tau_13/dz of the diagnosed SGS stress, to
    round-off, with the dynamic viscosity."""
    g = stretched_grid()
    st = make_stepper(g, model="dynamic")
    u, v, w = random_velocity(g, seed=3, mean_u=2.0)
    u += np.linspace(0.0, 3.0, g.nz)[None, None, :]
    st.closure.dynamic.update(u, v, w)
    assert np.any(st.closure.dynamic.cs2d2 > 0)
    e = np.zeros(g.shape)
    st.boundary(u, v, w, e)
    zero_c, zero_f = np.zeros(g.nz), np.zeros(g.nz + 1)
    ou, ov, ow = np.zeros_like(u), np.zeros_like(v), np.zeros_like(w)
    _momentum_stage(u, v, w, st.nu, st.closure.rv, st.taux, st.tauy, np.zeros_like(u), np.zeros_like(v),
                    np.zeros_like(w), ou, ov, ow, 1.0, 1.0 / g.dx, 1.0 / g.dy, g.dz_c, g.dz_f,
                    zero_c, zero_c, zero_f, 0.0, 0.0, False, True, 2)
    tau = sgs.sgs_stress_uw_profile(u, w, st.nu, st.closure.rv, st.taux, g.dz_f, 1.0 / g.dx)
    want = -(tau[1:] - tau[:-1]) / g.dz_c
    got = ou.mean(axis=(0, 1))
    assert np.abs(want).max() > 1e-3
    assert np.allclose(got, want, rtol=1e-10, atol=1e-12 * np.abs(want).max())
    # the column's total: only the bed stress is left (the lid is free slip)
    col = (got * g.dz_c).sum()
    assert col == pytest.approx(st.taux.mean(), rel=1e-10)
    st.close()


def test_restart_is_bit_for_bit_between_coefficient_updates():
    from saltstudy.solver.model import Model

    sc = with_closure(smoke_scene(), model="dynamic", dynamic_interval=3)
    a = Model.from_scene(sc)
    for _ in range(7):
        a.step(a.next_dt())
    b = Model.from_scene(sc)
    for _ in range(4):                            # between updates (at steps 0, 3, 6)
        b.step(b.next_dt())
    ck = b.checkpoint()
    assert "closure/cs2d2" in ck
    c = Model.from_scene(sc, restart=ck)
    for _ in range(3):
        c.step(c.next_dt())
    for name in ("u", "v", "w", "e", "p"):
        assert np.array_equal(getattr(a.state, name), getattr(c.state, name)), name
    assert np.array_equal(a.stepper.closure.dynamic.cs2d2, c.stepper.closure.dynamic.cs2d2)
    assert a.stepper.closure.dynamic.n_updates == 3 and np.any(a.stepper.closure.dynamic.cs2d2 > 0)
    for m in (a, b, c):
        m.close()


def test_similarity_rescale_keeps_the_coefficient():
    from saltstudy.solver.similarity import rescale_restart

    ck = {"u": np.ones(3), "e": np.ones(3), "closure/cs2d2": np.full(3, 1e-4)}
    out = rescale_restart(ck, 2.0)
    assert np.array_equal(out["closure/cs2d2"], ck["closure/cs2d2"])
    assert np.array_equal(out["u"], 2.0 * ck["u"]) and np.array_equal(out["e"], 4.0 * ck["e"])


def test_bad_closure_model_names_the_field(tmp_path):
    from saltstudy.cli import app

    bad = tmp_path / "bad.toml"
    bad.write_text('number = 1\n[forcing]\nu_star_s = 0.4\n[particles]\nQ = 200\n'
                   '[closure]\nmodel = "smagorinsky"\n')
    r = CliRunner().invoke(app, ["validate", str(bad)])
    assert r.exit_code == 2 and "closure.model" in r.output, r.output
    bad.write_text('number = 1\n[forcing]\nu_star_s = 0.4\n[particles]\nQ = 200\n'
                   '[closure]\nmodel = "dynamic"\nviscosity = "anisotropic"\n')
    r = CliRunner().invoke(app, ["validate", str(bad)])
    assert r.exit_code == 2 and "viscosity" in r.output, r.output
    bad.write_text('number = 1\n[forcing]\nu_star_s = 0.4\n[particles]\nQ = 200\n'
                   '[closure]\nmodel = "dynamic"\ndynamic_interval = 0\n')
    r = CliRunner().invoke(app, ["validate", str(bad)])
    assert r.exit_code == 2 and "closure.dynamic_interval" in r.output, r.output


@pytest.mark.slow
def test_coefficient_falls_toward_the_wall_in_a_spun_up_layer():
    """Spun-up particle-free layer (quick grid, 150 s, case 1, the last 50 s averaged): the
    plane-averaged C_s on the lowest levels, where the test filters reach into the production
    range, is below its value in the layer above, and beta < 1 there (Porte-Agel et al. 2000)."""
    from saltstudy.instruments.loglaw_probe import build_scene, probe_loglaw

    scene = build_scene(1, "quick", "top", None, '{"closure": {"model": "dynamic"}}')
    res = probe_loglaw(scene, 150.0, 50.0, log=lambda s: None)
    dyn = res["windows"][-1]["dynamic"]
    z, cs, beta = (np.asarray(dyn[k]) for k in ("z", "c_s", "beta"))
    above = (z > 0.3) & (z < 1.5)
    print("z", np.round(z, 3), "\nC_s", np.round(cs, 3), "\nbeta", np.round(beta, 2))
    assert cs[:2].max() < 0.8 * cs[above].max()
    assert np.all(np.diff(cs[:4]) > 0)                    # rising away from the bed
    assert 0.0 < beta[0] < 1.0
