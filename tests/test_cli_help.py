"""``saltstudy --help`` by audience: the user's commands first, then the instruments' groups, at
most ten entries with one line each; the probes reachable in the ``probe`` group."""
from __future__ import annotations

import click
import typer
from typer.testing import CliRunner

from saltstudy.cli import INSTRUMENTS_PANEL, TOP_LEVEL, USER_PANEL, app

USER = ["run-all", "run", "status", "figures", "cases", "validate", "analyse"]


def test_the_top_level_lists_the_users_commands_then_the_instruments():
    group = typer.main.get_command(app)
    names = group.list_commands(click.Context(group))
    assert len(names) <= 10
    assert names == USER + ["bench", "probe"]
    for name in names:
        short, panel = TOP_LEVEL[name]
        assert panel == (USER_PANEL if name in USER else INSTRUMENTS_PANEL)
        cmd = group.get_command(click.Context(group), name)
        assert cmd.short_help == short and "\n" not in short and len(short) <= 70
    out = CliRunner().invoke(app, ["--help"], terminal_width=100).output
    assert out.index(USER_PANEL) < out.index("run-all") < out.index("analyse") \
        < out.index(INSTRUMENTS_PANEL) < out.index("bench") < out.index("probe")


def test_the_probes_sit_in_the_probe_group():
    group = typer.main.get_command(app)
    assert "coherence" not in group.list_commands(click.Context(group))
    runner = CliRunner()
    for name in ("loglaw", "coherence", "steady-layer", "column-budget"):
        r = runner.invoke(app, ["probe", name, "--help"])
        assert r.exit_code == 0, (name, r.output)
    r = runner.invoke(app, ["probe", "--help"], terminal_width=100)
    assert all(name in r.output for name in ("loglaw", "coherence", "steady-layer"))
