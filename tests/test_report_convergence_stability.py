"""Convergence (error against run time) and stability reports on synthetic inputs."""
from __future__ import annotations

import json

import numpy as np
import pytest

from report_fixtures import make_analysis_dataset, write_analysis
from saltstudy.ncio import write_dataset
from saltstudy.report.convergence import build_convergence_report, ladder_summary
from saltstudy.report.stability import build_stability_report


def _with_halves(path, spread, stats=("u_star_s", "lambda_y")):
    """Give ``stats`` two half-window values ±``spread`` (relative) around the whole window's."""
    import xarray as xr
    with xr.open_dataset(path) as ds:
        ds = ds.load()
    for name in stats:
        v = float(ds[name])
        ds[f"{name}_halves"] = (("half",), np.array([v * (1 - spread), v * (1 + spread)]),
                                {"units": ds[name].attrs.get("units", "1"),
                                 "long_name": f"{name} over each half"})
    ds.to_netcdf(path)
    return path


@pytest.fixture()
def ladder(tmp_path):
    # bias multiplies every statistic; finest rung (largest wall time) has bias 1.0; each run's
    # half windows differ by 2 % in u*s (free fit) and lambda_y
    spec = {"case02@coarse": (1.30, 10.0), "case02@mid": (1.05, 100.0), "case02@fine": (1.00, 1000.0)}
    runs = {l: _with_halves(write_analysis(tmp_path / f"{l}.nc", 2, bias=b, wall_time_s=w, label=l), 0.01)
            for l, (b, w) in spec.items()}
    return runs, spec


def test_errors_against_finest_and_paper(ladder, tmp_path):
    runs, _ = ladder
    out = build_convergence_report(runs, tmp_path / "rep")
    res = out["result"]
    assert res.finest == "case02@fine"
    rows = {r["label"]: r for r in res.rungs}
    assert [r["label"] for r in res.rungs] == ["case02@coarse", "case02@mid", "case02@fine"]
    assert rows["case02@coarse"]["err_finest"]["u_star_s"] == pytest.approx(0.30)
    assert rows["case02@mid"]["err_finest"]["lambda_y"] == pytest.approx(0.05)
    assert rows["case02@fine"]["err_finest"]["z_m"] == 0.0
    # against the paper: Table 2 gives u*s = 0.54 and lambda_y = 0.3 for case 2; bias 1 matches
    assert rows["case02@fine"]["err_paper"]["u_star_s"] == pytest.approx(0.0, abs=1e-12)
    assert rows["case02@coarse"]["err_paper"]["lambda_y"] == pytest.approx(0.30)
    assert np.isnan(rows["case02@fine"]["err_paper"]["z0s_stress"])   # the paper gives no z0s per case
    assert res.cheapest["u_star_s"] == {"10%": "case02@mid", "25%": "case02@mid"}
    # the St height is read off the St profile as Table 2's page reads it, against the paper's
    # ~0.1 z_m for a 200 um soil
    from saltstudy.report.data import load_runs
    from saltstudy.report.tables import st_below_one_height
    h = st_below_one_height(load_runs({"f": runs["case02@fine"]})["f"])
    assert np.isfinite(h) and rows["case02@fine"]["values"]["St_height"] == h
    assert rows["case02@fine"]["err_paper"]["St_height"] == pytest.approx(abs(h - 0.1) / 0.1)
    for f in ("convergence.png", "convergence.pdf", "convergence.md", "convergence.json"):
        assert (tmp_path / "rep" / f).is_file()
    md = (tmp_path / "rep" / "convergence.md").read_text()
    assert "| u*s (free fit) | case02@mid | case02@mid |" in md
    # z_m has no half windows here, so no rung can show it is within a threshold
    assert "| z_m | none | none |" in md
    js = json.loads((tmp_path / "rep" / "convergence.json").read_text())
    assert js["finest"] == "case02@fine"


