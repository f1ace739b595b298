"""Benchmark of the grain component: ns per parcel-step on the reduced grid in a frozen flow
(``saltstudy bench particles``; docs/BENCHMARKS.md).

The flow is a frozen log-law wind (u*s of case 2) with 30% u* periodic perturbations; the parcels
start in the lowest 0.3 m with random velocities, so they splash, sub-step and couple as in a run.
``--phases`` times each kernel (particles.StepKernels) per parcel-step; ``--against REV`` alternates
rounds with revision REV in fresh processes (instruments/revision.py); ``--cpu-time`` times the
main thread's CPU time (with ``NUMBA_NUM_THREADS=1``: other jobs' load hardly moves it).
"""
from __future__ import annotations

import importlib
import json
import math
import time
from contextlib import contextmanager, nullcontext

import numpy as np

from .revision import RevisionError, alternate, medians, revision_path, run_isolated

#: the package this module belongs to (``saltstudy``)
_PACKAGE = __name__.split(".")[0]


def _frozen_flow(st, u_star: float, z0: float) -> None:
    g = st.grid
    kx, ky = 2 * math.pi / g.Lx, 2 * math.pi / g.Ly
    X, Xc = g.x_f[:, None, None], g.x_c[:, None, None]
    Y, Yf = g.y_c[None, :, None], g.y_f[None, :, None]
    zc, zf = g.z_c[None, None, :], g.z_f[None, None, :]
    a = 0.3 * u_star
    st.u[...] = u_star / 0.4 * np.log(zc / z0) + a * np.sin(3 * kx * X) * np.cos(5 * ky * Y)
    st.v[...] = a * np.sin(2 * kx * Xc) * np.sin(3 * ky * Yf) + 0.0 * zc
    st.w[...] = a * np.cos(4 * kx * Xc) * np.sin(2 * ky * Y) * np.tanh(zf / 0.05)
    st.w[..., 0] = st.w[..., -1] = 0.0
    st.e[...] = 0.5 * u_star ** 2


def _first_module(*names: str):
    """The first of ``names`` that imports (ModuleNotFoundError if none does)."""
    for name in names[:-1]:
        try:
            return importlib.import_module(name)
        except ModuleNotFoundError:
            continue
    return importlib.import_module(names[-1])


def _component(pkg: str, n: int, dt: float, case: int, fidelity: str):
    """A warmed-up grain component of package ``pkg`` with the bench's flow and parcels."""
    cfg = importlib.import_module(pkg + ".config")
    G = importlib.import_module(pkg + ".solver.grid")
    # a revision from before the solver was laid out by process keeps particles.py at the top
    P = _first_module(pkg + ".solver.grains.particles", pkg + ".solver.particles")
    S = importlib.import_module(pkg + ".solver.state")
    scene = cfg.resolve_scene(cfg.load_case(case), cfg.load_fidelity(fidelity))
    grid = G.Grid.from_spec(scene.fidelity.grid)
    st = S.FlowState.zeros(grid)
    _frozen_flow(st, scene.case.forcing.u_star_s, scene.case.surface.z0)
    s = P.Saltation(grid, scene, capacity=2 * n)
    rng = np.random.default_rng(1)
    s.add_parcels(rng.uniform(0, grid.Lx, n), rng.uniform(0, grid.Ly, n),
                  rng.uniform(1e-3, 0.3, n), u=rng.uniform(0, 4, n), v=rng.normal(0, 0.3, n),
                  w=rng.normal(0, 1, n), d=None)
    s.dynamics(st, dt)  # compile / warm up
    return s, st


def _emit(out: dict, as_json: bool, lines) -> None:
    print(json.dumps(out) if as_json else "\n".join(lines))


#: the bench's clock: wall time, or with ``--cpu-time`` the main thread's (time.thread_time)
_clock = time.perf_counter

@contextmanager
def timed_kernels(acc: dict, component):
    """Accumulate seconds per kernel of the grain component's step in ``acc`` while inside (each
    of particles.StepKernels wrapped in a timer)."""
    saved = component.kernels

    def timed(name, f):
        def g(*args):
            t0 = _clock()
            out = f(*args)
            acc[name] = acc.get(name, 0.0) + _clock() - t0
            return out
        return g

    component.kernels = type(saved)(*(timed(name, f) for name, f in saved._asdict().items()))
    try:
        yield
    finally:
        component.kernels = saved


