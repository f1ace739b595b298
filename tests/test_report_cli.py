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
