"""``saltstudy figures``: build a study's report from the analysis archives in the cache."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

__all__ = ["register", "figures_command"]


def figures_command(study: str, out: Optional[Path], report_dir: Optional[Path]) -> Path:
    """Resolve the study's analysis archives under ``out`` and build the report. Returns index.html."""
    from .. import __version__
    from ..workflow import paths as wpaths          # lazy: report does not need the workflow otherwise
    from .build import build_report

    out_dir = Path(out) if out is not None else wpaths.default_out_dir()
    runs = wpaths.analysis_paths(study, out_dir)
    study_name = Path(study).stem if str(study).endswith(".toml") else str(study)
    if report_dir is None:
        drd = getattr(wpaths, "default_report_dir", None)
        report_dir = drd(study_name) if drd else Path("reports") / study_name
    meta = {"study": study_name, "out_dir": str(out_dir), "package_version": __version__}
    try:  # the cache keys let the report find failure records and samples.nc (stability, animation)
        from ..workflow import keys as wkeys
        from ..config import load_study, study_file
        st = load_study(study)
        meta["study_file"] = str(study_file(st))
        meta["keys"] = {l: {"spinup": k.spinup, "saltation": k.saltation, "analysis": k.analysis}
                        for l, k in wkeys.study_keys(st).items()}
    except Exception:
        pass
    return build_report(study_name, runs, Path(report_dir), meta)


def register(app: typer.Typer) -> None:
    @app.command("figures")
    def figures(
        study: str = typer.Option("reduced", "--study", help="study name (workflows/NAME.toml) or file"),
        out: Optional[Path] = typer.Option(None, "--out", help="cache directory holding the archives "
                                                              "(default: $SALTSTUDY_OUT or .saltstudy-cache)"),
        report_dir: Optional[Path] = typer.Option(None, "--report-dir",
                                                  help="where the report goes (default: reports/<study>)"),
    ) -> None:
        """Figures 1-13, Table 2 beside the paper, summary.json and index.html from the archives."""
        from ..config import ConfigError
        try:
            index = figures_command(study, out, report_dir)
        except ConfigError as exc:
            typer.echo(f"error: {exc}", err=True)
            raise typer.Exit(2)
        except ModuleNotFoundError as exc:
            typer.echo(f"error: {exc} (the workflow package is needed to locate archives)", err=True)
            raise typer.Exit(2)
        typer.echo(f"report: {index}")

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
