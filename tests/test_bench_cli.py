"""`saltstudy bench flow|particles --json`: the fields a benchmark reports, from real (short) runs.

Timings are not asserted (a noisy machine would make that flaky); the structure and the sanity
of the numbers are.
"""
from __future__ import annotations

import json
import time

import pytest
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.config import load_fidelity


def _json(args):
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout.strip().splitlines()[-1])


def test_bench_flow_json_has_the_grids_fields():
    out = _json(["bench", "flow", "--steps", "2", "--no-big", "--json"])
    assert out["threads"] >= 1 and out["max_rss_mb"] > 0
    (g,) = out["grids"]
    grid = load_fidelity("reduced").grid       # the bench times the laptop study's grid
    assert g["shape"] == [grid.nx, grid.ny, grid.nz]
    assert g["ns_per_cell_step"] > 0 and g["pressure_floor_ns_per_cell"] > 0
    assert g["ratio"] == pytest.approx(g["ns_per_cell_step"] / g["pressure_floor_ns_per_cell"],
                                       rel=1e-12)
    assert g["closure"] == "deardorff" and g["mean_ns_per_cell_step"] > 0


def test_bench_flow_compares_closures_and_rejects_an_unknown_one():
    out = _json(["bench", "flow", "--steps", "5", "--no-big", "--json", "--closure", "deardorff",
                 "--closure", "dynamic"])
    assert [g["closure"] for g in out["grids"]] == ["deardorff", "dynamic"]
    res = CliRunner().invoke(app, ["bench", "flow", "--closure", "smagorinsky", "--no-big"])
    assert res.exit_code == 2 and "--closure" in res.output


def test_bench_flow_compares_advection_orders_and_rejects_an_unknown_one():
    out = _json(["bench", "flow", "--steps", "2", "--no-big", "--json", "--advection-order", "2",
                 "--advection-order", "4"])
    assert [g["advection_order"] for g in out["grids"]] == [2, 4]
    assert all(g["ns_per_cell_step"] > 0 for g in out["grids"])
    res = CliRunner().invoke(app, ["bench", "flow", "--advection-order", "3", "--no-big"])
    assert res.exit_code == 2 and "--advection-order" in res.output


@pytest.mark.slow   # compiles a second copy of every flow kernel (~2 min on 2 cores)
def test_bench_flow_against_a_revision_times_each_side_in_its_own_process():
    """--against HEAD on the reduced grid: both sides step the same grid, every round each, each
    round in a fresh process (the revision's package is never imported here)."""
    out = _json(["bench", "flow", "--against", "HEAD", "--no-big", "--steps", "2", "--rounds",
                 "2", "--json"])
    assert out["against"] == "HEAD" and out["advection_order"] == 2
    (g,) = out["grids"]
    grid = load_fidelity("reduced").grid
    assert g["shape"] == [grid.nx, grid.ny, grid.nz]
    assert g["vertical_diffusion"] == load_fidelity("reduced").time.vertical_diffusion
    assert len(g["this_rounds"]) == len(g["against_rounds"]) == 2
    assert g["this"] > 0 and g["against"] > 0
    import sys
    assert not any(m.startswith("saltstudy_") for m in sys.modules)


def test_bench_flow_against_an_unknown_revision_or_two_orders_is_a_clear_error():
    res = CliRunner().invoke(app, ["bench", "flow", "--against", "no-such-rev", "--no-big"])
    assert res.exit_code != 0
    assert "--against" in res.output and "no-such-rev" in res.output
    res = CliRunner().invoke(app, ["bench", "flow", "--against", "HEAD", "--no-big",
                                   "--advection-order", "2", "--advection-order", "4"])
    assert res.exit_code == 2 and "--against" in res.output


def test_bench_particles_json_has_the_runs_fields():
    out = _json(["bench", "particles", "--n", "2000", "--n", "4000", "--steps", "3", "--json"])
    assert [r["n_parcels"] for r in out["runs"]] == [2000, 4000]
    for r in out["runs"]:
        assert r["ns_per_parcel_step"] > 0 and r["mean_ns_per_parcel_step"] > 0
        assert r["n_end"] > 0 and r["impacts_per_step"] >= 0


def test_bench_particles_cpu_time_clock_is_set_per_invocation():
    from saltstudy.instruments import bench_particles

    out = _json(["bench", "particles", "--n", "2000", "--steps", "3", "--cpu-time", "--json"])
    assert out["runs"][0]["ns_per_parcel_step"] > 0
    assert bench_particles._clock is time.thread_time
    _json(["bench", "particles", "--n", "2000", "--steps", "3", "--json"])
    assert bench_particles._clock is time.perf_counter


def test_bench_particles_fills_the_grid_of_the_fidelity_asked_and_names_a_bad_one():
    out = _json(["bench", "particles", "--n", "2000", "--steps", "2", "--fidelity", "fine",
                 "--json"])
    g = load_fidelity("fine").grid
    assert out["fidelity"] == "fine" and out["grid"] == [g.nx, g.ny, g.nz]
    assert out["runs"][0]["ns_per_parcel_step"] > 0
    res = CliRunner().invoke(app, ["bench", "particles", "--fidelity", "no-such", "--n", "10"])
    assert res.exit_code != 0 and "--fidelity" in res.output