def test_error_bars_from_the_half_windows_decide_what_is_noise(tmp_path):
    """A rung whose halves differ by more than its distance from the reference is within the
    noise; one whose halves agree is not."""
    runs = {}
    for label, bias, wall, spread in (("case02@noisy", 1.05, 10.0, 0.2), ("case02@quiet", 1.05, 20.0, 0.0),
                                      ("case02@ref", 1.00, 100.0, 0.0)):
        p = write_analysis(tmp_path / f"{label}.nc", 2, bias=bias, wall_time_s=wall, label=label)
        runs[label] = _with_halves(p, spread, ("lambda_y",))
    res = build_convergence_report(runs, tmp_path / "rep", reference="case02@ref")["result"]
    rows = {r["label"]: r for r in res.rungs}
    assert rows["case02@noisy"]["error_bar"]["lambda_y"] == pytest.approx(0.2 * 0.3 * 1.05, rel=0.2)
    assert rows["case02@noisy"]["within_noise"]["lambda_y"] is True       # 5 % off, bar ~ 20 %
    assert rows["case02@quiet"]["within_noise"]["lambda_y"] is False      # 5 % off, no bar
    assert rows["case02@quiet"]["within_noise"]["z_m"] is None            # no halves recorded
    js = json.loads((tmp_path / "rep" / "convergence.json").read_text())
    assert js["rungs"][0]["error_bar"]["lambda_y"] > 0


def test_declared_order_wins_over_wall_time(ladder, tmp_path):
    runs, _ = ladder
    out = build_convergence_report(runs, tmp_path / "rep",
                                   order=["case02@fine", "case02@coarse", "case02@mid"])
    assert out["result"].finest == "case02@mid"
    rows = {r["label"]: r for r in out["result"].rungs}
    assert rows["case02@fine"]["err_finest"]["u_star_s"] == pytest.approx(0.05 / 1.05)
    assert rows["case02@mid"]["err_finest"]["u_star_s"] == 0.0


def test_cheapest_rung_comes_from_the_ladder_not_from_extra_scenes(ladder, tmp_path):
    runs, _ = ladder
    # a second seed of the coarse rung that happens to land on the reference, and cheap
    seed2 = write_analysis(tmp_path / "c2_seed2.nc", 2, bias=1.0, wall_time_s=5.0, label="c2_seed2")
    out = build_convergence_report({**runs, "c2_seed2": seed2}, tmp_path / "rep",
                                   order=["case02@coarse", "case02@mid", "case02@fine"])
    res = out["result"]
    assert res.cheapest["u_star_s"] == {"10%": "case02@mid", "25%": "case02@mid"}
    assert "c2_seed2" in {r["label"] for r in res.rungs}    # still listed and compared


def test_named_reference_rung_wins(ladder, tmp_path):
    # a sensitivity study compares one-knob variants with their base, not with the dearest variant
    runs, _ = ladder
    out = build_convergence_report(runs, tmp_path / "rep", reference="case02@mid")
    res = out["result"]
    assert res.finest == "case02@mid" and res.named_reference
    rows = {r["label"]: r for r in res.rungs}
    assert rows["case02@fine"]["err_finest"]["u_star_s"] == pytest.approx(0.05 / 1.05)
    assert rows["case02@coarse"]["err_finest"]["lambda_y"] == pytest.approx(0.25 / 1.05)
    assert rows["case02@mid"]["err_finest"]["z_m"] == 0.0
    assert "Reference rung: case02@mid." in (tmp_path / "rep" / "convergence.md").read_text()
    # an unknown or missing reference falls back to the finest rung
    fallback = build_convergence_report(runs, tmp_path / "rep2", reference="case02@nope")["result"]
    assert fallback.finest == "case02@fine" and not fallback.named_reference


