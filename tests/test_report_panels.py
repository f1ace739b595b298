"""Per-case figures draw the runs a study has: the paper's case, or the study's nearest run
standing in for it under its own label (report/panels.py), never an empty "not in study" frame."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import xarray as xr
from matplotlib.text import Text

from report_fixtures import make_analysis_dataset, write_study
from saltstudy.ncio import write_dataset
from saltstudy.report.build import build_report
from saltstudy.report.data import ReportContext, RunData, load_runs
from saltstudy.report.figures import make_figures
from saltstudy.report.panels import BY_MU1, BY_U_STAR_S, nearest_runs, panel_runs

PER_CASE = ("fig06", "fig07", "fig09", "fig10", "fig11", "fig12")


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


# ------------------------------------------------------------------------------------------------
# figures of a study without cases 1 and 4
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def no_1_4(tmp_path_factory):
    root = tmp_path_factory.mktemp("no14")
    runs = write_study(root / "a", cases=[2, 3, 5, 6, 7, 8, 9, 10])
    return root, runs


def _ctx(runs, meta=None):
    return ReportContext("t", load_runs(runs, meta), meta or {})


def _texts(fig) -> list[str]:
    return [t.get_text() for t in fig.findobj(Text)]


def _image_axes(fig):
    return [ax for ax in fig.axes if ax.get_images()]


def test_fig09_rows_are_filled_by_the_nearest_cases(no_1_4):
    _, runs = no_1_4
    res = make_figures(_ctx(runs), ["fig09"])["fig09"]
    assert not any(n.startswith("error") for n in res.notes), res.notes
    axes = _image_axes(res.fig)
    assert len(axes) == 6                                # three rows of (C_p, u)
    titles = [ax.get_title(loc="left") for ax in axes]
    # row 1: case 2 for case 1 (0.54 m/s); row 2: case 3 for case 4 (0.65 m/s); row 3: case 6
    assert titles[0].startswith("(a) case 2, u*s =")
    assert titles[0].endswith("\n(nearest to the paper's case 1 by u*s)")
    assert titles[1].startswith("(b) case 2") and "paper's case 1" in titles[1]
    assert titles[2].startswith("(a) case 3") and titles[2].endswith("(nearest to the paper's case 4 by u*s)")
    assert titles[4].startswith("(a) case 6") and "nearest" not in titles[4]
    assert set(res.data) == {f"{v}_{k}" for v in ("C_p_snapshot", "u_snapshot")
                             for k in ("case02_for_case1", "case03_for_case4", "case6")}
    ctx = _ctx(runs)
    snap = ctx.by_case(3).ds["C_p_snapshot"].values
    np.testing.assert_allclose(res.data["C_p_snapshot_case03_for_case4"], snap / np.abs(snap).max())
    # no title calls a substitute by the paper's case
    assert not any(t.startswith(("(a) case 1", "(b) case 1", "(a) case 4", "(b) case 4")) for t in titles)


def test_no_figure_says_not_in_study(no_1_4):
    _, runs = no_1_4
    figs = make_figures(_ctx(runs))
    for name, res in figs.items():
        assert not any(n.startswith("error") for n in res.notes), (name, res.notes)
        assert not any("not in study" in n for n in res.notes), (name, res.notes)
        assert not any("not in study" in t for t in _texts(res.fig)), name
    # the panels of cases 1-6 draw the four the study has, those of cases 2, 7-10 all five
    for name in ("fig06", "fig07", "fig11", "fig12"):
        a, b = figs[name].fig.axes[:2]
        assert sum(l.get_label().startswith("case ") for l in a.get_lines()) == 4, name
        assert sum(l.get_label().startswith("case ") for l in b.get_lines()) == 5, name
    for row, n in ((0, 4), (2, 5)):
        ax = figs["fig10"].fig.axes[row]
        assert sum(l.get_label().startswith("case ") for l in ax.get_lines()) == n


def test_report_html_does_not_say_not_in_study(no_1_4, tmp_path):
    _, runs = no_1_4
    index = build_report("no14", runs, tmp_path / "r", {"figure_formats": ["png"], "figure_dpi": 40})
    text = index.read_text(encoding="utf-8")
    assert "not in study" not in text
    for n in range(1, 14):
        assert (tmp_path / "r" / f"fig{n:02d}.png").is_file()


def test_quick_study_draws_two_rows_of_fig09(tmp_path):
    """The default study's cases (2, 6, 7, 9, 10): case 2 takes case 1's row; no run at 200 µm is
    left for case 4's row, which is left out rather than drawn empty."""
    runs = write_study(tmp_path / "q", cases=[2, 6, 7, 9, 10])
    figs = make_figures(_ctx(runs))
    res = figs["fig09"]
    axes = _image_axes(res.fig)
    assert len(axes) == 4
    assert [ax.get_title(loc="left").split(",")[0] for ax in axes] == [
        "(a) case 2", "(b) case 2", "(a) case 6", "(b) case 6"]
    assert "paper's case 1 by u*s" in axes[0].get_title(loc="left")
    for name in PER_CASE:
        assert not any("not in study" in t for t in _texts(figs[name].fig)), name
        assert not figs[name].notes, (name, figs[name].notes)
    # the panels of cases 1-6 hold the two runs at 200 µm, those of cases 2, 7-10 four
    a, b = figs["fig11"].fig.axes[:2]
    assert [l.get_label().split(",")[0] for l in a.get_lines() if l.get_label().startswith("case")] \
        == ["case 2", "case 6"]
    assert [l.get_label().split(",")[0] for l in b.get_lines() if l.get_label().startswith("case")] \
        == ["case 2", "case 7", "case 9", "case 10"]


