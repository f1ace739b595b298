"""What one scene costs per step, and what a whole run of it would cost: ``saltstudy bench scene``
(docs/BENCHMARKS.md, "Whole runs at the paper's resolution"). Per numba thread count: median wall
time per step of the flow alone and with parcels, extrapolated to the scene's spin-up and
saltation and to N cores by Amdahl's law from the 1 -> 2 thread speed-up (a best case); the flow
is the initial perturbed log law. With ``saltation_seconds`` S each ``--vertical-diffusion``
scheme runs the first S s of the real saltation run from the cached spin-up instead, alternating
over ``rounds`` (separate runs scatter by tens of per cent).
"""
from __future__ import annotations

import json
import resource
import statistics
import time

import numba


def _scene(case: int, fidelity: str, parcels: int | None):
    from ..config import PAPER_AREA_M2, load_case, load_fidelity, resolve_scene
    scene = resolve_scene(load_case(case), load_fidelity(fidelity))
    if parcels:
        g = scene.fidelity.grid
        # n_initial is given per 300 m^2 at the paper's Q: invert Scene.n_initial
        scene = scene.replace(case={"particles": {"n_initial": max(1, int(round(
            parcels * PAPER_AREA_M2 / (g.Lx * g.Ly) * scene.fidelity.q_multiplier)))}})
    return scene


def _time_steps(model, steps: int, warm: int = 3) -> dict:
    for _ in range(warm):
        model.step(model.next_dt())
    wall, dts = [], []
    for _ in range(steps):
        dt = model.next_dt()
        t0 = time.perf_counter()
        model.step(dt)
        wall.append(time.perf_counter() - t0)
        dts.append(dt)
    return {"s_per_step": statistics.median(wall), "s_per_step_mean": statistics.fmean(wall),
            "dt_mean": statistics.fmean(dts), "steps_per_sim_s": 1.0 / statistics.fmean(dts)}


