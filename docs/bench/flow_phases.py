"""Where the flow step's time goes: the stepper's pieces timed by wrapping them.

    NUMBA_NUM_THREADS=1 python docs/bench/flow_phases.py [explicit|implicit] [double|single]

Case 1 on the paper fidelity's grid (200 x 150 x 100), advection order 2; two warm-up steps,
then 10 timed steps. Prints ns per cell-step for each piece (docs/BENCHMARKS.md, "Single
precision and the flow's threads").
"""
import collections
import json
import sys
import time

import numba

import saltstudy.solver.flow.stepper as stepper_module
from saltstudy.config import TimeStepping, load_case, load_fidelity, resolve_scene
from saltstudy.solver.model import Model

scheme = sys.argv[1] if len(sys.argv) > 1 else "explicit"
precision = sys.argv[2] if len(sys.argv) > 2 else "double"
fid = load_fidelity("paper")
ts = TimeStepping.model_validate({**fid.time.model_dump(), "advection_order": 2,
                                  "vertical_diffusion": scheme, "precision": precision})
model = Model.from_scene(resolve_scene(load_case(1), fid.model_copy(update={"time": ts})))
spent = collections.defaultdict(float)


def timed(f, label):
    def g(*args, **kwargs):
        t0 = time.perf_counter()
        out = f(*args, **kwargs)
        spent[label] += time.perf_counter() - t0
        return out
    return g


st = model.stepper
for obj, name, label in ((st, "bed_stress_into", "bed stress"), (st.closure, "viscosity", "viscosity"),
                         (st.pressure, "project", "projection")):
    setattr(obj, name, timed(getattr(obj, name), label))
for name, label in (("_momentum_stage", "momentum stage"), ("_tke_stage", "TKE stage"),
                    ("momentum_stage_implicit", "momentum stage"), ("tke_stage_implicit", "TKE stage")):
    setattr(stepper_module, name, timed(getattr(stepper_module, name), label))
for _ in range(2):
    model.step(model.next_dt())
spent.clear()
dt, n = model.next_dt(), 10
for _ in range(n):
    t0 = time.perf_counter()
    model.step(dt)
    spent["whole step"] += time.perf_counter() - t0
per = {k: round(v / n / model.grid.n_cells * 1e9, 1) for k, v in spent.items()}
per["rest"] = round(per["whole step"] - sum(v for k, v in per.items() if k != "whole step"), 1)
print(json.dumps({"threads": numba.get_num_threads(), "vertical_diffusion": scheme,
                  "precision": precision, "ns_per_cell_step": per}))
