"""Benchmark of the flow solver: wall time per full time step on the reduced and the paper grid.

For each grid the model is built from case 1 at the named fidelity (only the grid matters), spun a
couple of steps to compile the kernels and leave the initial state, then ``steps`` steps are timed
one by one; the median is reported as ns per cell-step (wall time / (nx ny nz)), and the mean beside
it (the dynamic closure refreshes its coefficient every ``closure.dynamic_interval`` steps, a cost
the median leaves out and the mean over a multiple of that interval includes). ``closures`` runs
the same grids with each SGS closure in turn (``--closure``, repeated), and ``orders`` with each
horizontal advection order (``--advection-order 2 --advection-order 4``: the fidelity's
``time.advection_order``, which sets the projection's order too), in one process. The *pressure
floor* is the median time of the FFT pair + tridiagonal solve alone (``PressureSolver.solve_rhs_inplace``),
three per step (one per RK3 stage), in the same units; ``ratio`` = step / floor says how far the whole
step is above that irreducible cost. Peak resident memory (ru_maxrss) is reported after the largest grid.
``precisions`` (``--precision single --precision double``: the fidelity's ``time.precision``) and
``schemes`` (``--vertical-diffusion``) likewise; ``fidelities`` (``--fidelity``) picks the grids.
With ``rounds`` > 1 (``--rounds N`` without ``--against``) every configuration is timed in N
rounds, each in a fresh process, alternating between the configurations (the order reversed every
other round), and the median over the rounds is reported: one process's speed drifts by tens of
per cent on a shared machine (docs/BENCHMARKS.md).

``against`` (``--against REV``) times this checkout's step against git revision REV's on the same
grids (``instruments/revision.py``): each side builds its own model from its own fidelity file,
with this checkout's vertical diffusion scheme for that grid and the advection order asked for
forced on both (what the step's work depends on), warmed, then ``rounds`` rounds of ``steps``
steps alternate between them, the order flipped every round, each round of each side in a fresh
process that builds that side alone (revision.py says why).
Reported per grid: the median over rounds of each side's median step, ns per cell-step.
"""
from __future__ import annotations

import importlib
import json
import resource
import statistics
import time

import numba

__all__ = ["bench_flow", "bench_grid", "side_grid", "compare_flow", "GRIDS"]

#: the package this module belongs to (``saltstudy``)
_PACKAGE = (__package__ or __name__).split(".")[0]

#: (label, fidelity providing the grid): the laptop study's grid and the paper's
GRIDS = (("reduced", "reduced"), ("paper", "paper"))


def _times(f, n: int) -> list[float]:
    ts = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        ts.append(time.perf_counter() - t0)
    return ts


def _median_time(f, n: int) -> float:
    return statistics.median(_times(f, n))


def bench_grid(fidelity: str, steps: int = 10, closure: str = "deardorff",
               advection_order: int = 2, precision: str | None = None,
               vertical_diffusion: str | None = None) -> dict:
    """One grid's timing (module doc): case 1 at ``fidelity`` with the closure, the advection
    order and, when given, the precision and the vertical diffusion scheme forced (None: the
    fidelity's)."""
    from ..config import TimeStepping, load_case, load_fidelity, resolve_scene
    from ..solver.model import Model

    fid = load_fidelity(fidelity)
    forced = {"advection_order": advection_order}
    if precision is not None:
        forced["precision"] = precision
    if vertical_diffusion is not None:
        forced["vertical_diffusion"] = vertical_diffusion
    ts = TimeStepping.model_validate({**fid.time.model_dump(), **forced})
    scene = resolve_scene(load_case(1, overrides={"closure": {"model": closure}}),
                          fid.model_copy(update={"time": ts}))
    m = Model.from_scene(scene)
    for _ in range(2):
        m.step(m.next_dt())
    dt = m.next_dt()
    ts_ = _times(lambda: m.step(dt), steps)
    t_step = statistics.median(ts_)
    ps = m.stepper.pressure
    t_p = _median_time(ps.solve_rhs_inplace, max(3, steps))
    n = m.grid.n_cells
    ns_step = t_step / n * 1e9
    floor = 3.0 * t_p / n * 1e9
    m.close()
    return {"shape": list(m.grid.shape), "fidelity": fidelity, "closure": closure,
            "advection_order": advection_order, "precision": ts.precision,
            "vertical_diffusion": ts.vertical_diffusion, "steps": steps,
            "ns_per_cell_step": ns_step, "mean_ns_per_cell_step": statistics.fmean(ts_) / n * 1e9,
            "ms_per_step": t_step * 1e3, "pressure_floor_ns_per_cell": floor, "ratio": ns_step / floor}


def _variants(fidelities, closures, orders, precisions, schemes) -> list[dict]:
    return [{"fidelity": f, "closure": c, "advection_order": o, "precision": p,
             "vertical_diffusion": v}
            for f in fidelities for c in closures for o in orders for p in precisions
            for v in schemes]


