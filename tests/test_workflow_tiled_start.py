"""A grid started from another fidelity's spin-up, tiled (``fidelity.spinup.tiled_from``): the
paper's box from the fine rung's spin-up, here a smoke box twice as wide and long from the smoke
spin-up, with the real solver."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.config import ConfigError, load_case, load_fidelity, project_root, resolve_scene
from saltstudy.workflow import keys
from saltstudy.workflow.paths import output_path

WIDE = """based_on = "smoke"
description = "the smoke grid tiled 2 x 2"

[grid]
Lx = 4.8
Ly = 3.2
nx = 32
ny = 24

[spinup]
tiled_from = "smoke"
"""
STUDY = 'description = "one wide smoke case"\nfidelity = "smoke-wide"\ncases = [2]\n'


@pytest.fixture
def home(tmp_path, monkeypatch):
    h = tmp_path / "home"
    for d in ("cases", "workflows"):
        shutil.copytree(project_root() / d, h / d)
    fids = h / "workflows" / "fidelities"
    (fids / "smoke-wide.toml").write_text(WIDE)
    (fids / "wide-stagger.toml").write_text(WIDE.replace("[spinup]\n", "[spinup]\nstagger = 1.0\n"))
    (fids / "wide-of-wide.toml").write_text(WIDE.replace('tiled_from = "smoke"',
                                                         'tiled_from = "smoke-wide"'))
    (fids / "wide-of-nothing.toml").write_text(WIDE.replace('tiled_from = "smoke"',
                                                            'tiled_from = "nosuch"'))
    (h / "workflows" / "wide.toml").write_text(STUDY)
    monkeypatch.setenv("SALTSTUDY_HOME", str(h))
    monkeypatch.setenv("SALTSTUDY_OUT", str(tmp_path / "out"))
    return h


def test_the_tiled_grid_shares_the_source_spinup_and_runs_its_own_saltation(home):
    plain = resolve_scene(load_case(2), load_fidelity("smoke"))
    wide = resolve_scene(load_case(2), load_fidelity("smoke-wide"))
    assert wide.spinup_fidelity.name == "smoke" and plain.spinup_fidelity is None
    assert wide.spinup_scene().fidelity.grid == plain.fidelity.grid
    kp, kw = keys.run_keys(plain.label, plain), keys.run_keys(wide.label, wide)
    assert kw.spinup == kp.spinup
    assert kw.saltation != kp.saltation and kw.analysis != kp.analysis
    # an untiled scene's keys do not carry the knob, so caches written without it stay valid
    assert "tiled_from" not in keys.saltation_slice(plain)["fidelity"]["spinup"]
    assert "tiled_from" not in plain.spinup_slice()["spinup"]
    assert keys.saltation_slice(wide)["fidelity"]["spinup"]["tiled_from"] == "smoke"


@pytest.mark.parametrize("name, needle", [
    ("wide-stagger", "stagger: a start tiled from another fidelity's spin-up is not staggered"),
    ("wide-of-wide", "spinup.tiled_from = 'smoke-wide' is itself tiled from 'smoke'"),
    ("wide-of-nothing", "fidelity 'nosuch': unknown"),
])
def test_a_tiled_start_that_cannot_run_names_the_field(home, name, needle):
    with pytest.raises((ConfigError, ValueError)) as err:
        resolve_scene(load_case(2), load_fidelity(name))
    assert needle in str(err.value)


def test_a_tiled_study_spins_up_on_the_source_grid_and_runs_on_its_own(home, tmp_path):
    r = CliRunner().invoke(app, ["run-all", "--study", "wide", "--quiet"])
    assert r.exit_code == 0, r.output
    scene = resolve_scene(load_case(2), load_fidelity("smoke-wide"), "case02")
    k = keys.run_keys(scene.label, scene)
    out = tmp_path / "out"
    with xr.open_dataset(output_path(out, "spinup", k.spinup)) as sp, \
            xr.open_dataset(output_path(out, "saltation", k.saltation)) as s, \
            xr.open_dataset(output_path(out, "analysis", k.analysis)) as a:
        assert sp.sizes["x"] == 16 and sp.sizes["y"] == 12
        assert s.sizes["x"] == 32 and s.sizes["y"] == 24
        assert float(s.attrs["t_activation"]) == pytest.approx(float(sp.attrs["restart__t"]))
        assert np.all(np.isfinite(s["u_mean"].values))
        # the particle-free reference is read on the run's levels (the same z here)
        assert np.isfinite(float(a["u_star_0"])) and np.isfinite(float(a["u_star_s_stress"]))
