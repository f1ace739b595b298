"""Table 2 beside the paper, and the scalar results the paper's text states, computed vs paper.

A row per run: the computed value and, where the run is one of the paper's cases unchanged, the
paper's value and (computed - paper) / paper; a missing archive or a run without sustained
saltation (report/saltation.py) is a row saying so; values the paper does not give are "—".
"""
from __future__ import annotations

import html
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..analysis.paper_grid import PAPER, PAPER_FIRST_LAYER
from ..config import roughness_table
from .data import ReportContext, RunData, case_number_of, profile
from .reference import CASES_WIND, PAPER_LABEL, TABLE2_COLUMNS, paper_results, paper_table2
from .saltation import NO_SALTATION, saltation_state

__all__ = ["Cell", "model_departures", "table2_rows", "scalar_results", "table2_markdown", "table2_html",
           "table2_dataset", "results_html", "st_below_one_height", "fmt",
           "rel_diff", "md_table", "html_table", "figure_html", "write_json"]


def fmt(v: float | None, digits: int = 3) -> str:
    if v is None or not isinstance(v, (int, float)) or not math.isfinite(v):
        return "—"
    if v != 0 and (abs(v) < 1e-2 or abs(v) >= 1e4):
        return f"{v:.{digits - 1}e}"
    return f"{v:.{digits}g}"


def rel_diff(computed: float, ref: float) -> float:
    ok = math.isfinite(computed) and math.isfinite(ref) and ref != 0
    return (computed - ref) / ref if ok else math.nan


def _pct(v: float) -> str:
    return f"{v:+.0%}" if math.isfinite(v) else "—"


def md_table(heads: list[str], rows) -> list[str]:
    """The lines of a markdown table of text cells."""
    def line(cells) -> str:
        return "| " + " | ".join(cells) + " |"
    return [line(heads), "|" + "---|" * len(heads)] + [line(r) for r in rows]


def html_table(heads: list[str], rows, cls: Callable[[int, int], str] = lambda i, j: "") -> str:
    """An HTML table of text cells (escaped); ``cls(i, j)``: the class of row i's cell j (i = -1:
    the header), "" for none."""
    def cell(tag: str, text: str, c: str) -> str:
        return f"<{tag}{f' class={c!r}' if c else ''}>{html.escape(text)}</{tag}>"
    head = "".join(cell("th", h, cls(-1, j)) for j, h in enumerate(heads))
    body = "".join("<tr>" + "".join(cell("td", c, cls(i, j)) for j, c in enumerate(r)) + "</tr>"
                   for i, r in enumerate(rows))
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def figure_html(stem: str, alt: str, caption: str = "") -> str:
    """A figure of the page: ``stem``.png, linked to ``stem``.pdf."""
    cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    return (f"<figure><a href='{stem}.pdf'><img src='{stem}.png' alt='{html.escape(alt)}'></a>"
            f"{cap}</figure>")


def _json_safe(obj: Any) -> Any:
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    return obj


def write_json(path: Path, data: Any) -> None:
    """``data`` as JSON in ``path``, every non-finite number as null."""
    Path(path).write_text(json.dumps(_json_safe(data), indent=2, allow_nan=False) + "\n",
                          encoding="utf-8")


@dataclass
class Cell:
    computed: float
    paper: float
    rel: float
    se: float = math.nan          # standard error of the computed value, where the analysis gives one


