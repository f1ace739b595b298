"""Table 2, summary.json and Figs 1, 3, 8 per run of a study: scenes of one's own, runs without
sustained saltation, airborne parcels at the case's Q (synthetic archives, tests/report_fixtures.py)."""
from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest

from report_fixtures import make_analysis_dataset
from saltstudy.config import load_case
from saltstudy.ncio import open_dataset, write_dataset
from saltstudy.report.build import build_report
from saltstudy.report.data import ReportContext, load_runs, paper_case_of
from saltstudy.report.figures import make_figures
from saltstudy.report.reference import paper_table2
from saltstudy.report.saltation import NO_SALTATION, SUSTAINED, saltation_state
from saltstudy.report.tables import table2_rows

FAST = {"figure_formats": ["png"], "figure_dpi": 40}


def archive(path, case, *, label=None, case_edit=None, n_parcels=None, q_multiplier=None, **kw):
    """A synthetic analysis archive of ``case``; ``case_edit(dict)`` changes its archived case,
    ``n_parcels(t)`` replaces the parcel series (and its window mean), ``q_multiplier`` sets the
    parcel weight as Q x it."""
    ds = make_analysis_dataset(case, label=label, **kw)
    scene = json.loads(ds.attrs["case_json"])
    if case_edit is not None:
        case_edit(scene["case"])
    if q_multiplier is not None:
        scene["fidelity"]["q_multiplier"] = q_multiplier
        ds.attrs["Q"] = float(scene["case"]["particles"]["Q"]) * q_multiplier
    ds.attrs["case_json"] = json.dumps(scene)
    if n_parcels is not None:
        t = ds["time"].values
        n = np.asarray(n_parcels(t), float)
        ds["n_parcels"] = (("time",), n, {"units": "1"})
        ds["n_parcels_mean"] = ((), float(n[t > 30].mean()), {"units": "1"})
    return write_dataset(ds, path)


def set_u_star(u):
    def edit(case):
        case["forcing"]["u_star_s"] = u
    return edit


def decaying(n0):
    """A release of ``n0`` parcels that lands and is not replaced."""
    return lambda t: np.floor(n0 * np.exp(-t / 3.0))


def _row(md: str, name: str) -> str:
    return next(l for l in md.splitlines() if l.startswith(f"| {name} |"))


# ------------------------------------------------------------------------------------------
def test_paper_case_is_a_case_of_table2_unchanged_but_for_the_seed():
    for n in range(1, 11):
        c = load_case(n).model_dump(mode="json")
        assert paper_case_of(c) == n
        assert paper_case_of({**c, "seed": 2, "name": "c_seed2", "description": "again"}) == n
    c2 = load_case(2).model_dump(mode="json")
    changed = [
        load_case(2, overrides={"forcing": {"u_star_s": 0.20}}),
        load_case(2, overrides={"soil": {"modes": [{"mu": 2.5e-4}]}}),
        load_case(2, overrides={"particles": {"Q": 1200}}),
        load_case(2, overrides={"closure": {"model": "dynamic"}}),
        load_case(2, overrides={"splash": {"a_ej": 0.05}}),
    ]
    for c in changed:
        assert paper_case_of(c.model_dump(mode="json")) is None
    assert paper_case_of({**c2, "number": 11}) is None         # no row 11 in Table 2


