"""Each figure is drawn from the archives: change an archive value and the drawn data change."""
from __future__ import annotations

import hashlib
import math
import re
import shutil

import numpy as np
import pytest

from report_fixtures import make_analysis_dataset, modify_archive, write_analysis, write_study
from saltstudy.report.data import ReportContext, load_runs
from saltstudy.report.figures import FIGURES, make_figures


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = tmp_path_factory.mktemp("fig")
    return root, write_study(root / "a")


def figure_data_digest(fig) -> str:
    """SHA-256 of every data array drawn on ``fig`` (lines, collections, images): whether the
    plotted data changed, without comparing image bytes."""
    h = hashlib.sha256()
    for ax in fig.axes:
        for ln in ax.get_lines():
            h.update(np.ascontiguousarray(ln.get_xydata(), dtype=float).tobytes())
        for c in ax.collections:
            off = c.get_offsets()
            h.update(np.ascontiguousarray(np.asarray(off, dtype=float)).tobytes())
        for im in ax.get_images():
            h.update(np.ascontiguousarray(np.asarray(im.get_array(), dtype=float)).tobytes())
    return h.hexdigest()


def _ctx(runs):
    return ReportContext("t", load_runs(runs))


def _scale(f):
    return lambda v: np.asarray(v, float) * f


# figure -> (case whose archive changes, variable, change)
CHANGES = {
    "fig01": (2, "n_parcels", _scale(1.3)),
    "fig02": (2, "u_mean", _scale(1.1)),
    "fig03": (5, "z0s", _scale(2.0)),
    "fig04": (3, "z_m", _scale(1.2)),
    "fig05": (10, "psd_air", lambda v: np.roll(v, 1, axis=-1)),
    "fig06": (4, "tau_p", _scale(0.5)),
    "fig07": (9, "G", _scale(0.7)),
    "fig08": (7, "G_tot", _scale(1.5)),
    "fig09": (6, "C_p_snapshot", lambda v: np.roll(v, 3, axis=1)),
    "fig10": (8, "S_u", lambda v: np.asarray(v) * np.linspace(1, 2, np.asarray(v).size)),
    "fig11": (1, "R_cu", _scale(0.5)),
    "fig12": (10, "St", _scale(3.0)),
    "fig13": (4, "sigma_G_over_G_tot", _scale(1.4)),
}


def test_every_figure_has_a_change_test():
    assert set(CHANGES) == set(FIGURES)


@pytest.mark.parametrize("name", sorted(CHANGES))
def test_figure_follows_archive(study, tmp_path, name):
    root, runs = study
    case, var, change = CHANGES[name]
    before = make_figures(_ctx(runs), [name])[name]
    assert not any(n.startswith("error") for n in before.notes), before.notes
    label = f"case{case:02d}"
    again = make_figures(_ctx(runs), [name])[name]
    assert figure_data_digest(before.fig) == figure_data_digest(again.fig)   # deterministic
    # an unrelated scalar does not change the figure
    p0 = tmp_path / "unrelated.nc"
    shutil.copy(runs[label], p0)
    modify_archive(p0, "streamer_speed", _scale(7.0))
    same = make_figures(_ctx({**runs, label: p0}), [name])[name]
    assert figure_data_digest(same.fig) == figure_data_digest(before.fig)
    # the figure's variable does
    p = tmp_path / "changed.nc"
    shutil.copy(runs[label], p)
    modify_archive(p, var, change)
    after = make_figures(_ctx({**runs, label: p}), [name])[name]
    assert figure_data_digest(after.fig) != figure_data_digest(before.fig)
    changed = [k for k in before.data if k in after.data
               and not np.array_equal(np.asarray(before.data[k]), np.asarray(after.data[k]), equal_nan=True)]
    assert changed, f"{name}: returned data unchanged after changing {var} of {label}"


def test_profile_normalisation_is_the_papers(study):
    """Fig 6 plots tau_p / (rho u*s^2) against z / z_m, u*s read from the stress at z_ref."""
    _, runs = study
    ctx = _ctx(runs)
    res = make_figures(ctx, ["fig06"])["fig06"]
    r = ctx.by_case(3)
    tau = r.ds["tau_p"].values
    z = r.ds["z"].values
    vis = z / r.scalar("z_m") <= 1.5 * 1.05
    expect = tau[vis] / (r.rho * r.scalar("u_star_s_stress") ** 2)
    np.testing.assert_allclose(res.data["(a)case3"], expect)
    line = [ln for ln in res.fig.axes[0].get_lines() if ln.get_label().startswith("case 3")][0]
    np.testing.assert_allclose(line.get_ydata(), z[vis] / r.scalar("z_m"))


