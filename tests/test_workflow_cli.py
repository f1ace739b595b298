"""Bad input to the workflow commands: clear error, exit 2, nothing in the cache touched."""
from __future__ import annotations

import shutil

import pytest
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.config import project_root


@pytest.fixture
def home(tmp_path, monkeypatch):
    h = tmp_path / "home"
    for d in ("cases", "workflows"):
        shutil.copytree(project_root() / d, h / d)
    monkeypatch.setenv("SALTSTUDY_HOME", str(h))
    monkeypatch.setenv("SALTSTUDY_OUT", str(tmp_path / "out"))
    return h


@pytest.mark.parametrize("text, expect", [
    ("fidelity = 'smoke'\ncases = [99]\n", "case 99: unknown case"),
    ("fidelity = 'nosuch'\ncases = [1]\n", "fidelity 'nosuch': unknown"),
    ("fidelity = 'smoke'\ncases = [1]\nbogus = 3\n", "bogus: unknown key"),
    ("fidelity = 'smoke'\ncases = [1\n", "not valid TOML"),
    ("fidelity = 'smoke'\ncases = []\n", "at least one entry"),
])
@pytest.mark.parametrize("command", ["run-all", "status"])
def test_bad_study_exits_2_and_touches_nothing(home, tmp_path, text, expect, command):
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    r = CliRunner().invoke(app, [command, "--study", str(bad)])
    assert r.exit_code == 2, r.output
    assert expect in r.output
    assert not (tmp_path / "out").exists()


def test_unknown_study_and_case(home, tmp_path):
    r = CliRunner().invoke(app, ["run-all", "--study", "nosuch"])
    assert r.exit_code == 2 and "study 'nosuch': unknown" in r.output
    r = CliRunner().invoke(app, ["run", "42"])
    assert r.exit_code == 2 and "case 42: unknown case" in r.output
    r = CliRunner().invoke(app, ["run", "1", "--fidelity", "nosuch"])
    assert r.exit_code == 2 and "fidelity 'nosuch'" in r.output
    assert not (tmp_path / "out").exists()


def test_bad_case_file_referenced_by_a_study(home, tmp_path):
    p = home / "cases" / "case03.toml"
    p.write_text(p.read_text().replace("[particles]", "[particles]\nQ_typo = 3"))
    r = CliRunner().invoke(app, ["run-all", "--study", "smoke"])
    assert r.exit_code == 2 and "case03.toml" in r.output and "Q_typo" in r.output
    assert not (tmp_path / "out").exists()