def test_table2_has_a_row_per_run_named_by_its_label(tmp_path):
    runs = {
        "case02": archive(tmp_path / "a.nc", 2),
        "c2_seed2": archive(tmp_path / "b.nc", 2, label="c2_seed2", seed=7,
                            case_edit=lambda c: c.update(seed=2, name="c2_seed2")),
        "gale": archive(tmp_path / "c.nc", 6, label="gale", case_edit=set_u_star(1.5)),
        "case01@smoke": archive(tmp_path / "d.nc", 1, label="case01@smoke"),
        "case01@fine": archive(tmp_path / "e.nc", 1, label="case01@fine", bias=1.01),
        "lost": None,
    }
    out = tmp_path / "rep"
    build_report("mine", runs, out, {**FAST, "case_numbers": {"lost": 2}})
    rows = table2_rows(ReportContext("mine", load_runs(runs, {"case_numbers": {"lost": 2}})))
    # every run once, the paper's cases first by number, then the others in the study's order
    assert [r["name"] for r in rows] == ["case01@smoke", "case01@fine", "case 2", "c2_seed2",
                                        "gale", "lost"]
    md = (out / "table2.md").read_text()
    paper2, paper1 = paper_table2()[2]["u_star_s"], paper_table2()[1]["u_star_s"]
    for name in ("case 2", "c2_seed2"):
        assert f" / {paper2:.3g} (" in _row(md, name).split("|")[2], name
    for name in ("case01@smoke", "case01@fine"):
        assert f" / {paper1:.3g} (" in _row(md, name).split("|")[2], name
    gale = _row(md, "gale")
    us = f"{float(make_analysis_dataset(6)['u_star_s']):.3g}"
    assert us in gale and " / " not in gale           # a case of one's own: no paper value
    g = next(r for r in rows if r["name"] == "gale")
    assert g["paper_case"] is None and all(math.isnan(c.paper) for c in g["cells"].values())
    assert re.search(r"\| lost \| \*no archive\*", md)
    html = (out / "table2.html").read_text()
    assert "gale<span class='se'> (own case)</span>" in html
    assert "c2_seed2</td>" in html and "case 2</td>" in html


def test_no_sustained_saltation_row_summary_and_figures(tmp_path):
    runs = {
        "case02": archive(tmp_path / "a.nc", 2),
        # below the fluid threshold (u*t = 0.26 m/s in the archive)
        "calm": archive(tmp_path / "b.nc", 2, label="calm", case_edit=set_u_star(0.20),
                        n_parcels=decaying(625)),
        # above it, but the release lands and is not replaced
        "fading": archive(tmp_path / "c.nc", 2, label="fading", case_edit=set_u_star(0.30),
                          n_parcels=decaying(625)),
    }
    ctx = ReportContext("t", load_runs(runs))
    calm, fading = saltation_state(ctx.runs["calm"]), saltation_state(ctx.runs["fading"])
    assert saltation_state(ctx.runs["case02"]).status == SUSTAINED
    assert calm.status == fading.status == NO_SALTATION
    assert "0.200 m s-1 below the fluid threshold u*t = 0.260 m s-1" in calm.reason
    assert "below the fluid threshold" not in fading.reason
    # 10 000 per 300 m2 on 10 x 7.5 m2 with parcels 4x heavier: 625 released
    assert fading.n_parcels_released == 625 and fading.n_parcels_mean < 625
    assert "against 625 released at activation" in fading.reason

    out = tmp_path / "rep"
    build_report("t", runs, out, FAST)
    md = (out / "table2.md").read_text()
    for name in ("calm", "fading"):
        row = _row(md, name)
        assert f"**{NO_SALTATION}**: " in row and "released at activation" in row
        g = f"{float(ctx.runs[name].scalar('G_tot')):.3g}"
        assert g not in row                             # its statistics are no result
    assert NO_SALTATION not in _row(md, "case 2")
    html = (out / "table2.html").read_text()
    assert html.count("class=\"nosalt\"") == 4           # two rows in each of the two tables
    s = json.loads((out / "summary.json").read_text())
    sc = s["cases"]["calm"]["saltation"]
    assert sc["status"] == NO_SALTATION and sc["u_star_s"] == 0.20 and sc["u_star_t"] == 0.26
    assert sc["n_parcels_released"] == 625 and sc["n_parcels_end"] == 0
    assert sc["units"]["u_star_s"] == "m s-1" and sc["units"]["n_parcels_end"] == "1"
    assert s["cases"]["2"]["saltation"]["status"] == SUSTAINED
    # not drawn as a result in the scatter figures, said so
    figs = make_figures(ctx, ["fig03", "fig08"])
    for f in figs.values():
        assert f.data["x_ratio"].size == 1
        assert any(n == f"calm: {NO_SALTATION}, not drawn" for n in f.notes)
    # σG/G_tot over the cases: the run with saltation only
    assert "over the 1 runs" in md