def model_departures(scene: dict) -> list[str]:
    """Where a run's model and cost depart from the paper's description, in words, from the run's
    resolved scene (``{"case": ..., "fidelity": ...}`` as archived). Physics first, then cost."""
    case, fid = scene.get("case", {}) or {}, scene.get("fidelity", {}) or {}
    clo = case.get("closure", {}) or {}
    out = []
    if clo.get("model", "deardorff") != "deardorff":
        out.append(f"SGS closure {clo['model']} (the paper: Deardorff's TKE model)")
    elif clo.get("viscosity", "isotropic") != "anisotropic":
        out.append("one SGS eddy viscosity for every stress (closure.viscosity; the paper's eq. A1: "
                   "a horizontal and a vertical one)")
    if clo.get("delta", "scotti") == "scotti":
        # the paper's text takes the SGS length "from the grid spacing"; its ARPS uses
        # (dx dy dz)^(1/3) without a correction for flat cells
        out.append("the SGS filter length times Scotti et al.'s (1993) flat-cell factor "
                   "(closure.delta; the paper's ARPS: (dx dy dz)^(1/3))")
    spl = case.get("splash", {}) or {}
    if spl.get("impact_speed", "magnitude") != "magnitude":
        out.append("eqs. 6 and 8 of the normal impact speed |w| (splash.impact_speed; the paper: "
                   "the impact velocity, read as the speed)")
    if (case.get("forcing", {}) or {}).get("drive", "top") != "top":
        out.append("a mean pressure-gradient drive (the paper: a top drive)")
    q = fid.get("q_multiplier", 1.0)
    count = fid.get("parcels_per_m2")
    if count is not None:
        out.append(f"parcels {q:.3g}x the paper's Q, weighed for {count:g} airborne parcels per m2 "
                   "(the paper's rule for its Q, [28]; the count at Q from data/airborne_counts.toml)")
    elif q != 1.0:
        out.append(f"parcels {q:g}x heavier than the paper's Q")
    if (fid.get("spinup", {}) or {}).get("equilibrium_roughness"):
        read = ", ".join(str(n) for n in sorted(roughness_table()[0]))
        out.append("saltation started on the particle-free flow lowered to the level the model's "
                   f"saltating column settles to (z0s read from the model's own runs for cases "
                   f"{read}, Charnock's form with the model's C otherwise; "
                   "data/equilibrium_roughness.toml)")
    if ((fid.get("relaxation", {}) or {}).get("gain", 0.0) or 0.0) > 0:
        out.append("a column relaxation force over the first seconds of saltation")
    grid = fid.get("grid", {}) or {}
    dz0 = grid.get("dz_bottom")
    if dz0 is not None and dz0 > PAPER_FIRST_LAYER * 1.001:
        # z_m +24-38 % and G_tot +29-63 % from 2 cm to 1 cm in cases 2 and 6 (reports/investigations/grid-rungs)
        out.append(f"a first level of {100 * dz0:g} cm (the paper's: 1 cm)")
    dx = float(grid.get("Lx", math.nan)) / float(grid.get("nx", math.nan))
    if math.isfinite(dx) and dx > PAPER["setup"]["dx_m"] * 1.001:
        out.append(f"a horizontal spacing of {dx:.3g} m (the paper's: 0.10 m)")
    # the paper's text is silent on the scheme; its model, ARPS 5.1.5, advects momentum with
    # fourth-order quadratically conservative differences (Xue et al. 2000)
    if int((fid.get("time", {}) or {}).get("advection_order", 2) or 2) != 4:
        out.append("second-order horizontal advection (time.advection_order; the paper's ARPS: "
                   "fourth order)")
    return out


def _departures_text(ctx: ReportContext) -> str:
    """One sentence on the departures the study's runs share (the first run's, if they differ)."""
    seen = list(dict.fromkeys(d for run in ctx.runs.values() for d in model_departures(run.scene)))
    if not seen:
        return "Model as the paper describes it."
    return "Departures from the paper's model, in some or all runs: " + "; ".join(seen) + "."


def _start_text(ctx: ReportContext) -> str:
    """Whether the runs' u*s errors are one draw (cases starting at a shared spin-up's end) or
    staggered along it (``fidelity.spinup.stagger``)."""
    staggers = {float(((r.scene or {}).get("fidelity") or {}).get("spinup", {}).get("stagger") or 0.0)
                for r in ctx.runs.values()}
    if staggers and all(st > 0 for st in staggers):
        return (f"Cases sharing a spin-up start {', '.join(f'{st:g}' for st in sorted(staggers))} s "
                "apart along it (fidelity spinup.stagger), at different phases of its swings.")
    return ("Cases sharing a spin-up start from its one end state: their u*s errors are one draw "
            "of the swing, not independent.")


