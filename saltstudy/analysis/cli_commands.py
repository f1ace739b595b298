"""``saltstudy analyse``: samples.nc (+ spinup.nc) -> analysis.nc for one case."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    @app.command("analyse")
    def analyse(
        case_dir: Optional[Path] = typer.Argument(
            None, help="a run directory holding samples.nc and spinup.nc (alternative to the options)"),
        samples: Optional[Path] = typer.Option(None, "--samples", help="samples.nc of the case"),
        spinup: Optional[Path] = typer.Option(None, "--spinup", help="spinup.nc (particle-free profiles)"),
        out: Optional[Path] = typer.Option(None, "--out", help="analysis.nc to write "
                                           "(default: beside samples.nc)"),
        wall_time: Optional[float] = typer.Option(None, "--wall-time", help="solver wall time [s] "
                                                  "to record (default: samples.nc's)"),
    ) -> None:
        """Statistics of one case (u*s, z0s, z_m, tau_p, G, sigma_G, lambda_x/y, delta_y, R_cu, St, ...)."""
        from .analyse import analyse_case

        if case_dir is not None and not case_dir.is_dir():
            typer.echo(f"error: {case_dir}: not a directory", err=True)
            raise typer.Exit(2)
        if case_dir is not None:
            samples = samples or case_dir / "samples.nc"
            found = case_dir / "spinup.nc"
            spinup = spinup or (found if found.is_file() else None)
        for path in (samples, spinup):
            if path is not None and not path.is_file():
                typer.echo(f"error: {path}: no such file", err=True)
                raise typer.Exit(2)
        if samples is None:
            typer.echo("error: give a run directory or --samples PATH", err=True)
            raise typer.Exit(2)
        out = out or samples.with_name("analysis.nc")
        try:
            path = analyse_case(samples, spinup, out, wall_time_s=wall_time)
        except (OSError, KeyError, ValueError) as exc:
            typer.echo(f"error: {samples}: cannot analyse ({exc})", err=True)
            raise typer.Exit(1)
        from ..ncio import open_dataset
        ds = open_dataset(path)
        typer.echo(f"wrote {path}")
        for name in ("u_star_s", "z0s", "z_m", "G_tot", "sigma_G_over_G_tot", "lambda_x", "lambda_y",
                     "delta_y", "R_cu_upper", "u_star_t"):
            typer.echo(f"  {name} = {float(ds[name]):.4g} {ds[name].attrs.get('units', '')}"
                       if name in ds else f"  {name}: -")