def test_bench_particles_phases_sum_within_the_step_and_leave_the_solver_as_it_was():
    from saltstudy.solver.grains import particles

    def names():
        return {k: v for k, v in vars(particles).items() if not k.startswith("__")}

    before = names()
    out = _json(["bench", "particles", "--n", "3000", "--steps", "12", "--phases", "--json"])
    (r,) = out["runs"]
    ph = r["phases_ns_per_parcel_step"]
    # over 12 steps the advance and the implicit estimate (two-way) run every step, the
    # reordering once (every particles.SORT_INTERVAL = 10 steps)
    assert {"advance_all", "implicit_coefficients", "cell_order", "gather"} <= set(ph)
    assert set(ph) <= set(particles.StepKernels._fields)
    assert all(v > 0 for v in ph.values())
    # the kernels are timed inside the timed steps: together they cannot exceed the step
    assert sum(ph.values()) <= r["steps_ns_per_parcel_step"] * (1 + 1e-9)
    assert names() == before


def test_timed_kernels_hands_the_component_its_own_kernels_back():
    """bench_particles.timed_kernels times a component's kernels through its ``kernels`` record:
    inside, each is a timer around the component's own; after, the record is the one it had."""
    from test_particles_helpers import component, scene

    from saltstudy.instruments.bench_particles import timed_kernels
    from saltstudy.solver.grains import particles

    s, _ = component(scene(2))
    assert s.kernels is particles.KERNELS
    acc = {}
    with timed_kernels(acc, s):
        assert s.kernels != particles.KERNELS
        assert s.kernels.collect_events(0, s._flag, s._ev) == 0
    assert s.kernels is particles.KERNELS
    assert list(acc) == ["collect_events"] and acc["collect_events"] >= 0.0


@pytest.mark.slow   # compiles a second copy of every grain kernel (~1.5 min on 2 cores)
def test_bench_particles_against_a_revision_times_each_side_in_its_own_process():
    """--against HEAD: the revision's package is extracted from git and timed alternately with
    this checkout's; both sides get every round, each round in a fresh process (the revision's
    package is never imported here)."""
    out = _json(["bench", "particles", "--against", "HEAD", "--n", "2000", "--steps", "2",
                 "--rounds", "2", "--json"])
    assert out["against"] == "HEAD"
    (r,) = out["runs"]
    assert r["n_parcels"] == 2000
    assert len(r["this_rounds"]) == len(r["against_rounds"]) == 2
    assert r["this"] > 0 and r["against"] > 0
    import sys
    assert not any(m.startswith("saltstudy_") for m in sys.modules)


def test_bench_particles_against_an_unknown_revision_is_a_clear_error():
    res = CliRunner().invoke(app, ["bench", "particles", "--against", "no-such-rev", "--n", "100"])
    assert res.exit_code != 0
    assert "--against" in res.output and "no-such-rev" in res.output


def test_bench_scene_json_has_the_costs_and_an_extrapolation():
    out = _json(["bench", "scene", "--case", "2", "--fidelity", "smoke", "--steps", "3",
                 "--threads", "1", "--parcels", "3000", "--json"])
    assert out["grid"] == [16, 12, 16] and out["cells"] == 16 * 12 * 16
    (row,) = out["rows"]
    assert row["threads"] == 1 and row["peak_rss_MB"] > 0
    for part in ("flow", "grains"):
        assert row[part]["s_per_step"] > 0 and 0 < row[part]["dt_mean"] <= 0.02
        assert row[part]["steps_per_sim_s"] == pytest.approx(1.0 / row[part]["dt_mean"])
    # the release is the requested count (rounded through n_initial per 300 m^2), less what
    # deposited in the few steps
    assert 2000 <= row["grains"]["parcels"] <= 3100
    m = out["extrapolation"]["measured"]["1"]
    assert m["saltation_s"] > 0 and m["spinup_s"][0] <= m["spinup_s"][1]
    slow = _json(["bench", "scene", "--case", "2", "--fidelity", "smoke", "--steps", "2",
                  "--threads", "1", "--saltation-dt", "0.001", "--json"])
    # a step 1 ms long costs the saltation 1 / (0.001 steps_per_sim_s) times more steps
    g = slow["rows"][0]["grains"]
    sm = slow["extrapolation"]["measured"]["1"]["saltation_s"]
    assert sm == pytest.approx(2.0 / 0.001 * g["s_per_step"])      # smoke: 2 s of saltation
    res = CliRunner().invoke(app, ["bench", "scene", "--steps", "0"])
    assert res.exit_code == 2 and "--steps" in res.output


def test_bench_scene_saltation_phases_time_the_grain_kernels_inside_a_real_run(tmp_path):
    """--saltation-seconds --phases: the grain kernels timed inside the scene's own saltation
    start (smoke grid, 0.1 s), on the same footing as the grains' wall per parcel-step."""
    out = _json(["bench", "scene", "--case", "2", "--fidelity", "smoke", "--saltation-seconds",
                 "0.1", "--phases", "--out", str(tmp_path), "--json"])
    (m,) = out["schemes"].values()
    ph = m["phases_ns_per_parcel_step"]
    assert {"advance_all", "implicit_coefficients"} <= set(ph)
    (r,) = m["rounds"]
    assert sum(ph.values()) <= r["ns_per_parcel_step"] * (1 + 1e-9)
    assert out["start"] == "the fidelity's own spin-up"
    res = CliRunner().invoke(app, ["bench", "scene", "--phases"])
    assert res.exit_code == 2 and "--saltation-seconds" in res.output