#: Table 2 variables with a standard error in analysis.nc
TABLE2_SE = {"u_star_s": "u_star_s_se", "u_star_s_stress": "u_star_s_stress_se"}


def _computed(c: Cell) -> str:
    return fmt(c.computed) + (f" ± {fmt(c.se, 2)}" if math.isfinite(c.se) else "")


def table2_rows(ctx: ReportContext) -> list[dict]:
    """One row per run, named by its label (a plain case: "case N"), the paper's values beside
    a run that is one of its cases unchanged (``RunData.paper_case``)."""
    table = paper_table2()
    rows = []
    # the runs labelled as a paper case (caseNN, caseNN@rung) by case number, a ladder's rungs
    # in the study's order; then the others in the study's order
    for r in sorted(ctx.runs.values(), key=lambda r: (case_number_of(r.label) or math.inf)):
        n = r.paper_case
        name = f"case {r.case}" if r.plain_case and r.case is not None else r.label
        row = {"name": name, "case": r.case, "label": r.label, "paper_case": n, "status": r.status,
               "saltation": saltation_state(r), "cells": {}}
        prow = table.get(n, {}) if n is not None else {}
        for var, pkey, _, _ in TABLE2_COLUMNS:
            c = r.scalar(var)
            p = prow.get(pkey, math.nan) if pkey else math.nan
            se = r.scalar(TABLE2_SE[var]) if var in TABLE2_SE else math.nan
            row["cells"][var] = Cell(c, p, rel_diff(c, p), se)
        rows.append(row)
    return rows


def _no_saltation(row: dict) -> bool:
    return row["status"] == "ok" and row["saltation"].status == NO_SALTATION


def st_below_one_height(run: RunData) -> float:
    """Lowest z/z_m in (0, 1] above which St < 1 everywhere up to z_m; the lowest level inside
    if St < 1 everywhere, NaN if undefined."""
    p, zm = profile(run, "St"), run.scalar("z_m")
    if p is None or not (math.isfinite(zm) and zm > 0):
        return math.nan
    zeta, st = p[0] / zm, p[1]
    inside = (zeta > 0) & (zeta <= 1.0) & np.isfinite(st)
    if not inside.any():
        return math.nan
    zeta, st = zeta[inside], st[inside]
    above = st >= 1.0
    if not above.any():
        return float(zeta[0])
    last = int(np.nonzero(above)[0].max())
    return float(zeta[last + 1]) if last + 1 < zeta.size else math.nan