def test_summary_parcels_per_m2_at_the_cases_Q_and_airborne_mass(tmp_path):
    runs = {"case07": archive(tmp_path / "a.nc", 7),                 # parcels 4x Q, 10 x 7.5 m2
            "light": archive(tmp_path / "b.nc", 2, label="light", q_multiplier=20.0,
                             lx=2.4, ly=1.6, case_edit=set_u_star(0.6))}
    out = tmp_path / "rep"
    build_report("t", runs, out, FAST)
    s = json.loads((out / "summary.json").read_text())
    assert s["units"]["n_parcels_per_m2_at_Q"] == "m-2"
    assert s["units"]["airborne_mass_per_m2"] == "kg m-2"
    c7, light = s["cases"]["7"], s["cases"]["light"]
    assert c7["n_parcels_per_m2_at_Q"] == pytest.approx(c7["n_parcels_mean"] * 4 / 75.0, rel=1e-12)
    assert light["n_parcels_per_m2_at_Q"] == pytest.approx(light["n_parcels_mean"] * 20 / (2.4 * 1.6),
                                                          rel=1e-12)
    for key, path in (("7", runs["case07"]), ("light", runs["light"])):
        expect = float(open_dataset(path)["airborne_mass_per_m2"])
        assert expect > 0
        assert s["cases"][key]["airborne_mass_per_m2"] == pytest.approx(expect, rel=1e-12)
    # an archive without the mass still has the key, null
    ds = make_analysis_dataset(2)
    ds = ds.drop_vars("airborne_mass_per_m2")
    runs2 = {"case02": write_dataset(ds, tmp_path / "old.nc")}
    build_report("t2", runs2, tmp_path / "rep2", FAST)
    s2 = json.loads((tmp_path / "rep2" / "summary.json").read_text())
    assert s2["cases"]["2"]["airborne_mass_per_m2"] is None
    assert s2["cases"]["2"]["n_parcels_per_m2_at_Q"] is not None


def test_fig01_every_case_beside_the_papers_parcels_per_m2(tmp_path):
    runs = {f"case{n:02d}": archive(tmp_path / f"{n}.nc", n) for n in (1, 2, 6, 9)}
    runs["calm"] = archive(tmp_path / "calm.nc", 2, label="calm", case_edit=set_u_star(0.20),
                           n_parcels=decaying(625))
    ctx = ReportContext("t", load_runs(runs))
    res = make_figures(ctx, ["fig01"])["fig01"]
    # ≈ 6e5 parcels on 20 m x 15 m (case 2, [31]): 2,000 per m2, the same for every case ([28])
    assert res.data["paper_per_m2"][0] == pytest.approx(2000.0)
    for label, r in ctx.runs.items():
        y = res.data[f"per_m2_{label}"]
        np.testing.assert_allclose(y, r.ds["n_parcels"].values * 4 / 75.0, rtol=1e-12)
        assert res.data[f"mean_per_m2_{label}"][0] == pytest.approx(r.scalar("n_parcels_mean") * 4 / 75.0)
    ax = res.fig.axes[0]
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert sum("Dupont et al. 2013 [28], [31]" in l and "2,000" in l for l in labels) == 1
    assert sum(l.startswith(f"case {n}:") for l in labels for n in (1, 2, 6, 9)) == 4
    assert any(l.startswith("calm:") and NO_SALTATION in l for l in labels)


def test_figs_3_and_8_place_runs_at_the_stress_reading_of_u_star_s(tmp_path):
    runs = {f"case{n:02d}": archive(tmp_path / f"{n}.nc", n) for n in (1, 2, 6)}
    ctx = ReportContext("t", load_runs(runs))
    expect = sorted(r.scalar("u_star_s_stress") / r.scalar("u_star_t") for r in ctx.runs.values())
    fit = sorted(r.scalar("u_star_s") / r.scalar("u_star_t") for r in ctx.runs.values())
    assert not np.allclose(expect, fit)               # the two readings differ in these archives
    for name, res in make_figures(ctx, ["fig03", "fig08"]).items():
        np.testing.assert_allclose(sorted(res.data["x_ratio"]), expect, rtol=1e-12, err_msg=name)
        assert "total stress" in res.fig.axes[0].get_xlabel()
