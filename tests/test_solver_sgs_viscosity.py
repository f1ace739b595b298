"""Horizontal and vertical SGS eddy viscosities (closure.viscosity, solver/closures/sgs.py).

The anisotropic option gives the horizontal stresses nu_h = c_m l_h sqrt(e) and the vertical ones
nu_v = c_m l_v sqrt(e). Every diagnostic that reads a vertical SGS flux (the stress profile, the
drive's stress at z_ref) must carry the same nu_v as the momentum kernel, or the budgets they
close would not close.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import make_stepper, random_velocity, smoke_scene, stretched_grid, with_closure
from saltstudy.solver.closures import sgs
from saltstudy.solver.flow.forcing import total_stress_at_face
from saltstudy.solver.flow.stepper import _momentum_stage


def test_viscosity_lengths_follow_the_choice():
    g = stretched_grid()
    l = sgs.length_scale(g)
    lh, lv = sgs.viscosity_lengths(g, viscosity="isotropic")
    assert np.array_equal(lh, l) and np.array_equal(lv, l)
    lh, lv = sgs.viscosity_lengths(g, viscosity="anisotropic")
    lw = sgs.C_L * 0.4 * g.z_c
    n = sgs.BLEND_N
    assert np.allclose(lh, (math.sqrt(g.dx * g.dy) ** -n + lw ** -n) ** (-1 / n), rtol=1e-14)
    assert np.allclose(lv, (g.dz_c ** -n + lw ** -n) ** (-1 / n), rtol=1e-14)
    # flat cells near the bed: the vertical length is the shorter, the horizontal the longer
    assert lv[0] < l[0] < lh[0]
    with pytest.raises(ValueError, match="viscosity"):
        sgs.viscosity_lengths(g, viscosity="cubic")


@pytest.mark.parametrize("viscosity", ["isotropic", "anisotropic"])
def test_vertical_flux_diagnostics_match_the_momentum_kernel(viscosity):
    g = stretched_grid()
    # nu_mol = 0: the kernels scale the molecular part of nu by rv as well (stepper.py)
    stepper = make_stepper(g, nu_mol=0.0, wall=False, viscosity=viscosity)
    st = stepper.closure
    assert np.all(st.rv == 1.0) == (viscosity == "isotropic")
    u, v, w = random_velocity(g, seed=3, mean_u=2.0)
    u += np.linspace(0.0, 3.0, g.nz)[None, None, :]       # a mean shear for a mean flux
    e = np.random.default_rng(4).uniform(0.01, 0.2, g.shape)
    nu = np.zeros(g.shape)
    sgs.compute_nu(e, st.cml, st.nu_mol, nu)
    zero_c, zero_f = np.zeros(g.nz), np.zeros(g.nz + 1)
    tau0 = np.zeros(g.shape[:2])
    ou, ov, ow = np.zeros_like(u), np.zeros_like(v), np.zeros_like(w)
    _momentum_stage(u, v, w, nu, st.rv, tau0, tau0, np.zeros_like(u), np.zeros_like(v),
                    np.zeros_like(w), ou, ov, ow, 1.0, 1.0 / g.dx, 1.0 / g.dy, g.dz_c, g.dz_f,
                    zero_c, zero_c, zero_f, 0.0, 0.0, False, True, 2)
    # horizontal mean of du/dt = -d tau_13 / dz, tau_13 the diagnosed SGS stress on the faces
    tau = sgs.sgs_stress_uw_profile(u, w, nu, st.rv, tau0, g.dz_f, 1.0 / g.dx)
    want = -(tau[1:] - tau[:-1]) / g.dz_c
    got = ou.mean(axis=(0, 1))
    assert np.allclose(got, want, rtol=1e-10, atol=1e-12 * np.abs(want).max())
    # the drive's SGS flux is the same number
    for k in (1, g.nz // 2, g.nz - 1):
        _, s_face = total_stress_at_face(u, w, e, k, st.cml_v, st.nu_mol, g.dz_f, 1.0 / g.dx,
                                         tau0)
        assert s_face == pytest.approx(tau[k], rel=1e-10)
    stepper.close()


def test_bad_viscosity_names_the_field():
    from pydantic import ValidationError

    s = smoke_scene(1)
    with pytest.raises(ValidationError, match="viscosity"):
        s.case.closure.model_validate({**s.case.closure.model_dump(), "viscosity": "cubic"})


def test_model_uses_the_case_choice():
    from saltstudy.solver.model import Model

    s = smoke_scene(1)
    assert s.case.closure.viscosity == "isotropic"
    an = with_closure(s, viscosity="anisotropic")
    m1, m2 = Model.from_scene(s), Model.from_scene(an)
    assert np.all(m1.stepper.closure.rv == 1.0)
    assert np.allclose(m2.stepper.closure.cml_v, m2.stepper.closure.cml * m2.stepper.closure.rv, rtol=1e-14)
    assert np.any(m2.stepper.closure.rv < 0.9)
    m1.step(0.01)
    m2.step(0.01)
    assert np.isfinite(m2.state.u).all() and not np.array_equal(m1.state.u, m2.state.u)
    m1.close()
    m2.close()
