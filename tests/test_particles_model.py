"""The grain component inside the Model (solver/model.py): extreme scenes, Fig. 1 and Fig. 2."""
from __future__ import annotations

import math

import numpy as np
import pytest

from test_particles_helpers import scene

model_mod = pytest.importorskip("saltstudy.solver.model", reason="solver/model.py not present")
Model = model_mod.Model

from saltstudy.solver.diagnostics.grains import (grain_counters, grain_planes,  # noqa: E402
                                                    grain_profiles, grain_size_hist)


def _run(sc, steps, extra_parcels=0, spin_steps=0):
    m = Model.from_scene(sc, saltation=True)
    for _ in range(spin_steps):
        m.step(m.next_dt())
    m.activate_saltation()
    s = m.components[0]
    if extra_parcels:  # the smoke grid releases only a handful: add a realistic load near the bed
        rng = np.random.default_rng(11)
        g = s.grid
        s.add_parcels(rng.uniform(0, g.Lx, extra_parcels), rng.uniform(0, g.Ly, extra_parcels),
                      rng.uniform(1e-3, 0.1, extra_parcels), u=rng.uniform(0, 3, extra_parcels),
                      w=-rng.uniform(0, 1, extra_parcels),
                      d=np.full(extra_parcels, sc.case.soil.modes[0].mu))
    for _ in range(steps):
        m.step(m.next_dt())
    return m


EXTREME = {
    "case7_90um_Q28000": (7, {}),
    "case6_ustar_1.10": (6, {}),
    "ustar_1.5_200um": (2, {"forcing": {"u_star_s": 1.5}}),
    "400um_ustar_0.54": (10, {}),
    "soil_20um": (7, {"soil": {"modes": [{"mu": 20e-6}]}}),
}


@pytest.mark.parametrize("label", [pytest.param(k, marks=() if k == "case7_90um_Q28000"
                                                 else pytest.mark.slow) for k in EXTREME])
def test_extreme_scenes_stay_finite(label):
    number, ov = EXTREME[label]
    sc = scene(number, "smoke", **ov)
    m = _run(sc, steps=60, extra_parcels=3000, spin_steps=5)
    s = m.components[0]
    st = m.state
    for f in (st.u, st.v, st.w, st.e):
        assert np.all(np.isfinite(f))
    assert np.all(np.isfinite(s.u)) and np.all(np.isfinite(s.z))
    assert np.all(s.z >= 0) and np.all(s.z <= s.grid.Lz)
    assert s.counters()["n_impacts"] > 0
    assert st.tke_sink is not None and np.all(st.tke_sink >= 0)
    # records have the contract's shapes
    g = s.grid
    pl = grain_planes(m)
    assert pl["C_p"].shape == (g.nx, g.ny)
    assert abs(pl["C_p"].sum() * g.dx * g.dy - s.Q * s.n) < 1e-6 * s.Q * s.n
    pr = grain_profiles(m)
    assert abs(pr["pn"].sum() - s.Q * s.n) < 1e-6 * s.Q * s.n
    assert grain_size_hist(m, np.linspace(0, 1e-3, 11)).shape == (g.nz, 10)
    c = grain_counters(m)
    assert c["n_parcels"] == s.n and math.isfinite(c["G_tot"])


def test_checkpoint_through_model_bit_for_bit():
    sc = scene(2, "smoke")
    m = _run(sc, steps=10, extra_parcels=500)
    ck = m.checkpoint()
    m2 = Model.from_scene(sc, saltation=True, restart=ck)
    for _ in range(8):
        m.step(0.004)
        m2.step(0.004)
    a, b = m.components[0], m2.components[0]
    assert a.n == b.n and np.array_equal(a.x, b.x) and np.array_equal(m.state.u, m2.state.u)


@pytest.mark.slow
def test_case2_overshoot_plateau_and_wind_reduction():
    """Case 2 at the smoke-sized domain with a reduced-like run: parcel count rises, overshoots
    and levels off (paper Fig. 1); the mean wind in the lowest 0.3 m drops against the
    particle-free flow (Fig. 2)."""
    sc = scene(2, "smoke")
    m0 = Model.from_scene(sc, saltation=False)
    t_spin = 20.0
    while m0.t < t_spin:
        m0.step(m0.next_dt(limit=t_spin - m0.t))
    ck = m0.checkpoint()
    ref = Model.from_scene(sc, saltation=False, restart=ck)
    m = Model.from_scene(sc, saltation=True, restart=ck)
    m.activate_saltation()
    s = m.components[0]
    counts, times = [], []
    T = 30.0
    low = m.grid.z_c < 0.3
    u_ref, u_salt = [], []
    while m.t < t_spin + T:
        dt = m.next_dt(limit=t_spin + T - m.t)
        m.step(dt)
        counts.append(s.n)
        times.append(m.t - t_spin)
    while ref.t < t_spin + T:
        ref.step(ref.next_dt(limit=t_spin + T - ref.t))
    u_salt = m.state.u.mean(axis=(0, 1))[low]
    u_ref = ref.state.u.mean(axis=(0, 1))[low]
    counts = np.array(counts)
    times = np.array(times)
    print("parcels at t = 1, 5, 10, 20, 30 s:",
          [int(counts[np.searchsorted(times, t) - 1]) for t in (1, 5, 10, 20, 30)])
    print("u (z<0.3 m) salt / ref:", np.round(u_salt, 3), np.round(u_ref, 3))
    peak = counts.max()
    late = counts[times > 0.7 * T].mean()
    assert peak > 5 * s.n_initial                # saltation took off
    assert peak > 1.1 * late                     # overshoot then lower plateau
    assert np.all(u_salt < u_ref)                # wind reduced in the saltation layer
