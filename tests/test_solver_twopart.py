"""The two-part SGS model of Sullivan et al. (1994) (solver/closures/twopart.py): the isotropy factor on
fields whose mean and fluctuating strain are known, the mean-field viscosity's log-law matching at
the first face, column-momentum conservation of its tendency, the fluctuation-only TKE production,
a restart, and the configuration's rule that it replaces the near-wall term."""
from __future__ import annotations

import math

import numpy as np
import pytest
from typer.testing import CliRunner

from solver_helpers import random_velocity, smoke_scene, stretched_grid, with_closure
from saltstudy.solver.closures import sgs
from saltstudy.solver.closures.twopart import GAMMA_MIN, TwoPartModel


class _State:
    def __init__(self, u, v, w, e=None):
        self.u, self.v, self.w = u, v, w
        self.e = np.zeros(u.shape) if e is None else e


def _log_profile(g, u_star=0.4, z0=1e-5, kappa=0.4):
    return u_star / kappa * np.log(g.z_c / z0)


def _rlog(g, z0=1e-5):
    z1 = g.z_c[0]
    return 1.0 / (z1 * math.log(z1 / z0))


def test_isotropy_factor_is_floor_for_pure_mean_shear_and_one_without_mean():
    g = stretched_grid()
    rlog = _rlog(g)
    tp = TwoPartModel(g, 0.4, rlog)
    u = np.broadcast_to(_log_profile(g), g.shape).copy()
    v = np.zeros(g.shape)
    w = np.zeros(g.shape[:2] + (g.nz + 1,))
    tp.update_gamma(_State(u, v, w))
    assert np.all(tp.gamma == GAMMA_MIN)
    # the mean shear on the faces: the log law's resolved differences, and its gradient at the bed
    assert tp.mdu[0] == pytest.approx(u[0, 0, 0] * rlog, rel=1e-12)
    assert np.allclose(tp.mdu[1:-1], np.diff(u[0, 0, :]) / g.dz_f[1:-1], rtol=1e-12)
    # fluctuations without a mean (random field less its plane means): gamma = 1
    u, v, w = random_velocity(g, seed=4)
    u -= u.mean(axis=(0, 1), keepdims=True)
    v -= v.mean(axis=(0, 1), keepdims=True)
    tp.update_gamma(_State(u, v, w))
    s_mean = np.sqrt(0.5 * (tp.mdu[:-1] ** 2 + tp.mdu[1:] ** 2 + tp.mdv[:-1] ** 2 + tp.mdv[1:] ** 2))
    assert np.abs(s_mean[1:]).max() < 1e-12          # the interior faces carry no mean shear
    assert np.all(tp.gamma[1:] > 0.999)


def test_isotropy_factor_of_a_sheared_fluctuating_field():
    """gamma = S' / (S' + <S>) with S'^2 = <2 S_ij S_ij> - <S>^2 (the field's own strain)."""
    g = stretched_grid()
    rlog = _rlog(g)
    tp = TwoPartModel(g, 0.4, rlog)
    u, v, w = random_velocity(g, seed=5)
    u = 0.05 * u + _log_profile(g)[None, None, :]
    v, w = 0.05 * v, 0.05 * w
    tp.update_gamma(_State(u, v, w))
    nx, ny, nz = g.shape
    tot = np.zeros(nz)
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                sh, sv = sgs.strain_sq_at(u, v, w, i, j, k, (i - 1) % nx, (i + 1) % nx, (j - 1) % ny,
                                          (j + 1) % ny, k < nz - 1, k > 0, 1 / g.dx, 1 / g.dy,
                                          g.rdz_c, g.rdz_f, rlog)
                tot[k] += sh + sv
    tot /= nx * ny
    smean2 = 0.5 * (tp.mdu[:-1] ** 2 + tp.mdu[1:] ** 2 + tp.mdv[:-1] ** 2 + tp.mdv[1:] ** 2)
    sp = np.sqrt(tot - smean2)
    want = sp / (sp + np.sqrt(smean2))
    assert np.allclose(tp.gamma, np.maximum(want, GAMMA_MIN), rtol=1e-10)
    assert np.all((want > 0.05) & (want < 0.99))      # both parts matter in this field


