"""Table 2 beside the paper, and the scalar results the paper's text states, computed vs paper.

Table 2 has a row per run of the study. A row holds the computed value (from analysis.nc) and,
where the run is one of the paper's cases unchanged, the paper's value (from the package's copy of
the paper's numbers, reference only) and the relative difference (computed - paper) / paper.
Missing archives are rows saying so; values the paper does not give are "—"; a run without
sustained saltation (report/saltation.py) is a row giving the numbers that show it.
"""
from __future__ import annotations

import html
import math
from dataclasses import dataclass

import numpy as np

from .data import ReportContext, RunData, case_number_of, profile
from .reference import CASES_WIND, PAPER_LABEL, TABLE2_COLUMNS, paper_results, paper_table2
from .saltation import NO_SALTATION, saltation_state

__all__ = ["Cell", "model_departures", "table2_rows", "scalar_results", "table2_markdown", "table2_html",
           "results_markdown", "results_html", "st_below_one_height", "fmt", "rel_diff"]


def fmt(v: float | None, digits: int = 3) -> str:
    if v is None or not isinstance(v, (int, float)) or not math.isfinite(v):
        return "—"
    if v != 0 and (abs(v) < 1e-2 or abs(v) >= 1e4):
        return f"{v:.{digits - 1}e}"
    return f"{v:.{digits}g}"


def rel_diff(computed: float, ref: float) -> float:
    if not (math.isfinite(computed) and math.isfinite(ref)) or ref == 0:
        return math.nan
    return (computed - ref) / ref


def _pct(v: float) -> str:
    return f"{v:+.0%}" if math.isfinite(v) else "—"


@dataclass
class Cell:
    computed: float
    paper: float
    rel: float
    se: float = math.nan          # standard error of the computed value, where the analysis gives one


#: the paper's grid (Dupont et al. 2013, section 2.4): first level and horizontal spacing [m]
PAPER_DZ_BOTTOM = 0.01
PAPER_DX = 0.10


def model_departures(scene: dict) -> list[str]:
    """Where a run's model and cost depart from the paper's description, in words, from the run's
    resolved scene (``{"case": ..., "fidelity": ...}`` as archived). Physics first, then cost."""
    case, fid = scene.get("case", {}) or {}, scene.get("fidelity", {}) or {}
    clo = case.get("closure", {}) or {}
    out = []
    if clo.get("model", "deardorff") != "deardorff":
        out.append(f"SGS closure {clo['model']} (the paper: Deardorff's TKE model)")
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
    rl = fid.get("relaxation", {}) or {}
    if (rl.get("until", 0.0) or 0.0) > 0 and rl.get("target", "bed_stress") == "profile":
        out.append("a column relaxation over the first seconds of saltation: the mean wind above "
                   "the saltation layer nudged to the particle-free profile's shape")
    elif (rl.get("until", 0.0) or 0.0) > 0 and (rl.get("gain", 0.0) or 0.0) > 0:
        out.append("a column relaxation force over the first seconds of saltation")
    grid = fid.get("grid", {}) or {}
    dz0 = grid.get("dz_bottom")
    if dz0 is not None and dz0 > PAPER_DZ_BOTTOM * 1.001:
        # z_m +24-38 % and G_tot +29-63 % from 2 cm to 1 cm in cases 2 and 6 (reports/investigations/grid-rungs)
        out.append(f"a first level of {100 * dz0:g} cm (the paper's: 1 cm)")
    try:
        dx = float(grid["Lx"]) / float(grid["nx"])
    except (KeyError, TypeError, ValueError, ZeroDivisionError):
        dx = math.nan
    if math.isfinite(dx) and dx > PAPER_DX * 1.001:
        out.append(f"a horizontal spacing of {dx:.3g} m (the paper's: 0.10 m)")
    # the paper's text is silent on the scheme; its model, ARPS 5.1.5, advects momentum with
    # fourth-order quadratically conservative differences (Xue et al. 2000)
    if int((fid.get("time", {}) or {}).get("advection_order", 2) or 2) != 4:
        out.append("second-order horizontal advection (time.advection_order; the paper's ARPS: "
                   "fourth order)")
    return out


def _departures_text(ctx: ReportContext) -> str:
    """One sentence on the departures the study's runs share (the first run's, if they differ)."""
    seen: list[str] = []
    for run in ctx.runs.values():
        for d in model_departures(run.scene):
            if d not in seen:
                seen.append(d)
    if not seen:
        return "Model as the paper describes it."
    return "Departures from the paper's model, in some or all runs: " + "; ".join(seen) + "."


def _start_text(ctx: ReportContext) -> str:
    """Whether the runs' u*s errors are one draw: cases sharing a spin-up start at its end, or
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


def _row_order(ctx: ReportContext) -> list[RunData]:
    """Every run of the study once: those labelled as a paper case (``caseNN``, ``caseNN@rung``)
    by case number, a ladder's rungs in the study's order; then the others in the study's order."""
    runs = list(ctx.runs.values())
    cased = [r for r in runs if case_number_of(r.label) is not None]
    return sorted(cased, key=lambda r: case_number_of(r.label)) + \
        [r for r in runs if case_number_of(r.label) is None]


