"""Where the stress at 2 m comes from: the x-momentum budget of the column above z_ref in one
saltation archive, or in a run still going, from its checkpoint (``saltstudy probe column-budget``;
docs/USAGE.md): is a long run's column settled while its window fills? With the top drive the mean
x-momentum above z_ref per unit area, P, obeys

    dP/dt = M - tau(z_ref),        M = sum_k f_k (u_drive - <u>_k) dz_k,

M the momentum the Rayleigh layer feeds in (solver/flow/forcing.py): tau from ``u_star_ref``, M
from ``u_drive`` and ``u_mean``, -dP/dt from the first and last profiles of the sampling window.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

BLOCK_S = 5.0


def column_momentum(u_mean: np.ndarray, z_w: np.ndarray, z_ref: float) -> np.ndarray:
    """P = integral of the mean u from z_ref to the top face [m^2 s^-1] for profiles ``u_mean``
    (..., nz) on cells bounded by ``z_w`` (nz+1,)."""
    from ..analysis.balance import layer_weights
    z_w = np.asarray(z_w, dtype=np.float64)
    return np.asarray(u_mean, dtype=np.float64) @ layer_weights(z_w, z_ref, z_w[-1])


def _running_dataset(run_dir: Path):
    """What the budget reads, as a saltation archive holds it, from a running or stopped saltation
    task's directory: the records so far in checkpoint.npz, the rest from task.json's scene."""
    import xarray as xr

    from ..config.fidelity import GridSpec
    from ..solver.grid import Grid
    from ..workflow.archives import z_ref_below
    from ..workflow.paths import read_task_json

    tj = read_task_json(run_dir) or {}
    if tj.get("task") != "saltation" or "config" not in tj:
        raise ValueError(f"{run_dir}: no samples.nc and no saltation task.json")
    dims = {"series:__times__": "time_series", "series:u_star_ref": "time_series",
            "series:u_drive": "time_series", "sample:__times__": "time", "sample:u_mean": "time"}
    with np.load(run_dir / "checkpoint.npz", allow_pickle=False) as z:
        rec = {k.split(":rec:")[1]: z[k] for k in z.files if k.split(":rec:")[-1] in dims}
    run, spec = tj["config"], GridSpec.model_validate(tj["config"]["fidelity"]["grid"])
    forcing, grid = run["case"]["forcing"], Grid.from_spec(spec)
    return xr.Dataset(
        {k.split(":")[1]: ((dims[k], "z") if k == "sample:u_mean" else dims[k], v)
         for k, v in rec.items() if not k.endswith("__times__")},
        coords={"time_series": rec.get("series:__times__", []), "z": grid.z_c, "z_w": grid.z_f,
                "time": rec.get("sample:__times__", [])},
        attrs={"case_json": json.dumps(run), "Lz": spec.Lz, "label": tj.get("label", ""),
               "u_star_target": forcing["u_star_s"],   # the budget needs the top drive
               "z_ref_eff": z_ref_below(forcing["z_ref"], spec.Lz, spec.damping_depth)})


def column_budget(samples: Path, block_s: float = BLOCK_S,
                  window: tuple[float, float] | None = None) -> dict:
    """The budget of the column above z_ref over the sampling window, or over the volumes within
    ``window`` (start, end) [s after activation] (module doc), stresses over u*s^2; ``samples``
    a task's directory: the run's records so far. ValueError for an archive without these
    records, not driven from the top, or with < 2 volumes in it."""
    from ..ncio import open_dataset
    from ..solver.flow.damping import rayleigh_profile

    ds = _running_dataset(Path(samples)) if Path(samples).is_dir() else open_dataset(samples)
    need = ("u_star_ref", "u_drive", "time_series", "u_mean", "time", "z", "z_w")
    missing = [n for n in need if n not in ds]
    if missing:
        raise ValueError(f"{samples}: no {', '.join(map(repr, missing))} (not a saltation archive "
                         f"with the drive's record and mean profiles)")
    for a in ("case_json", "Lz", "u_star_target", "z_ref_eff"):
        if a not in ds.attrs:
            raise ValueError(f"{samples}: no attribute {a!r}")
    run = json.loads(ds.attrs["case_json"])
    if run["case"]["forcing"].get("drive", "top") != "top":
        raise ValueError(f"{samples}: forcing.drive is {run['case']['forcing']['drive']!r}; the "
                         f"budget needs the top drive")
    grid = run["fidelity"]["grid"]
    Lz, z_ref, us_t = (float(ds.attrs[a]) for a in ("Lz", "z_ref_eff", "u_star_target"))
    target = us_t * us_t
    ts, us, ud, t, z_c, z_w, um = (ds[n].values for n in ("time_series", "u_star_ref", "u_drive",
                                                          "time", "z", "z_w", "u_mean"))
    if window is not None:
        keep = (t >= window[0] - 1e-9) & (t <= window[1] + 1e-9)
        t, um = t[keep], um[keep]
    if t.size < 2:
        raise ValueError(f"{samples}: {t.size} volume(s) in the window: the storage needs two")
    t0, t1 = float(t[0]), float(t[-1])
    f = rayleigh_profile(z_c, Lz, float(grid["damping_depth"]), float(grid["damping_timescale"]))
    M = (f * np.diff(z_w) * (np.interp(t, ts, ud)[:, None] - um)).sum(axis=1)
    P = column_momentum(um, z_w, z_ref)

    def u_star(a: float, b: float, right: bool = True) -> float:
        """The rms u* at z_ref over [a, b] (or [a, b))."""
        return math.sqrt(float(np.mean(us[(ts >= a) & ((ts <= b) if right else (ts < b))] ** 2)))

    tau = u_star(t0, t1) ** 2
    storage = (P[0] - P[-1]) / (t1 - t0)
    mid = 0.5 * (t0 + t1)
    halves = [u_star(t0, mid), u_star(mid, t1)]
    blocks = [{"t0": float(a), "t1": float(a + block_s), "u_star_2m": u_star(a, a + block_s, False)}
              for a in np.arange(0.0, ts.max() - 0.5 * block_s + 1e-9, block_s)
              if ((ts >= a) & (ts < a + block_s)).any()]
    return {"samples": str(samples), "label": str(ds.attrs.get("label", "")), "u_star_s": us_t,
            "z_ref": z_ref, "window": [t0, t1], "u_star_2m": math.sqrt(tau),
            "tau_2m": tau / target, "M_drive": float(np.mean(M)) / target,
            "storage": float(storage) / target,
            "residual": (tau - float(np.mean(M)) - storage) / target,
            "halves": halves, "blocks": blocks}


def format_column_budget(rows: list[dict]) -> str:
    lines = ["x-momentum of the column above z_ref over the sampling window, each term over u*s^2",
             "(tau = M + storage + residual; storage = -dP/dt, a decelerating column reads high)",
             "",
             f"{'run':<14} {'u*s':>6} {'u* 2 m':>7} {'(+%)':>6} {'tau':>6} {'M drive':>8} "
             f"{'storage':>8} {'resid.':>7}  halves"]
    for r in rows:
        ex = 100.0 * (r["u_star_2m"] / r["u_star_s"] - 1.0)
        lines.append(f"{r['label'][:14]:<14} {r['u_star_s']:6.3f} {r['u_star_2m']:7.3f} {ex:+6.1f} "
                     f"{r['tau_2m']:6.2f} {r['M_drive']:8.2f} {r['storage']:8.2f} "
                     f"{r['residual']:7.2f}  {r['halves'][0]:.3f} / {r['halves'][1]:.3f}")
    lines += ["", "u* at 2 m in 5-s blocks from activation, over u*s:"]
    for r in rows:
        lines.append(f"{r['label'][:14]:<14} " + " ".join(
            f"{b['u_star_2m'] / r['u_star_s']:.2f}" for b in r["blocks"]))
    return "\n".join(lines)


def register_column_budget(probe_app) -> None:
    import typer

    from ..workflow.cli_commands import fail

    @probe_app.command("column-budget")
    def column_budget_cmd(paths: list[Path] = typer.Argument(
            ..., help="saltation archives (samples.nc) or the directories holding them; a "
            "directory with only checkpoint.npz is a run still going: its records so far"),
            as_json: bool = typer.Option(False, "--json", help="one JSON list"),
            window: tuple[float, float] | None = typer.Option(
                None, "--window", help="START END [s after activation]: the volumes "
                "within it (default: the whole sampling window)")) -> None:
        """The x-momentum budget of the column above 2 m: why the stress there reads as it does."""
        rows = []
        for path in paths:
            samples = path / "samples.nc" if path.is_dir() else path
            if not samples.is_file() and (path / "checkpoint.npz").is_file():
                samples = path
            try:
                if not samples.exists():
                    raise ValueError(f"{samples}: no such file" + (
                        " (nor a checkpoint yet)" if path.is_dir() else ""))
                rows.append(column_budget(samples, window=window))
            except (OSError, ValueError) as exc:
                fail(str(exc))
        typer.echo(json.dumps(rows) if as_json else format_column_budget(rows))