def scalar_results(ctx: ReportContext) -> list[dict]:
    """The numbers the paper's text states, computed from this study's archives vs the paper."""
    ref = paper_results()
    rows: list[dict] = []

    def add(name, computed, paper, unit, how):
        ranged = isinstance(paper, (list, tuple))
        pstr = f"{fmt(paper[0])}–{fmt(paper[1])}" if ranged else fmt(paper)
        if isinstance(computed, (list, tuple)):   # a computed range beside the paper's
            lo, hi = computed
            cstr = f"{fmt(lo)}–{fmt(hi)}" if math.isfinite(lo) and math.isfinite(hi) else "—"
            rstr = (f"{_pct(rel_diff(lo, paper[0]))} / {_pct(rel_diff(hi, paper[1]))}"
                    if ranged else "—")
        else:
            cstr = fmt(computed)
            if not ranged:
                rstr = _pct(rel_diff(computed, paper))
            elif math.isfinite(computed):
                rstr = "inside range" if paper[0] <= computed <= paper[1] else "outside range"
            else:
                rstr = "—"
        rows.append({"quantity": name, "computed": cstr, "paper": pstr, "difference": rstr,
                     "unit": unit, "how": how,
                     "computed_value": computed, "paper_value": paper})

    def result(r: RunData | None) -> bool:
        """A run whose statistics are of saltation (report/saltation.py)."""
        return r is not None and r.ok and saltation_state(r).status != NO_SALTATION

    def value(n: int, name: str) -> float:
        r = ctx.by_case(n)
        return r.scalar(name) if result(r) else math.nan

    n_zm = sum(math.isfinite(value(n, "z_m")) for n in CASES_WIND)
    add("z_m, case 1 – case 6", [value(1, "z_m"), value(6, "z_m")],
        ref.get("fig4_zm_cases_1_to_6_m", [math.nan, math.nan]), "m",
        f"z_m of case 1 and case 6 (cases 1–6 present with z_m: {n_zm})")
    sg = [v for r in ctx.scatter_runs()
          if result(r) and math.isfinite(v := r.scalar("sigma_G_over_G_tot"))]
    add("σG/G_tot, range over cases", [min(sg), max(sg)] if sg else [math.nan, math.nan],
        ref.get("fig13_sigmaG_over_Gtot", [math.nan, math.nan]), "1",
        f"min and max over the {len(sg)} runs with a value")
    add("τp surface fraction, case 6", value(6, "tau_p_surface_fraction"),
        ref.get("fig6_taup_surface_fraction_case6", math.nan), "1",
        "τp at the bed (exponential fit of the lowest layers) / ρu*² at the reference height "
        "(analysis scalar tau_p_surface_fraction)")
    rc = [(n, v) for n in CASES_WIND if math.isfinite(v := value(n, "R_cu_upper"))]
    add("R_cu in the upper layer (z ≥ 0.6 z_m), mean of cases 1–6",
        float(np.mean([v for _, v in rc])) if rc else math.nan,
        ref.get("fig11_Rcu_upper_layer", math.nan), "1",
        "mean of R_cu_upper over cases " + (", ".join(str(n) for n, _ in rc) or "none")
        + (f"; per case {', '.join(f'{v:.2f}' for _, v in rc)}" if rc else ""))
    hs = [(r, h) for r in ctx.scatter_runs() if result(r) and r.mu1 >= 200e-6 - 1e-9
          and math.isfinite(h := st_below_one_height(r))]
    add("height above which St < 1 (µ1 ≥ 200 µm), largest over cases",
        max(h for _, h in hs) if hs else math.nan,
        ref.get("fig12_St_below_1_above_z_over_zm", math.nan), "z/z_m",
        "lowest z/z_m above which St < 1 up to z_m, computed from the St profile by the report; "
        + ("per case " + ", ".join(f"{r.label}: {h:.2f}" for r, h in hs) if hs else "no profile"))
    return rows


