"""Workflow commands ``run-all``, ``run``, ``status``, ``figures``. Exit codes: 0 success; 1 a
task failed; 2 bad input (the cache untouched); 3 the out dir is held by another process.
"""
from __future__ import annotations

import time
from pathlib import Path
from typing import Optional

import typer

from ..config import ConfigError

#: the study ``run-all`` runs without --study: must finish in minutes on a laptop
DEFAULT_STUDY = "quick"
#: the fidelity ``run CASE`` uses without --fidelity
DEFAULT_FIDELITY = "smoke"

_OUT_HELP = "cache directory (default: $SALTSTUDY_OUT, else <project>/.saltstudy-cache)"
_WAIT_HELP = ("if another saltstudy process uses the out dir, wait for it to finish (default: "
              "refuse at once, exit 3)")
#: exit code when the out dir is in use by another process
EXIT_BUSY = 3


def fail(message: str, code: int = 2) -> None:
    """Print a clear error on stderr and exit (2: bad input)."""
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code)


def _hold(out_dir: Path, wait: bool):
    """Hold the out dir for a command; exit 3 naming the holder if in use (without ``wait``)."""
    from .lock import Busy, hold_out_dir
    from .progress import emit

    try:
        return hold_out_dir(out_dir, wait=wait, log=emit)
    except Busy as exc:
        fail(f"{exc}; rerun with --wait to wait for it, or use another --out", EXIT_BUSY)


def _out(out: Optional[Path]) -> Path:
    from .paths import default_out_dir

    return Path(out) if out is not None else default_out_dir()


