"""The numba warm-up before solver work (workflow/warmup.py): shrunk scenes keep every option,
the child runs once per code path, and a first run equals its rerun (slow: compiles from cold)."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from saltstudy.config import load_case, load_fidelity, load_study, resolve_scene
from saltstudy.workflow import keys as K
from saltstudy.workflow.warmup import ensure_warm, signature, warm_scene


@pytest.mark.parametrize("study", ["reduced", "convergence", "stability", "paper",
                                   "investigations/equilibrium-bedshear-long", "investigations/knobs"])
def test_warm_scene_shrinks_cost_and_keeps_options(study):
    for rk in K.study_keys(load_study(study)).values():
        s, w = rk.scene, warm_scene(rk.scene)
        fs, fw = s.fidelity, w.fidelity
        assert (fw.grid.nx, fw.grid.ny) == (16, 12) and fw.grid.nz <= 16
        assert fw.grid.dz_bottom * fw.grid.nz < fw.grid.Lz
        assert fw.saltation_duration == 2.0 and fw.sampling.end <= 2.0
        assert fw.spinup.t_max == 2.0 and fw.spinup.u_star_ref == fs.spinup.u_star_ref
        # what selects code paths is kept
        assert w.case == s.case
        assert fw.relaxation.gain == fs.relaxation.gain
        assert fw.relaxation.until <= fw.sampling.start
        assert fw.q_multiplier == fs.q_multiplier and fw.time == fs.time
        assert fw.outputs == fs.outputs


def test_signature_follows_switches_not_constants():
    smoke = load_fidelity("smoke")
    s2 = resolve_scene(load_case(2), smoke)
    s9 = resolve_scene(load_case(9), smoke)           # another soil and Q: same code paths
    one_way = resolve_scene(load_case(2, overrides={"physics": {"two_way_coupling": False}}), smoke)
    assert signature(s2) == signature(s9)
    assert signature(one_way) != signature(s2)
    assert signature(resolve_scene(load_case(2), load_fidelity("reduced"))) != signature(s2)


def test_ensure_warm_runs_the_child_once(tmp_path, monkeypatch):
    monkeypatch.delenv("SALTSTUDY_NO_WARMUP", raising=False)
    smoke = load_fidelity("smoke")
    scenes = [resolve_scene(load_case(c), smoke) for c in (2, 9)]
    logs: list[str] = []
    assert ensure_warm(scenes, log=logs.append, marker_dir=tmp_path)
    assert not any("failed" in m for m in logs), logs
    markers = list(tmp_path.glob("*.json"))
    assert len(markers) == 1 and signature(scenes[0]) in markers[0].read_text()
    assert not ensure_warm(scenes, log=logs.append, marker_dir=tmp_path)   # done: no child
    assert len(logs) == 1
    monkeypatch.setenv("SALTSTUDY_NO_WARMUP", "1")
    assert not ensure_warm(scenes, marker_dir=tmp_path / "other")
    assert not ensure_warm([], marker_dir=tmp_path / "other")


@pytest.mark.slow
def test_first_run_from_cold_cache_equals_its_rerun(tmp_path):
    """From an empty numba cache: `saltstudy run` (warm-up child compiles, the run loads) and a
    second `saltstudy run` into another directory give bit-identical archives."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    env.pop("SALTSTUDY_NO_WARMUP", None)
    exe = [str(Path(sys.executable).parent / "saltstudy")]
    runs = []
    for name in ("first", "again"):
        out = tmp_path / name
        r = subprocess.run(exe + ["run", "2", "--fidelity", "smoke", "--out", str(out), "--quiet"],
                           env=env, capture_output=True, text=True)
        assert r.returncode == 0, r.stderr[-2000:]
        runs.append(out)
    assert list((tmp_path / "numba" / "warmup").glob("*.json"))
    a, b = (xr.open_dataset(next(Path(o, "saltation").glob("*/samples.nc"))) for o in runs)
    for name in ("u", "w", "e", "n_parcels", "C_p"):
        assert np.array_equal(a[name].values, b[name].values, equal_nan=True), name


def test_touching_a_solver_file_invalidates_the_marker(tmp_path, monkeypatch):
    """numba recompiles a kernel whose source file's time stamp changed, even with the same
    content (a checkout): the warm-up must run again then."""
    import saltstudy.workflow.warmup as W

    sigs = ["abc"]
    m1 = W._marker(sigs, tmp_path)
    assert W._marker(sigs, tmp_path) == m1
    real = W._source_stamps()
    monkeypatch.setattr(W, "_source_stamps", lambda: [(p, t + 1, n) for p, t, n in real])
    assert W._marker(sigs, tmp_path) != m1
    assert W._marker(["abd"], tmp_path) != m1
    assert any(p.endswith("solver/flow/stepper.py") for p, _, _ in real)