def table2_markdown(ctx: ReportContext) -> str:
    heads = ["run"] + [f"{lab} [{unit}]" for _, _, lab, unit in TABLE2_COLUMNS]
    cells = []
    for row in table2_rows(ctx):
        if row["status"] != "ok" or _no_saltation(row):
            # u*s, u*t: escaped, or their asterisks would open emphasis
            why = (f"*{row['status']}*" if row["status"] != "ok" else
                   f"**{NO_SALTATION}**: " + row["saltation"].reason.replace("*", "\\*"))
            cells.append([row["name"], why] + [""] * (len(heads) - 2))
            continue
        cells.append([row["name"]])
        for var, pkey, _, _ in TABLE2_COLUMNS:
            c = row["cells"][var]
            paper = pkey and row["paper_case"] is not None
            cells[-1].append(_computed(c) + (f" / {fmt(c.paper)}" if paper else "")
                             + (f" ({_pct(c.rel)})" if paper and math.isfinite(c.rel) else ""))
    lines = [f"# Table 2 — computed beside {PAPER_LABEL}", "",
             f"Study `{ctx.study}`. One row per run. Each cell: computed / paper (relative "
             "difference); the paper's value only beside a run that is one of its cases "
             "unchanged (a different seed aside), none beside a case of one's own. "
             "“—”: not given by the paper or undefined in the run. A run whose u*s is below the "
             f"fluid threshold u*t, or whose parcels aloft fall below those released, is marked "
             f"“{NO_SALTATION}” with the numbers that show it, not its statistics. "
             "u*s ± its standard error "
             "over the 3-D samples (the scatter of the per-sample fits). u*s is the free log-law "
             "fit above the saltation layer; “u*s, stress at z_ref” is the paper's own reading "
             "(section 3.1: u* from ⟨u'w'⟩ at 2 m) and leads the table; z0s with it is the paper's "
             "roughness regression. The drive feeds u*s² of momentum in at the top (through a 20-s "
             "lag); over a short window the stress at 2 m departs from it by what the column "
             "above 2 m gains or loses (`saltstudy probe column-budget`) and with the box's slow "
             "swings (its bar: the standard error of 10-s block means, which a window of a few "
             "blocks underrates): started at the saltating column's level the `reduced` study's "
             "ten 30-s windows read −2.5 % on average (−13 to +7 %; the column's storage +0.005 "
             "u*s², a ~0.1 swing either way), after the bed-stress relaxation +11 % (−7 to +19 %, "
             "the column still draining; reports/reduced/FINDINGS.md); `quick`'s 12-s window "
             "reads within about ±40 %. " + _start_text(ctx) + " " + _departures_text(ctx), "",
             *md_table(heads, cells)]
    lines += ["", f"## Results stated in the text — computed vs {PAPER_LABEL}", "",
              *md_table(_RESULT_HEADS, [[r[k] for k in _RESULT_KEYS] for r in scalar_results(ctx)])]
    return "\n".join(lines) + "\n"


def table2_dataset(ctx: ReportContext):
    """Table 2 as an xarray Dataset along ``run`` (:func:`table2_rows`' order): per column the
    computed value (SI), ``<name>_paper``, ``<name>_rel_diff`` and ``<name>_se`` where they
    exist; NaN statistics for a run without an archive or saltation (``status``, ``saltation``,
    ``saltation_reason`` say why)."""
    import xarray as xr

    rows = table2_rows(ctx)
    run = [r["label"] for r in rows]

    def column(values, units: str, long_name: str, dtype=float) -> xr.DataArray:
        return xr.DataArray(np.asarray(values, dtype=dtype), dims=("run",),
                            attrs={"units": units, "long_name": long_name})

    shown = [r["status"] == "ok" and not _no_saltation(r) for r in rows]
    data: dict[str, xr.DataArray] = {}
    for var, pkey, lab, unit in TABLE2_COLUMNS:
        cells = [r["cells"][var] if ok else Cell(math.nan, math.nan, math.nan)
                 for r, ok in zip(rows, shown)]
        data[var] = column([c.computed for c in cells], unit, lab)
        if var in TABLE2_SE:
            data[f"{var}_se"] = column([c.se for c in cells], unit, f"standard error of {lab}")
        if pkey:
            data[f"{var}_paper"] = column([c.paper for c in cells], unit, f"{lab}, {PAPER_LABEL}")
            data[f"{var}_rel_diff"] = column([c.rel for c in cells], "1",
                                             f"{lab}: (computed - paper) / paper")
    data["paper_case"] = column([-1 if r["paper_case"] is None else r["paper_case"] for r in rows],
                                "1", "the paper's case the run is, unchanged (-1: a case of one's own)",
                                int)
    for name, values, long_name in (
            ("status", [r["status"] for r in rows], "the run's archive: ok, or why not"),
            ("saltation", [r["saltation"].status for r in rows],
             "whether the run holds saltation (report/saltation.py)"),
            ("saltation_reason", [r["saltation"].reason for r in rows],
             "the numbers that decide it")):
        data[name] = column(values, "1", long_name, str)
    return xr.Dataset(data, coords={"run": ("run", run, {"long_name": "the run's label"}),
                                    "name": ("run", [r["name"] for r in rows],
                                             {"long_name": "the row's name in the report"})},
                      attrs={"title": f"Table 2 — computed beside {PAPER_LABEL}", "study": ctx.study,
                             "model": _departures_text(ctx)})


