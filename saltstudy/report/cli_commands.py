"""The report commands of the investigations, in the ``probe`` group beside the probes
(instruments/loglaw_probe.py): ``saltstudy probe loglaw-report`` (particle-free log-law probes)
and ``saltstudy probe variants-report`` (model variants over seeds). A study's own report:
``saltstudy figures`` (workflow/cli_commands.py), which finds its archives in the cache."""
from __future__ import annotations

from pathlib import Path

import typer

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the investigations' report commands to ``app`` (the ``probe`` group)."""
    @app.command("loglaw-report")
    def loglaw_report(
        directory: Path = typer.Argument(..., help="directory of `saltstudy probe loglaw --json` results"),
        n_last: int = typer.Option(2, "--last", help="windows averaged per probe (the last ones)"),
    ) -> None:
        """Summary table, phi(z) and spanwise-spectrum figures of particle-free log-law probes."""
        from .loglaw import build_loglaw_report
        try:
            summary = build_loglaw_report(directory, n_last=n_last)
        except (ValueError, KeyError, OSError) as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2)
        for name, s in summary["probes"].items():
            typer.echo(f"{name}: {'all pass' if s['all_pass'] else 'fails'}")
        typer.echo(f"report: {Path(directory) / 'summary.md'}")

    @app.command("variants-report")
    def variants_report(
        directory: Path = typer.Argument(..., help="a report directory with the summary.json of a "
                                         "study whose runs are labelled c<case>_<variant>_s<seed>"),
    ) -> None:
        """Model variants replicated over seeds: mean, seed scatter and ratio to the baseline."""
        from .variants import build_variants_report
        try:
            build_variants_report(directory)
        except (ValueError, OSError) as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2)
        typer.echo(f"table: {Path(directory) / 'variants.md'}")
