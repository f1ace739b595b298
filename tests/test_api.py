"""The study from Python (saltstudy/api.py, docs/USAGE.md "From Python"): the light import, the
validating ``replace``, and the worked example docs/examples/own_scene.py end to end at smoke
cost (tests/conftest.py), with the cache, lazy samples and Table 2 it reads through."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import saltstudy
from saltstudy.config import resolve_scene, study_file


def test_import_is_light_and_help_names_the_api():
    code = ("import sys, pydoc, saltstudy\n"
            "heavy = [m for m in ('numba', 'dask', 'xarray', 'matplotlib') if m in sys.modules]\n"
            "print(heavy)\n"
            "print(pydoc.render_doc(saltstudy))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    heavy, text = out.split("\n", 1)
    assert heavy == "[]"
    for name in ("load_case", "load_fidelity", "load_study", "replace", "run", "run_study",
                 "open_results", "Results", "table2", "samples", "analysis"):
        assert name in text, name
    assert {"run", "run_study", "open_results", "load_case", "Results"} <= set(saltstudy.__all__)


def test_replace_deep_merges_validates_and_keeps_a_studys_file():
    case = saltstudy.load_case(2)
    own = case.replace(name="mine", forcing={"u_star_s": 0.47})
    assert (own.forcing.u_star_s, own.forcing.z_ref, own.label) == (0.47, case.forcing.z_ref, "mine")
    assert case.forcing.u_star_s == 0.54                    # the original is untouched
    with pytest.raises(saltstudy.ConfigError, match=r"forcing\.u_star_s"):
        case.replace(forcing={"u_star_s": -1.0})
    with pytest.raises(saltstudy.ConfigError, match=r"soil\.modes\.0\.sigma"):
        case.replace(soil={"modes": [{"mu": 2e-4, "sigma": 0.5}]})
    fid = saltstudy.load_fidelity("smoke")
    with pytest.raises(saltstudy.ConfigError, match="sampling ends"):
        fid.replace(saltation_duration=0.5)                 # a model validator runs too
    study = saltstudy.load_study("quick")
    assert study_file(study.replace(cases=(2,))) == study_file(study)


def test_own_scene_example_end_to_end(own_scene):
    table2, out = own_scene["table2"], own_scene["out"]
    assert own_scene["figure"].stat().st_size > 10_000
    assert list(table2.run.values) == ["case02", "sand150um"]
    assert list(table2.status.values) == ["ok", "ok"]
    assert list(table2.paper_case.values) == [2, -1]
    # the paper's values stand beside its own case only
    assert table2.u_star_s_stress_paper.sel(run="case02") == 0.54
    assert np.isnan(table2.u_star_s_stress_paper.sel(run="sand150um"))
    # each run's Fig. 8 point and z_m: Table 2 holds its analysis archive's numbers
    for label, case in (("case02", 2), ("sand150um", own_scene["case"])):
        a = saltstudy.run(case, own_scene["fidelity"], out=out).analysis()
        row = table2.sel(run=label)
        assert float(row.G_tot) == float(a.G_tot) > 0
        assert float(row.z_m) == float(a.z_m) > 0
        assert math.isfinite(float(row.u_star_s_stress / row.u_star_t))
    assert table2.u_star_t.attrs["units"] == "m s-1"
    # a finer sand has the lower threshold (Shao and Lu 2000)
    assert table2.u_star_t.sel(run="sand150um") < table2.u_star_t.sel(run="case02")
    assert table2.to_dataframe().loc["sand150um", "name"] == "sand150um"


def test_a_run_again_is_cached_and_a_study_finds_it(own_scene):
    out, own = own_scene["out"], own_scene["case"]
    again = saltstudy.run(2, own_scene["fidelity"], out=out)
    assert [o.status for o in again.outcomes] == ["cached"] * 3
    with again.samples() as s:                      # lazily: dask arrays, read when computed
        assert s.u.chunks is not None
        assert s.u.dims == ("time", "x", "y", "z")
        assert float(s.n_parcels.max().compute()) > 0
    # the same two runs as a study written in code: its scene, case 2 with the example's
    # changes, is the example's run (a label is no part of a run's key)
    changes = {"soil": {"modes": [{"mu": own.soil.modes[0].mu}]}, "particles": {"Q": own.particles.Q}}
    study = saltstudy.Study(name="mine", fidelity=str(own_scene["fidelity"]), cases=(2,), report=False,
                            scenes=[{"label": "sand150um", "case": 2, "overrides": changes}])
    res = saltstudy.open_results(study, out=out)
    assert res.labels == ["case02", "sand150um"] and all(r.ok for r in res.runs.values())
    ran = saltstudy.run_study(study, out=out)
    assert ran.summary.exit_code == 0 and not ran.summary.solver_work
    assert {o.status for o in ran.summary.outcomes} == {"cached"}
    assert float(ran.analysis("sand150um").G_tot) == float(res.table2().G_tot.sel(run="sand150um"))


def test_a_run_not_made_is_no_result(tmp_path):
    run = saltstudy.Run.of(resolve_scene(saltstudy.load_case(3), saltstudy.load_fidelity("smoke")),
                           tmp_path)
    assert not run.ok
    with pytest.raises(FileNotFoundError, match="case03: no complete analysis.nc"):
        run.analysis()
    t2 = saltstudy.Results([run]).table2()
    assert t2.status.item() == "no archive" and np.isnan(t2.G_tot.item())
    with pytest.raises(ValueError, match="two runs labelled 'case03'"):
        saltstudy.Results([run, run])


def test_the_usage_python_block_names_what_exists():
    """docs/USAGE.md, "From Python": its code is Python, every ``saltstudy.NAME`` is public and
    every method it calls exists on the API's objects or on xarray's."""
    import ast
    from pathlib import Path

    import xarray as xr

    text = (Path(__file__).resolve().parent.parent / "docs" / "USAGE.md").read_text()
    block = text.split("## From Python", 1)[1].split("```python", 1)[1].split("```", 1)[0]
    tree = ast.parse(block)
    public = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)
              and isinstance(n.value, ast.Name) and n.value.id == "saltstudy"}
    assert public and public <= set(saltstudy.__all__)
    called = {n.func.attr for n in ast.walk(tree) if isinstance(n, ast.Call)
              and isinstance(n.func, ast.Attribute)} - public
    owners = (saltstudy.Run, saltstudy.Results, saltstudy.Case, xr.Dataset, xr.DataArray)
    assert called and [m for m in called if not any(hasattr(o, m) for o in owners)] == []
