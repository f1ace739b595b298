"""Blow-up: a NaN stops the run with a SolverBlowUp that names step, time, field and place."""
from __future__ import annotations

import math

import numpy as np
import pytest

from solver_helpers import smoke_scene
from saltstudy.solver.diagnostics.checks import first_nonfinite, locate_nonfinite
from saltstudy.solver.model import Model
from saltstudy.solver.state import SolverBlowUp


def test_check_names_field_and_index():
    m = Model.from_scene(smoke_scene())
    m.state.e[3, 4, 5] = np.inf
    with pytest.raises(SolverBlowUp) as err:
        locate_nonfinite(m.state)
    exc = err.value
    assert exc.field == "e" and exc.index == (3, 4, 5) and math.isinf(exc.value)
    assert "step 0" in str(exc) and "'e'" in str(exc) and "(3, 4, 5)" in str(exc)
    assert first_nonfinite(np.zeros((3, 3, 3))) is None


def test_nan_injected_stops_the_next_step():
    m = Model.from_scene(smoke_scene())
    m.step(m.next_dt())
    m.state.u[2, 3, 4] = np.nan
    with pytest.raises(SolverBlowUp) as err:
        m.step(1e-3)
    exc = err.value
    assert exc.step == 2 and exc.field in ("u", "v", "w", "e")
    assert len(exc.index) == 3 and math.isnan(exc.value)
    assert "solver blow-up at step 2" in str(exc)


def test_courant_runaway_is_caught():
    m = Model.from_scene(smoke_scene())
    with pytest.raises(SolverBlowUp, match="Courant"):
        m.step(50 * m.next_dt())
