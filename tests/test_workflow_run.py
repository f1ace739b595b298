"""The workflow with the real solver at smoke size: caching, reruns, resume, distributed runs.

The 2-case study uses cases 2 and 9: the same wind and seed (one shared spin-up), different soils.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.config import load_case, load_fidelity, load_study, project_root, resolve_scene
from saltstudy.ncio import CF_VERSION, is_complete, open_dataset
from saltstudy.solver.state import SolverBlowUp
from saltstudy.workflow import archives, keys
from saltstudy.workflow.driver import Interrupted
from saltstudy.workflow.paths import output_path, task_dir
from saltstudy.workflow.status import study_status
from saltstudy.workflow.tasks import read_task_json, saltation_task, spinup_task
from solver_helpers import lacking_metadata

STUDIES = Path(__file__).resolve().parent / "studies"      # the smoke-size studies the tests run
STUDY = 'description = "two smoke cases sharing a spin-up"\nfidelity = "smoke"\ncases = [2, 9]\n'


@pytest.fixture
def home(tmp_path, monkeypatch):
    h = tmp_path / "home"
    for d in ("cases", "workflows"):
        shutil.copytree(project_root() / d, h / d)
    (h / "workflows" / "two.toml").write_text(STUDY)
    monkeypatch.setenv("SALTSTUDY_HOME", str(h))
    monkeypatch.setenv("SALTSTUDY_OUT", str(tmp_path / "out"))
    return h


def starts(output: str, task: str) -> list[str]:
    """Labels of the tasks of kind ``task`` that did work, from the run-all log."""
    return [line.split()[2] for line in output.splitlines() if line.startswith(f"[start] {task} ")]


def assert_same_data(a: xr.Dataset, b: xr.Dataset, rtol: float = 0.0) -> None:
    assert set(a.variables) == set(b.variables)
    for n in a.variables:
        x, y = a[n].values, b[n].values
        if rtol == 0.0:
            assert np.array_equal(x, y, equal_nan=True), n
        else:
            np.testing.assert_allclose(x, y, rtol=rtol, atol=1e-12, err_msg=n)


def test_run_all_caches_and_reruns_only_what_changed(home, tmp_path):
    out = tmp_path / "out"
    cli = CliRunner()
    r = cli.invoke(app, ["run-all", "--study", "two", "--quiet"])
    assert r.exit_code == 0, r.output
    assert starts(r.output, "spinup") == ["case02,case09"]        # shared spin-up, run once
    assert sorted(starts(r.output, "saltation")) == ["case02", "case09"]
    assert "report:" in r.output
    summary = home / "reports" / "two" / "summary.json"
    s = json.loads(summary.read_text())
    assert (s["tasks_from_cache"], s["tasks_total"]) == (0, 5)     # one spin-up, two runs, two analyses

    # archives: complete, readable by xarray, every variable described, global attributes present
    st = load_study("two")
    ks = keys.study_keys(st)
    for label, k in ks.items():
        for task in ("spinup", "saltation", "analysis"):
            assert is_complete(output_path(out, task, getattr(k, task))), (label, task)
        for task in ("spinup", "saltation"):
            with xr.open_dataset(output_path(out, task, getattr(k, task))) as ds:
                assert lacking_metadata(ds) == []
                assert ds.attrs["Conventions"] == CF_VERSION      # tests/test_cf_archives.py
                for a in ("case_json", "package_version", "fidelity", "seed", "wall_time_s"):
                    assert a in ds.attrs
                assert ds.attrs["wall_time_s"] > 0
                assert json.loads(ds.attrs["case_json"])["fidelity"]["name"] == "smoke"
    with xr.open_dataset(output_path(out, "saltation", ks["case02"].saltation)) as s:
        samp = load_fidelity("smoke").sampling
        assert s["u"].dims == ("time", "x", "y", "z") and s["u"].dtype == np.float32
        np.testing.assert_array_equal(s["time"].values, samp.start + samp.interval * np.arange(samp.count))
        assert np.all(np.isfinite(s["u"].values)) and float(s["n_parcels"][0]) > 0
    assert all(row.state == "done" for row in study_status(st, out) if row.task != "report")

    # second invocation: all cached, no solver work, says so
    r = cli.invoke(app, ["run-all", "--study", "two", "--quiet"])
    assert r.exit_code == 0, r.output
    assert "all runs cached: no solver work" in r.output
    assert starts(r.output, "spinup") == starts(r.output, "saltation") == starts(r.output, "analysis") == []

    # edit one case (its particles only): its saltation and analysis rerun, not the shared
    # spin-up, nothing of the other case; status says stale before the rerun
    p = home / "cases" / "case09.toml"
    p.write_text(p.read_text().replace("[splash]", "").rstrip() + "\n\n[splash]\na_ej = 0.04\n")
    assert load_case(9).splash.a_ej == 0.04
    states = {(row.label, row.task): row.state for row in study_status(st, out)}
    assert states[("case09", "saltation")] == "stale" and states[("case02", "saltation")] == "done"
    assert states[("case09", "spinup")] == "done"
    r = cli.invoke(app, ["run-all", "--study", "two", "--quiet"])
    assert r.exit_code == 0, r.output
    assert starts(r.output, "spinup") == []
    assert starts(r.output, "saltation") == ["case09"] and starts(r.output, "analysis") == ["case09"]
    assert json.loads(summary.read_text())["tasks_from_cache"] == 3
    try:
        import saltstudy.report as rep
        has_report = hasattr(rep, "build_report")
    except ImportError:
        has_report = False
    if has_report:
        assert starts(r.output, "report") == ["two"]

    # a truncated archive in the cache is detected and recomputed, never trusted
    ks = keys.study_keys(st)
    victim = output_path(out, "saltation", ks["case02"].saltation)
    reference = open_dataset(victim)
    victim.write_bytes(victim.read_bytes()[:1000])
    assert not is_complete(victim)
    r = cli.invoke(app, ["run-all", "--study", "two", "--quiet"])
    assert r.exit_code == 0, r.output
    assert starts(r.output, "saltation") == ["case02"] and starts(r.output, "spinup") == []
    assert_same_data(open_dataset(victim), reference)   # deterministic: same seed, same result


def test_interrupt_and_resume_equals_uninterrupted(tmp_path):
    scene = resolve_scene(load_case(1), load_fidelity("smoke"))
    a, b = tmp_path / "a", tmp_path / "b"
    sp = spinup_task(scene, a)
    full = open_dataset(saltation_task(scene, sp, a))
    # same spin-up in the second cache; interrupt twice (before and inside the sampling window)
    shutil.copytree(sp.parent, b / "spinup" / sp.parent.name)
    sp_b = b / "spinup" / sp.parent.name / "spinup.nc"
    key = keys.saltation_key(scene, keys.spinup_key(scene))
    d = task_dir(b, "saltation", key)
    for n in (30, 40):
        with pytest.raises(Interrupted):
            saltation_task(scene, sp_b, b, interrupt_after_steps=n, checkpoint_interval=1e9)
        assert (d / "checkpoint.npz").is_file()
        assert read_task_json(d)["state"] == "failed"
        assert not output_path(b, "saltation", key).exists()
    status = {(r.label, r.task): r.state for r in
              study_status(load_study("smoke"), b) if r.label == "case01"}
    assert status[("case01", "saltation")] == "partial"
    resumed = open_dataset(saltation_task(scene, sp_b, b))
    assert resumed.attrs["resumed_from_t"] > 0
    assert not (d / "checkpoint.npz").exists()
    assert resumed.attrs["n_steps"] == full.attrs["n_steps"]
    assert_same_data(resumed, full)


def test_spinup_interrupted_and_resumed_equals_uninterrupted(tmp_path):
    """A spin-up killed twice (before and after t_min, where the steadiness test starts) resumes
    from its checkpoint and writes the archive of an uninterrupted one, bit for bit."""
    scene = resolve_scene(load_case(1), load_fidelity("smoke"))
    a, b = tmp_path / "a", tmp_path / "b"
    full = open_dataset(spinup_task(scene, a))
    key = keys.spinup_key(scene)
    d = task_dir(b, "spinup", key)
    for n in (30, 25):                    # steps of at most 0.02 s: stops near 0.6 s, then 1.1 s
        with pytest.raises(Interrupted):
            spinup_task(scene, b, checkpoint_interval=1e9, interrupt_after_steps=n)
        assert (d / "checkpoint.npz").is_file()
        assert not output_path(b, "spinup", key).exists()
    status = {(r.label, r.task): r.state for r in
              study_status(load_study("smoke"), b) if r.label == "case01"}
    assert status[("case01", "spinup")] == "partial"
    resumed = open_dataset(spinup_task(scene, b))
    assert not (d / "checkpoint.npz").exists()
    assert resumed.attrs["t_end"] == full.attrs["t_end"]
    assert_same_data(resumed, full)


def test_blowup_mid_run_keeps_the_last_checkpoint(tmp_path, monkeypatch):
    """A field that turns non-finite mid-run (a NaN put into u before the 25th saltation step)
    stops the run with the diagnostic and leaves the checkpoint of the last good state."""
    from saltstudy.solver.model import Model

    scene = resolve_scene(load_case(2), load_fidelity("smoke"))
    sp = spinup_task(scene, tmp_path)
    key = keys.saltation_key(scene, keys.spinup_key(scene))
    d = task_dir(tmp_path, "saltation", key)
    step, calls = Model.step, []

    def poisoned(self, dt):
        calls.append(dt)
        if len(calls) == 25:
            self.state.u[2, 3, 4] = np.nan
        return step(self, dt)

    monkeypatch.setattr(Model, "step", poisoned)
    with pytest.raises(SolverBlowUp) as err:
        saltation_task(scene, sp, tmp_path, checkpoint_interval=0.0)   # a checkpoint every step
    assert "non-finite" in str(err.value) and len(err.value.index) == 3
    tj = read_task_json(d)
    assert tj["state"] == "failed" and "SolverBlowUp" in tj["error"] and "step" in tj["error"]
    assert not output_path(tmp_path, "saltation", key).exists()
    with np.load(d / "checkpoint.npz", allow_pickle=False) as z:
        meta = json.loads(str(z["meta"]))
        u = np.asarray(z["model:u"])
    assert meta["n_steps"] == 24 and meta["t_since_activation"] > 0
    assert np.isfinite(u).all()                     # the state before the NaN


def test_too_large_saltation_step_stops_with_the_place(tmp_path):
    """The stability study's deliberately unstable scene (smoke size): stopped by the Courant
    check with the step, time, field and cell, not by a hang or a NaN."""
    fid = load_fidelity(STUDIES / "stability-smoke" / "smoke-dt-too-large.toml")
    scene = resolve_scene(load_case(2), fid)
    sp = spinup_task(scene, tmp_path)
    with pytest.raises(SolverBlowUp) as err:
        saltation_task(scene, sp, tmp_path)
    msg = str(err.value)
    assert "Courant number" in msg and "beyond sqrt(3)" in msg and "z = " in msg
    assert err.value.step > 0 and np.isfinite(err.value.value)


@pytest.mark.slow
def test_sigkill_mid_saltation_then_rerun_resumes(home, tmp_path):
    """A process killed with SIGKILL after its first checkpoint: the rerun resumes from it."""
    fid = home / "workflows" / "fidelities" / "smoke.toml"
    text = fid.read_text().replace("checkpoint_interval_wall = 5.0", "checkpoint_interval_wall = 0.5")
    text = text.replace("saltation_duration = 2.0", "saltation_duration = 6.0")
    fid.write_text(text.replace("[sampling]\nstart = 1.0", "[sampling]\nstart = 4.0"))
    # `saltstudy run` compiles in a child first (workflow/warmup.py), so that the killed, the
    # resumed and the reference process all load the kernels from the cache: bit-for-bit
    out_k, out_ref = tmp_path / "killed", tmp_path / "ref"
    exe = Path(sys.executable).parent / "saltstudy"
    env = {**os.environ, "SALTSTUDY_OUT": str(out_k)}
    proc = subprocess.Popen([str(exe), "run", "1", "--quiet"], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # paths by glob, not by keys computed here: the keys belong to the subprocess's code
    deadline = time.time() + 600
    while not list(out_k.glob("saltation/*/checkpoint.npz")) and proc.poll() is None \
            and time.time() < deadline:
        time.sleep(0.05)
    assert list(out_k.glob("saltation/*/checkpoint.npz")), "no checkpoint was written"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not any(is_complete(p) for p in out_k.glob("saltation/*/samples.nc"))
    r = subprocess.run([str(exe), "run", "1", "--quiet"], env=env, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    (killed,) = out_k.glob("saltation/*/samples.nc")
    resumed = open_dataset(killed)
    assert resumed.attrs.get("resumed_from_t", 0) > 0
    assert not list(out_k.glob("saltation/*/checkpoint.npz"))
    r = subprocess.run([str(exe), "run", "1", "--quiet"], env={**env, "SALTSTUDY_OUT": str(out_ref)},
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    (ref,) = out_ref.glob("saltation/*/samples.nc")
    assert ref.parent.name == killed.parent.name
    assert_same_data(resumed, open_dataset(ref))


@pytest.mark.slow
def test_distributed_local_cluster_equals_threaded(home, tmp_path):
    """2 worker processes x 1 thread: archives identical to the local threaded run on two workers,
    whose tasks' numba threads change as the others start and end (workflow/cores.py)."""
    from distributed import LocalCluster

    from saltstudy.workflow.graph import run_study

    (home / "workflows" / "two.toml").write_text(STUDY + "report = false\n")
    # the threaded run in its own process: this process may hold freshly compiled kernels, while
    # `run-all` warms the cache in a child first (workflow/warmup.py) and then loads from it, as
    # the workers below do
    r = subprocess.run([str(Path(sys.executable).parent / "saltstudy"), "run-all", "--study", "two",
                        "--quiet", "--workers", "2", "--out", str(tmp_path / "local")],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr
    st = load_study("two")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cl:
        dist = run_study(st, tmp_path / "dist", scheduler=cl.scheduler_address, quiet=True)
    assert dist.exit_code == 0, [o for o in dist.outcomes if not o.ok]
    assert sorted(o.task for o in dist.computed) == ["analysis", "analysis", "saltation", "saltation", "spinup"]
    for task, name in (("spinup", "spinup.nc"), ("saltation", "samples.nc")):
        local = sorted(p.parent.name for p in (tmp_path / "local").glob(f"{task}/*/{name}"))
        assert local == sorted(p.parent.name for p in (tmp_path / "dist").glob(f"{task}/*/{name}"))
        assert len(local) == (1 if task == "spinup" else 2)
        for key in local:
            x = open_dataset(tmp_path / "local" / task / key / name)
            y = open_dataset(tmp_path / "dist" / task / key / name)
            # the results do not depend on the numba thread count: bit for bit
            assert_same_data(x, y)
