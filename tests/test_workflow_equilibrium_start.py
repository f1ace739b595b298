"""A saltation run started at its column's equilibrium level (``fidelity.spinup.equilibrium_roughness``):
the particle-free start lowered by the log-law shift (u*s / kappa) ln(z0s / z0), z0s the roughness
the model's saltating column settles to (data/equilibrium_roughness.toml)."""
from __future__ import annotations

import math

import numpy as np
import pytest

import saltstudy.config
from saltstudy.config import ConfigError, equilibrium_roughness, load_case, load_fidelity, resolve_scene
from saltstudy.ncio import open_dataset, write_dataset
from saltstudy.report.tables import model_departures
from saltstudy.solver.grid import Grid
from saltstudy.solver.similarity import shift_restart
from saltstudy.workflow import archives, keys


def _scene(case: int = 2, on: bool = True, **overrides):
    fid = load_fidelity("reduced")
    fid = fid.model_copy(update={"spinup": fid.spinup.model_copy(update={"equilibrium_roughness": on})})
    return resolve_scene(load_case(case, overrides=overrides or None), fid)


def _spinup_archive(tmp_path, sc):
    """A spin-up archive of ``sc``'s grid holding a random particle-free restart at u* 0.4 m/s."""
    g = Grid.from_spec(sc.fidelity.grid)
    nx, ny, nz = g.shape
    rng = np.random.default_rng(3)
    ckpt = {"u": 5.0 + rng.random((nx, ny, nz)), "v": rng.random((nx, ny, nz)),
            "w": rng.random((nx, ny, nz + 1)), "e": rng.random((nx, ny, nz)),
            "p": rng.random((nx, ny, nz)), "t": 80.0, "step": 9, "rng_state": "abc",
            "u_drive": 9.5, "t_activation": float("nan"),
            "controller/tau_ref_filtered": 0.16, "controller/tau_ref_last": 0.16}
    prof = {"u": np.ones(nz), "uw_res": np.zeros(nz + 1), "uw_sgs": np.zeros(nz + 1),
            "tke_res": np.ones(nz), "e_sgs": np.ones(nz), "v": np.zeros(nz)}
    hist = {"t": np.arange(3.0), "u_star": np.full(3, 0.4), "tke": np.ones(3)}
    ds = archives.spinup_dataset(sc.spinup_scene(), g, ckpt, prof, hist, True, "steady", 9.5, 80.0,
                                 1.0, "k", (60.0, 80.0, 3))
    return open_dataset(write_dataset(ds, tmp_path / "spinup.nc"))


def test_shift_lowers_the_wind_and_its_drive_and_nothing_else():
    rng = np.random.default_rng(0)
    ck = {"u": rng.random((4, 3, 5)), "v": rng.random((4, 3, 5)), "e": rng.random((4, 3, 5)),
          "u_drive": 7.25, "t": 3.0}
    out = shift_restart(ck, 1.5)
    assert np.array_equal(out["u"], ck["u"] - 1.5) and out["u_drive"] == 5.75
    assert out["v"] is ck["v"] and out["e"] is ck["e"] and out["t"] == 3.0
    with pytest.raises(ValueError, match="finite"):
        shift_restart(ck, float("nan"))


def test_the_start_is_the_similarity_start_lowered_by_the_log_law_shift(tmp_path, monkeypatch):
    """With z0s = 1 mm over z0 = 10 um the whole column starts (u*s / kappa) ln 100 lower, its
    turbulence, pressure and drive force as the particle-free start's."""
    monkeypatch.setattr(saltstudy.config, "equilibrium_roughness", lambda case: 1.0e-3)
    on, off = _scene(on=True), _scene(on=False)
    ds = _spinup_archive(tmp_path, off)
    a, b = archives.start_restart(ds, on), archives.start_restart(ds, off)
    c = on.case
    du = c.forcing.u_star_s / c.air.kappa * math.log(1.0e-3 / c.surface.z0)
    assert du == pytest.approx(c.forcing.u_star_s / 0.4 * math.log(100.0))
    assert np.allclose(b["u"] - a["u"], du, rtol=0, atol=1e-12)
    assert b["u_drive"] - a["u_drive"] == pytest.approx(du, abs=1e-12)
    for k in ("v", "w", "e", "p"):
        assert np.array_equal(a[k], b[k]), k


def test_the_knob_keeps_the_shared_spinup_and_the_keys_of_runs_without_it(monkeypatch):
    import saltstudy.config.loading as loading
    monkeypatch.setattr(loading, "roughness_table", lambda: ({2: 4.0e-4}, 0.016, "a test table"))
    on, off = _scene(on=True), _scene(on=False)
    k_on, k_off = keys.run_keys(on.label, on), keys.run_keys(off.label, off)
    assert k_on.spinup == k_off.spinup and k_on.links == k_off.links
    assert k_on.saltation != k_off.saltation
    assert "equilibrium_roughness" not in keys.saltation_slice(off)["fidelity"]["spinup"]
    # a new measurement of z0s is a new run
    monkeypatch.setattr(loading, "roughness_table", lambda: ({2: 5.0e-4}, 0.016, "a test table"))
    assert keys.run_keys(on.label, on).saltation != k_on.saltation


def test_the_roughness_follows_the_physics_not_the_number(monkeypatch):
    """A case renumbered to take another case's start keeps its own z0s; other physics takes
    Charnock's form C u*s^2/g, never below the bed's z0."""
    import saltstudy.config.loading as loading
    monkeypatch.setattr(loading, "roughness_table", lambda: ({1: 4.0e-4}, 0.02, "a test table"))
    assert equilibrium_roughness(load_case(1)) == 4.0e-4
    assert equilibrium_roughness(load_case(1, overrides={"number": 4})) == 4.0e-4
    for case in (load_case(2), load_case(1, overrides={"splash": {"a_ej": 0.05}})):
        u = case.forcing.u_star_s
        assert equilibrium_roughness(case) == pytest.approx(0.02 * u * u / 9.81, rel=1e-12)
    calm = load_case(2, overrides={"forcing": {"u_star_s": 0.01}})
    assert equilibrium_roughness(calm) == calm.surface.z0


def test_a_roughness_reaching_the_first_level_is_refused_with_the_field_named():
    fid = load_fidelity("reduced").model_dump()
    fid["spinup"]["equilibrium_roughness"] = True
    from saltstudy.config import Fidelity
    fid = Fidelity.model_validate(fid)
    gale = load_case(6, overrides={"forcing": {"u_star_s": 2.5}})   # C u*s^2/g ~ 1 cm
    with pytest.raises(ConfigError, match="fidelity.spinup.equilibrium_roughness.*first level"):
        resolve_scene(gale, fid)
    resolve_scene(load_case(6), fid)   # 2 mm, below the 5 mm level


def test_every_stock_roughness_lies_above_the_bed_and_below_the_first_level():
    z1 = Grid.from_spec(load_fidelity("reduced").grid).z_c[0]
    for n in range(1, 11):
        case = load_case(n)
        assert case.surface.z0 < equilibrium_roughness(case) < z1, n


def test_table_2_names_the_start():
    lines = model_departures(_scene(on=True).model_dump(mode="json"))
    assert any("equilibrium_roughness" in line for line in lines)
    assert not any("equilibrium_roughness" in line
                   for line in model_departures(_scene(on=False).model_dump(mode="json")))