def bench_flow(steps: int = 10, big: bool = True, closures=("deardorff",), orders=(2,),
               precisions=(None,), schemes=(None,), fidelities=None, rounds: int = 1) -> dict:
    """Run the benchmark; returns {"threads", "grids": [...], "max_rss_mb"} (one entry of grids
    per grid, closure, advection order, precision and vertical diffusion scheme; None: the
    fidelity's). ``fidelities``: the grids (default: the reduced and, with ``big``, the paper's).
    With ``rounds`` > 1 every variant is timed in ``rounds`` rounds, each in a fresh process, the
    variants' order reversed every other round; an entry then reports the median over the rounds
    (``ns_per_cell_step``) and the rounds (``rounds``), and max_rss_mb is the largest round's."""
    fids = list(fidelities) if fidelities else [fid for _, fid in GRIDS if big or fid != "paper"]
    var = _variants(fids, closures, orders, precisions, schemes)
    if rounds <= 1:
        grids = [bench_grid(steps=steps, **v) for v in var]
        rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0   # Linux: kB
        return {"threads": numba.get_num_threads(), "threading_layer": _layer(), "grids": grids,
                "max_rss_mb": rss_mb}
    from .revision import run_isolated

    per = [[] for _ in var]
    rss = []
    for r in range(rounds):
        order = range(len(var)) if r % 2 == 0 else reversed(range(len(var)))
        for q in order:
            res = run_isolated(f"{__name__}:side_grid", {"steps": steps, **var[q]})
            per[q].append(res)
            rss.append(res["max_rss_mb"])
    grids = []
    for v, rs in zip(var, per):
        g = dict(rs[0])
        g.pop("max_rss_mb")
        for key in ("ns_per_cell_step", "mean_ns_per_cell_step", "ms_per_step",
                    "pressure_floor_ns_per_cell"):
            g[key] = statistics.median(x[key] for x in rs)
        g["ratio"] = g["ns_per_cell_step"] / g["pressure_floor_ns_per_cell"]
        g["rounds"] = [x["ns_per_cell_step"] for x in rs]
        grids.append(g)
    return {"threads": numba.get_num_threads(), "threading_layer": per[0][0]["threading_layer"],
            "grids": grids, "max_rss_mb": max(rss), "rounds": rounds}


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


def _side_model(pkg: str, fidelity: str, numerics: dict):
    """Case 1's model at ``fidelity`` built by package ``pkg`` (this checkout's or a revision's)
    with the time-stepping ``numerics`` (e.g. the advection order and the vertical diffusion
    scheme, which set the step's work) forced, warmed by two steps; returns (model, dt). A
    revision without one of those options must already do what is asked (second-order,
    explicit), or the two sides would time different work."""
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
    m = Model.from_scene(cfg.resolve_scene(cfg.load_case(1), fid))
    for _ in range(2):
        m.step(m.next_dt())
    return m, m.next_dt()


def side_flow(pkg: str, fidelity: str, numerics: dict, steps: int) -> dict:
    """One round of one side of ``compare_flow``, run in its own process: package ``pkg``'s model
    (``_side_model``), ``steps`` steps timed. Returns {"median": ns per cell-step, "shape"}."""
    m, dt = _side_model(pkg, fidelity, numerics)
    n = m.grid.n_cells
    t = statistics.median(_times(lambda: m.step(dt), steps)) / n * 1e9
    shape = list(m.grid.shape)
    m.close()
    return {"median": t, "shape": shape}


def compare_flow(against: str, steps: int = 10, rounds: int = 7, big: bool = True,
                 advection_order: int = 2, as_json: bool = False) -> dict:
    """This checkout's LES step against revision ``against``'s (module doc), every round of every
    side in a fresh process (revision.run_isolated). Returns {"threads", "against",
    "advection_order", "grids": [{"fidelity", "shape", "this", "against", "this_rounds",
    "against_rounds"}]}, times in ns per cell-step."""
    from .revision import revision_path, run_isolated

    name, path = revision_path(against)
    sides = {"this": _PACKAGE, "against": name}
    grids = []
    for _, fid in GRIDS:
        if fid == "paper" and not big:
            continue
        from ..config import load_fidelity
        numerics = {"advection_order": advection_order,
                    "vertical_diffusion": load_fidelity(fid).time.vertical_diffusion}
        per = {k: [] for k in sides}
        shape = None
        for r in range(rounds):
            for side in (("this", "against") if r % 2 == 0 else ("against", "this")):
                res = run_isolated(f"{__name__}:side_flow", {"pkg": sides[side], "fidelity": fid,
                                   "numerics": numerics, "steps": steps}, [path])
                per[side].append(res["median"])
                shape = shape or res["shape"]
        grids.append({"fidelity": fid, "shape": shape,
                      "vertical_diffusion": numerics["vertical_diffusion"],
                      "this": statistics.median(per["this"]),
                      "against": statistics.median(per["against"]),
                      "this_rounds": per["this"], "against_rounds": per["against"]})
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


def main(steps: int = 10, big: bool = True, as_json: bool = False, closures=("deardorff",),
         orders=(2,), precisions=(None,), schemes=(None,), fidelities=None, rounds: int = 1) -> None:
    res = bench_flow(steps, big, tuple(closures), tuple(orders), tuple(precisions),
                     tuple(schemes), fidelities, rounds)
    print(json.dumps(res) if as_json else format_report(res))


if __name__ == "__main__":
    import sys
    main(steps=int(sys.argv[1]) if len(sys.argv) > 1 else 10, big="--no-big" not in sys.argv,
         as_json="--json" in sys.argv)
