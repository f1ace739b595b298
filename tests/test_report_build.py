"""build_report end to end on synthetic analysis archives of all ten cases."""
from __future__ import annotations

import json
import math
import re

import pytest

from report_fixtures import make_analysis_dataset, write_analysis, write_study
from saltstudy.ncio import open_dataset, write_dataset
from saltstudy.report.build import build_report
from saltstudy.report.reference import paper_table2

FIGS = [f"fig{i:02d}" for i in range(1, 14)]


@pytest.fixture(scope="module")
def full_report(tmp_path_factory):
    root = tmp_path_factory.mktemp("study")
    runs = write_study(root / "archives", with_cp_stack=False)
    # case 1 carries a C_p plane stack, for the animation
    runs["case01"] = write_analysis(root / "archives" / "case01" / "analysis.nc", 1, with_cp_stack=True)
    out = root / "report"
    index = build_report("unit-test-study", runs, out,
                         {"fidelity": "reduced", "study_config": {"name": "unit-test-study", "cases": list(range(1, 11))},
                          "package_version": "9.9.9", "animation_frames": 8, "figure_dpi": 60})
    return runs, out, index


def test_all_outputs_written(full_report):
    runs, out, index = full_report
    assert index == out / "index.html" and index.is_file()
    for f in FIGS:
        png, pdf = out / f"{f}.png", out / f"{f}.pdf"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", f
        assert pdf.read_bytes()[:5] == b"%PDF-", f
    for name in ("table2.md", "table2.html", "summary.json"):
        assert (out / name).stat().st_size > 100


def test_index_is_self_contained(full_report):
    _, out, index = full_report
    text = index.read_text()
    srcs = re.findall(r"""(?:src|href)=['"]([^'"#]+)['"]""", text)
    assert srcs
    for s in srcs:
        assert not s.startswith("/") and "://" not in s, s
        assert (out / s).exists(), s
    for f in FIGS:
        assert f"src='{f}.png'" in text
    assert "9.9.9" in text                          # package version
    assert "unit-test-study" in text                # study configuration shown
    assert "120.0 s" in text or "120 s" in text     # wall time per case (fixture: 120 s)


def test_summary_keys_units_and_values(full_report):
    runs, out, _ = full_report
    s = json.loads((out / "summary.json").read_text())
    assert set(s) >= {"study", "fidelity", "total_wall_time_s", "task_time_sum_s", "machine",
                      "package_version", "cases", "units"}
    assert s["study"] == "unit-test-study" and s["fidelity"] == "reduced"
    assert s["package_version"] == "9.9.9"
    assert isinstance(s["machine"]["cores"], int) and s["machine"]["cores"] >= 1
    assert s["machine"]["processor"]
    assert sorted(s["cases"], key=int) == [str(n) for n in range(1, 11)]
    assert s["units"]["u_star_s"] == "m s-1" and s["units"]["z_m"] == "m"
    assert s["units"]["G_tot"] == "kg m-1 s-1" and s["units"]["wall_time_s"] == "s"
    # built without a run: no elapsed time to tell; the task times are the archives' (120 s each)
    assert s["total_wall_time_s"] is None and s["run_started"] is None
    assert s["task_time_sum_s"] == pytest.approx(10 * 120.0)
    for n in (2, 7):
        ds = open_dataset(runs[f"case{n:02d}"])
        c = s["cases"][str(n)]
        assert c["wall_time_s"] == pytest.approx(120.0)
        scalars = [k for k, v in ds.data_vars.items() if v.ndim == 0]
        assert set(scalars) <= set(c)
        for k in scalars:
            v = float(ds[k].values)
            assert (c[k] is None) if math.isnan(v) else c[k] == pytest.approx(v), k
    assert s["cases"]["9"]["delta_y"] is None      # NaN in the archive -> null
    # every reading of delta_y, for C_p and for u, under its own name (docs/STREAMERS.md)
    for field in ("delta_y", "delta_y_u"):
        for reading in ("premultiplied", "density", "correlation"):
            assert f"{field}_{reading}" in s["cases"]["2"] and s["units"][f"{field}_{reading}"] == "m"
    assert s["cases"]["2"]["delta_y"] == s["cases"]["2"]["delta_y_premultiplied"]