def register(app: typer.Typer) -> None:
    @app.command("run-all")
    def run_all(
        study: str = typer.Option(DEFAULT_STUDY, "--study", help="study name (workflows/NAME.toml) or a study file"),
        out: Optional[Path] = typer.Option(None, "--out", help=_OUT_HELP),
        workers: int = typer.Option(1, "--workers", min=1, help="tasks at once locally, each with "
                                    "cores // N numba threads (1 on a laptop)"),
        scheduler: Optional[str] = typer.Option(None, "--scheduler", help="dask.distributed "
                                                "scheduler address, e.g. tcp://host:8786"),
        quiet: bool = typer.Option(False, "--quiet", help="plain log lines instead of a live display"),
        report_dir: Optional[Path] = typer.Option(None, "--report-dir",
                                                  help="where the report goes (default: <project>/reports/<study>)"),
        wait: bool = typer.Option(False, "--wait", help=_WAIT_HELP),
    ) -> None:
        """Run a whole study (spin-up, saltation, analysis per case; one report), reusing the cache."""
        started = time.time()   # the origin of the report's elapsed wall time (summary.json)
        from ..config import load_study
        from . import keys as K
        from .graph import run_study
        from .paths import output_path
        from ..ncio import is_complete

        out_dir = _out(out)
        # Validate everything before touching the cache: a bad study or case exits 2 here.
        try:
            st = load_study(study)
            runs = K.study_keys(st)
        except ConfigError as exc:
            fail(str(exc))
        typer.echo(f"study {st.name}: {len(runs)} runs, out dir {out_dir}")
        held = _hold(out_dir, wait)
        if held.lock.waited_s > 1.0:
            started = time.time()     # the run starts when the other has finished
        with held:
            todo = [(l, t) for l, rk in runs.items() for t in ("spinup", "saltation", "analysis")
                    if not is_complete(output_path(out_dir, t, getattr(rk, t)))]
            if not todo:
                typer.echo("all runs cached: no solver work to do")
            else:
                typer.echo(f"{len(todo)} of {3 * len(runs)} run tasks to compute")
            summary = run_study(st, out_dir, workers=workers, scheduler=scheduler, quiet=quiet,
                                report_dir=report_dir, started=started)
        _print_summary(summary, st.report)
        if todo and not summary.solver_work and not any(o.status == "failed"
                                                        for o in summary.outcomes):
            typer.echo("no solver work was needed (spin-ups and saltation runs all cached)")
        raise typer.Exit(summary.exit_code)

    @app.command("run")
    def run_one(
        case: str = typer.Argument(..., help="case number (cases/caseNN.toml) or a case file"),
        fidelity: str = typer.Option(DEFAULT_FIDELITY, "--fidelity", help="fidelity name or file"),
        out: Optional[Path] = typer.Option(None, "--out", help=_OUT_HELP),
        quiet: bool = typer.Option(False, "--quiet", help="plain log lines instead of a live display"),
        wait: bool = typer.Option(False, "--wait", help=_WAIT_HELP),
    ) -> None:
        """Run one case: spin-up, saltation, analysis (cached like run-all; no report)."""
        from ..config import load_case, load_fidelity, resolve_scene
        from .graph import run_scene

        out_dir = _out(out)
        try:
            c = load_case(case)
            scene = resolve_scene(c, load_fidelity(fidelity))
        except ConfigError as exc:
            fail(str(exc))
        t0 = time.perf_counter()
        with _hold(out_dir, wait):
            _, outcomes = run_scene(scene, out_dir, quiet=quiet)
        for o in outcomes:
            typer.echo(f"{o.task:<9} {o.status:<8} {o.path or o.error or ''}")
        typer.echo(f"wall time {time.perf_counter() - t0:.1f} s")
        raise typer.Exit(1 if any(o.status == "failed" for o in outcomes) else 0)

    @app.command("status")
    def status(
        study: str = typer.Option(DEFAULT_STUDY, "--study", help="study name or file"),
        out: Optional[Path] = typer.Option(None, "--out", help=_OUT_HELP),
    ) -> None:
        """Per run and task: done / stale / failed / partial / running / stopped / missing."""
        from ..config import load_study
        from .status import format_status, out_dir_state, study_status

        out_dir = _out(out)
        try:
            st = load_study(study)
            rows = study_status(st, out_dir)
        except ConfigError as exc:
            fail(str(exc))
        typer.echo(f"study {st.name}, out dir {out_dir}")
        typer.echo(format_status(rows))
        typer.echo(out_dir_state(out_dir))

    @app.command("figures")
    def figures(
        study: str = typer.Option("reduced", "--study", help="study name (workflows/NAME.toml) or file"),
        out: Optional[Path] = typer.Option(None, "--out", help=_OUT_HELP),
        report_dir: Optional[Path] = typer.Option(None, "--report-dir",
                                                  help="where the report goes (default: reports/<study>)"),
        wait: bool = typer.Option(False, "--wait", help=_WAIT_HELP),
        recorded: bool = typer.Option(
            False, "--recorded", help="draw from the archives run-all last recorded for each run "
            "(studies/NAME/runs.json), though the code or configuration has changed since; the "
            "report names the source keys that made them"),
    ) -> None:
        """Figures 1-13, Table 2 beside the paper, summary.json and index.html from the archives."""
        from ..config import load_study
        from ..report import build_report
        from . import keys as wkeys
        from . import paths as wpaths
        from .report_meta import cache_meta, study_meta
        from .tasks import build_report_staged

        out_dir = _out(out)
        study_name = Path(study).stem if str(study).endswith(".toml") else str(study)
        try:
            st = load_study(study)
            meta = study_meta(st, study_name, out_dir, wkeys.study_keys(st))
        except ConfigError as exc:
            fail(str(exc))
        with _hold(out_dir, wait):
            runs = wpaths.analysis_paths(study, out_dir)
            if recorded:
                runs, meta["keys"] = wpaths.recorded_analysis_paths(study_name, list(runs), out_dir)
            index = build_report_staged(build_report, study_name, runs, Path(
                report_dir or wpaths.default_report_dir(study_name)), cache_meta(meta))
        typer.echo(f"report: {index}")


def _print_summary(summary, report_wanted: bool = True) -> None:
    from collections import Counter

    counts = Counter(o.status for o in summary.outcomes)
    typer.echo(f"study {summary.study}: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items()))
               + f" in {summary.wall_s:.1f} s")
    expected = {id(o) for o in summary.expected_blowups}
    for o in summary.outcomes:
        if id(o) in expected:
            typer.echo(f"  blew up as the scene expects: {o.task} {','.join(o.labels)}: {o.error}")
        elif o.status in ("failed", "skipped"):
            typer.echo(f"  {o.status}: {o.task} {','.join(o.labels)}: {o.error}", err=o.status == "failed")
    for label in summary.unexpected_completions:
        typer.echo(f"  {label}: expected a solver blow-up (scene expect = 'blow-up') but the run "
                   "completed", err=True)
    if summary.report_dir is not None:
        typer.echo(f"report: {summary.report_dir}")
    elif not report_wanted:
        typer.echo("report: none (the study sets report = false)")
    else:
        typer.echo("report: not built (see messages above)")
