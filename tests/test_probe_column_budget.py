"""`saltstudy probe column-budget`: the x-momentum budget of the column above z_ref closes on a
synthetic archive whose column decelerates at a known rate, and the command's errors."""
from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.instruments.column_budget import column_budget, column_momentum
from saltstudy.solver.flow.damping import rayleigh_profile

LZ, NZ, DEPTH, TSCALE, Z_REF, US = 6.0, 24, 1.5, 5.0, 2.0, 0.5


def _archive(path, decel: float, drive: str = "top"):
    """A column whose mean wind falls by ``decel`` m/s per s at every height, a constant drive
    velocity, and the stress at z_ref that the budget then requires at every instant."""
    z_w = np.linspace(0.0, LZ, NZ + 1)
    z = 0.5 * (z_w[1:] + z_w[:-1])
    t = np.linspace(12.0, 42.0, 13)
    ts = np.arange(0.0, 42.0 + 1e-9, 0.05)
    base = 2.5 * np.log(z / 1e-4)
    u_drive = float(base[-1]) + 3.0
    f = rayleigh_profile(z, LZ, DEPTH, TSCALE)
    dz = np.diff(z_w)

    def drive_force(tt):
        return float(np.sum(f * dz * (u_drive - (base - decel * tt))))

    storage = decel * (LZ - Z_REF)  # -dP/dt
    tau = np.array([drive_force(tt) + storage for tt in ts])
    run = {"case": {"forcing": {"drive": drive}},
           "fidelity": {"grid": {"damping_depth": DEPTH, "damping_timescale": TSCALE}}}
    ds = xr.Dataset(
        {"u_star_ref": ("time_series", np.sqrt(tau)),
         "u_drive": ("time_series", np.full(ts.size, u_drive)),
         "u_mean": (("time", "z"), base[None, :] - decel * t[:, None])},
        coords={"time_series": ts, "time": t, "z": z, "z_w": z_w},
        attrs={"case_json": json.dumps(run), "Lz": LZ, "u_star_target": US, "z_ref_eff": Z_REF,
               "label": "synthetic"})
    ds.to_netcdf(path)
    return tau, storage


def test_column_momentum_counts_the_cut_cell_by_its_part_above_z_ref():
    z_w = np.array([0.0, 1.0, 3.0, 4.0])
    u = np.array([10.0, 20.0, 30.0])
    # half of the middle cell lies above 2 m
    assert column_momentum(u, z_w, 2.0) == pytest.approx(20.0 * 1.0 + 30.0 * 1.0)


def test_the_budget_closes_and_splits_the_excess_into_drive_and_storage(tmp_path):
    decel = 0.004
    tau, storage = _archive(tmp_path / "samples.nc", decel)
    r = column_budget(tmp_path / "samples.nc")
    target = US * US
    assert r["storage"] == pytest.approx(storage / target, rel=1e-9)
    assert r["residual"] == pytest.approx(0.0, abs=2e-3)
    assert r["tau_2m"] == pytest.approx(r["M_drive"] + r["storage"], abs=2e-3)
    # the decelerating column reads above what the drive feeds in
    assert r["tau_2m"] > r["M_drive"]
    assert r["window"] == [12.0, 42.0]
    assert len(r["blocks"]) == 8 and r["blocks"][0]["t0"] == 0.0


def test_a_steady_column_stores_nothing(tmp_path):
    _archive(tmp_path / "samples.nc", 0.0)
    r = column_budget(tmp_path / "samples.nc")
    assert r["storage"] == pytest.approx(0.0, abs=1e-12)
    assert r["tau_2m"] == pytest.approx(r["M_drive"], rel=1e-3)