def test_summary_wall_time_is_elapsed_and_tasks_are_summed_once(tmp_path):
    """total_wall_time_s: start of the run to the end of the report; task_time_sum_s: a spin-up
    shared by several runs counted once; a rebuild without a run keeps the elapsed time."""
    import time

    runs = {}
    for n, spin in ((2, "/cache/spinup/A/spinup.nc"), (9, "/cache/spinup/A/spinup.nc"),
                    (1, "/cache/spinup/B/spinup.nc")):
        ds = make_analysis_dataset(n, wall_time_s=100.0)     # spin-up 30 s + saltation 70 s
        ds.attrs.update(spinup_wall_time_s=30.0, spinup_path=spin, analysis_seconds=2.0)
        runs[f"case{n:02d}"] = write_dataset(ds, tmp_path / f"c{n}.nc")
    out = tmp_path / "r"
    t0 = time.time()
    build_report("timed", runs, out, {"figure_formats": ["png"], "figure_dpi": 40,
                                      "run_started": t0 - 100.0})
    took = time.time() - t0
    s = json.loads((out / "summary.json").read_text())
    assert 100.0 <= s["total_wall_time_s"] <= 100.0 + took + 1.0
    assert s["run_started"] and s["run_finished"]
    assert s["task_times_s"] == pytest.approx({"spinup": 60.0, "saltation": 210.0, "analysis": 6.0})
    assert s["task_time_sum_s"] == pytest.approx(276.0)
    assert sum(c["wall_time_s"] for c in s["cases"].values()) == pytest.approx(300.0)
    index = (out / "index.html").read_text()
    assert "wall time, start to end" in index and "sum of task times" in index
    build_report("timed", runs, out, {"figure_formats": ["png"], "figure_dpi": 40})  # figures only
    s2 = json.loads((out / "summary.json").read_text())
    assert s2["total_wall_time_s"] == s["total_wall_time_s"] and s2["run_started"] == s["run_started"]


def test_table2_beside_paper(full_report):
    runs, out, _ = full_report
    md = (out / "table2.md").read_text()
    ds = open_dataset(runs["case02"])
    us = float(ds["u_star_s"].values)
    paper = paper_table2()[2]["u_star_s"]
    row = next(line for line in md.splitlines() if line.startswith("| case 2 |"))
    rel = (us - paper) / paper
    assert f"{us:.3g} / {paper:.3g} ({rel:+.0%})" in row
    html = (out / "table2.html").read_text()
    assert f"{us:.3g}" in html and "paper" in html
    # the text's numbers: z_m of cases 1 and 6 beside 0.22-0.55 m
    z1 = float(open_dataset(runs["case01"])["z_m"].values)
    z6 = float(open_dataset(runs["case06"])["z_m"].values)
    line = next(l for l in md.splitlines() if l.startswith("| z_m, case 1"))
    assert f"{z1:.3g}–{z6:.3g}" in line and "0.22–0.55" in line
    tau_line = next(l for l in md.splitlines() if "surface fraction, case 6" in l)
    f6 = float(open_dataset(runs["case06"])["tau_p_surface_fraction"].values)
    assert f"{f6:.3g}" in tau_line and "| 0.5 |" in tau_line