def bench_particles(n_list=(1e5, 1e6), steps: int = 20, as_json: bool = False, dt: float = 0.005,
                    case: int = 2, fidelity: str = "reduced", phases: bool = False) -> dict:
    """Time ``steps`` component steps per parcel count: the median step's ns per parcel-step, and
    the mean, which includes the reordering steps (the amortized cost of a run). ``phases``: also
    ns per parcel-step per kernel and of all timed steps, which the kernels' sum cannot exceed."""
    import numba

    runs = []
    for n in map(int, n_list):
        s, st = _component(_PACKAGE, n, dt, case, fidelity)
        times, acc, imp, parcel_steps, wall = [], {}, 0, 0, 0.0
        with timed_kernels(acc, s) if phases else nullcontext():
            for _ in range(steps):
                n0 = max(s.n, 1)
                t0 = _clock()
                s.dynamics(st, dt)
                t1 = _clock() - t0
                times.append(t1 / n0 * 1e9)
                wall += t1
                imp += s.last_step["n_impacts"]
                parcel_steps += n0
        run = {"n_parcels": n, "ns_per_parcel_step": float(np.median(times)),
               "mean_ns_per_parcel_step": float(np.mean(times)),
               "n_end": int(s.n), "impacts_per_step": imp / steps}
        if phases:
            # per parcel-step of all the timed steps together (the kernels' shares of it)
            run["steps_ns_per_parcel_step"] = wall / parcel_steps * 1e9
            run["phases_ns_per_parcel_step"] = {k: v / parcel_steps * 1e9 for k, v in
                                                sorted(acc.items(), key=lambda kv: -kv[1])}
        runs.append(run)
    out = {"threads": int(numba.get_num_threads()), "fidelity": fidelity,
           "grid": list(st.grid.shape), "runs": runs}

    def text():
        yield (f"grain component, {fidelity} grid {st.grid.shape}, {out['threads']} numba "
               f"threads, median of {steps} steps, dt = {dt} s")
        for r in runs:
            yield (f"  {r['n_parcels']:>9d} parcels: {r['ns_per_parcel_step']:8.1f} ns per "
                   f"parcel-step (mean with the reordering steps "
                   f"{r['mean_ns_per_parcel_step']:.1f}; {r['impacts_per_step']:.0f} impacts/step)")
            if "phases_ns_per_parcel_step" in r:
                yield (f"      {'all timed steps':24s} {r['steps_ns_per_parcel_step']:8.1f} ns, "
                       "of which")
            for k, v in r.get("phases_ns_per_parcel_step", {}).items():
                yield f"      {k:24s} {v:8.1f} ns"

    _emit(out, as_json, text())
    return out


def side_median(pkg: str, n: int, steps: int, dt: float, case: int, fidelity: str,
                cpu_time: bool = False) -> float:
    """One round of one side of ``compare_particles`` (in its own process): the median step of
    package ``pkg``'s component, ns per parcel-step."""
    clock = time.thread_time if cpu_time else time.perf_counter
    s, st = _component(pkg, n, dt, case, fidelity)
    times = []
    for _ in range(steps):
        n0 = max(s.n, 1)
        t0 = clock()
        s.dynamics(st, dt)
        times.append((clock() - t0) / n0 * 1e9)
    return float(np.median(times))


def compare_particles(against: str, n_list=(1e5, 1e6), steps: int = 12, rounds: int = 7,
                      as_json: bool = False, dt: float = 0.005, case: int = 2,
                      fidelity: str = "reduced") -> dict:
    """This checkout against revision ``against``, per parcel count: the median over rounds of
    each side's median step [ns per parcel-step], every round in a fresh process."""
    import numba

    name, path = revision_path(against)
    sides = {"this": _PACKAGE, "against": name}
    runs = []
    for n in map(int, n_list):
        per = alternate(rounds, sides, lambda side: run_isolated(
            f"{__name__}:side_median", {"pkg": sides[side], "n": n, "steps": steps, "dt": dt,
                                       "case": case, "fidelity": fidelity,
                                       "cpu_time": _clock is time.thread_time}, [path]))
        runs.append({"n_parcels": n, **medians(per)})
    out = {"threads": int(numba.get_num_threads()), "against": against, "runs": runs}

    def text():
        yield (f"grain component, this checkout against {against}, {out['threads']} numba "
               f"threads, {rounds} alternating rounds of {steps} steps, medians")
        for r in runs:
            yield (f"  {r['n_parcels']:>9d} parcels: {r['this']:8.1f} ns per parcel-step here, "
                   f"{r['against']:8.1f} at {against} ({r['this'] / r['against'] - 1:+.1%})")

    _emit(out, as_json, text())
    return out


def register_bench(bench_app) -> None:
    import typer

    @bench_app.command("particles")
    def particles(n: list[float] = typer.Option([1e5, 1e6], "--n", help="parcel counts"),
                  steps: int = typer.Option(20, "--steps", help="timed steps per count"),
                  as_json: bool = typer.Option(False, "--json", help="one JSON object on stdout"),
                  phases: bool = typer.Option(False, "--phases",
                                              help="also ns per parcel-step of each kernel"),
                  against: str = typer.Option(None, "--against", help="git revision to time "
                                              "this checkout against, alternating rounds, each in "
                                              "its own process"),
                  rounds: int = typer.Option(7, "--rounds", help="alternating rounds (--against)"),
                  cpu_time: bool = typer.Option(False, "--cpu-time", help="time the main "
                                                "thread's CPU time (with NUMBA_NUM_THREADS=1: "
                                                "the code's work, whatever else runs)"),
                  fidelity: str = typer.Option("reduced", "--fidelity", help="whose grid the "
                                               "frozen flow fills (e.g. fine: the paper's spacing)")
                  ) -> None:
        """ns per parcel-step of the grain component on a fidelity's grid (frozen flow)."""
        from ..config import load_fidelity
        try:
            load_fidelity(fidelity)
        except (FileNotFoundError, ValueError) as e:
            raise typer.BadParameter(str(e), param_hint="--fidelity") from e
        global _clock
        _clock = time.thread_time if cpu_time else time.perf_counter
        if against:
            try:
                compare_particles(against, tuple(n), steps=steps, rounds=rounds, as_json=as_json,
                                  fidelity=fidelity)
            except RevisionError as e:
                raise typer.BadParameter(str(e), param_hint="--against") from e
        else:
            bench_particles(tuple(n), steps=steps, as_json=as_json, phases=phases,
                            fidelity=fidelity)