def test_fig06_normalises_by_the_stress_u_star_s_of_its_labels(tmp_path):
    """An archive whose stress u*s is 0.8 of its free-fit u*s: tau_p is divided by rho times
    the stress value squared (the u*s the label shows), 1/0.64 of the free-fit normalisation."""
    ds = make_analysis_dataset(1)
    fit = float(ds["u_star_s"].values)
    ds["u_star_s_stress"] = ((), 0.8 * fit, {"units": "m s-1"})
    from saltstudy.ncio import write_dataset
    p = write_dataset(ds, tmp_path / "c1.nc")
    ctx = _ctx({"case01": p})
    res = make_figures(ctx, ["fig06"])["fig06"]
    r = ctx.by_case(1)
    z, tau = r.ds["z"].values, r.ds["tau_p"].values
    vis = z / r.scalar("z_m") <= 1.5 * 1.05
    got = res.data["(a)case1"]
    np.testing.assert_allclose(got, tau[vis] / (r.rho * (0.8 * fit) ** 2))
    np.testing.assert_allclose(got * 0.64, tau[vis] / (r.rho * fit ** 2))
    label = next(ln.get_label() for ln in res.fig.axes[0].get_lines()
                 if ln.get_label().startswith("case 1"))
    assert label == f"case 1, u*s = {0.8 * fit:.2f} m s⁻¹"
    assert not res.notes


def test_fig06_without_the_stress_reading_uses_the_free_fit_and_says_so(tmp_path):
    ds = make_analysis_dataset(1).drop_vars("u_star_s_stress")
    from saltstudy.ncio import write_dataset
    p = write_dataset(ds, tmp_path / "c1.nc")
    ctx = _ctx({"case01": p})
    res = make_figures(ctx, ["fig06"])["fig06"]
    r = ctx.by_case(1)
    z, tau = r.ds["z"].values, r.ds["tau_p"].values
    vis = z / r.scalar("z_m") <= 1.5 * 1.05
    np.testing.assert_allclose(res.data["(a)case1"], tau[vis] / (r.rho * r.scalar("u_star_s") ** 2))
    label = next(ln.get_label() for ln in res.fig.axes[0].get_lines()
                 if ln.get_label().startswith("case 1"))
    assert label.endswith("(free log fit)")
    assert res.notes == ["case01: no stress u*s in the archive, τp over ρu*s² of the free log fit"]


def test_fig02_u_ref_height(tmp_path):
    """u_ref at 2 m when the domain allows, else at half the undamped depth; u/u_ref = 1 there."""
    deep = write_analysis(tmp_path / "deep.nc", 2, lz=6.0, damping_depth=1.5)
    shallow = write_analysis(tmp_path / "shallow.nc", 2, lz=3.0, damping_depth=1.0)
    for path, zref in ((deep, 2.0), (shallow, 1.0)):
        res = make_figures(_ctx({"case02": path}), ["fig02"])["fig02"]
        assert res.data["u_ref_height"][0] == pytest.approx(zref)
        u = res.data["u_mean_norm"]
        z = res.data["z"]
        assert np.interp(np.log(zref), np.log(z), u) == pytest.approx(1.0)


def test_missing_and_absent_cases_are_noted(tmp_path):
    runs = write_study(tmp_path / "a", cases=[1, 2, 6], missing=(6,))
    figs = make_figures(_ctx(runs))
    assert any("case 6: no archive" in n for n in figs["fig09"].notes)
    # case 4's row goes to the nearest run left (case 2); case 6's failed run is noted, not drawn
    assert not any("not in study" in n for n in figs["fig09"].notes)
    assert {k for k in figs["fig09"].data if k.startswith("C_p")} == {
        "C_p_snapshot_case1", "C_p_snapshot_case02_for_case4"}
    # Fig. 5: the 200 µm panel only; no run at 90 or 400 µm, so no frame for them
    assert not figs["fig05"].notes
    assert set(figs["fig05"].data) == {"psd_air_case2", "psd_bed_case2"}
    assert [ax.get_title(loc="left").split(":")[0] for ax in figs["fig05"].fig.axes] == [
        "(b) µ1 = 200 µm"]
    assert figs["fig04"].data["z_m"].size == 2          # cases 1, 2 only; none invented
    assert set(figs["fig06"].data) == {"(a)case1", "(a)case2", "(b)case2"}
    for name, res in figs.items():
        assert not any(n.startswith("error") for n in res.notes), (name, res.notes)


def test_no_saltation_case_is_not_drawn(tmp_path):
    """A run with z_m undefined (u*s below threshold) is noted, not plotted against z/z_m."""
    ds = make_analysis_dataset(1)
    ds["z_m"] = ((), math.nan, {"units": "m"})
    from saltstudy.ncio import write_dataset
    p = write_dataset(ds, tmp_path / "c1.nc")
    res = make_figures(_ctx({"case01": p}), ["fig06"])["fig06"]
    assert any("case 1: z_m undefined" in n for n in res.notes)
    assert not res.data