def test_missing_rung_and_wall_time_override(ladder, tmp_path):
    runs, _ = ladder
    runs = {**runs, "case02@huge": None}
    out = build_convergence_report(runs, tmp_path / "rep", wall_times={"case02@coarse": 5000.0})
    res = out["result"]
    assert res.finest == "case02@coarse"       # now the most expensive
    rows = {r["label"]: r for r in res.rungs}
    assert rows["case02@huge"]["status"] == "no archive"
    assert np.isnan(rows["case02@huge"]["err_finest"]["u_star_s"])


def test_each_case_is_compared_with_its_own_reference(tmp_path):
    """A ladder run for two winds: case 6's coarse rung is held against case 6's fine run, not
    case 2's; the case with more rungs heads the report."""
    spec = {"case02@coarse": (2, 1.30, 10.0, 24), "case02@mid": (2, 1.05, 100.0, 48),
            "case02@fine": (2, 1.00, 1000.0, 100), "case06@coarse": (6, 1.20, 12.0, 24),
            "case06@fine": (6, 1.00, 1500.0, 100)}
    runs = {l: write_analysis(tmp_path / f"{l}.nc", c, bias=b, wall_time_s=w, label=l, nx=nx)
            for l, (c, b, w, nx) in spec.items()}
    order = ["case02@coarse", "case06@coarse", "case02@mid", "case02@fine", "case06@fine"]
    out = build_convergence_report(runs, tmp_path / "rep", order=order, reference="case02@fine")
    assert list(out["results"]) == [2, 6]
    r6 = out["results"][6]
    assert r6.finest == "case06@fine" and not r6.named_reference   # the top of the ladder
    rows6 = {r["label"]: r for r in r6.rungs}
    assert rows6["case06@coarse"]["err_finest"]["lambda_y"] == pytest.approx(0.20)
    assert rows6["case06@coarse"]["case"] == 6
    # the summary: case 2's coarse rung is 30 % off in every statistic, its mid rung 5 %
    summ = {r["rung"]: r for r in ladder_summary(out["results"][2])}
    assert set(summ) == {"coarse", "mid"}
    assert summ["coarse"]["median_error"] == pytest.approx(0.30, rel=1e-6)
    assert summ["coarse"]["share_within_25"] < 0.5 <= summ["mid"]["share_within_10"]
    assert (tmp_path / "rep" / "convergence_summary.png").is_file()
    js = json.loads((tmp_path / "rep" / "convergence.json").read_text())
    assert [r["rung"] for r in js["cases"]["6"]["ladder_summary"]] == ["coarse"]
    assert js["primary_case"] == 2 and js["reference"] == "case02@fine"
    assert js["cases"]["6"]["reference"] == "case06@fine"
    by = {r["label"]: r for r in js["rungs"]}
    assert set(by) == set(spec)
    assert by["case06@coarse"]["reference"] == "case06@fine"
    assert by["case02@fine"]["dx"] == pytest.approx(0.10)          # 10 m over 100 columns
    assert by["case02@fine"]["dz_bottom"] == pytest.approx(0.0101, rel=5e-3)   # the fixture: 1 cm + stretching
    for f in ("convergence.png", "convergence_case06.png", "convergence.md"):
        assert (tmp_path / "rep" / f).is_file()
    md = (tmp_path / "rep" / "convergence.md").read_text()
    assert "## Case 6" in md and "Reference rung: case06@fine." in md
    assert "convergence_case06.png" in out["html"]


def test_a_run_without_a_case_gets_its_own_section(ladder, tmp_path):
    runs, _ = ladder
    out = build_convergence_report({**runs, "orphan": None}, tmp_path / "rep")
    assert list(out["results"]) == [2, None]
    assert out["results"][None].rungs[0]["status"] == "no archive"
    assert (tmp_path / "rep" / "convergence_nocase.png").is_file()
    assert "Runs without a case number" in (tmp_path / "rep" / "convergence.md").read_text()


