"""The convergence and stability studies end to end at smoke size, through `saltstudy run-all`.

Real solver, real archives, real reports: the convergence-smoke ladder (case 2 at two grids) and
the stability-smoke scenes (the stiff and extreme cases of the stability study, at smoke size),
both in tests/studies/ with their own smoke-size fidelities beside them. Their real-size
counterparts (`--study convergence`, `--study stability`) are documented in the README with
expected run times.
"""
from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.config import load_study, project_root, study_runs

STUDIES = Path(__file__).resolve().parent / "studies"


@pytest.fixture
def home(tmp_path, monkeypatch):
    """A project copy whose smoke fidelities run half as long; its test studies in home/studies/."""
    h = tmp_path / "home"
    for d in ("cases", "workflows"):
        shutil.copytree(project_root() / d, h / d)
    shutil.copytree(STUDIES, h / "studies")
    # half the smoke runs' simulated time: these tests check the studies' plumbing end to end
    for f in (h / "workflows" / "fidelities" / "smoke.toml",
              h / "studies" / "convergence-smoke" / "smoke-fine.toml",
              h / "studies" / "stability-smoke" / "smoke-maxcfl.toml"):
        text = f.read_text()
        for old, new in (("saltation_duration = 2.0", "saltation_duration = 1.0"),
                         ("t_min = 1.0", "t_min = 0.5"), ("t_max = 3.0", "t_max = 1.5"),
                         ("window = 1.0", "window = 0.5"), ("start = 1.0", "start = 0.4"),
                         ("interval = 0.5", "interval = 0.3")):
            assert old in text, (f.name, old)
            text = text.replace(old, new)
        f.write_text(text)
    monkeypatch.setenv("SALTSTUDY_HOME", str(h))
    monkeypatch.setenv("SALTSTUDY_OUT", str(tmp_path / "out"))
    return h


@pytest.fixture
def home_with_case2(home, own_scene):
    """``home`` whose cache starts as a copy of the worked example's (conftest.py): its fidelity
    is this smoke's, so case 2's spin-up and saltation are found there, not computed again."""
    shutil.copytree(own_scene["out"], os.environ["SALTSTUDY_OUT"])
    return home


def _run_all(study: str, report_dir):
    r = CliRunner().invoke(app, ["run-all", "--study", study, "--quiet", "--report-dir", str(report_dir)])
    assert r.exit_code == 0, r.output
    return r.output


def test_convergence_smoke_study_end_to_end(home_with_case2, tmp_path):
    home = home_with_case2
    rep = tmp_path / "rep"
    _run_all(str(home / "studies" / "convergence-smoke.toml"), rep)
    js = json.loads((rep / "convergence.json").read_text())
    labels = [r["label"] for r in js["rungs"]]
    assert labels == ["case02@smoke", "case02@smoke-fine"]
    assert js["finest"] == "case02@smoke-fine"
    # produced by this code: the report says which
    from saltstudy import __version__
    assert js["study"] == "convergence-smoke" and js["package_version"] == __version__
    assert "commit" in js
    by = {r["label"]: r for r in js["rungs"]}
    for label in labels:
        assert by[label]["status"] == "ok"
        assert by[label]["wall_time_s"] > 0
    # errors against the finest rung are computed, zero on the finest itself
    assert by["case02@smoke-fine"]["err_finest"]["u_star_s"] == 0.0
    coarse = by["case02@smoke"]["err_finest"]["u_star_s"]
    assert coarse is not None and math.isfinite(coarse) and coarse >= 0
    # against the paper: case 2 has u*s = 0.54 in Table 2
    assert math.isfinite(by["case02@smoke"]["err_paper"]["u_star_s"])
    for f in ("convergence.png", "convergence.pdf", "convergence.md", "index.html", "fig02.png",
              "convergence_summary.png"):
        assert (rep / f).is_file(), f
    page = (rep / "index.html").read_text()
    assert "Error against run time" in page
    # the summary figure heads the section
    assert page.index("convergence_summary.png") < page.index("src='convergence.png'")


