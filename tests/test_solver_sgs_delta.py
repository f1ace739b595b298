"""SGS filter width: Scotti et al. (1993) anisotropy correction (solver/closures/sgs.py)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import smoke_scene, stretched_grid, with_closure
from saltstudy.solver.closures import sgs


def test_scotti_factor_is_one_for_cubes_and_known_for_flat_cells():
    assert sgs.scotti_factor(0.1, 0.1, np.array([0.1]))[0] == pytest.approx(1.0, abs=1e-15)
    # dx = dy, dz = dx/4: a1 = 1/4, a2 = 1 -> cosh(sqrt(4/27) ln 4)
    f = sgs.scotti_factor(0.2, 0.2, np.array([0.05]))[0]
    assert f == pytest.approx(math.cosh(math.sqrt(4.0 / 27.0) * math.log(4.0)), rel=1e-14)
    # symmetric in the three spacings (a tall cell is as anisotropic as the flat one)
    assert sgs.scotti_factor(0.05, 0.2, np.array([0.2]))[0] == pytest.approx(f, rel=1e-14)
    assert sgs.scotti_factor(0.2, 0.2, np.array([0.8]))[0] == pytest.approx(f, rel=1e-14)


def test_delta_profile_and_length_scale_follow_the_choice():
    g = stretched_grid()
    geo, sco = sgs.delta_profile(g, "geometric"), sgs.delta_profile(g, "scotti")
    assert np.allclose(geo, (g.dx * g.dy * g.dz_c) ** (1 / 3), rtol=1e-14)
    assert np.all(sco >= geo) and sco[0] > 1.1 * geo[0]       # the flat first cells get the most
    assert np.all(sgs.length_scale(g, delta="scotti") >= sgs.length_scale(g, delta="geometric"))
    with pytest.raises(ValueError, match="delta"):
        sgs.delta_profile(g, "cubic")


def test_model_uses_the_case_choice():
    from saltstudy.solver.model import Model

    s = smoke_scene(1)
    assert s.case.closure.delta == "scotti"
    g_over = with_closure(s, delta="geometric")
    m1, m2 = Model.from_scene(s), Model.from_scene(g_over)
    assert np.all(m1.stepper.closure.l >= m2.stepper.closure.l) and m1.stepper.closure.l[0] > m2.stepper.closure.l[0]
    m1.close()
    m2.close()