def test_stability_table(tmp_path):
    ok = make_analysis_dataset(6, label="gale")
    ok["max_cfl"] = (("time",), np.linspace(0.2, 0.93, ok.sizes["time"]), {"units": "1"})
    gale = write_dataset(ok, tmp_path / "gale.nc")
    bare = make_analysis_dataset(7, label="fine_sand")
    bare = bare.drop_vars(["E_splash_over_E_impact"])
    fine = write_dataset(bare, tmp_path / "fine.nc")
    # a samples.nc with a velocity field and splash energies
    import xarray as xr
    smp = xr.Dataset({"u": (("time", "x", "y", "z"), np.full((2, 3, 3, 4), 4.0) + np.arange(4)),
                      "w": (("time", "x", "y", "z"), np.full((2, 3, 3, 4), -0.7)),
                      "E_splash": (("time_series",), np.array([0.0, 2.0])),
                      "E_impact": (("time_series",), np.array([1.0, 5.0])),
                      "max_cfl": (("time_series",), np.array([0.3, 0.61]))})
    sp = write_dataset(smp, tmp_path / "samples.nc")
    out = build_stability_report({"gale": gale, "fine_sand": fine, "crash": None}, tmp_path / "rep",
                                 failures={"crash": "SolverBlowUp: step 12, t=0.3 s, field w, (1, 2, 0) = inf"},
                                 samples={"fine_sand": sp})
    rows = {r["label"]: r for r in out["rows"]}
    assert rows["gale"]["status"] == "completed"
    assert rows["gale"]["max_cfl"] == pytest.approx(0.93)
    assert rows["gale"]["E_splash_over_E_impact"] == pytest.approx(0.55)
    assert rows["crash"]["status"] == "failed" and "SolverBlowUp" in rows["crash"]["error"]
    assert rows["fine_sand"]["max_cfl"] == pytest.approx(0.61)              # from samples.nc
    assert rows["fine_sand"]["u_min"] == pytest.approx(4.0) and rows["fine_sand"]["u_max"] == pytest.approx(7.0)
    assert rows["fine_sand"]["w_absmax"] == pytest.approx(0.7)
    assert rows["fine_sand"]["E_splash_over_E_impact"] == pytest.approx(0.4)
    md = (tmp_path / "rep" / "stability.md").read_text()
    assert "n/a" in md                          # fine_sand has no step limits
    assert "SolverBlowUp: step 12" in md
    line = next(l for l in md.splitlines() if l.startswith("| crash |"))
    assert line.count("n/a") >= 6
    js = json.loads((tmp_path / "rep" / "stability.json").read_text())
    assert {r["label"] for r in js["scenes"]} == {"gale", "fine_sand", "crash"}
    assert rows["crash"]["finite"] is False             # a blow-up is by definition not finite


def _with_scene(tmp_path, label, bias, wall, seed, *, duration=30.0, ly=7.5, knob=None):
    """An analysis whose scene carries a seed and a sampling window (and optionally one knob)."""
    from report_fixtures import make_analysis_dataset
    ds = make_analysis_dataset(2, bias=bias, wall_time_s=wall, label=label, ly=ly)
    scene = json.loads(ds.attrs["case_json"])
    scene["case"]["seed"] = seed
    scene["case"]["name"] = label
    scene["fidelity"]["sampling"] = {"start": 12.0, "interval": duration / 12, "count": 13}
    if knob is not None:
        scene["case"]["forcing"]["controller_timescale"] = knob
    ds.attrs["case_json"] = json.dumps(scene)
    return write_dataset(ds, tmp_path / f"{label}.nc")


