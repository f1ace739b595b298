"""The advance's lane passes (solver/grains/advance.py): the vectorized passes (branch-free, no libm)
and their exact redos (one lane at a time, libm allowed) compute the same numbers wherever the
vectorized pass keeps a lane, and leave to the exact pass every lane it cannot do; the lane
rows have names of their own."""
from __future__ import annotations

import ast
import collections
from pathlib import Path

import numpy as np

from saltstudy._jit import jit
from saltstudy.solver.grains import drag as D
from saltstudy.solver.grains import layout as LY
from saltstudy.solver.grains import motion as M

L = LY._LANES


@jit
def _passes(lf, li, nb, exact, prm):
    """_lane_start, two drag updates and _lane_move on lanes 0..nb-1, vectorized (exact=False:
    the lanes they leave stay marked _FIX) or all exact."""
    S = LY._Step(prm[0], prm[1], prm[2], prm[3], prm[3] * prm[3], prm[4], prm[5], prm[6],
                 prm[7], prm[8], prm[9], prm[10], True, True, 40)
    fix = np.zeros((4, nb), dtype=np.int64)
    for l in range(nb):
        if exact:
            M._lane_start(lf, li, l, S, True)
        else:
            M._lane_start(lf, li, l, S, False)
    for l in range(nb):
        fix[0, l] = li[LY._FIX + l]
    for it in range(2):
        for l in range(nb):
            if exact:
                D._lane_drag_update(lf, li, l, it, S, it == 0, True)
            elif it == 0:
                D._lane_drag_update(lf, li, l, it, S, True, False)
            else:
                D._lane_drag_update(lf, li, l, it, S, False, False)
        for l in range(nb):
            fix[1 + it, l] = li[LY._FIX + l]
    for l in range(nb):
        li[LY._ITER + l] = 0
        if exact:
            M._lane_move(lf, li, l, S, True)
        else:
            M._lane_move(lf, li, l, S, False)
    for l in range(nb):
        fix[3, l] = li[LY._FIX + l]
    return fix


def _lanes(rng, nb):
    """Lanes as _load_lane leaves them: grains of 60-400 um from the bed to 0.3 m, moving and
    seeing a wind, some without a drag rate (kd = -k0, after a splash) or with a time credit."""
    lf = np.zeros(LY._LANE_ROWS_F * L)
    li = np.zeros(LY._LANE_ROWS_I * L, dtype=np.int64)
    r = np.arange(nb)

    def put(row, v):
        lf[row + r] = v

    put(LY._X, rng.uniform(0, 10, nb))
    put(LY._Y, rng.uniform(0, 7.5, nb))
    put(LY._Z, np.where(rng.random(nb) < 0.3, rng.uniform(6e-4, 3e-3, nb),
                       rng.uniform(3e-3, 0.3, nb)))
    put(LY._U, rng.uniform(0, 5, nb))
    put(LY._V, rng.normal(0, 0.3, nb))
    put(LY._W, rng.normal(-0.5, 1.5, nb))
    d = rng.uniform(60e-6, 400e-6, nb)
    put(LY._D, d)
    put(LY._T, 0.004 + np.where(rng.random(nb) < 0.2, rng.uniform(0, 0.004, nb), 0.0))
    put(LY._US, lf[LY._U + r] + rng.normal(0, 1.0, nb))
    put(LY._VS, rng.normal(0, 0.5, nb))
    put(LY._WS, rng.normal(0, 0.3, nb))
    # the drag rate of the slip (a parcel's kd is its last step's), a few per cent off; some
    # without one (kd = -k0 after a splash)
    slip = np.sqrt((lf[LY._US + r] - lf[LY._U + r]) ** 2 + (lf[LY._VS + r] - lf[LY._V + r]) ** 2
                   + (lf[LY._WS + r] - lf[LY._W + r]) ** 2)
    tp = 2650.0 * d * d / (18 * 1.2 * 1.5e-5)
    k = (1 + 0.15 * (slip * d / 1.5e-5) ** 0.687) / tp * rng.uniform(0.97, 1.03, nb)
    put(LY._KD, np.where(rng.random(nb) < 0.1, -1.0, 1.0) * k)
    put(LY._DZK, rng.choice([0.01, 0.02, 0.05], nb))
    put(LY._EC, rng.uniform(-0.01, 0.2, nb))
    put(LY._TLC, rng.uniform(0.01, 0.1, nb))
    li[LY._ACTIVE + r] = (rng.random(nb) < 0.95).astype(np.int64)
    return lf, li


def test_vectorized_lane_passes_agree_with_the_exact_ones_where_they_keep_a_lane():
    rng = np.random.default_rng(4)
    # dt, g, h_imp, tol, Lx, Ly, Lz, rho, nu, rho_p, Q (layout._Step)
    prm = np.array([0.004, 9.81, 5e-4, 1e-3, 10.0, 7.5, 3.0, 1.2, 1.5e-5, 2650.0, 4800.0])
    kept = 0
    fix_counts = np.zeros(4, dtype=np.int64)
    for _ in range(20):
        lf, li = _lanes(rng, L)
        lf2, li2 = lf.copy(), li.copy()
        fix = _passes(lf, li, L, False, prm)
        _passes(lf2, li2, L, True, prm)
        active = li[LY._ACTIVE:LY._ACTIVE + L] != 0
        fix_counts += fix[:, active].sum(axis=1)
        # a lane every vectorized pass kept: the same numbers as the exact passes
        ok = active & ~fix.any(axis=0)
        kept += ok.sum()
        # the air's impulses are differences of the parcel's momenta: round-off of those
        qm = lf2[LY._QM:LY._QM + L][ok]
        scale = qm * (np.abs(lf2[LY._U:LY._U + L]) + np.abs(lf2[LY._W:LY._W + L])
                      + np.abs(lf2[LY._UN:LY._UN + L]) + np.abs(lf2[LY._WN:LY._WN + L]) + 1.0)[ok]
        for row in range(LY._LANE_ROWS_F):
            a = lf[row * L:(row + 1) * L][ok]
            b = lf2[row * L:(row + 1) * L][ok]
            atol = 1e-14 * scale if row * L in (LY._RU, LY._RV, LY._RW) else 0.0
            assert np.all(np.abs(a - b) <= 1e-14 * np.abs(b) + atol), f"row {row}"
        # every lane without a drag rate or with a hit is left to the exact pass somewhere
        kd = lf2[LY._KD:LY._KD + L]
        assert not (ok & (kd < 0)).any()
        assert not (ok & (li2[LY._HIT:LY._HIT + L] != 0)).any()
    assert kept > 20 * L // 2, fix_counts  # most lanes stay on the vectorized path


def test_lane_rows_and_module_constants_are_bound_once():
    """A lane row named like a parameter index (e.g. the TKE-rate row and prm's TKE switch)
    rebinds it for every kernel of the module: each top-level name of each grain module once."""
    for path in sorted(Path(LY.__file__).parent.glob("*.py")):
        tree = ast.parse(path.read_text())
        names = collections.Counter()
        for node in tree.body:
            if isinstance(node, ast.Assign):
                for target in node.targets:
                    names.update(n.id for n in ast.walk(target) if isinstance(n, ast.Name))
            elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                names[node.name] += 1
            elif isinstance(node, ast.ImportFrom):
                names.update(a.asname or a.name for a in node.names)
        assert [k for k, v in names.items() if v > 1] == [], path.name
