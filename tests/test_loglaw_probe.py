"""The windowed log-law probe (instruments/loglaw_probe.py): its cospectrum, its roll-damping
diagnostic, its input errors and a short run on the smoke grid."""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from solver_helpers import random_velocity, stretched_grid  # (solver_helpers imports saltstudy first)
from saltstudy.config import ConfigError
from saltstudy.instruments.loglaw_probe import (HEIGHTS, build_scene, damp_x_uniform_circulation,
                                           probe_loglaw, spanwise_spectrum_u,
                                           spectral_peak_wavelength, streamwise_cospectrum_uw)


@pytest.mark.parametrize("nx", [16, 15])
def test_streamwise_cospectrum_sums_to_the_resolved_stress(nx):
    rng = np.random.default_rng(3)
    ny, nz, k = 6, 5, 2
    u = rng.normal(size=(nx, ny, nz)) + np.linspace(0, 1, nz)
    w = rng.normal(size=(nx, ny, nz + 1))
    w[:, :, 1:] += 0.5 * u             # a correlation, so the stress is not ~0
    c = streamwise_cospectrum_uw(SimpleNamespace(u=u, w=w), k)
    uf = 0.5 * (u[:, :, k - 1] + u[:, :, k])
    uc = 0.5 * (uf + np.roll(uf, -1, axis=0))
    direct = np.mean((uc - uc.mean()) * (w[:, :, k] - w[:, :, k].mean()))
    assert c.shape == (nx // 2 + 1,)
    assert abs(direct) > 0.1
    assert c.sum() == pytest.approx(direct, rel=1e-12)
    # a field uniform in x puts all of it at kx = 0
    c0 = streamwise_cospectrum_uw(SimpleNamespace(u=np.repeat(u[:1], nx, 0), w=np.repeat(w[:1], nx, 0)), k)
    assert c0[0] == pytest.approx(c0.sum(), rel=1e-12) and np.allclose(c0[1:], 0.0, atol=1e-14)


@pytest.mark.parametrize("ny", [24, 25])
def test_spanwise_spectrum_sums_to_the_variance_and_finds_a_streak_spacing(ny):
    rng = np.random.default_rng(4)
    nx, nz, k, Ly = 10, 4, 1, 3.0
    y = (np.arange(ny) + 0.5) * Ly / ny
    streaks = 0.8 * np.cos(2 * np.pi * 4 * y / Ly)            # 4 streaks across the box: 0.75 m
    u = 5.0 + streaks[None, :, None] + 0.2 * rng.normal(size=(nx, ny, nz))
    p = spanwise_spectrum_u(SimpleNamespace(u=u), k)
    plane = u[:, :, k]
    assert p.shape == (ny // 2 + 1,)
    assert p[0] == pytest.approx(np.mean((plane.mean(axis=1) - plane.mean()) ** 2), rel=1e-12)
    assert p.sum() == pytest.approx(np.mean((plane - plane.mean()) ** 2), rel=1e-12)
    assert spectral_peak_wavelength(p, Ly) == pytest.approx(0.75)
    # a second, stronger streak spacing wins
    u2 = u + 1.5 * np.cos(2 * np.pi * 6 * y / Ly)[None, :, None]
    assert spectral_peak_wavelength(spanwise_spectrum_u(SimpleNamespace(u=u2), k), Ly) == pytest.approx(0.5)


def test_premultiplied_peak_finds_streaks_on_a_red_spectrum():
    """A k^-2 spectrum with a bump at mode 6: the raw maximum is the box scale, the premultiplied
    one the bump."""
    m = np.arange(25, dtype=float)
    p = np.zeros(25)
    p[1:] = m[1:] ** -2.0
    p[6] *= 8.0
    assert spectral_peak_wavelength(p, 7.5) == pytest.approx(7.5)
    assert spectral_peak_wavelength(p, 7.5, premultiplied=True) == pytest.approx(7.5 / 6)


def test_roll_damping_removes_the_x_mean_circulation_and_keeps_the_divergence():
    from saltstudy.solver.flow.pressure import PressureSolver, divergence

    g = stretched_grid()
    u, v, w = random_velocity(g, seed=5, mean_u=2.0)
    ps = PressureSolver(g)
    ps.project(u, v, w, None, 1.0)
    v_fluct = v - v.mean(axis=0, keepdims=True)
    w_fluct = w - w.mean(axis=0, keepdims=True)
    v_plane = v.mean(axis=(0, 1))
    assert np.abs(w.mean(axis=0)).max() > 1e-3      # the field has an x-mean circulation
    damp_x_uniform_circulation(v, w, 1.0)
    assert np.abs(w.mean(axis=0)).max() < 1e-12
    vbar = v.mean(axis=0)
    assert np.abs(vbar - vbar.mean(axis=0, keepdims=True)).max() < 1e-12
    # the x-varying part and the plane-mean v are untouched
    assert np.allclose(v - v.mean(axis=0, keepdims=True), v_fluct, atol=1e-13)
    assert np.allclose(w - w.mean(axis=0, keepdims=True), w_fluct, atol=1e-13)
    assert np.allclose(v.mean(axis=(0, 1)), v_plane, atol=1e-13)
    # still divergence-free: a projection has (almost) nothing left to remove
    assert np.abs(divergence(g, u, v, w)).max() * g.dx / np.abs(u).max() < 1e-10
    u2, v2, w2 = u.copy(), v.copy(), w.copy()
    ps.project(u2, v2, w2, None, 1.0)
    assert np.abs(v2 - v).max() < 1e-10 and np.abs(w2 - w).max() < 1e-10
    ps.close()


def test_bad_probe_input_names_the_option_or_field():
    with pytest.raises(ValueError, match="--grid: not valid JSON"):
        build_scene(1, "smoke", "top", "{nx: 3}")
    with pytest.raises(ValueError, match="--overrides: expected a JSON object"):
        build_scene(1, "smoke", "top", None, "[1, 2]")
    with pytest.raises(ConfigError, match="grid.nx"):
        build_scene(1, "smoke", "top", '{"nx": -3}')
    with pytest.raises(ConfigError, match="surface.z0"):
        build_scene(1, "smoke", "top", None, '{"surface": {"z0": -1}}')
    scene = build_scene(1, "smoke", "top")
    with pytest.raises(ValueError, match="window"):
        probe_loglaw(scene, 1.0, 2.0)
    with pytest.raises(ValueError, match="roll_damping"):
        probe_loglaw(scene, 2.0, 1.0, roll_damping=-1.0)


def test_probe_runs_windows_on_the_smoke_grid():
    scene = build_scene(1, "smoke", "pressure_gradient", '{"nx": 16, "ny": 12}',
                        '{"closure": {"delta": "geometric"}}')
    lines = []
    res = probe_loglaw(scene, 4.0, 2.0, roll_damping=0.5, log=lines.append)
    assert scene.case.closure.delta == "geometric" and res["drive"] == "pressure_gradient"
    assert res["grid"][:2] == [16, 12]
    assert [round(r["t"]) for r in res["windows"]] == [2, 4]
    for r in res["windows"]:
        assert len(r["phi"]) == len(HEIGHTS) == len(r["u_star_stress_ratio"])
        ratios = [f["u_star_ratio"] for f in r["fit"].values()]
        assert all(np.isfinite(ratios)) and all(x > 0 for x in ratios)
        assert np.isfinite(r["kx0_share"])
        assert r["paper"]["u_star_ratio"] > 0 and r["paper"]["z0"] > 0
        sp = r["u_spanwise"]
        assert len(sp["power"]) == 12 // 2 + 1 and sp["peak_wavelength"] > 0
        assert sp["peak_over_dx"] == pytest.approx(sp["peak_wavelength"] / (scene.fidelity.grid.Ly / 12))
        prof = r["phi_profile"]
        assert len(prof["z"]) == len(prof["phi"]) > 3 and max(prof["z"]) < 0.5 * res["L"][2]
        assert "dynamic" not in r                       # the Deardorff closure has no coefficient

    json.dumps(res)                                     # the --json output is serialisable
    assert any("phi" in line for line in lines)


def test_probe_reports_the_dynamic_coefficient():
    scene = build_scene(1, "smoke", "top", '{"nx": 16, "ny": 12}', '{"closure": {"model": "dynamic"}}')
    res = probe_loglaw(scene, 2.0, 2.0, log=lambda s: None)
    dyn = res["windows"][0]["dynamic"]
    assert len(dyn["z"]) == len(dyn["c_s"]) == len(dyn["beta"]) > 3
    assert all(0.0 <= c <= 0.35 for c in dyn["c_s"]) and max(dyn["c_s"]) > 0.0


def test_out_file_is_rewritten_after_every_window(tmp_path):
    """--out: the result so far replaces the file after each window, under a temporary name first."""
    import json

    from saltstudy.instruments.loglaw_probe import _writer

    target = tmp_path / "probe.json"
    write = _writer(str(target))
    write({"windows": [1]})
    write({"windows": [1, 2]})
    assert json.loads(target.read_text()) == {"windows": [1, 2]}
    assert [p.name for p in tmp_path.iterdir()] == ["probe.json"]
    assert _writer("") is None
