"""Benchmark of the grain component: ns per parcel-step on the reduced grid in a frozen flow.

    python -m saltstudy.solver.bench_particles [--json] [--phases] [--steps N] [--n 1e5 --n 1e6]
    saltstudy bench particles ...          (registered by the solver's cli_commands via register_bench)

The flow is a frozen synthetic log-law wind (u*s of case 2) with smooth periodic perturbations of
30% u* in u, v, w; the parcels are spread in the lowest 0.3 m with random velocities, so they
splash, sub-step and couple two-way as in a run. Timing excludes compilation (one warm-up step).

``--phases`` also times each kernel the component calls (the implicit estimate, the parcel
advance, the bed events, the reordering, ...), as ns per parcel-step over the timed steps: where
the time goes, for whoever works on the speed target. The kernels are wrapped for the bench only,
and the solver is left as it was afterwards.
"""
from __future__ import annotations

import json
import math
import time
from contextlib import contextmanager, nullcontext

import numpy as np

__all__ = ["bench_particles", "register_bench"]


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


#: the kernels of Saltation.dynamics timed by --phases (module-level names in solver/particles.py)
PHASE_KERNELS = ("implicit_coefficients", "implicit_corrections", "_advance_all", "splash_runs",
                 "ejecta_reserve", "apply_exchange", "tke_rates", "chunk_assign",
                 "_vmax_and_ztop", "grid_absmax", "_collect_events", "_compact")


@contextmanager
def _timed_kernels(acc: dict, component):
    """Accumulate wall seconds per kernel in ``acc`` while inside (and the parcel reordering,
    ``component._sort``, as "_sort"); restores the originals on exit."""
    from . import particles

    saved = {name: getattr(particles, name) for name in PHASE_KERNELS}

    def timed(name, f):
        def g(*args, **kw):
            t0 = time.perf_counter()
            out = f(*args, **kw)
            acc[name] = acc.get(name, 0.0) + time.perf_counter() - t0
            return out
        return g

    for name, f in saved.items():
        setattr(particles, name, timed(name, f))
    component._sort = timed("_sort", component._sort)
    try:
        yield
    finally:
        for name, f in saved.items():
            setattr(particles, name, f)
        del component._sort


def bench_particles(n_list=(1e5, 1e6), steps: int = 20, as_json: bool = False, dt: float = 0.005,
                    case: int = 2, fidelity: str = "reduced", phases: bool = False) -> dict:
    """Time ``steps`` component steps for each parcel count; print and return
    {"threads": ..., "runs": [{"n_parcels", "ns_per_parcel_step", "mean_ns_per_parcel_step",
    "n_end", "impacts_per_step"}]}. ``ns_per_parcel_step`` is the median step; the mean also
    counts the steps that reorder the parcels (every ``particles.SORT_INTERVAL``-th), which the
    median leaves out: it is the amortized cost of a run. ``phases``: each run also gets
    ``phases_ns_per_parcel_step`` {kernel: ns} and ``steps_ns_per_parcel_step``, the whole steps
    on the same footing (total time over total parcel-steps), which the kernels' sum cannot
    exceed."""
    import numba

    from ..config import load_case, load_fidelity, resolve_scene
    from .grid import Grid
    from .particles import Saltation
    from .state import FlowState

    scene = resolve_scene(load_case(case), load_fidelity(fidelity))
    grid = Grid.from_spec(scene.fidelity.grid)
    runs = []
    for n in n_list:
        n = int(n)
        st = FlowState.zeros(grid)
        _frozen_flow(st, scene.case.forcing.u_star_s, scene.case.surface.z0)
        s = Saltation(grid, scene, capacity=2 * n)
        rng = np.random.default_rng(1)
        s.add_parcels(rng.uniform(0, grid.Lx, n), rng.uniform(0, grid.Ly, n),
                      rng.uniform(1e-3, 0.3, n), u=rng.uniform(0, 4, n), v=rng.normal(0, 0.3, n),
                      w=rng.normal(0, 1, n), d=None)
        s.dynamics(st, dt)  # compile / warm up
        times = []
        imp = 0
        acc: dict = {}
        parcel_steps = 0
        wall = 0.0
        with _timed_kernels(acc, s) if phases else nullcontext():
            for _ in range(steps):
                n0 = max(s.n, 1)
                t0 = time.perf_counter()
                s.dynamics(st, dt)
                t1 = time.perf_counter() - t0
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
    out = {"threads": int(numba.get_num_threads()), "runs": runs}
    if as_json:
        print(json.dumps(out))
    else:
        print(f"grain component, {fidelity} grid {grid.shape}, {out['threads']} numba threads, "
              f"median of {steps} steps, dt = {dt} s")
        for r in runs:
            print(f"  {r['n_parcels']:>9d} parcels: {r['ns_per_parcel_step']:8.1f} ns per parcel-step "
                  f"(mean with the reordering steps {r['mean_ns_per_parcel_step']:.1f}; "
                  f"{r['impacts_per_step']:.0f} impacts/step)")
            if "phases_ns_per_parcel_step" in r:
                print(f"      {'all timed steps':24s} {r['steps_ns_per_parcel_step']:8.1f} ns, of which")
            for k, v in r.get("phases_ns_per_parcel_step", {}).items():
                print(f"      {k:24s} {v:8.1f} ns")
    return out


def register_bench(bench_app) -> None:
    """Add the ``particles`` command to the given typer sub-app (``saltstudy bench particles``)."""
    import typer

    @bench_app.command("particles")
    def particles(n: list[float] = typer.Option([1e5, 1e6], "--n", help="parcel counts"),
                  steps: int = typer.Option(20, "--steps", help="timed steps per count"),
                  as_json: bool = typer.Option(False, "--json", help="one JSON object on stdout"),
                  phases: bool = typer.Option(False, "--phases",
                                              help="also ns per parcel-step of each kernel")) -> None:
        """ns per parcel-step of the grain component on the reduced grid (frozen flow)."""
        bench_particles(tuple(n), steps=steps, as_json=as_json, phases=phases)


if __name__ == "__main__":
    import sys

    args = sys.argv[1:]
    ns = [float(args[i + 1]) for i, a in enumerate(args) if a == "--n"] or [1e5, 1e6]
    st = int(args[args.index("--steps") + 1]) if "--steps" in args else 20
    bench_particles(ns, steps=st, as_json="--json" in args, phases="--phases" in args)