def measure(scene, steps: int, threads: int) -> dict:
    from ..solver.model import Model
    numba.set_num_threads(threads)
    flow = Model.from_scene(scene, saltation=False)
    out = {"threads": threads, "flow": _time_steps(flow, steps)}
    del flow
    if scene.case.physics.saltation:
        m = Model.from_scene(scene, saltation=True)
        m.activate_saltation()
        res = _time_steps(m, steps)
        res["parcels"] = int(m.components[0].n)
        out["grains"] = res
    out["peak_rss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return out


def extrapolate(scene, rows: list[dict], cores: tuple[int, ...] = (2, 8, 32),
                saltation_dt: float | None = None) -> dict:
    """Hours of one run of ``scene`` on each core count; ``saltation_dt`` [s]: a real saltation
    run's mean step, if known (the grain layer makes the diffusion limit stiffer)."""
    by = {r["threads"]: r for r in rows}
    f = scene.fidelity

    def run_s(r: dict) -> dict:
        spin = [t * r["flow"]["steps_per_sim_s"] * r["flow"]["s_per_step"]
                for t in (f.spinup.t_min, f.spinup.t_max)]
        g = r.get("grains") or r["flow"]
        rate = 1.0 / saltation_dt if saltation_dt else g["steps_per_sim_s"]
        salt = f.saltation_duration * rate * g["s_per_step"]
        return {"spinup_s": spin, "saltation_s": salt}

    out: dict = {"measured": {t: run_s(r) for t, r in by.items()}, "saltation_dt": saltation_dt}
    if 1 in by and 2 in by:
        key = "grains" if "grains" in by[1] else "flow"
        s2 = by[1][key]["s_per_step"] / by[2][key]["s_per_step"]
        serial = min(1.0, max(0.0, 2.0 / s2 - 1.0))
        base = run_s(by[1])
        speedups = {n: 1.0 / (serial + (1.0 - serial) / n) for n in cores}
        out.update(speedup_1_to_2=s2, serial_fraction=serial, amdahl={n: {
            "speedup": sp, "saltation_h": base["saltation_s"] / sp / 3600.0,
            "spinup_h": [x / sp / 3600.0 for x in base["spinup_s"]]} for n, sp in speedups.items()})
    return out


def bench_scene(case: int = 2, fidelity: str = "paper", steps: int = 20,
                threads: tuple[int, ...] = (1, 2), parcels: int | None = None,
                as_json: bool = False, saltation_dt: float | None = None,
                vertical_diffusion: str | None = None) -> dict:
    scene = _scene(case, fidelity, parcels)
    if vertical_diffusion:
        scene = _with_scheme(scene, vertical_diffusion)
    g = scene.fidelity.grid
    rows = [measure(scene, steps, t) for t in threads if t <= numba.config.NUMBA_NUM_THREADS]
    res = {"case": case, "fidelity": fidelity, "grid": [g.nx, g.ny, g.nz],
           "cells": g.nx * g.ny * g.nz, "steps": steps, "rows": rows,
           "extrapolation": extrapolate(scene, rows, saltation_dt=saltation_dt)}
    if as_json:
        print(json.dumps(res))
        return res
    print(f"case {case} at fidelity {fidelity}: {g.nx}x{g.ny}x{g.nz} = {res['cells']:,} cells, "
          f"{steps} timed steps (median)")
    for r in rows:
        fl = r["flow"]
        line = (f"  {r['threads']} thread(s): flow {fl['s_per_step']:.3f} s/step, dt {fl['dt_mean'] * 1e3:.2f} ms")
        if "grains" in r:
            gr = r["grains"]
            line += (f"; with {gr['parcels']:,} parcels {gr['s_per_step']:.3f} s/step, "
                     f"dt {gr['dt_mean'] * 1e3:.2f} ms")
        print(line + f"; peak {r['peak_rss_MB']:.0f} MB")
    ex = res["extrapolation"]
    for t, m in ex["measured"].items():
        print(f"  one run on {t} thread(s): spin-up {m['spinup_s'][0] / 3600:.1f}-{m['spinup_s'][1] / 3600:.1f} h, "
              f"saltation {m['saltation_s'] / 3600:.1f} h")
    if "amdahl" in ex:
        print(f"  speed-up 1 -> 2 threads {ex['speedup_1_to_2']:.2f} (serial fraction "
              f"{ex['serial_fraction']:.2f}); Amdahl, best case:")
        for n, e in ex["amdahl"].items():
            print(f"    {n:3d} cores: x{e['speedup']:.1f}, saltation {e['saltation_h']:.1f} h, "
                  f"spin-up {e['spinup_h'][0]:.1f}-{e['spinup_h'][1]:.1f} h")
    return res


def _with_scheme(scene, scheme: str):
    return scene.replace(fidelity={"time": {"vertical_diffusion": scheme}})


def _saltation_seconds(scene, restart: dict, seconds: float, phases: bool = False) -> dict:
    """The first ``seconds`` of ``scene``'s saltation run from ``restart`` (projected first when
    tiled from ``scene.spinup_fidelity``'s spin-up, as the workflow's driver does; ``phases``: the
    grain kernels' ns per parcel-step)."""
    from contextlib import nullcontext

    from .bench_particles import timed_kernels
    from ..solver.model import Model
    from ..solver.simulation import IterationInterval, Simulation
    from ..solver.tiling import project_restart
    from ..analysis.series import limiting_step
    from ..solver.diagnostics.health import step_limits
    m = Model.from_scene(scene, saltation=True, restart=restart)
    if scene.spinup_fidelity is not None:
        project_restart(m)
    m.activate_saltation()
    ts = scene.fidelity.time
    limits: dict[str, int] = {}
    acc: dict = {}
    tally = {"wall": 0.0, "wall_grains": 0.0, "parcel_steps": 0}

    def before_step() -> None:
        tally["limits"] = step_limits(m)
        tally["n0"] = int(m.components[0].n) if m.components else 0

    def after_step(sim) -> None:
        info, lim = sim.last_step, tally["limits"]
        which = limiting_step(lim["dt_courant"], lim["dt_diffusion"], lim["dt_grains"],
                              ts.dt_max, ts.dt_fixed)
        if info.dt < min(v for v in (*lim.values(), ts.dt_max)) * (1 - 1e-9):
            which = "end"           # the last step, cut to land on the end
        limits[which] = limits.get(which, 0) + 1
        tally["wall"] += info.wall_time
        tally["wall_grains"] += info.wall_components
        tally["parcel_steps"] += tally["n0"]
        before_step()

    sim = Simulation(m, stop_time=seconds)
    sim.add_callback("tally", after_step, IterationInterval(1))
    timed = timed_kernels(acc, m.components[0]) if phases and m.components else nullcontext()
    try:
        with timed:
            before_step()
            sim.run()
        steps, wall, wall_grains = sim.n_steps, tally["wall"], tally["wall_grains"]
        parcel_steps = tally["parcel_steps"]
        n = int(m.components[0].n) if m.components else 0
    finally:
        m.close()
    return {"steps": steps, "steps_per_simulated_s": steps / seconds,
            "wall_per_simulated_s": wall / seconds,
            "wall_per_simulated_s_flow": (wall - wall_grains) / seconds,
            "wall_per_simulated_s_grains": wall_grains / seconds,
            "limits": {k: v / steps for k, v in sorted(limits.items())},
            "parcels_at_end": n,
            "ns_per_parcel_step": 1e9 * wall_grains / parcel_steps if parcel_steps else None,
            "phases_ns_per_parcel_step": ({k: v / parcel_steps * 1e9 for k, v in sorted(
                acc.items(), key=lambda kv: -kv[1])} if acc and parcel_steps else None),
            "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0}


def bench_schemes(case: int = 2, fidelity: str = "quick", schemes: tuple[str, ...] = (),
                  saltation_seconds: float = 5.0, rounds: int = 1, out_dir=None,
                  as_json: bool = False, spinup_from: str | None = None,
                  phases: bool = False) -> dict:
    """Each vertical-diffusion scheme over the first ``saltation_seconds`` of the scene's
    saltation run (module doc); medians by scheme under ``"schemes"``. ``spinup_from``: start from
    that fidelity's spin-up tiled onto this grid (solver/tiling.py)."""
    from pathlib import Path

    from ..ncio import open_dataset
    from ..workflow import archives
    from ..workflow.paths import default_out_dir
    from ..workflow.tasks import spinup_task
    from .revision import alternate
    scene = _scene(case, fidelity, None)
    schemes = tuple(schemes) or (scene.fidelity.time.vertical_diffusion,)
    start = "the fidelity's own spin-up"
    if spinup_from:   # as a fidelity with spinup.tiled_from: archives.start_restart tiles it
        scene = scene.model_copy(
            update={"spinup_fidelity": _scene(case, spinup_from, None).fidelity})
        src, dst = scene.spinup_fidelity.grid, scene.fidelity.grid
        start = (f"{spinup_from}'s spin-up ({src.nx}x{src.ny}x{src.nz}) tiled {dst.nx // src.nx}x"
                 f"{dst.ny // src.ny}, interpolated in z below its Rayleigh layer, log law above")
    # the workflow's own spin-up archive (returned at once when the cache holds it)
    sp_path = spinup_task(scene, Path(out_dir) if out_dir else default_out_dir())
    restart = archives.start_restart(open_dataset(sp_path), scene)
    per = alternate(rounds, schemes, lambda name: _saltation_seconds(
        _with_scheme(scene, name), restart, saltation_seconds, phases=phases))
    out = {"case": case, "fidelity": fidelity, "saltation_seconds": saltation_seconds,
           "rounds": rounds, "threads": int(numba.get_num_threads()), "spinup": str(sp_path),
           "start": start, "schemes": {}}
    for name, rows in per.items():
        med = {k: statistics.median(x[k] for x in rows) for k in
               ("steps_per_simulated_s", "wall_per_simulated_s", "wall_per_simulated_s_flow",
                "wall_per_simulated_s_grains")}
        keys = sorted({k for x in rows for k in x["limits"]})
        med["limits"] = {k: statistics.fmean(x["limits"].get(k, 0.0) for x in rows) for k in keys}
        med["peak_rss_MB"] = max(x["peak_rss_MB"] for x in rows)
        nsp = [x["ns_per_parcel_step"] for x in rows if x["ns_per_parcel_step"] is not None]
        med["ns_per_parcel_step"] = statistics.median(nsp) if nsp else None
        med["parcels_at_end"] = statistics.median(x["parcels_at_end"] for x in rows)
        med["phases_ns_per_parcel_step"] = rows[-1]["phases_ns_per_parcel_step"]
        med["rounds"] = rows
        out["schemes"][name] = med
    if as_json:
        print(json.dumps(out))
        return out
    print(f"case {case} at fidelity {fidelity}: the first {saltation_seconds:g} s of saltation from "
          f"the spin-up, {out['threads']} numba thread(s), {rounds} round(s), medians; start: {start}")
    for name, m in out["schemes"].items():
        lim = ", ".join(f"{k} {100 * v:.0f} %" for k, v in m["limits"].items())
        print(f"  {name:9s}: {m['steps_per_simulated_s']:7.1f} steps per simulated s, "
              f"{m['wall_per_simulated_s']:8.2f} s wall per simulated s (flow "
              f"{m['wall_per_simulated_s_flow']:.2f}, grains {m['wall_per_simulated_s_grains']:.2f}); "
              f"step set by: {lim}; {m['parcels_at_end']:,.0f} parcels at the end"
              + (f", {m['ns_per_parcel_step']:.0f} ns per parcel-step" if m["ns_per_parcel_step"] else "")
              + f"; peak {m['peak_rss_MB']:.0f} MB")
        for k, v in (m["phases_ns_per_parcel_step"] or {}).items():
            print(f"      {k:26s} {v:6.1f} ns per parcel-step")
    if len(schemes) == 2:
        a, b = (out["schemes"][k] for k in schemes)
        print(f"  {schemes[0]} / {schemes[1]}: wall x{a['wall_per_simulated_s'] / b['wall_per_simulated_s']:.2f}, "
              f"flow x{a['wall_per_simulated_s_flow'] / b['wall_per_simulated_s_flow']:.2f}, "
              f"steps x{a['steps_per_simulated_s'] / b['steps_per_simulated_s']:.2f}")
    return out


def register_bench_scene(bench_app) -> None:
    import typer

    @bench_app.command("scene")
    def scene_cmd(case: int = typer.Option(2, "--case", help="case number"),
                  fidelity: str = typer.Option("paper", "--fidelity", help="fidelity name"),
                  steps: int = typer.Option(20, "--steps", help="timed steps (median)"),
                  threads: list[int] = typer.Option([1, 2], "--threads", help="numba threads; repeat"),
                  parcels: int = typer.Option(0, "--parcels", help="parcels (0: n_initial)"),
                  saltation_dt: float = typer.Option(0.0, "--saltation-dt", help="a real saltation "
                                                     "run's mean step [s] (0: the measured one)"),
                  vertical_diffusion: list[str] = typer.Option(
                      [], "--vertical-diffusion", help="vertical diffusion scheme (explicit, "
                      "implicit); repeat to compare, alternating (default: the fidelity's)"),
                  saltation_seconds: float = typer.Option(
                      0.0, "--saltation-seconds", help="time this many seconds of the scene's real "
                      "saltation run from its (cached) spin-up instead of extrapolating"),
                  rounds: int = typer.Option(1, "--rounds", help="alternating rounds of the "
                                             "schemes (--saltation-seconds)"),
                  out: str = typer.Option(None, "--out", help="cache holding the spin-up"),
                  spinup_from: str = typer.Option(
                      None, "--spinup-from", help="with --saltation-seconds: this fidelity's "
                      "spin-up tiled onto this grid (e.g. --fidelity paper --spinup-from fine)"),
                  phases: bool = typer.Option(False, "--phases", help="with --saltation-seconds: "
                                              "also the grain kernels' ns per parcel-step"),
                  as_json: bool = typer.Option(False, "--json", help="one JSON object on stdout")) -> None:
        """s per step of one scene (flow, flow + grains), extrapolated to its whole run and to N
        cores; or, with --saltation-seconds, the real cost of each vertical-diffusion scheme."""
        from ..solver.flow.vertical_diffusion import VERTICAL_DIFFUSION
        from ..workflow.cli_commands import fail

        bad = [v for v in vertical_diffusion if v not in VERTICAL_DIFFUSION]
        if bad:
            fail(f"--vertical-diffusion: unknown scheme {bad[0]!r} (known: "
                 f"{', '.join(VERTICAL_DIFFUSION)})")
        if saltation_seconds < 0 or rounds < 1:
            fail("--saltation-seconds must be positive and --rounds at least 1")
        if saltation_seconds > 0:
            from pathlib import Path
            bench_schemes(case, fidelity, tuple(vertical_diffusion), saltation_seconds, rounds,
                          Path(out) if out else None, as_json, spinup_from, phases)
            return
        for flag, given in (("--spinup-from", spinup_from), ("--phases", phases)):
            if given:
                fail(f"{flag}: needs --saltation-seconds")
        if len(vertical_diffusion) > 1:
            fail("--vertical-diffusion: comparing schemes needs --saltation-seconds")
        if steps < 1:
            fail("--steps: must be at least 1")
        if saltation_dt < 0:
            fail("--saltation-dt: must be positive (or 0 for the measured step)")
        bench_scene(case, fidelity, steps, tuple(threads), parcels or None, as_json,
                    saltation_dt or None,
                    vertical_diffusion[0] if vertical_diffusion else None)