def _scene(tmp_path, label: str, case: int, u_star_s: float):
    """An archive of a user's own scene: no case number, ``case``'s data, target ``u_star_s``."""
    ds = make_analysis_dataset(case, label=label)
    scene = json.loads(ds.attrs["case_json"])
    scene["case"]["number"] = None
    scene["case"]["forcing"]["u_star_s"] = u_star_s
    ds.attrs["case_json"] = json.dumps(scene)
    del ds.attrs["case_number"]
    return write_dataset(ds, tmp_path / f"{label}.nc")


def test_a_scene_stands_in_beside_the_papers_values(tmp_path):
    """A scene at 0.75 m/s takes case 4's place in the panels of cases 1-6, labelled by its own
    name; the paper's values keep their own label."""
    runs = {**write_study(tmp_path / "s", cases=[2, 6]), "gust": _scene(tmp_path, "gust", 4, 0.75)}
    ctx = _ctx(runs)
    assert ctx.by_case(4) is None and ctx.runs["gust"].case is None
    figs = make_figures(ctx, ["fig09", "fig10", "fig11"])
    labels = [l.get_label() for l in figs["fig11"].fig.axes[0].get_lines()]
    assert any(l.startswith("gust (nearest to the paper's case 4 by u*s), u*s =") for l in labels)
    assert any(l.startswith("Dupont et al. 2013: R_cu") for l in labels)
    assert "(a)gust_for_case4" in figs["fig11"].data
    spectra = [l.get_label() for l in figs["fig10"].fig.axes[0].get_lines()]
    assert "Dupont et al. 2013: δy (Table 2)" in spectra
    assert any(l.startswith("gust (nearest to the paper's case 4") for l in spectra)
    titles = [ax.get_title(loc="left") for ax in _image_axes(figs["fig09"].fig)]
    assert [t.split(",")[0].split("\n")[0] for t in titles] == [
        "(a) case 2", "(b) case 2", "(a) gust", "(b) gust", "(a) case 6", "(b) case 6"]
    # nothing the figures draw calls a run by a paper case it is not
    for res in figs.values():
        for t in _texts(res.fig):
            assert not t.startswith(("case 1", "case 4", "(a) case 4", "(b) case 4")), t


