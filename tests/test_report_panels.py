"""Per-case figures draw the runs a study has: the paper's case, or the study's nearest run
standing in for it under its own label (report/panels.py), never an empty "not in study" frame."""
from __future__ import annotations

import xarray as xr

from saltstudy.report.data import RunData
from saltstudy.report.panels import BY_MU1, BY_U_STAR_S, nearest_runs


def _run(label: str, case: int | None, u_star_s: float, mu1_um: float,
         computed_u_star_s: float | None = None) -> RunData:
    ds = None
    if computed_u_star_s is not None:
        ds = xr.Dataset({"u_star_s_stress": ((), computed_u_star_s, {"units": "m s-1"}),
                         "u_star_s": ((), computed_u_star_s, {"units": "m s-1"})})
    scene = {"case": {"number": case, "forcing": {"u_star_s": u_star_s},
                      "soil": {"modes": [{"mass_fraction": 1.0, "mu": mu1_um * 1e-6}]}}}
    return RunData(label, case, None, ds=ds, scene=scene)


def _labels(chosen: dict[int, RunData]) -> dict[int, str]:
    return {n: r.label for n, r in chosen.items()}


# ------------------------------------------------------------------------------------------------
# the choice of the nearest run
# ------------------------------------------------------------------------------------------------
def test_nearest_by_target_u_star_s_not_by_the_computed_one():
    """Slot 4 (0.75 m/s): case 3's target 0.65 is nearer than case 5's 0.93, although their
    computed u*s (0.90 and 0.76) would say the opposite."""
    c3 = _run("case03", 3, 0.65, 200, computed_u_star_s=0.90)
    c5 = _run("case05", 5, 0.93, 200, computed_u_star_s=0.76)
    assert _labels(nearest_runs([4], [c5, c3], BY_U_STAR_S)) == {4: "case03"}


def test_a_run_goes_to_the_paper_case_it_is_nearest_to_and_only_once():
    c3 = _run("case03", 3, 0.65, 200)
    # case 3 is nearer to case 4 (ln 0.75/0.65 = 0.14) than to case 1 (0.46) or case 6 (0.53)
    assert _labels(nearest_runs([1, 4, 6], [c3], BY_U_STAR_S)) == {4: "case03"}
    c2 = _run("case02", 2, 0.54, 200)
    assert _labels(nearest_runs([1, 4, 6], [c2, c3], BY_U_STAR_S)) == {1: "case02", 4: "case03"}


def test_a_run_stands_in_only_along_the_figures_series():
    """A u*s series holds µ1 at 200 µm: case 7 (90 µm, 0.57 m/s) does not stand in for case 4
    though it is nearer in u*s than case 6. A µ1 series holds u*s at ≈0.54 m/s: case 1 (200 µm,
    0.41 m/s) does not stand in for case 8 (100 µm)."""
    c6 = _run("case06", 6, 1.10, 200)
    c7 = _run("case07", 7, 0.57, 90)
    assert _labels(nearest_runs([4], [c7, c6], BY_U_STAR_S)) == {4: "case06"}
    c1 = _run("case01", 1, 0.41, 200)
    assert nearest_runs([8], [c1], BY_MU1) == {}
    assert _labels(nearest_runs([8], [c1, c7], BY_MU1)) == {8: "case07"}


def test_ties_are_broken_by_case_number_then_label_whatever_the_order():
    a = _run("zeta", None, 0.75, 200)
    b = _run("alpha", None, 0.75, 200)
    c = _run("case04_fast", 4, 0.75, 200)
    for order in ([a, b, c], [c, b, a], [b, a, c]):
        assert _labels(nearest_runs([4], order, BY_U_STAR_S)) == {4: "case04_fast"}
        assert _labels(nearest_runs([4], [r for r in order if r is not c], BY_U_STAR_S)) == {4: "alpha"}
    # equal u*s distance: the µ1 distance decides (210 µm is nearer to the paper's 200 µm)
    near = _run("near", None, 0.54, 210)
    far = _run("far", None, 0.54, 190)
    assert _labels(nearest_runs([2], [far, near], BY_U_STAR_S)) == {2: "near"}