def test_seed_replicates_set_the_noise_of_every_rung(tmp_path):
    """Two runs alike but for the seed give a bar that every rung of the case inherits, scaled by
    its sampled extent; a run that differs in a setting is not a replicate."""
    runs = {"case02@coarse": _with_scene(tmp_path, "case02@coarse", 1.00, 10.0, 1),
            "c2_seed2": _with_scene(tmp_path, "c2_seed2", 1.20, 10.0, 2),
            "c2_knob": _with_scene(tmp_path, "c2_knob", 1.50, 10.0, 3, knob=60.0),
            "case02@fine": _with_scene(tmp_path, "case02@fine", 1.15, 1000.0, 1,
                                       duration=120.0, ly=1.875)}
    out = build_convergence_report(runs, tmp_path / "rep", order=["case02@coarse", "case02@fine"])
    res = out["result"]
    assert res.seed_groups == [["c2_seed2", "case02@coarse"]]
    # the same realization listed twice is one seed, not a third
    twice = build_convergence_report({**runs, "case02@again": runs["case02@coarse"]}, tmp_path / "rep2",
                                     order=["case02@coarse", "case02@fine"])["result"]
    assert len(twice.seed_groups[0]) == 2
    assert ({r["label"]: r for r in twice.rungs}["case02@coarse"]["seed_bar"]
            == {r["label"]: r for r in res.rungs}["case02@coarse"]["seed_bar"])
    rows = {r["label"]: r for r in res.rungs}
    a, b = (rows[l]["values"]["lambda_y"] for l in ("case02@coarse", "c2_seed2"))
    rel = abs(a - b) / np.sqrt(2) / ((a + b) / 2)
    assert rows["case02@coarse"]["seed_bar"]["lambda_y"] == pytest.approx(rel * a)
    # the fine run samples 4x as long on a quarter of the area: the same extent, the same relative bar
    f = rows["case02@fine"]["values"]["lambda_y"]
    assert rows["case02@fine"]["seed_bar"]["lambda_y"] == pytest.approx(rel * f)
    # these archives record no half windows: the seed bar (~12 % of the value at both rungs, ~17 %
    # in quadrature) is the whole bar, and holds the coarse rung's 13 % difference from fine
    assert np.isnan(rows["case02@coarse"]["half_window_bar"]["lambda_y"])
    assert rows["case02@coarse"]["error_bar"]["lambda_y"] == rows["case02@coarse"]["seed_bar"]["lambda_y"]
    assert rows["case02@coarse"]["within_noise"]["lambda_y"] is True
    # the knob variant (50 % off) stays outside it
    assert rows["c2_knob"]["within_noise"]["lambda_y"] is False
    js = json.loads((tmp_path / "rep" / "convergence.json").read_text())
    assert js["cases"]["2"]["seed_replicates"] == [["c2_seed2", "case02@coarse"]]
    assert "Seed replicates: c2_seed2 and case02@coarse" in (tmp_path / "rep" / "convergence.md").read_text()


def test_without_replicates_the_half_windows_alone_are_the_bar(ladder, tmp_path):
    runs, _ = ladder
    res = build_convergence_report(runs, tmp_path / "rep")["result"]
    assert res.seed_groups == []
    for row in res.rungs:
        assert all(np.isnan(v) for v in row["seed_bar"].values())
        for s, eb in row["error_bar"].items():
            hw = row["half_window_bar"][s]
            assert (np.isnan(eb) and np.isnan(hw)) or eb == hw
    assert "No run of this case is repeated" in (tmp_path / "rep" / "convergence.md").read_text()


def test_a_rung_noisier_than_the_threshold_is_not_named_cheapest(ladder, tmp_path):
    """A cheap run that lands 5 % from the reference with a ±15 % bar agrees by chance: it may be
    named within 25 % but not within 10 %."""
    runs, _ = ladder
    lucky = _with_halves(write_analysis(tmp_path / "lucky.nc", 2, bias=1.05, wall_time_s=1.0,
                                        label="case02@lucky"), 0.15)
    res = build_convergence_report({"case02@lucky": lucky, **runs}, tmp_path / "rep",
                                   order=["case02@lucky", "case02@coarse", "case02@mid", "case02@fine"])["result"]
    rows = {r["label"]: r for r in res.rungs}
    assert rows["case02@lucky"]["err_finest"]["u_star_s"] == pytest.approx(0.05)
    assert res.cheapest["u_star_s"] == {"10%": "case02@mid", "25%": "case02@lucky"}


