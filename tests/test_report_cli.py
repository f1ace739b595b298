"""`saltstudy figures` resolves archives through the workflow's path functions and builds the report."""
from __future__ import annotations

import pytest
from typer.testing import CliRunner

from report_fixtures import write_study


def test_figures_command(tmp_path, monkeypatch):
    paths = pytest.importorskip("saltstudy.workflow.paths")
    from saltstudy.cli import app

    runs = write_study(tmp_path / "a", cases=[2, 7], missing=(7,))
    seen = {}

    def fake_analysis_paths(study, out_dir=None):
        seen["study"], seen["out"] = study, out_dir
        return runs

    monkeypatch.setattr(paths, "analysis_paths", fake_analysis_paths)
    out = tmp_path / "cache"
    rep = tmp_path / "rep"
    res = CliRunner().invoke(app, ["figures", "--study", "smoke", "--out", str(out), "--report-dir", str(rep)])
    assert res.exit_code == 0, res.output
    assert seen == {"study": "smoke", "out": out}
    assert (rep / "index.html").is_file() and (rep / "fig13.pdf").is_file()
    assert str(rep / "index.html") in res.output


def test_figures_command_bad_study(tmp_path):
    pytest.importorskip("saltstudy.workflow.paths")
    from saltstudy.cli import app
    res = CliRunner().invoke(app, ["figures", "--study", "no-such-study", "--out", str(tmp_path)])
    assert res.exit_code == 2
    assert "no-such-study" in res.output


def test_figures_recorded_draws_the_archives_run_all_last_recorded(tmp_path):
    """--recorded reads runs.json's keys, not the present code's: an archive an earlier revision
    made is drawn, and a run with nothing recorded is drawn as missing."""
    import json

    from saltstudy.cli import app
    from saltstudy.workflow.paths import output_path, runs_file
    from report_fixtures import write_analysis

    out, rep = tmp_path / "cache", tmp_path / "rep"
    archive = output_path(out, "analysis", "from-an-older-revision")
    archive.parent.mkdir(parents=True)
    write_analysis(archive, 2, label="case02")
    runs_file(out, "smoke").parent.mkdir(parents=True)
    runs_file(out, "smoke").write_text(json.dumps(
        {"labels": {"case02": {"analysis": "from-an-older-revision"}}}))
    plain = CliRunner().invoke(app, ["figures", "--study", "smoke", "--out", str(out),
                                     "--report-dir", str(tmp_path / "plain")])
    assert plain.exit_code == 0, plain.output
    assert json.loads((tmp_path / "plain" / "summary.json").read_text())["cases"]["2"]["status"] \
        == "no archive"
    res = CliRunner().invoke(app, ["figures", "--study", "smoke", "--out", str(out),
                                   "--report-dir", str(rep), "--recorded"])
    assert res.exit_code == 0, res.output
    cases = json.loads((rep / "summary.json").read_text())["cases"]
    assert cases["2"]["status"] == "ok" and cases["1"]["status"] == "no archive"
