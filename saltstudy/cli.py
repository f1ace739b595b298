"""The ``saltstudy`` command line: each area adds its commands through ``register(app)`` in its
``cli_commands.py``; here the configuration-only commands and the top level's order
(:data:`TOP_LEVEL`).
"""
from __future__ import annotations

import importlib
import json
from pathlib import Path

import typer
from typer.core import TyperGroup

from ._identity import __version__
from .config import ConfigError, list_case_numbers, load_case, validate_file
from .workflow.cli_commands import fail

USER_PANEL = "Run a study and read its results"
INSTRUMENTS_PANEL = "Instruments: what measures the model"

#: ``saltstudy --help``'s order and one-line helps: the user's commands, then the instruments
TOP_LEVEL: dict[str, tuple[str, str]] = {
    "run-all": ("Run a study (default: quick) and build its report.", USER_PANEL),
    "run": ("Run one case at one fidelity: spin-up, saltation, analysis.", USER_PANEL),
    "status": ("Which runs of a study are done, stale, failed or missing.", USER_PANEL),
    "figures": ("Redraw a study's report (Figures 1-13, Table 2) from its archives.", USER_PANEL),
    "cases": ("The paper's ten cases: list them, or show one in full.", USER_PANEL),
    "validate": ("Check a case, fidelity or study file before running it.", USER_PANEL),
    "analyse": ("Compute one run's statistics (analysis.nc) from its archives.", USER_PANEL),
    "bench": ("Speed benchmarks of the solver.", INSTRUMENTS_PANEL),
    "probe": ("Diagnostic runs of the model.", INSTRUMENTS_PANEL),
}


class _TopLevel(TyperGroup):
    """Lists the commands in :data:`TOP_LEVEL`'s order (typer lists groups last)."""

    def list_commands(self, ctx) -> list[str]:
        names = super().list_commands(ctx)
        order = list(TOP_LEVEL)
        return sorted(names, key=lambda n: order.index(n) if n in order else len(order))


app = typer.Typer(cls=_TopLevel, add_completion=False, no_args_is_help=True,
                  help="LES + Lagrangian saltation: reproduce Dupont et al. (2013).")
cases_app = typer.Typer(no_args_is_help=True, help="The cases of the study (Table 2).")
app.add_typer(cases_app, name="cases")


@app.callback(invoke_without_command=True)
def _main(version: bool = typer.Option(False, "--version", help="print the version and exit")) -> None:
    if version:
        typer.echo(__version__)
        raise typer.Exit(0)


@cases_app.command("list")
def cases_list() -> None:
    """A table of the cases: u*s, mu1, Q, and u*t from Shao & Lu (2000)."""
    from .physics.threshold import threshold_for_soil

    typer.echo(f"{'case':>4}  {'u*s [m/s]':>9}  {'mu1 [um]':>8}  {'sigma':>5}  {'Q':>7}  {'u*t [m/s]':>9}")
    for n in list_case_numbers():
        try:
            c = load_case(n)
        except ConfigError as exc:
            fail(str(exc))
        mode = c.soil.modes[0]
        ut = threshold_for_soil(c.soil, c.air, c.threshold)
        mu = "+".join(f"{m.mu * 1e6:g}" for m in c.soil.modes)
        typer.echo(f"{n:>4}  {c.forcing.u_star_s:>9.2f}  {mu:>8}  {mode.sigma:>5.2f}  "
                   f"{c.particles.Q:>7g}  {ut:>9.3f}")


@cases_app.command("show")
def cases_show(number: int = typer.Argument(..., help="case number"),
               as_json: bool = typer.Option(False, "--json", help="machine-readable JSON")) -> None:
    """The fully resolved case (all defaults filled in)."""
    try:
        c = load_case(number)
    except ConfigError as exc:
        fail(str(exc))
    data = c.model_dump(mode="json")
    if as_json:
        typer.echo(json.dumps(data, indent=2))
        return

    def show(d: dict, indent: int = 0) -> None:
        for k, v in d.items():
            if isinstance(v, dict):
                typer.echo(" " * indent + f"{k}:")
                show(v, indent + 2)
            else:
                typer.echo(" " * indent + f"{k} = {v}")

    show(data)


@app.command("validate")
def validate(path: Path = typer.Argument(..., help="a case, fidelity or study TOML file")) -> None:
    """Check a case, fidelity or study file; exit 2 with the field and reason if it is invalid."""
    try:
        kind = validate_file(path)
    except ConfigError as exc:
        fail(str(exc))
    typer.echo(f"{path}: valid {kind}")


for _area in ("saltstudy.workflow.cli_commands", "saltstudy.analysis.cli_commands",
              "saltstudy.instruments.cli_commands"):
    importlib.import_module(_area).register(app)

for _info in (*app.registered_commands, *app.registered_groups):
    if _info.name in TOP_LEVEL:
        _info.short_help, _info.rich_help_panel = TOP_LEVEL[_info.name]