def table2_rows(ctx: ReportContext) -> list[dict]:
    """One row per run of the study, named by its label (a plain case: "case N"). The paper's
    values stand beside a run only where it is one of the paper's cases unchanged
    (``RunData.paper_case``); a run of one's own gets none. ``saltation`` says whether the run
    holds saltation (report/saltation.py); a run without is no result."""
    table = paper_table2()
    rows = []
    for r in _row_order(ctx):
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


def _no_saltation_text(row: dict) -> str:
    return f"{NO_SALTATION}: {row['saltation'].reason}"


def st_below_one_height(run: RunData) -> float:
    """Lowest z/z_m in (0, 1] above which St < 1 everywhere up to z_m; NaN if undefined."""
    p = profile(run, "St")
    if p is None:
        return math.nan
    return st_height(p[0], p[1], run.scalar("z_m"))


def st_height(z: np.ndarray, st: np.ndarray, zm: float) -> float:
    """Lowest z/z_m in (0, 1] above which the profile ``st`` at heights ``z`` [m] stays below 1
    up to z_m [m]; the lowest level inside if St < 1 everywhere, NaN if undefined."""
    if not (math.isfinite(zm) and zm > 0):
        return math.nan
    zeta = np.asarray(z, dtype=float) / zm
    st = np.asarray(st, dtype=float)
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

    def add(name, computed, paper, unit, how, compare="value"):
        if isinstance(paper, (list, tuple)):
            pstr = f"{fmt(paper[0])}–{fmt(paper[1])}"
        else:
            pstr = fmt(paper)
        if isinstance(computed, (list, tuple)):
            cstr = f"{fmt(computed[0])}–{fmt(computed[1])}" if all(math.isfinite(c) for c in computed) else "—"
            if isinstance(paper, (list, tuple)):
                rel = (rel_diff(computed[0], paper[0]), rel_diff(computed[1], paper[1]))
                rstr = f"{_pct(rel[0])} / {_pct(rel[1])}"
            else:
                rstr = "—"
        else:
            cstr = fmt(computed)
            if isinstance(paper, (list, tuple)):
                inside = math.isfinite(computed) and paper[0] <= computed <= paper[1]
                rstr = ("inside range" if inside else "outside range") if math.isfinite(computed) else "—"
            else:
                rstr = _pct(rel_diff(computed, paper))
        rows.append({"quantity": name, "computed": cstr, "paper": pstr, "difference": rstr,
                     "unit": unit, "how": how,
                     "computed_value": computed, "paper_value": paper})

    def result(r: RunData | None) -> bool:
        """A run whose statistics are of saltation (report/saltation.py)."""
        return r is not None and r.ok and saltation_state(r).status != NO_SALTATION

    zms = [ctx.by_case(n).scalar("z_m") for n in CASES_WIND if result(ctx.by_case(n))]
    zms = [z for z in zms if math.isfinite(z)]
    z1 = ctx.by_case(1).scalar("z_m") if result(ctx.by_case(1)) else math.nan
    z6 = ctx.by_case(6).scalar("z_m") if result(ctx.by_case(6)) else math.nan
    add("z_m, case 1 – case 6", [z1, z6], ref.get("fig4_zm_cases_1_to_6_m", [math.nan, math.nan]), "m",
        f"z_m of case 1 and case 6 (cases 1–6 present with z_m: {len(zms)})")
    sg = [r.scalar("sigma_G_over_G_tot") for r in ctx.scatter_runs() if result(r)]
    sg = [v for v in sg if math.isfinite(v)]
    add("σG/G_tot, range over cases", [min(sg), max(sg)] if sg else [math.nan, math.nan],
        ref.get("fig13_sigmaG_over_Gtot", [math.nan, math.nan]), "1",
        f"min and max over the {len(sg)} runs with a value")
    r6 = ctx.by_case(6)
    add("τp surface fraction, case 6",
        r6.scalar("tau_p_surface_fraction") if result(r6) else math.nan,
        ref.get("fig6_taup_surface_fraction_case6", math.nan), "1",
        "τp at the bed (exponential fit of the lowest layers) / ρu*² at the reference height "
        "(analysis scalar tau_p_surface_fraction)")
    rc = [(n, ctx.by_case(n).scalar("R_cu_upper")) for n in CASES_WIND if result(ctx.by_case(n))]
    rc = [(n, v) for n, v in rc if math.isfinite(v)]
    add("R_cu in the upper layer (z ≥ 0.6 z_m), mean of cases 1–6",
        float(np.mean([v for _, v in rc])) if rc else math.nan,
        ref.get("fig11_Rcu_upper_layer", math.nan), "1",
        "mean of R_cu_upper over cases " + (", ".join(str(n) for n, _ in rc) or "none")
        + (f"; per case {', '.join(f'{v:.2f}' for _, v in rc)}" if rc else ""))
    hs = []
    for r in ctx.scatter_runs():
        if result(r) and math.isfinite(r.mu1) and r.mu1 >= 200e-6 - 1e-9:
            h = st_below_one_height(r)
            if math.isfinite(h):
                hs.append((r, h))
    add("height above which St < 1 (µ1 ≥ 200 µm), largest over cases",
        max(h for _, h in hs) if hs else math.nan,
        ref.get("fig12_St_below_1_above_z_over_zm", math.nan), "z/z_m",
        "lowest z/z_m above which St < 1 up to z_m, computed from the St profile by the report; "
        + ("per case " + ", ".join(f"{r.label}: {h:.2f}" for r, h in hs) if hs else "no profile"))
    return rows