def test_a_table_read_back_with_no_new_run_is_its_own_comparison(tmp_path):
    """The committed ladder (reports/convergence/convergence.json) re-read as the rungs below no
    new run gives back its reference, every error and noise verdict and its cheapest rungs."""
    from pathlib import Path

    from saltstudy.report.convergence import convergence_by_case
    table = json.loads((Path(__file__).parent.parent / "reports" / "convergence"
                        / "convergence.json").read_text())
    res = convergence_by_case({}, prior=table)
    assert sorted(res) == sorted(int(c) for c in table["cases"])
    old = {row["label"]: row for row in table["rungs"]}
    n = 0
    for case, r in res.items():
        assert r.finest == table["cases"][str(case)]["reference"]
        assert r.cheapest == table["cases"][str(case)]["cheapest"]
        for row in r.rungs:
            for s, e in row["err_finest"].items():
                was = old[row["label"]]["err_finest"][s]
                assert (was is None and np.isnan(e)) or e == was
                assert row["within_noise"][s] == old[row["label"]]["within_noise"][s]
                n += was is not None
    assert n > 200


def test_a_run_on_top_of_a_table_is_its_cases_reference(tmp_path):
    """A study's run tops an earlier table of its case: the table's rungs are compared with it,
    their own values and bars kept, and the table's seed bar is carried to the new rung."""
    low = {"case02@coarse": _with_scene(tmp_path, "case02@coarse", 1.30, 10.0, 1),
           "c2_seed2": _with_scene(tmp_path, "c2_seed2", 1.40, 12.0, 2),
           "case02@mid": _with_scene(tmp_path, "case02@mid", 1.05, 100.0, 1, duration=60.0)}
    first = build_convergence_report(low, tmp_path / "rep1", order=["case02@coarse", "case02@mid"])
    # the top rung samples 4x as long on a quarter of the area: the coarse rung's extent
    top = _with_scene(tmp_path, "case02@top", 1.00, 1000.0, 1, duration=120.0, ly=1.875)
    out = build_convergence_report({"case02@top": top}, tmp_path / "rep2",
                                   prior=tmp_path / "rep1" / "convergence.json")
    res = out["result"]
    assert res.finest == "case02@top"
    assert [r["label"] for r in res.rungs] == ["case02@coarse", "case02@mid", "c2_seed2", "case02@top"]
    rows = {r["label"]: r for r in res.rungs}
    assert rows["case02@coarse"]["err_finest"]["u_star_s"] == pytest.approx(0.30)
    assert rows["case02@mid"]["err_finest"]["lambda_y"] == pytest.approx(0.05)
    before = {r["label"]: r for r in first["result"].rungs}
    for key in ("values", "error_bar", "err_paper"):
        assert rows["case02@mid"][key] == pytest.approx(before["case02@mid"][key], nan_ok=True)
    rel = before["case02@coarse"]["seed_bar"]["u_star_s"] / before["case02@coarse"]["values"]["u_star_s"]
    assert np.isfinite(rel) and rel > 0
    assert rows["case02@top"]["seed_bar"]["u_star_s"] == pytest.approx(
        rel * rows["case02@top"]["values"]["u_star_s"])
    assert res.seed_groups == [["c2_seed2", "case02@coarse"]]
    # the second seed is a row, not a rung one could stop at
    assert "c2_seed2" not in res.on_ladder and "case02@coarse" in res.on_ladder
    js = json.loads((tmp_path / "rep2" / "convergence.json").read_text())
    assert js["ladder_table"]["file"] == "convergence.json"
    assert js["cases"]["2"]["reference"] == "case02@top"
