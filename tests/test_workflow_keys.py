"""Cache keys, the record schedule, archive round trips and checkpoint files (no solver needed)."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from saltstudy.config import load_case, load_fidelity, load_study, resolve_scene
from saltstudy.ncio import open_dataset, write_dataset
from saltstudy.solver.grid import Grid
from saltstudy.workflow import archives, keys
from saltstudy.workflow.driver import Recorder, Schedule, load_checkpoint, save_checkpoint
from solver_helpers import lacking_metadata


def scene(case=1, fidelity="smoke", **case_overrides):
    return resolve_scene(load_case(case, overrides=case_overrides or None), load_fidelity(fidelity))


def test_keys_do_not_depend_on_hash_seed():
    code = ("from saltstudy.workflow.keys import study_keys; from saltstudy.config import load_study;"
            "k = study_keys(load_study('smoke'))['case01']; print(k.spinup, k.saltation, k.analysis)")
    outs = {subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                           env={**os.environ, "PYTHONHASHSEED": s}).stdout for s in ("1", "2")}
    assert len(outs) == 1
    k = keys.run_keys("case01", scene(1))
    assert next(iter(outs)).split() == [k.spinup, k.saltation, k.analysis]


def test_what_changes_which_key():
    base = keys.run_keys("a", scene(1))
    # splash constants: saltation only, the spin-up is shared
    splash = keys.run_keys("a", scene(1, splash={"a_ej": 0.05}))
    assert splash.spinup == base.spinup and splash.saltation != base.saltation
    assert splash.analysis != base.analysis
    # wind: everything, unless the fidelity shares one spin-up by similarity (smoke does)
    assert load_fidelity("smoke").spinup.u_star_ref is not None
    wind = keys.run_keys("a", scene(1, forcing={"u_star_s": 0.5}))
    assert wind.spinup == base.spinup and wind.saltation != base.saltation
    # the paper fidelity spins each case up at its own wind (its parcels weighed as a multiple here,
    # since a count per m2 is measured for the numbered cases' own winds only)
    paper = load_fidelity("paper")
    paper = paper.model_validate({**paper.model_dump(), "parcels_per_m2": None})
    assert paper.spinup.u_star_ref is None
    q1, q2 = (keys.run_keys("a", resolve_scene(load_case(1, overrides={"forcing": {"u_star_s": u}}),
                                               paper)) for u in (0.41, 0.5))
    assert q1.spinup != q2.spinup and q1.saltation != q2.saltation
    # the label of a run and the checkpoint cadence change nothing
    other = keys.run_keys("other", scene(1))
    assert (other.spinup, other.saltation, other.analysis) == (base.spinup, base.saltation, base.analysis)
    f = load_fidelity("smoke")
    f2 = f.model_validate({**f.model_dump(), "checkpoint_interval_wall": 999.0})
    assert keys.run_keys("a", resolve_scene(load_case(1), f2)).saltation == base.saltation


def test_scenes_of_the_same_physics_share_one_run_under_two_labels(tmp_path):
    """A scene's label (its case's name) and the fidelity's name key nothing: two scenes that
    resolve to the same physics share one saltation and one analysis node of the graph, and the
    report gets both labels; another seed is another run."""
    from saltstudy.config import Study, study_runs
    from saltstudy.workflow.graph import build_graph
    st = Study.model_validate({"name": "t", "description": "", "fidelity": "smoke",
                               "scenes": [{"label": "x", "case": 1}, {"label": "y", "case": 1},
                                          {"label": "z", "case": 1, "overrides": {"seed": 5}}]})
    x, y, z = (keys.run_keys(r.label, r.scene) for r in study_runs(st))
    assert x.spinup == y.spinup and x.saltation == y.saltation and x.analysis == y.analysis
    assert z.saltation != x.saltation
    renamed = load_fidelity("smoke").model_copy(update={"name": "smoke-copy"})
    assert keys.run_keys("x", resolve_scene(load_case(1), renamed)).saltation == keys.run_keys(
        "x", resolve_scene(load_case(1), load_fidelity("smoke"))).saltation
    # where a fidelity file sits keys nothing either: the knobs investigation's reduced-q4 is the
    # convergence ladder's rung under its own name, and shares its archives
    knobs, ladder = (keys.run_keys("x", scene(2, ref)) for ref in
                     ("investigations/knobs/reduced-q4", "convergence/reduced-q4"))
    assert (knobs.spinup, knobs.saltation) == (ladder.spinup, ladder.saltation)
    plan = build_graph(st, tmp_path, report_dir=tmp_path / "rep")
    assert plan.graph["saltation:x"] is plan.graph["saltation:y"]
    assert plan.graph["analysis:x"] is plan.graph["analysis:y"]
    assert plan.graph["saltation:z"] is not plan.graph["saltation:x"]
    assert [r.name for r in plan.task_refs].count("saltation x") == 1
    assert not any(r.name == "saltation y" for r in plan.task_refs)


def test_cases_with_equal_wind_share_a_spinup():
    k = keys.study_keys(load_study("paper"))
    same = [l for l in k if k[l].spinup == k["case02"].spinup]
    # cases 2, 9, 10 have the same u*s and seed, differing in the soil only (Table 2)
    assert len(same) >= 2 and len(same) < len(k)
    assert len({k[l].saltation for l in same}) == len(same)


def test_similarity_shares_one_spinup_for_all_winds():
    k = keys.study_keys(load_study("smoke"))
    assert len({r.spinup for r in k.values()}) == 1
    assert len({r.saltation for r in k.values()}) == len(k)


def test_report_key_tracks_failed_runs():
    st = load_study("smoke")
    assert keys.report_key(st, {"a": "k1", "b": None}) != keys.report_key(st, {"a": "k1", "b": "k2"})


def test_schedule_lands_on_exact_multiples():
    sc = scene(1)
    s = Schedule.from_scene(sc)
    times = [t for t, _ in s.events]
    assert times == sorted(times) and len(set(times)) == len(times)
    samp = sc.fidelity.sampling
    sample_times = [t for t, g in s.events if "sample" in g]
    assert sample_times == [samp.start + i * samp.interval for i in range(samp.count)]
    planes = [t for t, g in s.events if "plane" in g]
    assert planes[0] == pytest.approx(samp.start) and planes[-1] == pytest.approx(samp.end)
    series = [t for t, g in s.events if "series" in g]
    assert series[0] == 0.0 and series[-1] == pytest.approx(sc.fidelity.saltation_duration)
    assert np.allclose(np.diff(series), samp.series_interval)
    assert times[-1] == pytest.approx(sc.fidelity.saltation_duration)


def _fake_checkpoint(g: Grid, rng) -> dict:
    nx, ny, nz = g.shape
    return {"u": rng.random((nx, ny, nz)), "v": rng.random((nx, ny, nz)),
            "w": rng.random((nx, ny, nz + 1)), "e": rng.random((nx, ny, nz)), "p": rng.random((nx, ny, nz)),
            "t": 1.2345678901234567, "step": 77, "flag": True, "rng_state": "abc", "u_drive": 3.5,
            "hist": rng.random(5), "ints": np.arange(4, dtype=np.int64), "t_activation": float("nan"),
            "controller/integral": 0.25, "saltation/x": rng.random(7), "saltation:x": rng.random(2)}


def test_spinup_archive_round_trips_the_restart(tmp_path):
    sc = scene(1)
    g = Grid.from_spec(sc.fidelity.grid)
    ckpt = _fake_checkpoint(g, np.random.default_rng(0))
    prof = {"u": np.ones(g.nz), "uw_res": np.zeros(g.nz + 1), "uw_sgs": np.zeros(g.nz + 1),
            "tke_res": np.ones(g.nz), "e_sgs": np.ones(g.nz), "v": np.ones(g.nz)}
    hist = {"t": np.arange(3.0), "u_star": np.ones(3), "tke": np.ones(3)}
    ds = archives.spinup_dataset(sc, g, ckpt, prof, hist, True, "steady", 3.5, 1.2, 0.1, "k", (0.2, 1.2, 3))
    p = write_dataset(ds, tmp_path / "spinup.nc")
    back = open_dataset(p)
    assert lacking_metadata(back) == []
    assert back["u"].dims == ("x_u", "y", "z") and back["w"].dims == ("x", "y", "z_w")
    for a in ("case_json", "package_version", "fidelity", "seed", "wall_time_s", "converged", "t_end"):
        assert a in back.attrs, a
    assert json.loads(back.attrs["case_json"])["case"]["number"] == 1
    r = archives.restart_from_dataset(back)
    assert set(r) == set(ckpt)
    for k, v in ckpt.items():
        if isinstance(v, np.ndarray):
            assert r[k].dtype == v.dtype and np.array_equal(r[k], v), k
        else:
            assert type(r[k]) is type(v) and (r[k] == v or (v != v and r[k] != r[k])), k


def test_checkpoint_file_round_trip_and_corruption(tmp_path):
    g = Grid.from_spec(load_fidelity("smoke").grid)
    ckpt = _fake_checkpoint(g, np.random.default_rng(1))
    rec = Recorder()
    for t in (0.0, 0.05):
        rec.add("series", t, {"n_parcels": 10, "G_tot_series": 0.1 * t})
    rec.add("sample", 1.0, {"u": np.ones((2, 3), np.float32)})
    sim = {"n_steps": 12, "origin": 0.75, "schedules": {"series": {"index": 3}},
           "callbacks": {"series": rec.checkpoint()}}
    path = tmp_path / "checkpoint.npz"
    save_checkpoint(path, ckpt, sim, {"wall_time_s": 1.5})
    model, sim2, meta = load_checkpoint(path)
    assert meta["wall_time_s"] == 1.5
    assert sim2["n_steps"] == 12 and sim2["origin"] == 0.75
    assert sim2["schedules"] == {"series": {"index": 3}}
    for k, v in ckpt.items():
        assert (np.array_equal(model[k], v) if isinstance(v, np.ndarray)
                else model[k] == v or (v != v and model[k] != model[k])), k
    assert type(model["step"]) is int and type(model["flag"]) is bool
    rec2 = Recorder.restore(sim2["callbacks"]["series"])
    for grp in ("series", "plane", "sample"):
        t1, v1 = rec.stacked(grp)
        t2, v2 = rec2.stacked(grp)
        assert np.array_equal(t1, t2) and v1.keys() == v2.keys()
        assert all(np.array_equal(v1[k], v2[k]) and v1[k].dtype == v2[k].dtype for k in v1)
    # a truncated checkpoint is ignored (the run starts over), never trusted
    path.write_bytes(path.read_bytes()[:200])
    assert load_checkpoint(path) is None
    assert load_checkpoint(tmp_path / "absent.npz") is None


def test_source_key_follows_the_kernels_not_the_tools(tmp_path):
    """An edit to a benchmark or a probe (instruments/) keeps every archive valid; an edit to a
    module a run executes makes them stale."""
    import shutil

    import saltstudy
    from saltstudy._identity import source_key
    pkg = Path(saltstudy.__file__).resolve().parent
    copy = tmp_path / "saltstudy"
    for sub in ("physics", "solver", "instruments"):
        shutil.copytree(pkg / sub, copy / sub, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(pkg / "_jit.py", copy / "_jit.py")
    base = source_key(copy)
    assert base == saltstudy.SOURCE_KEY
    tools = sorted((copy / "instruments").glob("*.py"))
    assert {"bench_scene.py", "bench_particles.py", "loglaw_probe.py"} <= {f.name for f in tools}
    for f in tools:
        f.write_text(f.read_text() + "\n# an edit\n")
    assert source_key(copy) == base
    adv = copy / "solver" / "flow" / "advection.py"
    adv.write_text(adv.read_text() + "\n# an edit\n")
    assert source_key(copy) != base
