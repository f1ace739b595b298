"""Benchmark of the flow solver (``saltstudy bench flow``; docs/BENCHMARKS.md): wall time per
full time step of case 1 on a fidelity's grid, ``steps`` steps timed one by one after two warm-up
steps. Reported in ns per cell-step: the median, and the mean beside it (the dynamic closure's
coefficient refresh every ``closure.dynamic_interval`` steps is in the mean only); the *pressure
floor* is three FFT pair + tridiagonal solves (one per RK3 stage), ``ratio`` = step / floor.
``rounds`` > 1 times every variant (closure, advection order, precision, vertical diffusion,
grid) in N rounds, each in a fresh process, the order reversed every other round: one process's
speed drifts by tens of per cent on a shared machine. ``against`` (``--against REV``) times this
checkout against revision REV the same way (``instruments/revision.py``), each side with its own
fidelity file and this checkout's scheme and asked advection order forced on both.
"""
from __future__ import annotations

import importlib
import json
import resource
import statistics
import time

import numba

#: the package this module belongs to (``saltstudy``)
_PACKAGE = __name__.split(".")[0]

#: (label, fidelity providing the grid): the laptop study's grid and the paper's
GRIDS = (("reduced", "reduced"), ("paper", "paper"))


def _times(f, n: int) -> list[float]:
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return ts


def bench_grid(fidelity: str, steps: int = 10, closure: str = "deardorff",
               advection_order: int = 2, precision: str | None = None,
               vertical_diffusion: str | None = None) -> dict:
    """One grid's timing (module doc): case 1 at ``fidelity`` with the closure, the advection
    order and, when given, the precision and the vertical diffusion scheme forced."""
    forced = {k: v for k, v in (("advection_order", advection_order), ("precision", precision),
                                ("vertical_diffusion", vertical_diffusion)) if v is not None}
    m, dt = _side_model(_PACKAGE, fidelity, forced, closure)
    ts_ = _times(lambda: m.step(dt), steps)
    t_p = statistics.median(_times(m.stepper.pressure.solve_rhs_inplace, max(3, steps)))
    n, ts = m.grid.n_cells, m.scene.fidelity.time
    ns_step, floor = statistics.median(ts_) / n * 1e9, 3.0 * t_p / n * 1e9
    m.close()
    return {"shape": list(m.grid.shape), "fidelity": fidelity, "closure": closure,
            "advection_order": advection_order, "precision": ts.precision,
            "vertical_diffusion": ts.vertical_diffusion, "steps": steps,
            "ns_per_cell_step": ns_step, "mean_ns_per_cell_step": statistics.fmean(ts_) / n * 1e9,
            "ms_per_step": ns_step * n * 1e-6, "pressure_floor_ns_per_cell": floor,
            "ratio": ns_step / floor}


def _variants(fidelities, closures, orders, precisions, schemes) -> list[dict]:
    return [{"fidelity": f, "closure": c, "advection_order": o, "precision": p,
             "vertical_diffusion": v}
            for f in fidelities for c in closures for o in orders for p in precisions
            for v in schemes]


def bench_flow(steps: int = 10, big: bool = True, closures=("deardorff",), orders=(2,),
               precisions=(None,), schemes=(None,), fidelities=None, rounds: int = 1) -> dict:
    """{"threads", "grids": [one entry per variant], "max_rss_mb"} (module doc); with rounds, an
    entry's times are medians over the rounds, listed under ``rounds``."""
    fids = list(fidelities) if fidelities else [fid for _, fid in GRIDS if big or fid != "paper"]
    var = _variants(fids, closures, orders, precisions, schemes)
    if rounds <= 1:
        grids = [bench_grid(steps=steps, **v) for v in var]
        rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0   # Linux: kB
        return {"threads": numba.get_num_threads(), "threading_layer": _layer(), "grids": grids,
                "max_rss_mb": rss_mb}
    from .revision import alternate, run_isolated

    per = alternate(rounds, range(len(var)),
                    lambda q: run_isolated(f"{__name__}:side_grid", {"steps": steps, **var[q]}))
    grids = []
    for rs in per.values():
        g = dict(rs[0])
        g.pop("max_rss_mb")
        for key in ("ns_per_cell_step", "mean_ns_per_cell_step", "ms_per_step",
                    "pressure_floor_ns_per_cell"):
            g[key] = statistics.median(x[key] for x in rs)
        g["ratio"] = g["ns_per_cell_step"] / g["pressure_floor_ns_per_cell"]
        g["rounds"] = [x["ns_per_cell_step"] for x in rs]
        grids.append(g)
    return {"threads": numba.get_num_threads(), "threading_layer": per[0][0]["threading_layer"],
            "grids": grids, "max_rss_mb": max(x["max_rss_mb"] for rs in per.values() for x in rs),
            "rounds": rounds}