_RESULT_HEADS = ["quantity", "computed", "paper", "difference", "unit", "how computed"]
_RESULT_KEYS = ("quantity", "computed", "paper", "difference", "unit", "how")


def _no_result_html(row: dict, span: int, no_saltation: str, out: list[str]) -> bool:
    """Close ``out``'s row with one cell saying why the run has no statistics, if it has none."""
    if row["status"] != "ok":
        out.append(f'<td class="missing" colspan="{span}">{html.escape(row["status"])}</td></tr>')
    elif _no_saltation(row):
        out.append(f'<td class="nosalt" colspan="{span}">{html.escape(no_saltation)}</td></tr>')
    return row["status"] != "ok" or _no_saltation(row)


def table2_html(ctx: ReportContext) -> str:
    """Table 2 as two HTML tables that fit a 1280 px page: the columns the paper gives per case
    (computed, paper, difference) and the computed-only columns. Headers wrap; numbers do not
    (right-aligned in tabular figures: the CSS of report/build.py)."""
    rows = table2_rows(ctx)
    e = html.escape
    cols = [c for c in TABLE2_COLUMNS if c[1]]
    only = [c for c in TABLE2_COLUMNS if not c[1]]
    out = [f'<table class="t2"><caption>Computed beside {e(PAPER_LABEL)}: value, the paper\'s '
           f"value (grey) and the difference (computed − paper)/paper, the paper's only beside a "
           f"run that is one of its cases unchanged. {e(_departures_text(ctx))}</caption>"
           '<thead><tr><th rowspan="2" class="run">run</th>']
    for _, _, lab, unit in cols:
        out.append(f'<th colspan="3" class="grp">{e(lab)} [{e(unit)}]</th>')
    out.append("</tr><tr>" + "<th>computed</th><th class='ref'>paper</th><th>diff.</th>" * len(cols)
               + "</tr></thead><tbody>")
    for row in rows:
        own = "<span class='se'> (own case)</span>" \
            if row["paper_case"] is None and row["status"] == "ok" else ""
        out.append(f"<tr><td class='run'>{e(row['name'])}{own}</td>")
        if _no_result_html(row, 3 * len(cols), f"{NO_SALTATION}: {row['saltation'].reason}", out):
            continue
        for var, _, _, _ in cols:
            c = row["cells"][var]
            se = f"<span class='se'> ± {fmt(c.se, 2)}</span>" if math.isfinite(c.se) else ""
            cls = "bad" if math.isfinite(c.rel) and abs(c.rel) > 0.25 else ""
            out.append(f"<td>{fmt(c.computed)}{se}</td><td class='ref'>{fmt(c.paper)}</td>"
                       f"<td class='{cls}'>{_pct(c.rel)}</td>")
        out.append("</tr>")
    out.append("</tbody></table>")
    if only:
        out.append('<table class="t2"><caption>Computed only (the paper does not give these per '
                   'case)</caption><thead><tr><th class="run">run</th>')
        out.extend(f"<th>{e(lab)} [{e(unit)}]</th>" for _, _, lab, unit in only)
        out.append("</tr></thead><tbody>")
        for row in rows:
            out.append(f"<tr><td class='run'>{e(row['name'])}</td>")
            if _no_result_html(row, len(only), NO_SALTATION, out):
                continue
            out.extend(f"<td>{e(_computed(row['cells'][var]))}</td>" for var, _, _, _ in only)
            out.append("</tr>")
        out.append("</tbody></table>")
    return "".join(out)


def results_html(ctx: ReportContext) -> str:
    return html_table(_RESULT_HEADS, [[r[k] for k in _RESULT_KEYS] for r in scalar_results(ctx)],
                      lambda i, j: {2: "ref", 5: "how" if i >= 0 else ""}.get(j, ""))
