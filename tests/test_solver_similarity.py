"""Reynolds-number similarity: one particle-free spin-up serves every u*s (solver.similarity)."""
from __future__ import annotations

import numpy as np
import pytest

import solver_helpers  # noqa: F401  (imports saltstudy first)
from saltstudy.config import load_case, load_fidelity, resolve_scene
from saltstudy.solver.similarity import rescale_restart
from saltstudy.workflow import keys


def _scene(u_star: float, dt: float, nu: float = 1e-12):
    """Smoke grid, pressure-gradient drive (no controller time constants), fixed step."""
    fid = load_fidelity("smoke")
    fid = fid.model_validate({**fid.model_dump(), "time": {**fid.time.model_dump(), "dt_fixed": dt}})
    case = load_case(1, overrides={"forcing": {"u_star_s": u_star, "drive": "pressure_gradient"},
                                   "air": {"nu": nu}})
    return resolve_scene(case, fid)


def _runs_at_u_star_and_twice(nu: float, n_steps: int = 60) -> list[dict[str, np.ndarray]]:
    """Fields u, v, w, e after n_steps at u* = 0.3 (dt 0.02 s) and at 0.6 (dt 0.01 s), same seed."""
    from saltstudy.solver.model import Model

    out = []
    for u_star, dt in ((0.3, 0.02), (0.6, 0.01)):
        m = Model.from_scene(_scene(u_star, dt, nu=nu), saltation=False)
        for _ in range(n_steps):
            m.step(dt)
        out.append({k: np.array(getattr(m.state, k)) for k in ("u", "v", "w", "e")})
        m.close()
    return out


def test_les_is_self_similar_in_u_star():
    """At u*2 = 2 u*1 and dt2 = dt1 / 2, the same seed gives u2 = 2 u1 and e2 = 4 e1 after many
    steps: the scaling the shared spin-up relies on holds for the whole discrete solver."""
    a, b = _runs_at_u_star_and_twice(nu=1e-12)
    assert np.abs(a["w"]).max() > 1e-3 * np.abs(a["u"]).max()   # turbulence, not a laminar state
    for k, p in (("u", 1), ("v", 1), ("w", 1), ("e", 2)):
        scale = np.abs(b[k]).max()
        assert np.abs(b[k] - 2.0 ** p * a[k]).max() <= 1e-9 * scale, k


def test_molecular_viscosity_breaks_similarity_only_slightly():
    """With the real air viscosity the scaled fields differ, but by far less than the turbulence.
    The difference is largest at the first level, where the molecular viscosity is the largest
    share of the total: after 60 steps 1.1 % of the largest velocity fluctuation under the paper's
    closure."""
    a, b = (r["u"] for r in _runs_at_u_star_and_twice(nu=1.5e-5))
    fluct = np.abs(a - a.mean(axis=(0, 1))).max()
    assert 0 < np.abs(b / 2.0 - a).max() < 0.02 * fluct


def test_rescale_restart_scales_velocities_and_squares():
    ck = {"u": np.ones((2, 2, 2)), "v": np.full((2, 2, 2), -1.0), "w": np.zeros((2, 2, 3)),
          "e": np.full((2, 2, 2), 0.5), "p": np.full((2, 2, 2), 2.0), "t": 10.0, "step": 7,
          "u_drive": 3.0, "controller/tau_ref_filtered": 0.25, "controller/tau_ref_last": -0.1,
          "rng_state": "{}"}
    r = rescale_restart(ck, 1.5)
    assert r["u"][0, 0, 0] == 1.5 and r["v"][0, 0, 0] == -1.5 and r["u_drive"] == 4.5
    assert r["e"][0, 0, 0] == pytest.approx(1.125) and r["p"][0, 0, 0] == pytest.approx(4.5)
    assert r["controller/tau_ref_filtered"] == pytest.approx(0.5625)
    assert r["controller/tau_ref_last"] == pytest.approx(-0.225)
    assert r["t"] == 10.0 and r["step"] == 7 and r["rng_state"] == "{}"
    assert ck["u"][0, 0, 0] == 1.0                      # the input is not modified


@pytest.mark.parametrize("a", [0.0, -1.0, float("nan"), float("inf")])
def test_rescale_restart_rejects_bad_factor(a):
    with pytest.raises(ValueError, match="scale factor"):
        rescale_restart({"u": np.ones(2)}, a)


def test_rescale_restart_rejects_a_state_with_grains():
    with pytest.raises(ValueError, match="particle-free"):
        rescale_restart({"u": np.ones(2), "grains/x": np.ones(3)}, 2.0)


def test_shared_spinup_key_and_scale():
    """With spinup.u_star_ref, cases of different u*s share one spin-up key and scene."""
    fid = load_fidelity("smoke")
    fid = fid.model_validate({**fid.model_dump(), "spinup": {**fid.spinup.model_dump(), "u_star_ref": 0.5}})
    s1, s6 = (resolve_scene(load_case(n), fid) for n in (1, 6))
    assert keys.spinup_key(s1) == keys.spinup_key(s6)
    assert s1.spinup_scene().case.forcing.u_star_s == 0.5
    # the similarity factor the spun-up flow is scaled by: u*s over the spin-up's u*
    assert s6.case.forcing.u_star_s / s6.spinup_scene().case.forcing.u_star_s == pytest.approx(1.10 / 0.5)
    # without it (the paper fidelity) each u*s has its own spin-up
    q1, q6 = (resolve_scene(load_case(n), load_fidelity("paper")) for n in (1, 6))
    assert load_fidelity("paper").spinup.u_star_ref is None
    assert keys.spinup_key(q1) != keys.spinup_key(q6)
    assert q6.case.forcing.u_star_s / q6.spinup_scene().case.forcing.u_star_s == 1.0
    assert q6.spinup_scene() is q6
