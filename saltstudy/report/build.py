"""``build_report``: figures 1-13 (png, pdf), Table 2 beside the paper (table2.md, .html),
summary.json, the convergence, stability and flux-law sections a study calls for, the C_p
animation and one self-contained index.html, from a study's analysis archives.
"""
from __future__ import annotations

import html
import json
import math
from collections import Counter
from pathlib import Path
from typing import Any

from .data import ReportContext, case_number_of, load_runs
from .figures import CAPTIONS, error_figure, make_figures
from .reference import PAPER_LABEL
from .plotting import save_figure
from .saltation import NO_SALTATION
from .summary import build_summary, finish_wall_time, run_key
from .tables import (figure_html, html_table, results_html, table2_html, table2_markdown,
                     write_json)

__all__ = ["build_report"]

FINDINGS_FILE = "FINDINGS.md"   # hand-written discussion kept beside a committed report

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;max-width:1200px;
margin:1.5em auto;padding:0 1em;color:#222;line-height:1.4}
h1{font-size:1.6em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.8em}
table{border-collapse:collapse;font-size:.85em;margin:.6em 0}
th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right}
th{background:#f3f3f3}td:first-child,th:first-child{text-align:left}
td.ref,th.ref{color:#777;background:#fafafa}td.missing{color:#b22;text-align:center;font-style:italic}
table.t2 td.nosalt{color:#8a5a00;text-align:left;font-style:italic;white-space:normal}
td.bad{color:#b22;font-weight:bold}td.how{text-align:left;font-size:.9em;color:#555}
figure{margin:1.2em 0}figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:.9em;color:#444}.notes{color:#b22;font-size:.85em}.findings{white-space:pre-wrap;font-size:.9em}
pre{background:#f6f6f6;padding:.8em;overflow:auto;font-size:.8em;max-height:30em}
.meta td{text-align:left}
table.t2{font-size:.8em;font-variant-numeric:tabular-nums;margin:.8em 0 1.2em}
table.t2 caption{text-align:left;font-size:1.05em;color:#444;padding-bottom:.3em}
table.t2 th{white-space:normal;vertical-align:bottom;padding:.2em .35em}
table.t2 th.grp{text-align:center}table.t2 th.run,table.t2 td.run{text-align:left}
table.t2 td{white-space:nowrap;padding:.2em .35em}table.t2 .se{color:#555;font-size:.9em}
"""


#: the optional sections' anchors and names in the page's links
_SECTIONS = {"findings": "Findings", "convergence": "Convergence", "stability": "Stability",
             "fluxlaw": "Flux law"}


def _is_ladder(ctx: ReportContext) -> bool:
    rungs = Counter(case_number_of(label) for label in ctx.runs if "@" in label)
    return any(n >= 2 for case, n in rungs.items() if case is not None)


def build_report(study_name: str, runs: dict[str, str | Path | None], report_dir: str | Path,
                 meta: dict[str, Any] | None = None) -> Path:
    """Build the report of ``study_name`` from ``runs`` (label -> analysis.nc path or None) into
    ``report_dir``; ``meta``'s keys: docs/ARCHITECTURE.md (``build_report``). Returns index.html."""
    from .study_meta import enrich_meta
    meta = enrich_meta(study_name, meta)
    report_dir = Path(report_dir)
    report_dir.mkdir(parents=True, exist_ok=True)
    ctx = ReportContext(study_name, load_runs(runs, meta), meta)

    results = make_figures(ctx)
    fig_notes: dict[str, list[str]] = {}
    formats = tuple(meta.get("figure_formats") or ("png", "pdf"))
    dpi = float(meta.get("figure_dpi", 110))
    for name, res in results.items():
        fig_notes[name] = res.notes
        try:
            save_figure(res.fig, report_dir, name, dpi, formats)
        except Exception as exc:  # a figure that cannot be rendered is replaced by its error
            save_figure(error_figure(name, exc), report_dir, name, dpi, formats)
            fig_notes[name] = res.notes + [f"error: {type(exc).__name__}: {exc}"]

    (report_dir / "table2.md").write_text(table2_markdown(ctx), encoding="utf-8")
    t2 = table2_html(ctx)
    rs = results_html(ctx)
    (report_dir / "table2.html").write_text(
        _page(f"Table 2 — {study_name}", f"<h1>Table 2 — computed beside {PAPER_LABEL}</h1>{t2}"
                                         f"<h2>Results stated in the text</h2>{rs}"), encoding="utf-8")
    summary = build_summary(ctx)      # written last, when the elapsed wall time is known

    wanted = set(meta.get("reports") or [])
    provenance = {k: meta.get(k) for k in ("study", "package_version", "commit", "source_key")}
    sections: list[str] = []
    if "convergence" in wanted or _is_ladder(ctx) or meta.get("ladder_table"):
        from .convergence import build_convergence_report
        conv = build_convergence_report(ctx.runs, report_dir, order=meta.get("order"),
                                        reference=meta.get("reference"), provenance=provenance,
                                        prior=meta.get("ladder_table"))
        sections.append("<h2 id='convergence'>Error against run time</h2>" + conv["summary_html"] +
                        "<p>Relative difference of each statistic from the reference rung and error "
                        "against the paper, versus the wall-clock time of the run (spin-up + saltation). Reference "
                        f"rung: <b>{html.escape(str(conv['result'].finest))}</b> (the study's "
                        "<code>reference</code> fidelity, else the finest rung)"
                        + (f"; the rungs below this study's runs are those of "
                           f"<code>{html.escape(Path(meta['ladder_table']).name)}</code>, the "
                           "study's <code>ladder_table</code>" if meta.get("ladder_table") else "")
                        + ".</p>"
                        + figure_html("convergence", "error against run time") + conv["html"])
    if "stability" in wanted or meta.get("failures") or meta.get("has_scenes") \
            or (any(case_number_of(l) is None for l in ctx.runs) and not _is_ladder(ctx)):
        from .stability import build_stability_report
        stab = build_stability_report(
            ctx.runs, report_dir, failures=meta.get("failures"), samples=meta.get("samples"),
            checkpoints=meta.get("checkpoints"), expect_blowup=set(meta.get("expect_blowup") or ()),
            provenance=provenance)
        sections.append("<h2 id='stability'>Stability of the scenes</h2>" + stab["html"])

    law = (meta.get("study_config") or {}).get("flux_law")
    if law:
        from .fluxlaw import build_fluxlaw_report
        fl = build_fluxlaw_report(ctx.runs, report_dir, law)
        sections.append("<h2 id='fluxlaw'>Total flux against a measured flux law</h2>" + fl["html"])

    anim_html = ""
    first = [ctx.by_case(1), ctx.by_case(2)] + list(ctx.runs.values())
    anim_label = meta.get("animation_label") or next((r.label for r in first if r and r.ok), None)
    if anim_label:
        from .animation import make_animation
        r = ctx.runs.get(anim_label)
        sp = ((meta.get("samples") or {}).get(anim_label)
              or (r.ds.attrs.get("samples_path") if r is not None and r.ok else None))
        gif = make_animation(report_dir / "cp_animation.gif", r.path if r else None, sp,
                             title=f"{anim_label}: C_p / C_p,max",
                             max_frames=int(meta.get("animation_frames", 30)))
        if gif is not None:
            anim_html = (f"<h2 id='animation'>Animation of C_p ({html.escape(anim_label)})</h2>"
                         "<figure><img src='cp_animation.gif' alt='C_p animation'></figure>")

    index = report_dir / "index.html"
    findings = report_dir / FINDINGS_FILE
    if findings.is_file():
        # the hand-written comparison with the paper kept beside a committed report: it survives
        # a rebuild (only generated files are rewritten) and is shown verbatim
        sections.insert(0, "<h2 id='findings'>Findings: where the run agrees with the paper and why "
                           f"not where it does not</h2><p>From <a href='{FINDINGS_FILE}'>{FINDINGS_FILE}</a>"
                           "; written by hand from this report's numbers.</p><pre class='findings'>"
                           + html.escape(findings.read_text(encoding="utf-8")) + "</pre>")
    finish_wall_time(summary, meta, report_dir / "summary.json")
    write_json(report_dir / "summary.json", summary)
    index.write_text(_index(ctx, summary, fig_notes, t2, rs, sections, anim_html), encoding="utf-8")
    return index


def _page(title: str, body: str) -> str:
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}"
            f"</title><style>{_CSS}</style></head><body>{body}</body></html>\n")


def _fmt_s(v: Any) -> str:
    if not isinstance(v, (int, float)) or not math.isfinite(v):
        return "—"
    if v >= 3600:
        return f"{v:.0f} s ({v / 3600:.2f} h)"
    if v >= 60:
        return f"{v:.0f} s ({v / 60:.1f} min)"
    return f"{v:.1f} s"


def _resumed_note(summary: dict[str, Any]) -> str:
    """Say so when the wall time is one leg of a resumed study: its tasks' recorded times exceed
    what the machine's cores could have run in it, so most of them came from the cache."""
    total, tasks = summary.get("total_wall_time_s"), summary.get("task_time_sum_s")
    cores = (summary.get("machine") or {}).get("cores") or 1
    try:
        resumed = float(tasks) > 1.05 * float(total) * float(cores)
    except (TypeError, ValueError):
        return ""
    return (" — the last run-all only: the rest came from the cache, computed earlier "
            "(the sum of task times below is the study's cost)") if resumed else ""


def _index(ctx, summary, fig_notes, t2, rs, sections, anim_html) -> str:
    e = html.escape
    meta = ctx.meta
    m = summary["machine"]
    n_ok = sum(1 for r in ctx.runs.values() if r.ok)
    a, b = summary.get("run_started"), summary.get("run_finished")
    started = f" ({e(str(a))} to {e(str(b))})" if a and b else ""
    split = ", ".join(f"{k} {_fmt_s(v)}" for k, v in (summary.get("task_times_s") or {}).items())
    parts = [f"<h1>saltstudy report — study <code>{e(ctx.study)}</code></h1>",
             f"<p>A reproduction of Dupont, Bergametti, Marticorena &amp; Simoëns (2013), <i>Modeling "
             f"saltation intermittency</i>, J. Geophys. Res. Atmos. 118. Computed values are drawn in "
             f"colour; the paper's numbers, where it gives them, in grey and labelled "
             f"“{PAPER_LABEL}”. {n_ok} of {len(ctx.runs)} runs have an analysis archive.</p>",
             "<table class='meta'>" + "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in (
                 ("study", e(ctx.study)), ("fidelity", e(str(summary["fidelity"]))),
                 ("package version", e(str(summary["package_version"]))),
                 ("wall time, start to end", _fmt_s(summary["total_wall_time_s"]) + started
                  + _resumed_note(summary)),
                 ("sum of task times", f"{_fmt_s(summary['task_time_sum_s'])} ({split}; a shared "
                                       "spin-up counted once)"),
                 ("machine", f"{m['cores']} cores, {e(m['processor'])} ({e(m['platform'])})")))
             + "</table>",
             "<p><a href='#tables'>Table 2</a> · <a href='#figures'>Figures</a> · "
             "<a href='#runs'>Runs and wall time</a> · <a href='#config'>Configuration</a> · "
             "<a href='summary.json'>summary.json</a> · <a href='table2.md'>table2.md</a>"
             + "".join(f" · <a href='#{k}'>{name}</a>" for k, name in _SECTIONS.items()
                       if any(f"id='{k}'" in s for s in sections)) + "</p>",
             f"<h2 id='tables'>Table 2 — computed beside {PAPER_LABEL}</h2>",
             "<p>One row per run: computed value, the paper's value (grey) and the relative "
             "difference (computed − paper)/paper, red when larger than 25 %; the paper's value "
             "only beside a run that is one of its cases unchanged. A run without sustained "
             "saltation (u*s below u*t, or fewer parcels aloft than released) shows the numbers "
             "that say so instead of statistics. The paper gives no per-case z0s, "
             "z_m, G_tot or σG/G_tot (only figures).</p>", t2,
             "<h3>Results stated in the paper's text</h3>", rs,
             "<h2 id='figures'>Figures</h2>"]
    for name, cap in CAPTIONS.items():
        notes = fig_notes.get(name) or []
        nh = f"<div class='notes'>{'<br>'.join(e(n) for n in notes)}</div>" if notes else ""
        parts.append(f"<figure id='{name}'><a href='{name}.pdf'><img src='{name}.png' alt='{name}'></a>"
                     f"<figcaption><b>{name.replace('fig', 'Figure ').replace(' 0', ' ')}.</b> {e(cap)} "
                     f"(<a href='{name}.pdf'>PDF</a>)</figcaption>{nh}</figure>")
    parts.extend(sections)
    if anim_html:
        parts.append(anim_html)
    parts.append("<h2 id='runs'>Runs and wall time</h2><p>Solver time per run: its spin-up + its "
                 "saltation run (a spin-up shared by several runs appears in each of them).</p>")
    cells, bad = [], []
    for r in ctx.runs.values():
        salt = (summary.get("cases", {}).get(run_key(r), {}) or {}).get("saltation") or {}
        status = r.status + (f", {salt['status']}" if r.ok and salt.get("status") == NO_SALTATION else "")
        cells.append([r.label, "" if r.case is None else str(r.case), str(r.fidelity or "—"),
                      status, _fmt_s(r.wall_time_s), str(r.path) if r.path else "—"])
        bad.append(not r.ok or status != r.status)
    parts.append(html_table(["run", "case", "fidelity", "status", "solver time", "archive"], cells,
                            lambda i, j: "bad" if i >= 0 and j == 3 and bad[i] else ""))
    cfg = meta.get("study_config")
    parts.append("<h2 id='config'>Study configuration</h2>"
                 + (f"<pre>{e(json.dumps(cfg, indent=2))}</pre>" if cfg is not None else
                    "<p>not provided</p>"))
    parts.append("<p style='font-size:.8em;color:#777'>Fig. 2: u_ref is ⟨u⟩ at 2 m as in the paper, or, "
                 "if the domain is too shallow, at half the undamped depth (where the solver holds u*); "
                 "the height used is drawn on the figure.</p>")
    return _page(f"saltstudy — {ctx.study}", "\n".join(parts))