# ------------------------------------------------------------------------------------------------
# rendering
# ------------------------------------------------------------------------------------------------
def table2_markdown(ctx: ReportContext) -> str:
    rows = table2_rows(ctx)
    heads = ["run"]
    for _, pkey, lab, unit in TABLE2_COLUMNS:
        heads.append(f"{lab} [{unit}]")
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
             "blocks underrates): after the column relaxation the air above 2 m is out of balance "
             "and swings for more than a minute, and the `reduced` study's ten 30-s windows read "
             "+11 % on average (−7 to +19 %, reports/reduced/FINDINGS.md); `quick`'s 12-s window "
             "reads within about ±40 %. " + _start_text(ctx) + " " + _departures_text(ctx), "",
             "| " + " | ".join(heads) + " |", "|" + "---|" * len(heads)]
    for row in rows:
        if row["status"] != "ok":
            lines.append(f"| {row['name']} | " + " | ".join([f"*{row['status']}*"] + [""] * (len(heads) - 2)) + " |")
            continue
        if _no_saltation(row):
            # u*s, u*t: escaped, or their asterisks would open emphasis
            why = row["saltation"].reason.replace("*", "\\*")
            lines.append(f"| {row['name']} | " + " | ".join(
                [f"**{NO_SALTATION}**: {why}"] + [""] * (len(heads) - 2)) + " |")
            continue
        cells = [row["name"]]
        for var, pkey, _, _ in TABLE2_COLUMNS:
            c = row["cells"][var]
            s = _computed(c)
            if pkey and row["paper_case"] is not None:
                s += f" / {fmt(c.paper)}"
                if math.isfinite(c.rel):
                    s += f" ({_pct(c.rel)})"
            cells.append(s)
        lines.append("| " + " | ".join(cells) + " |")
    lines += ["", f"## Results stated in the text — computed vs {PAPER_LABEL}", "",
              results_markdown(ctx)]
    return "\n".join(lines) + "\n"


def results_markdown(ctx: ReportContext) -> str:
    lines = ["| quantity | computed | paper | difference | unit | how computed |",
             "|---|---|---|---|---|---|"]
    for r in scalar_results(ctx):
        lines.append(f"| {r['quantity']} | {r['computed']} | {r['paper']} | {r['difference']} | "
                     f"{r['unit']} | {r['how']} |")
    return "\n".join(lines)


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
        if row["status"] != "ok":
            out.append(f'<td class="missing" colspan="{3 * len(cols)}">{e(row["status"])}</td></tr>')
            continue
        if _no_saltation(row):
            out.append(f'<td class="nosalt" colspan="{3 * len(cols)}">{e(_no_saltation_text(row))}'
                       "</td></tr>")
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
            if row["status"] != "ok":
                out.append(f'<td class="missing" colspan="{len(only)}">{e(row["status"])}</td></tr>')
                continue
            if _no_saltation(row):
                out.append(f'<td class="nosalt" colspan="{len(only)}">{e(NO_SALTATION)}</td></tr>')
                continue
            out.extend(f"<td>{e(_computed(row['cells'][var]))}</td>" for var, _, _, _ in only)
            out.append("</tr>")
        out.append("</tbody></table>")
    return "".join(out)


def results_html(ctx: ReportContext) -> str:
    e = html.escape
    out = ["<table><thead><tr><th>quantity</th><th>computed</th><th class='ref'>paper</th>"
           "<th>difference</th><th>unit</th><th>how computed</th></tr></thead><tbody>"]
    for r in scalar_results(ctx):
        out.append(f"<tr><td>{e(r['quantity'])}</td><td>{e(r['computed'])}</td>"
                   f"<td class='ref'>{e(r['paper'])}</td><td>{e(r['difference'])}</td>"
                   f"<td>{e(r['unit'])}</td><td class='how'>{e(r['how'])}</td></tr>")
    out.append("</tbody></table>")
    return "".join(out)