def side_grid(steps: int, **variant) -> dict:
    """One round of ``bench_flow`` with rounds, in its own process: ``bench_grid`` and the
    process's threading layer and peak memory."""
    out = bench_grid(steps=steps, **variant)
    out["threading_layer"] = _layer()
    out["max_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return out


def _layer() -> str:
    try:
        return numba.threading_layer()
    except ValueError:  # no parallel kernel has run yet
        return "unknown"


def format_report(res: dict) -> str:
    lines = [f"numba threads: {res['threads']} (layer {res['threading_layer']})"]
    for g in res["grids"]:
        nx, ny, nz = g["shape"]
        rounds = (f" over {len(g['rounds'])} rounds "
                  f"({min(g['rounds']):.0f}-{max(g['rounds']):.0f})" if "rounds" in g else "")
        lines.append(f"{nx}x{ny}x{nz} {g['closure']} order {g['advection_order']} "
                     f"{g['precision']} {g['vertical_diffusion']}: "
                     f"{g['ms_per_step']:.1f} ms/step (median of "
                     f"{g['steps']}), {g['ns_per_cell_step']:.0f} ns/cell-step{rounds} (mean "
                     f"{g['mean_ns_per_cell_step']:.0f}); pressure floor (3 x FFT pair + "
                     f"tridiagonal) {g['pressure_floor_ns_per_cell']:.0f} ns/cell; ratio {g['ratio']:.2f}")
    lines.append(f"peak resident memory: {res['max_rss_mb']:.0f} MB")
    return "\n".join(lines)


def _side_model(pkg: str, fidelity: str, numerics: dict, closure: str | None = None):
    """(model, dt): case 1 at ``fidelity`` built by package ``pkg`` with the time options
    ``numerics`` forced, warmed by two steps; a revision without an option must already do what
    is asked (second order, explicit), or the sides would time different work."""
    cfg = importlib.import_module(f"{pkg}.config")
    Model = importlib.import_module(f"{pkg}.solver.model").Model
    fid = cfg.load_fidelity(fidelity)
    fields = type(fid.time).model_fields
    implied = {"advection_order": 2, "vertical_diffusion": "explicit"}
    missing = {k: v for k, v in numerics.items() if k not in fields and v != implied.get(k)}
    if missing:
        raise ValueError(f"revision package {pkg} has no time option for {missing}")
    fid = fid.model_copy(update={"time": fid.time.model_copy(
        update={k: v for k, v in numerics.items() if k in fields})})
    case = cfg.load_case(1, **({"overrides": {"closure": {"model": closure}}} if closure else {}))
    m = Model.from_scene(cfg.resolve_scene(case, fid))
    for _ in range(2):
        m.step(m.next_dt())
    return m, m.next_dt()


def side_flow(pkg: str, fidelity: str, numerics: dict, steps: int) -> dict:
    """One round of one side of ``compare_flow`` (its own process): {"median" ns per cell-step,
    "shape"}."""
    m, dt = _side_model(pkg, fidelity, numerics)
    n = m.grid.n_cells
    t = statistics.median(_times(lambda: m.step(dt), steps)) / n * 1e9
    shape = list(m.grid.shape)
    m.close()
    return {"median": t, "shape": shape}


def compare_flow(against: str, steps: int = 10, rounds: int = 7, big: bool = True,
                 advection_order: int = 2, as_json: bool = False) -> dict:
    """This checkout's LES step against revision ``against``'s (module doc), ns per cell-step."""
    from ..config import load_fidelity
    from .revision import alternate, medians, revision_path, run_isolated

    name, path = revision_path(against)
    sides = {"this": _PACKAGE, "against": name}
    grids = []
    for _, fid in GRIDS:
        if fid == "paper" and not big:
            continue
        numerics = {"advection_order": advection_order,
                    "vertical_diffusion": load_fidelity(fid).time.vertical_diffusion}
        per = alternate(rounds, sides, lambda side: run_isolated(
            f"{__name__}:side_flow", {"pkg": sides[side], "fidelity": fid, "numerics": numerics,
                                     "steps": steps}, [path]))
        grids.append({"fidelity": fid, "shape": per["this"][0]["shape"],
                      "vertical_diffusion": numerics["vertical_diffusion"],
                      **medians(per, "median")})
    out = {"threads": numba.get_num_threads(), "against": against,
           "advection_order": advection_order, "steps": steps, "rounds": rounds, "grids": grids}
    if as_json:
        print(json.dumps(out))
    else:
        print(f"LES step, this checkout against {against}, advection order {advection_order}, "
              f"{out['threads']} numba threads, {rounds} alternating rounds of {steps} steps, "
              f"medians")
        for g in grids:
            nx, ny, nz = g["shape"]
            print(f"  {nx}x{ny}x{nz} ({g['vertical_diffusion']}): {g['this']:6.0f} ns per cell-step here, {g['against']:6.0f} "
                  f"at {against} ({g['this'] / g['against'] - 1:+.1%})")
    return out