def test_a_failed_run_is_noted_and_its_place_given_to_the_nearest(tmp_path):
    """Case 1 in the study without an archive: noted; its row goes to case 2."""
    runs = write_study(tmp_path / "f", cases=[1, 2, 6], missing=(1,))
    panel = panel_runs(_ctx(runs), (1, 4, 6), BY_U_STAR_S)
    assert panel.notes == ["case 1: no archive"]
    assert [(p.paper_case, p.run.label, p.substitute) for p in panel.runs] == [
        (1, "case02", True), (6, "case06", False)]


def test_a_figure_no_run_can_fill_says_so_without_a_frame(tmp_path):
    """Only 90 µm: Fig. 9 (cases 1, 4, 6 at 200 µm) has no row to draw."""
    runs = write_study(tmp_path / "o", cases=[7])
    res = make_figures(_ctx(runs), ["fig09", "fig11"])
    assert not res["fig09"].fig.axes
    assert any("µ1 = 200 µm" in t for t in _texts(res["fig09"].fig))
    assert len(res["fig11"].fig.axes) == 1                 # panel (b) only
    assert res["fig11"].fig.axes[0].get_title(loc="left").startswith("(b)")
    assert math.isfinite(float(np.nanmax(res["fig11"].data["(b)case7"])))


# ------------------------------------------------------------------------------------------------
# Figs. 2 and 5: the paper's cases 2 (Fig. 2) and 7, 2, 10 (Fig. 5's three grain sizes)
# ------------------------------------------------------------------------------------------------
def test_a_study_without_cases_2_7_10_draws_no_empty_frame(tmp_path):
    """Cases 1 and 6 only: case 1 (0.41 m/s, nearer to 0.54 than 1.10) stands in for case 2 in
    Fig. 2 and in Fig. 5's 200 µm panel; Fig. 5 has no run at 90 or 400 µm and draws that one
    panel only; nothing the report writes says "not in study"."""
    runs = write_study(tmp_path / "a", cases=[1, 6])
    ctx = _ctx(runs)
    figs = make_figures(ctx)
    for name, res in figs.items():
        assert not any(n.startswith("error") for n in res.notes), (name, res.notes)
        assert not any("not in study" in n for n in res.notes), (name, res.notes)
        assert not any("not in study" in t for t in _texts(res.fig)), name
    f2 = figs["fig02"]
    assert f2.fig.get_suptitle().endswith(
        "\ncase 1 (nearest to the paper's case 2 by u*s), u*s = "
        f"{ctx.by_case(1).scalar('u_star_s_stress'):.2f} m s⁻¹")
    z, u = ctx.by_case(1).ds["z"].values, ctx.by_case(1).ds["u_mean"].values
    np.testing.assert_allclose(f2.data["u_mean_norm"], u / np.interp(np.log(2.0), np.log(z), u))
    f5 = figs["fig05"]
    assert len(f5.fig.axes) == 1
    title = f5.fig.axes[0].get_title(loc="left")
    assert title.startswith("(b) µ1 = 200 µm: case 1, u*s =")
    assert title.endswith("\n(nearest to the paper's case 2 by u*s)")
    assert set(f5.data) == {"psd_air_case01_for_case2", "psd_bed_case01_for_case2"}
    np.testing.assert_array_equal(f5.data["psd_air_case01_for_case2"], ctx.by_case(1).ds["psd_air"].values)
    index = build_report("c16", runs, tmp_path / "r", {"figure_formats": ["png"], "figure_dpi": 40})
    assert "not in study" not in index.read_text(encoding="utf-8")


