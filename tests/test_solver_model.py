"""Model plumbing: time step, drive, TKE sink, components, diagnostics."""
from __future__ import annotations

import math
import sys

import numpy as np

from solver_helpers import smoke_scene
from saltstudy.solver.diagnostics import flow as df
from saltstudy.solver.model import Model, StepInfo
from saltstudy.solver.closures.sgs import E_MIN, delta_profile, length_scale
from saltstudy.solver.flow.wall import drag_coefficient, surface_stress


def test_next_dt_respects_cfl_and_limits():
    m = Model.from_scene(smoke_scene())
    dt = m.next_dt()
    assert 0 < dt <= m.scene.fidelity.time.dt_max
    info = m.step(dt)
    assert isinstance(info, StepInfo) and info.step == 1 and info.t == dt
    assert info.max_cfl <= m.scene.fidelity.time.cfl * 1.2
    assert m.next_dt(limit=1e-4) == 1e-4
    d = m.next_dt()
    assert m.next_dt(limit=1.5 * d) == 0.75 * d     # two equal steps, not one and a sliver


def test_no_saltation_scene_never_imports_particles():
    sys.modules.pop("saltstudy.solver.grains.particles", None)
    m = Model.from_scene(smoke_scene(), saltation=False)
    assert m.components == []
    assert "saltstudy.solver.grains.particles" not in sys.modules


def test_tke_sink_is_applied_implicitly():
    m = Model.from_scene(smoke_scene())
    rate = np.zeros(m.grid.shape)
    rate[:, :, 0] = 1e6               # a stiff sink: explicit would go negative
    m.state.tke_sink = rate
    m.step(m.next_dt())
    assert np.all(m.state.e[:, :, 0] < 1e-3) and np.all(m.state.e >= E_MIN)


def test_wall_stress_and_length_scale():
    cd = drag_coefficient(0.005, 1e-5, 0.4)
    assert math.isclose(cd, (0.4 / math.log(500)) ** 2)
    u = np.full((4, 4, 3), 5.0)
    v = np.zeros((4, 4, 3))
    tx, ty = surface_stress(u, v, cd)
    assert np.allclose(tx, -cd * 25.0) and np.allclose(ty, 0.0)
    m = Model.from_scene(smoke_scene())
    l = length_scale(m.grid)
    delta = delta_profile(m.grid)          # the filter width, with the Scotti factor by default
    assert np.all(l <= delta) and np.all(l <= 3.7 * 0.4 * m.grid.z_c + 1e-15)
    assert l[0] < 0.5 * delta[0]          # wall-limited near the bed
    assert np.allclose(m.stepper.closure.l, l)    # the model uses the case's (default) filter width


def test_drive_feed_forward_and_diagnostics_shapes():
    from saltstudy.config import load_case, load_fidelity, resolve_scene
    # the feed-forward of the top drive (explicitly: the package default may be the pressure gradient)
    fid = load_fidelity("smoke")
    # a 3 m domain under its 1 m damping layer (the feed-forward's log law is checked at 5 %)
    fid = fid.model_validate({**fid.model_dump(), "grid": {**fid.grid.model_dump(), "Lz": 3.0}})
    sc = resolve_scene(load_case(1, overrides={"forcing": {"drive": "top"}}), fid)
    m = Model.from_scene(sc)
    ustar = sc.case.forcing.u_star_s
    f = m.stepper.f_c * m.grid.dz_c
    # initial drive makes the momentum input of the damping layer ~ u*^2
    um = m.state.u.mean(axis=(0, 1))
    M = np.sum(f * (m.state.u_drive - um))
    assert abs(M - ustar**2) < 0.05 * ustar**2
    p = df.flow_profiles(m)
    nz = m.grid.nz
    assert p["u"].shape == (nz,) and p["uw_res"].shape == (nz + 1,) and p["eps_sgs"].shape == (nz,)
    assert np.all(p["sgs_transfer"] >= 0)
    pl = df.flow_planes(m, [0.002, 0.1, 0.4])["u_plane"]
    assert pl.shape == (m.grid.nx, m.grid.ny, 3)
    assert np.all(pl[..., 0].mean() < pl[..., 1].mean())   # log law below the first level
    uc, vc, wc = df.cell_centred_velocity(m)
    assert uc.shape == vc.shape == wc.shape == m.grid.shape
    assert df.u_star_at(m, 0.0) > 0
