"""Run-health diagnostics (solver/diagnostics/health.py) on states whose answer is known."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from test_particles_helpers import component, scene
from saltstudy.analysis.series import limiting_step
from saltstudy.solver.diagnostics.health import coupling_stiffness, parcel_balance


def test_loading_and_coupled_time_of_one_loaded_cell():
    """n parcels of one diameter at rest in one cell of still air: the loading is n Q m_p / (rho V)
    exactly, f(Re_p) = 1, and the coupled time is T_p / (1 + loading)."""
    s, st = component(scene(2), gravity=False)
    st.u[...] = 0.0
    st.v[...] = 0.0
    st.w[...] = 0.0
    g, k, d, n = s.grid, 3, 200e-6, 50
    s.add_parcels(np.full(n, 0.55), np.full(n, 0.45), np.full(n, g.z_c[k]), d=d)
    s.add_parcels([0.05], [0.05], [g.z_c[6]], d=d)       # a lone parcel elsewhere: less loaded
    out = coupling_stiffness(SimpleNamespace(components=[s], state=st))
    m_p = math.pi / 6 * s.rho_p * d ** 3
    loading = n * s.Q * m_p / (s.rho * g.dx * g.dy * g.dz_c[k])
    assert abs(out["loading_max"] / loading - 1) < 1e-12
    t_p = s.rho_p * d * d / (18 * s.rho * s.nu)
    assert abs(out["tau_c_min"] / (t_p / (1 + loading)) - 1) < 1e-12


def test_a_moving_grain_relaxes_faster_than_stokes():
    """With a slip velocity the drag correction f(Re_p) > 1 shortens the coupled time."""
    s, st = component(scene(2), gravity=False)
    st.u[...] = 0.0
    st.v[...] = 0.0
    st.w[...] = 0.0
    d = 200e-6
    s.add_parcels([0.55], [0.45], [s.grid.z_c[5]], u=3.0, d=d)
    out = coupling_stiffness(SimpleNamespace(components=[s], state=st))
    t_p = s.rho_p * d * d / (18 * s.rho * s.nu)
    re = 3.0 * d / s.nu
    f = 1 + 0.15 * re ** 0.687
    assert abs(out["tau_c_min"] * f * (1 + out["loading_max"]) / t_p - 1) < 1e-9


def test_no_parcels_no_numbers():
    s, st = component(scene(2), gravity=False)
    out = coupling_stiffness(SimpleNamespace(components=[s], state=st))
    assert math.isnan(out["loading_max"]) and math.isnan(out["tau_c_min"])


def test_parcel_balance_and_limiting_step():
    c = {"n_parcels": 115, "n_ejections": 40, "n_depositions": 25}
    assert parcel_balance(c, 100) == 0
    assert parcel_balance(dict(c, n_parcels=114), 100) == -1       # a parcel lost
    assert limiting_step(0.01, 0.02, math.inf, 0.05) == "courant"
    assert limiting_step(0.03, 0.02, 0.015, 0.05) == "grains"
    assert limiting_step(math.inf, math.inf, math.inf, 0.05) == "dt_max"
    assert limiting_step(0.01, 0.02, 0.015, 0.05, dt_fixed=0.1) == "fixed"
