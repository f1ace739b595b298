"""The flux-law section of a report: each run's G_tot against Creyssels et al. (2009) at the run's
own stress u*, on synthetic archives whose verdict is known by construction."""
from __future__ import annotations

import json

import pytest

from report_fixtures import make_analysis_dataset
from saltstudy.ncio import write_dataset
from saltstudy.physics.laws import creyssels2009_flux
from saltstudy.report.data import load_runs
from saltstudy.report.fluxlaw import build_fluxlaw_report


def _run(tmp_path, label, u_star, factor):
    ds = make_analysis_dataset(2, label=label)
    ds["u_star_s_stress"] = ((), u_star, {"units": "m s-1", "long_name": "u* of the stress"})
    ds["G_tot"] = ((), factor * creyssels2009_flux(u_star), {"units": "kg m-1 s-1", "long_name": "G_tot"})
    ds["G_decay_height"] = ((), 0.012, {"units": "m", "long_name": "e-folding height of G"})
    path = tmp_path / f"{label}.nc"
    write_dataset(ds, path)
    return path


def test_each_run_is_judged_at_its_own_stress_u_star(tmp_path):
    runs = {"u0.33": _run(tmp_path, "u0.33", 0.33, 1.10), "u0.49": _run(tmp_path, "u0.49", 0.49, 0.70),
            "u0.58": _run(tmp_path, "u0.58", 0.58, 1.24)}
    ctx_runs = load_runs(runs, {})
    out = build_fluxlaw_report(ctx_runs, tmp_path, "creyssels2009")
    rows = {r["label"]: r for r in out["rows"]}
    assert [r["label"] for r in out["rows"]] == ["u0.33", "u0.49", "u0.58"]     # ordered by u*
    assert rows["u0.33"]["ratio"] == pytest.approx(1.10) and rows["u0.33"]["within"]
    assert rows["u0.49"]["ratio"] == pytest.approx(0.70) and not rows["u0.49"]["within"]
    assert rows["u0.58"]["within"]
    assert rows["u0.49"]["law"] == pytest.approx(creyssels2009_flux(0.49))
    data = json.loads((tmp_path / "fluxlaw.json").read_text())
    assert data["law"] == "creyssels2009" and len(data["rows"]) == 3
    assert "NO" in (tmp_path / "fluxlaw.md").read_text()
    assert (tmp_path / "fluxlaw.png").stat().st_size > 0


def test_unknown_law_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match="flux_law"):
        build_fluxlaw_report({}, tmp_path, "bagnold")