def test_fig02_takes_the_nearest_u_star_s_at_200_um(tmp_path):
    """Without case 2: case 7 (0.57 m/s) is nearest in u*s but 90 µm; case 3 (0.65 m/s) is
    nearer than case 1 (0.41 m/s) and stands in."""
    runs = write_study(tmp_path / "a", cases=[1, 3, 7])
    ctx = _ctx(runs)
    res = make_figures(ctx, ["fig02"])["fig02"]
    assert "\ncase 3 (nearest to the paper's case 2 by u*s)" in res.fig.get_suptitle()
    np.testing.assert_array_equal(res.data["uw_flux"], ctx.by_case(3).ds["uw_flux"].values)
    # with case 2 in the study, case 2 itself, under its own name
    runs = write_study(tmp_path / "b", cases=[1, 2, 3])
    res = make_figures(_ctx(runs), ["fig02"])["fig02"]
    assert res.fig.get_suptitle().split("\n")[1].startswith("case 2, u*s =")
    assert "nearest" not in res.fig.get_suptitle()


def test_fig02_without_a_200_um_run_draws_no_frame(tmp_path):
    runs = write_study(tmp_path / "a", cases=[7, 10])
    res = make_figures(_ctx(runs), ["fig02"])["fig02"]
    assert not res.fig.axes and not res.data
    assert any("µ1 = 200 µm" in t for t in _texts(res.fig))


def _sized(tmp_path, label: str, case: int, mu1_um: float):
    """An archive of a scene of one's own: ``case``'s data, its soil at ``mu1_um``."""
    ds = make_analysis_dataset(case, label=label)
    scene = json.loads(ds.attrs["case_json"])
    scene["case"]["number"] = None
    scene["case"]["soil"]["modes"][0]["mu"] = mu1_um * 1e-6
    ds.attrs["case_json"] = json.dumps(scene)
    del ds.attrs["case_number"]
    return write_dataset(ds, tmp_path / f"{label}.nc")


def test_fig05_panels_hold_their_grain_size(tmp_path):
    """A run fills a Fig. 5 panel only within 10 % of its grain size: case 8 (100 µm, 11 % above
    90 µm) and case 9 (300 µm) fill no panel; a scene at 95 µm fills the 90 µm one."""
    runs = write_study(tmp_path / "a", cases=[2, 8, 9])
    res = make_figures(_ctx(runs), ["fig05"])["fig05"]
    assert set(res.data) == {"psd_air_case2", "psd_bed_case2"}
    assert len(res.fig.axes) == 1
    runs["fine"] = _sized(tmp_path, "fine", 8, 95.0)
    res = make_figures(_ctx(runs), ["fig05"])["fig05"]
    assert set(res.data) == {f"psd_{w}_{k}" for w in ("air", "bed") for k in ("fine_for_case7", "case2")}
    titles = [ax.get_title(loc="left") for ax in res.fig.axes]
    assert titles[0].startswith("(a) µ1 = 90 µm: fine, u*s =")
    assert titles[0].endswith("(nearest to the paper's case 7 by u*s)")
    assert titles[1].startswith("(b) µ1 = 200 µm: case 2, u*s =")


def test_fig05_within_a_grain_size_the_nearest_u_star_s_stands_in(tmp_path):
    """200 µm at 0.41 (case 1) and 0.65 m/s (case 3), no case 2: case 3 is nearer to 0.54."""
    runs = write_study(tmp_path / "a", cases=[1, 3])
    res = make_figures(_ctx(runs), ["fig05"])["fig05"]
    assert set(res.data) == {"psd_air_case03_for_case2", "psd_bed_case03_for_case2"}


def test_fig05_without_a_run_of_its_grain_sizes_draws_no_frame(tmp_path):
    runs = write_study(tmp_path / "a", cases=[8, 9])
    res = make_figures(_ctx(runs), ["fig05"])["fig05"]
    assert not res.fig.axes and not res.data
    assert any("µ1 = 90, 200 or 400 µm" in t for t in _texts(res.fig))