def test_missing_cases_are_drawn_as_missing(tmp_path):
    runs = write_study(tmp_path / "a", cases=[1, 2, 4, 6, 10], missing=(4,))
    out = tmp_path / "r"
    build_report("partial", runs, out, {"figure_formats": ["png"], "figure_dpi": 50})
    md = (out / "table2.md").read_text()
    assert re.search(r"\| case 4 \| \*no archive\*", md)
    assert "case 7" not in md                        # not in the study: no row at all
    s = json.loads((out / "summary.json").read_text())
    assert s["cases"]["4"]["status"] == "no archive" and "u_star_s" not in s["cases"]["4"]
    index = (out / "index.html").read_text()
    assert "case 4: no archive" in index             # figure notes are shown on the page
    assert "not in study" not in index               # cases 3, 5, 7-9 are simply not drawn


def test_hand_written_findings_survive_a_rebuild(tmp_path):
    runs = write_study(tmp_path / "a", cases=[2])
    out = tmp_path / "r"
    out.mkdir()
    (out / "FINDINGS.md").write_text("u*s agrees; lambda_y is 2x too small <because> of dx\n")
    build_report("findings", runs, out, {"figure_formats": ["png"], "figure_dpi": 50})
    index = (out / "index.html").read_text()
    assert "id='findings'" in index and "too small &lt;because&gt; of dx" in index
    assert (out / "FINDINGS.md").read_text().startswith("u*s agrees")
    out2 = tmp_path / "r2"
    build_report("nofindings", runs, out2, {"figure_formats": ["png"], "figure_dpi": 50})
    assert "id='findings'" not in (out2 / "index.html").read_text()


def test_stats_can_differ_from_paper(tmp_path):
    """The Table 2 difference column reflects the archive, not the paper (bias 1.5 -> +50%)."""
    runs = {"case02": write_analysis(tmp_path / "c2.nc", 2, bias=1.5)}
    from saltstudy.report.data import ReportContext, load_runs
    from saltstudy.report.tables import table2_rows
    rows = table2_rows(ReportContext("x", load_runs(runs)))
    assert rows[0]["cells"]["u_star_s"].rel == pytest.approx(0.5)
    assert rows[0]["cells"]["lambda_x"].rel == pytest.approx(0.5)


def test_animation_is_small_gif(full_report):
    _, out, _ = full_report
    gif = out / "cp_animation.gif"
    assert gif.is_file()
    assert gif.stat().st_size < 1_500_000
    from PIL import Image
    with Image.open(gif) as im:
        assert im.format == "GIF" and 2 <= im.n_frames <= 8


def test_convergence_ladder_study_does_not_crash(tmp_path):
    runs = {f"case02@rung{i}": write_analysis(tmp_path / f"r{i}.nc", 2, bias=b, wall_time_s=w)
            for i, (b, w) in enumerate(((1.3, 10.0), (1.05, 100.0), (1.0, 1000.0)))}
    out = tmp_path / "rep"
    build_report("convergence", runs, out, {"figure_formats": ["png"], "figure_dpi": 50})
    for f in FIGS:
        assert (out / f"{f}.png").is_file()
    assert (out / "convergence.png").is_file() and (out / "convergence.md").is_file()
    s = json.loads((out / "summary.json").read_text())
    assert set(s["cases"]) == set(runs)             # rungs keyed by label, not case number
    index = (out / "index.html").read_text()
    assert "convergence.png" in index


def test_a_study_on_top_of_a_ladder_table_gets_the_ladder_page(tmp_path):
    """One run and a ladder_table: the convergence page holds the table's rungs below the run,
    which is their reference."""
    runs = {f"case02@rung{i}": write_analysis(tmp_path / f"r{i}.nc", 2, bias=b, wall_time_s=w)
            for i, (b, w) in enumerate(((1.3, 10.0), (1.05, 100.0)))}
    build_report("low", runs, tmp_path / "low", {"figure_formats": ["png"], "figure_dpi": 40})
    top = {"case02": write_analysis(tmp_path / "top.nc", 2, bias=1.0, wall_time_s=1000.0)}
    out = tmp_path / "rep"
    build_report("top", top, out, {"figure_formats": ["png"], "figure_dpi": 40,
                                    "ladder_table": str(tmp_path / "low" / "convergence.json")})
    conv = json.loads((out / "convergence.json").read_text())
    assert [r["label"] for r in conv["rungs"]] == ["case02@rung0", "case02@rung1", "case02"]
    assert conv["reference"] == "case02"
    assert conv["rungs"][0]["err_finest"]["u_star_s"] == pytest.approx(0.30)
    assert "the study's <code>ladder_table</code>" in (out / "index.html").read_text()