def test_the_command_prints_the_table_and_names_what_is_wrong(tmp_path):
    _archive(tmp_path / "samples.nc", 0.002)
    runner = CliRunner()
    res = runner.invoke(app, ["probe", "column-budget", str(tmp_path), "--json"])
    assert res.exit_code == 0, res.output
    rows = json.loads(res.output)
    assert rows[0]["label"] == "synthetic"
    res = runner.invoke(app, ["probe", "column-budget", str(tmp_path / "none")])
    assert res.exit_code == 2 and "no such file" in res.output
    _archive(tmp_path / "pg.nc", 0.0, drive="pressure_gradient")
    res = runner.invoke(app, ["probe", "column-budget", str(tmp_path / "pg.nc")])
    assert res.exit_code == 2 and "top drive" in res.output


def test_a_window_reads_the_volumes_within_it(tmp_path):
    """Two halves of a uniformly decelerating column close alike; a window holding one volume is
    refused with the reason."""
    _, storage = _archive(tmp_path / "samples.nc", 0.004)
    runner = CliRunner()
    for a, b in ((12.0, 27.0), (27.0, 42.0)):
        res = runner.invoke(app, ["probe", "column-budget", str(tmp_path), "--json",
                                  "--window", str(a), str(b)])
        assert res.exit_code == 0, res.output
        r = json.loads(res.output)[0]
        assert r["window"] == [a, b]
        assert r["storage"] == pytest.approx(storage / US ** 2, rel=1e-9)
        assert r["residual"] == pytest.approx(0.0, abs=2e-3)
    res = runner.invoke(app, ["probe", "column-budget", str(tmp_path), "--window", "12", "13"])
    assert res.exit_code == 2 and "1 volume(s) in the window" in res.output


def test_a_run_still_going_reads_from_its_checkpoint_as_its_archive_will(tmp_path):
    """A smoke saltation run stopped between its second and third volume: the budget read from
    its checkpoint equals the finished archive's over the same two volumes, bit for bit, since a
    resumed run records what an uninterrupted one does."""
    import shutil

    from saltstudy.config import load_case, load_fidelity
    from saltstudy.config.loading import resolve_scene
    from saltstudy.ncio import open_dataset
    from saltstudy.workflow import keys
    from saltstudy.workflow.driver import Interrupted
    from saltstudy.workflow.paths import task_dir
    from saltstudy.workflow.tasks import saltation_task, spinup_task

    scene = resolve_scene(load_case(2), load_fidelity("smoke"))
    a, b = tmp_path / "a", tmp_path / "b"
    sp = spinup_task(scene, a)
    full = saltation_task(scene, sp, a)
    shutil.copytree(sp.parent, b / "spinup" / sp.parent.name)
    with pytest.raises(Interrupted):
        saltation_task(scene, b / "spinup" / sp.parent.name / "spinup.nc", b,
                       interrupt_after_steps=int(open_dataset(full).attrs["n_steps"]) - 3,
                       checkpoint_interval=1e9)
    d = task_dir(b, "saltation", keys.saltation_key(scene, keys.spinup_key(scene)))
    assert not (d / "samples.nc").exists()
    res = CliRunner().invoke(app, ["probe", "column-budget", str(d), "--json"])
    assert res.exit_code == 0, res.output
    live = json.loads(res.output)[0]
    assert live["window"] == [1.0, 1.5] and live["label"] == "case02"
    done = column_budget(full, window=(1.0, 1.5))
    for name in ("u_star_2m", "tau_2m", "M_drive", "storage", "residual", "halves", "z_ref"):
        assert live[name] == done[name], name
    # the 0.5-s blocks the stopped run has completed are the finished run's
    live_blocks = column_budget(d, block_s=0.5)["blocks"]
    assert [b["t0"] for b in live_blocks[:3]] == [0.0, 0.5, 1.0]
    assert live_blocks[:3] == column_budget(full, block_s=0.5)["blocks"][:3]
    (d / "task.json").unlink()
    res = CliRunner().invoke(app, ["probe", "column-budget", str(d)])
    assert res.exit_code == 2 and "no saltation task.json" in res.output