def test_stability_smoke_study_end_to_end(home, tmp_path):
    rep = tmp_path / "rep"
    study = home / "studies" / "stability-smoke.toml"
    out = _run_all(str(study), rep)       # exit 0: the one blow-up is the expected one
    assert "blew up as the scene expects: saltation case02_dt_too_large" in out
    labels = [r.label for r in study_runs(load_study(study))]
    assert len(labels) == 8
    js = json.loads((rep / "stability.json").read_text())
    assert js["package_version"] and js["study"] == "stability-smoke"
    rows = {r["label"]: r for r in js["scenes"]}
    assert sorted(rows) == sorted(labels)
    bad = rows.pop("case02_dt_too_large")
    assert bad["status"] == "blew up as expected" and bad["finite"] is False
    assert "Courant number" in bad["error"] and "step" in bad["error"]
    for label, row in rows.items():
        assert row["status"] == "completed", (label, row)
        assert row["finite"] is True
        assert 0 < row["max_cfl"] < 2.0, (label, row)
        assert math.isfinite(row["u_max"]) and math.isfinite(row["w_absmax"])
        assert row["wall_time_s"] > 0
        # parcels are only created by release and splash, removed by deposition
        assert row["parcel_balance"] == 0, (label, row)
        assert row["loading_max"] > 0 and row["dt_over_tau_c"] > 0
        assert row["limiting_step"].split()[0] in ("courant", "diffusion", "grains", "dt_max")
        # on average the splash returns less kinetic energy than the impacts bring (paper, sect. 2)
        e = row.get("E_splash_over_E_impact")
        if e is not None:
            assert 0 < e <= 1.0, (label, e)
    # the largest-time-step scene ran near its (raised) CFL limit
    assert rows["case02_max_cfl"]["max_cfl"] > rows["case07_90um_Q28000"]["max_cfl"]
    # parcels 4x heavier load the bed cells more than the case's own (same flow, same seed)
    assert rows["case06_Qx4"]["loading_max"] > rows["case06_u1.10"]["loading_max"]
    text = (rep / "stability.md").read_text()
    assert all(label in text for label in labels)


def test_scene_study_below_threshold_end_to_end(home_with_case2, tmp_path):
    """A study of one's own: a scene of case 2 below the fluid threshold and a scene from a case
    file beside the study file. Table 2 has a row per run under its label; the calm scene is
    marked, with its numbers, as holding no saltation; summary.json carries the grains per m²."""
    d = tmp_path / "mystudy"
    (d / "mycases").mkdir(parents=True)
    (d / "mycases" / "breeze.toml").write_text(
        "number = 2\n[forcing]\nu_star_s = 0.60\n[particles]\nQ = 600\n")
    study = d / "mine.toml"
    study.write_text('fidelity = "smoke"\ncases = [2]\n'
                     '[[scenes]]\nlabel = "calm_u0.20"\ncase = 2\n'
                     'overrides = { forcing = { u_star_s = 0.20 } }\n'
                     '[[scenes]]\nlabel = "breeze"\ncase = "mycases/breeze.toml"\n')
    rep = tmp_path / "rep"
    _run_all(str(study), rep)
    md = (rep / "table2.md").read_text()
    rows = {l.split("|")[1].strip(): l for l in md.splitlines() if l.startswith("| ")
            and not l.startswith("| run ") and not l.startswith("| quantity")}
    assert {"case 2", "calm_u0.20", "breeze"} <= set(rows)
    calm = rows["calm_u0.20"]
    assert r"**no sustained saltation**: u\*s = 0.200 m s-1 below the fluid threshold u\*t = 0.262" in calm
    assert "released at activation" in calm
    assert "no sustained saltation" not in rows["case 2"] + rows["breeze"]
    assert " / 0.54 (" in rows["case 2"]                  # the paper's case 2, its values beside
    assert " / " not in rows["breeze"]                    # a case of one's own: none
    assert "calm_u0.20" in (rep / "table2.html").read_text()
    s = json.loads((rep / "summary.json").read_text())
    assert s["units"]["n_parcels_per_m2_at_Q"] == "m-2"
    assert s["units"]["airborne_mass_per_m2"] == "kg m-2"
    c = s["cases"]["calm_u0.20"]
    assert c["saltation"]["status"] == "no sustained saltation"
    assert c["saltation"]["u_star_s"] == 0.20 and c["saltation"]["u_star_t"] < 0.27
    assert c["saltation"]["n_parcels_released"] >= 1
    for key in ("2", "calm_u0.20", "breeze"):
        e = s["cases"][key]
        # smoke: parcels 20x the case's Q on a 2.4 m x 1.6 m bed
        assert e["n_parcels_per_m2_at_Q"] == pytest.approx(e["n_parcels_mean"] * 20 / (2.4 * 1.6))
        assert e["airborne_mass_per_m2"] is not None and e["airborne_mass_per_m2"] >= 0
    assert s["cases"]["2"]["saltation"]["status"] == "sustained"
    assert s["cases"]["2"]["airborne_mass_per_m2"] > s["cases"]["calm_u0.20"]["airborne_mass_per_m2"]