def test_scene_study_does_not_crash(tmp_path):
    runs = {"gale": write_analysis(tmp_path / "g.nc", 6, label="gale"), "calm": None}
    out = tmp_path / "rep"
    build_report("stability", runs, out, {"failures": {"calm": "SolverBlowUp: u at (1,2,3) = nan"},
                                          "case_numbers": {"gale": 6, "calm": 1},
                                          "figure_formats": ["png", "pdf"], "figure_dpi": 50})
    s = json.loads((out / "summary.json").read_text())
    assert set(s["cases"]) == {"gale", "calm"}
    st = (out / "stability.md").read_text()
    assert "SolverBlowUp" in st and "failed" in st
    assert "stability" in (out / "index.html").read_text()


def test_report_names_the_solver_source_of_its_archives(tmp_path):
    """A report redrawn by ``figures`` records the source key in the archives' task.json."""
    from saltstudy.workflow.paths import task_dir
    from saltstudy.workflow.report_meta import cache_meta

    def archive(task, key, source):
        d = task_dir(tmp_path, task, key)
        d.mkdir(parents=True, exist_ok=True)
        (d / "task.json").write_text(json.dumps({"state": "done", "source_key": source}))

    archive("spinup", "s1", "abc123")
    archive("saltation", "r1", "abc123")
    archive("saltation", "r2", "abc123")
    keys = {"a": {"spinup": "s1", "saltation": "r1"}, "b": {"spinup": "s1", "saltation": "r2"}}
    meta = cache_meta({"out_dir": str(tmp_path), "keys": keys})
    assert meta["source_key"] == "abc123"

    archive("saltation", "r2", "def456")     # archives from two solver sources: both named
    meta = cache_meta({"out_dir": str(tmp_path), "keys": keys})
    assert meta["source_key"] == ["abc123", "def456"]
    # the workflow passes the running code's key: that one is kept
    meta = cache_meta({"out_dir": str(tmp_path), "keys": keys, "source_key": "live"})
    assert meta["source_key"] == "live"


def test_wall_time_of_a_resumed_study_says_it_is_the_last_leg():
    """A study finished from the cache: its page must not present the last leg as the cost."""
    from saltstudy.report.build import _resumed_note

    machine = {"cores": 2}
    resumed = {"total_wall_time_s": 52.0, "task_time_sum_s": 52_000.0, "machine": machine}
    assert "last run-all only" in _resumed_note(resumed)
    # two cores busy for the whole run: every task ran in it
    whole = {"total_wall_time_s": 1000.0, "task_time_sum_s": 1900.0, "machine": machine}
    assert _resumed_note(whole) == ""
    assert _resumed_note({"total_wall_time_s": None, "task_time_sum_s": 5.0}) == ""


def test_table2_caption_says_whether_the_cases_share_one_draw_of_the_swing():
    from saltstudy.report.data import ReportContext, RunData
    from saltstudy.report.tables import _start_text

    def ctx(stagger):
        scene = {"fidelity": {"spinup": {"u_star_ref": 0.54, "stagger": stagger}}}
        return ReportContext("x", {f"case0{n}": RunData(f"case0{n}", n, None, scene=scene)
                                   for n in (1, 2)})

    assert "6 s apart" in _start_text(ctx(6.0))
    assert "one draw" in _start_text(ctx(0.0))
    # archives written before the option existed carry no stagger: one draw
    assert "one draw" in _start_text(ReportContext("x", {"case01": RunData("case01", 1, None)}))