def test_fluctuation_production_removes_exactly_the_mean_shear():
    """strain_sq_fluct_at with the plane-mean shears taken out: zero on a pure mean shear, and on a
    sheared field the plane mean of the vertical part falls by the mean's square."""
    g = stretched_grid()
    rlog = _rlog(g)
    tp = TwoPartModel(g, 0.4, rlog)
    nx, ny, nz = g.shape
    u = np.broadcast_to(_log_profile(g), g.shape).copy()
    v, w = np.zeros(g.shape), np.zeros(g.shape[:2] + (nz + 1,))
    tp.update_gamma(_State(u, v, w))
    for k in (0, 3, nz - 1):
        sh, sv = sgs.strain_sq_fluct_at(u, v, w, 2, 3, k, 1, 3, 2, 4, k < nz - 1, k > 0, 1 / g.dx,
                                        1 / g.dy, g.rdz_c, g.rdz_f, rlog, tp.mdu[k], tp.mdv[k],
                                        tp.mdu[min(k + 1, nz)], tp.mdv[min(k + 1, nz)])
        assert sh == 0.0 and abs(sv) < 1e-20
        full = sgs.strain_sq_at(u, v, w, 2, 3, k, 1, 3, 2, 4, k < nz - 1, k > 0, 1 / g.dx, 1 / g.dy,
                                g.rdz_c, g.rdz_f, rlog)[1]
        assert full > 0


def test_mean_viscosity_holds_the_log_law_stress_at_the_first_face_and_conserves_momentum():
    """A laminar log-law column (no resolved stress, no SGS energy): nu_T* = u* kappa z_1, so that
    nu_T carries u*^2 on the first face; the implicit tendency moves no column momentum."""
    g = stretched_grid(nz=20)
    rlog = _rlog(g)
    tp = TwoPartModel(g, 0.4, rlog)
    u_star = 0.4
    u = np.broadcast_to(_log_profile(g, u_star), g.shape).copy()
    v, w = np.zeros(g.shape), np.zeros(g.shape[:2] + (g.nz + 1,))
    tp.update_gamma(_State(u, v, w))
    tp.update_mean_viscosity(0.0, u_star, dt=1e-4)
    z1 = g.z_f[1]
    assert tp.nu_T_star == pytest.approx(u_star * 0.4 * z1, rel=1e-12)
    # on face 1 nu_T is nu_T* scaled by the resolved mean shear over the log law's u*/(kappa z_1),
    # so the stress it carries is u*^2 times that ratio squared (the ratio is the log law's
    # two-level difference over its gradient, ~1.1 on a first level of 2 cm)
    s1 = tp.mdu[1]
    ratio = s1 / (u_star / (0.4 * z1))
    assert 1.0 < ratio < 1.15
    assert tp.nu_T[1] * s1 == pytest.approx(u_star ** 2 * ratio ** 2, rel=1e-12)
    # decays with the mean shear above
    assert np.all(np.diff(tp.nu_T[1:-1]) < 0) and tp.nu_T[0] == 0.0 and tp.nu_T[-1] == 0.0
    col = (tp.tend_u * g.dz_c).sum()
    assert abs(col) < 1e-12 * np.abs(tp.tend_u * g.dz_c).sum()
    # resolved and SGS stress already at the log law's: nothing left for nu_T
    tp.update_mean_viscosity(u_star * 0.4 * z1, u_star, dt=1e-4)
    assert tp.nu_T_star == 0.0 and np.all(tp.nu_T == 0.0)


def test_two_part_model_runs_and_restarts_bit_for_bit():
    from saltstudy.solver.model import Model

    for model in ("deardorff", "dynamic"):
        sc = with_closure(smoke_scene(), model=model, near_wall=False, two_part=True)
        a = Model.from_scene(sc)
        for _ in range(6):
            a.step(a.next_dt())
        tp = a.stepper.closure.two_part
        assert tp is not None and a.stepper.closure.near_wall is None
        assert np.all((tp.gamma >= GAMMA_MIN) & (tp.gamma <= 1.0)) and tp.gamma.min() < 1.0
        assert tp.nu_T_star >= 0.0
        b = Model.from_scene(sc)
        for _ in range(3):
            b.step(b.next_dt())
        c = Model.from_scene(sc, restart=b.checkpoint())
        for _ in range(3):
            c.step(c.next_dt())
        for name in ("u", "v", "w", "e"):
            assert np.array_equal(getattr(a.state, name), getattr(c.state, name)), (model, name)
        for m in (a, b, c):
            m.close()


def test_two_part_with_the_near_wall_term_is_refused(tmp_path):
    from saltstudy.cli import app

    bad = tmp_path / "bad.toml"
    bad.write_text('number = 1\n[forcing]\nu_star_s = 0.4\n[particles]\nQ = 200\n'
                   '[closure]\ntwo_part = true\nnear_wall = true\n')
    r = CliRunner().invoke(app, ["validate", str(bad)])
    assert r.exit_code == 2 and "two_part" in r.output and "near_wall" in r.output, r.output