def test_semi_empirical_laws_are_the_physics_module(study):
    laws = pytest.importorskip("saltstudy.physics.laws")
    _, runs = study
    ctx = _ctx(runs)
    res = make_figures(ctx, ["fig03", "fig08"])
    ut = ctx.by_case(2).scalar("u_star_t")
    for fig, table in (("fig03", laws.Z0S_LAWS), ("fig08", laws.GTOT_LAWS)):
        for name in table:
            y = res[fig].data[f"law_{name}"]
            assert y.size == 200 and np.all(np.isfinite(y[1:])), name
        # one explicit value: first law at the upper end of the plotted range
        xs = res[fig].data["x_ratio"]
        hi = max(4.5, float(xs.max()) * 1.1)
        name, (fn, _) = next(iter(table.items()))
        expect = fn(hi * ut, ut) if fig == "fig03" else fn(hi * ut, ut, d=200e-6)
        assert res[fig].data[f"law_{name}"][-1] == pytest.approx(float(expect), rel=1e-9)


def test_scene_study_draws_its_scenes_in_the_per_case_figures(tmp_path):
    """In a study of scenes (labels of the user's choosing), a scene of case 6 stands for case 6
    in the per-case figures, titled by its label, instead of a "not in study" panel."""
    path = write_analysis(tmp_path / "scene.nc", 6)
    ctx = ReportContext("t", load_runs({"c6_box20_s1": path}, {"case_numbers": {"c6_box20_s1": 6}}))
    assert ctx.by_case(6).label == "c6_box20_s1"
    assert ctx.by_case(1) is None
    res = make_figures(ctx, ["fig09"])["fig09"]
    assert "C_p_snapshot_case6" in res.data
    assert not any("case 6" in n for n in res.notes)
    assert not any("not in study" in n for n in res.notes)   # rows 1 and 4: no run to stand in
    titles = [ax.get_title(loc="left") for ax in res.fig.axes]
    assert [t.split(",")[0] for t in titles if t] == ["(a) c6_box20_s1", "(b) c6_box20_s1"]


def test_fig05_size_axes_are_labelled_in_plain_micrometres(study, tmp_path):
    """Each panel spans a decade of d or less: its labels are plain numbers (50, 100, 200), at
    least two per panel, none in scientific notation (6×10¹), also for a 90 µm soil binned
    from 53 to 152 µm, where powers of ten or 1-2-3-5 steps give a single tick (100)."""
    _, runs = study
    ds = make_analysis_dataset(7)
    ds = ds.assign_coords(d_bin=("d_bin", np.geomspace(53e-6, 152e-6, ds.sizes["d_bin"]),
                                 ds["d_bin"].attrs))
    from saltstudy.ncio import write_dataset
    narrow = write_dataset(ds, tmp_path / "c7.nc")
    res = make_figures(_ctx({**runs, "case07": narrow}), ["fig05"])["fig05"]
    assert len(res.fig.axes) == 3
    for ax in res.fig.axes:
        lo, hi = ax.get_xlim()
        labels = {}
        for kind, locs, fmt in (("major", ax.xaxis.get_majorticklocs(), ax.xaxis.get_major_formatter()),
                                ("minor", ax.xaxis.get_minorticklocs(), ax.xaxis.get_minor_formatter())):
            labels[kind] = [fmt(t, i) for i, t in enumerate(t for t in locs if lo <= t <= hi)]
            labels[kind] = [lab for lab in labels[kind] if lab]
        assert all(re.fullmatch(r"\d+", lab) for lab in labels["major"] + labels["minor"]), labels
        assert len(labels["major"]) >= 2, labels


def test_fig06_names_a_level_its_log_axis_cannot_draw(tmp_path):
    """τp < 0 at the first level above z_m and > 0 at the next (a coarse grid's noise above the
    layer): that level is a gap in the line and the level above it a lone dot, both said in a
    note with the height of the gap; the lone level is drawn where it is, inside the axes."""
    ds = make_analysis_dataset(7)
    z, zm = ds["z"].values, float(ds["z_m"].values)
    k = int(np.argmax(z > zm))
    tau = ds["tau_p"].values.copy()
    tau[k] = -1e-3 * tau[0]
    ds["tau_p"] = (("z",), tau, ds["tau_p"].attrs)
    from saltstudy.ncio import write_dataset
    p = write_dataset(ds, tmp_path / "c7.nc")
    res = make_figures(_ctx({"case07": p}), ["fig06"])["fig06"]
    assert res.notes == [f"case 7: τp ≤ 0 at z/z_m = {z[k] / zm:.2f}, a gap in its line on the log axis"]
    x = res.data["(b)case7"]
    assert np.isnan(x[k]) and x[k + 1] > 0
    ax = res.fig.axes[0]
    assert any("a gap in its line" in t.get_text() for t in ax.texts)
    lo, hi = ax.get_xlim()
    assert lo < x[k + 1] < hi and z[k + 1] / zm < ax.get_ylim()[1]


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
    from saltstudy.report.streamer_figures import premultiplied_over_variance

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
