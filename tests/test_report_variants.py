"""The variants table: seeds grouped per case and variant, the scatter between seeds, ratios to
the baseline, phi_air from the archive's profiles and the grains in the air."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from report_fixtures import make_analysis_dataset
from saltstudy.ncio import write_dataset
from saltstudy.report.variants import build_variants_report, phi_air, variants_table


def _archive(tmp_path, label, u_star, phi):
    """An archive whose air has a log-law-like profile of slope phi u*/(kappa z), stress u*^2."""
    ds = make_analysis_dataset(2, label=label)
    z = ds["z"].values
    ds["u_mean"] = (("z",), phi * u_star / 0.4 * np.log(z / 1e-4), {"units": "m s-1", "long_name": "u"})
    ds["uw_flux"] = (("z",), -u_star ** 2 + 0 * z, {"units": "m2 s-2", "long_name": "u'w'"})
    path = tmp_path / f"{label}.nc"
    write_dataset(ds, path)
    return str(path)


def test_phi_air_of_a_scaled_log_law(tmp_path):
    assert phi_air(_archive(tmp_path, "a", 0.5, 1.3)) == pytest.approx(1.3, rel=1e-6)


def test_table_groups_seeds_and_compares_with_the_baseline(tmp_path):
    runs = {}
    for variant, zm, phi in (("base", (0.20, 0.24), 1.0), ("off", (0.30, 0.34), 1.25)):
        for seed, z in zip((1, 2), zm):
            label = f"c6_{variant}_s{seed}"
            runs[label] = {"label": label, "status": "ok", "z_m": z, "n_parcels_mean": 100.0,
                           "archive": _archive(tmp_path, label, 1.1, phi)}
    runs["c6_off_s3"] = {"label": "c6_off_s3", "status": "failed"}          # left out
    runs["case02"] = {"label": "case02", "status": "ok", "z_m": 9.0}        # not a variant label
    t = variants_table({"cases": runs}, {l: 50.0 for l in runs})
    assert t["variants"] == ["base", "off"] and list(t["cases"]) == [6]
    st = t["cases"][6]["off"]["z_m"]
    assert st["mean"] == pytest.approx(0.32) and st["half_range"] == pytest.approx(0.02) and st["n"] == 2
    assert st["ratio"] == pytest.approx(0.32 / 0.22)
    assert t["cases"][6]["off"]["phi_air"]["mean"] == pytest.approx(1.25, rel=1e-6)
    assert t["cases"][6]["base"]["N_air"]["mean"] == pytest.approx(5000.0)
    assert math.isnan(t["cases"][6]["base"]["lambda_y"]["mean"])


def test_report_command_writes_the_tables(tmp_path):
    from saltstudy.cli import app

    runs = {f"c2_v_s{s}": {"label": f"c2_v_s{s}", "status": "ok", "G_tot": 0.02 * s,
                           "archive": _archive(tmp_path, f"c2_v_s{s}", 0.5, 1.0)} for s in (1, 2)}
    (tmp_path / "summary.json").write_text(json.dumps({"cases": runs}))
    r = CliRunner().invoke(app, ["probe", "variants-report", str(tmp_path)])
    assert r.exit_code == 0, r.output
    md = (tmp_path / "variants.md").read_text()
    assert "### Case 2" in md and "30 ± 10" in md                   # G_tot in g/m/s
    (tmp_path / "summary.json").write_text(json.dumps({"cases": {}}))
    r = CliRunner().invoke(app, ["probe", "variants-report", str(tmp_path)])
    assert r.exit_code == 2 and "[c<case>_]<variant>_s<seed>" in r.output


def test_labels_without_a_case_take_the_runs_case_number():
    """``<variant>_s<seed>`` labels (a study of one case's scenes) group by the run's own case
    number; a label of neither form is left out."""
    runs = {"paper_s1": {"label": "paper_s1", "case_number": 2, "status": "ok", "G_tot": 0.02},
            "paper_s2": {"label": "paper_s2", "case_number": 2, "status": "ok", "G_tot": 0.04},
            "alt_s1": {"label": "alt_s1", "case_number": 2, "status": "ok", "G_tot": 0.09},
            "other": {"label": "other", "case_number": 2, "status": "ok", "G_tot": 1.0}}
    t = variants_table({"cases": runs})
    assert t["variants"] == ["paper", "alt"]
    g = t["cases"][2]
    assert g["paper"]["G_tot"]["mean"] == pytest.approx(0.03)
    assert g["paper"]["G_tot"]["half_range"] == pytest.approx(0.01)
    assert g["alt"]["G_tot"]["ratio"] == pytest.approx(3.0)


def test_stokes_budget_reads_where_st_falls_below_one_and_the_drag_share(tmp_path):
    """St = 3 below 0.25 z_m and 0.5 above: St < 1 above the first level past 0.25 z_m; a drag
    share of eps_tot falling as exp(-z/z_m) read at 0.1 z_m; both enter the variants table."""
    from saltstudy.report.variants import stokes_budget

    ds = make_analysis_dataset(2, label="a")
    z = ds["z"].values
    zm = float(ds["z_m"].values)
    ds["St"] = (("z",), np.where(z / zm <= 0.25, 3.0, 0.5), {"units": "1", "long_name": "St"})
    share = 0.6 * np.exp(-z / zm)
    ds["eps_tot"] = (("z",), 0.1 / (z + 0.1), {"units": "m2 s-3", "long_name": "eps_tot"})
    ds["eps_drag"] = (("z",), share * ds["eps_tot"].values, {"units": "m2 s-3", "long_name": "eps_drag"})
    path = tmp_path / "a.nc"
    write_dataset(ds, path)
    b = stokes_budget(path)
    zeta = z / zm
    assert b["St_height"] == pytest.approx(zeta[zeta > 0.25].min())
    assert b["eps_drag_share"] == pytest.approx(0.6 * math.exp(-0.1), rel=0.02)
    runs = {"c2_v_s1": {"label": "c2_v_s1", "status": "ok", "archive": str(path)}}
    t = variants_table({"cases": runs})
    assert t["cases"][2]["v"]["St_height"]["mean"] == pytest.approx(b["St_height"])


def test_figure_labels_read_u_star_the_papers_way():
    """A run's legend gives u*s from the stress at z_ref (Table 2's leading column), not the free
    log fit; the fit only where the archive lacks the stress reading."""
    from saltstudy.report.data import RunData
    from saltstudy.report.plotting import case_label

    ds = make_analysis_dataset(2, label="case02")
    ds["u_star_s_stress"] = ((), 0.61, {"units": "m s-1", "long_name": "u* from the stress"})
    ds["u_star_s"] = ((), 0.48, {"units": "m s-1", "long_name": "u* free fit"})
    assert case_label(RunData("case02", 2, None, ds)).endswith("u*s = 0.61 m s⁻¹")
    assert case_label(RunData("case02", 2, None, ds.drop_vars("u_star_s_stress"))).endswith(
        "u*s = 0.48 m s⁻¹ (free log fit)")


def test_premultiplied_spectrum_over_its_variance_has_unit_area_in_log_wavelength():
    """On an even grid (Nyquist entry a half bin) and an odd one, the premultiplied density over
    the variance integrates to 1 against ln(wavelength); without the grid's size the Nyquist
    entry is left out."""
    from saltstudy.report.streaks import premultiplied_over_variance

    rng = np.random.default_rng(3)
    for ny in (64, 63):
        dy = 0.1
        ky = np.arange(ny // 2 + 1) / (ny * dy)
        S = rng.uniform(0.5, 2.0, ky.size)
        S[0] = 0.0
        wl, pre = premultiplied_over_variance(ky, S, ny * dy, dy)
        k = 1.0 / wl
        weight = np.full(k.size, ky[1] - ky[0]) / k          # d ln(wavelength) = dky / ky
        if ny % 2 == 0:
            weight[-1] *= 0.5                                # the doubled Nyquist point, half a bin
        assert np.sum(pre * weight) == pytest.approx(1.0, rel=1e-12)
    wl, _ = premultiplied_over_variance(ky, S, math.nan, dy)
    assert wl.size == ky.size - 2


def test_report_draws_the_streamer_curves_of_every_run(tmp_path):
    runs = {}
    for variant in ("box10", "box20"):
        for s in (1, 2):
            label = f"c6_{variant}_s{s}"
            runs[label] = {"label": label, "status": "ok", "lambda_y": 0.4,
                           "archive": _archive(tmp_path, label, 1.1, 1.0)}
    (tmp_path / "summary.json").write_text(json.dumps({"cases": runs}))
    build_variants_report(tmp_path)
    png = tmp_path / "streaks.png"
    assert png.exists() and png.stat().st_size > 10_000
