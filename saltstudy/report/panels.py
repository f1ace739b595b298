"""Which run fills each place of a per-case figure (:func:`panel_runs`): the study's own run of
the paper's case when it has usable data, else the nearest run along the figure's parameter,
labelled with the case it stands in for (:meth:`PanelRun.stand_in`), else nothing (no empty
frame). Figs. 6, 7, 10, 11 and 12 hold a panel of cases 1–6 (u*s varies, µ1 = 200 µm) and one of
cases 2, 7–10 (µ1 varies, :func:`wind_and_soil`); Figs. 2, 5 and 9 look for their cases by u*s.

**Who may stand in.** One run per case number (``by_case``'s) and every run without one, each at
most once per figure, and only if it holds the parameter the figure keeps fixed within
:data:`HELD_TOLERANCE` of the paper's case: a 90 µm run in the picture of the wind's effect at
200 µm would confound µ1 with u*s.

**Nearest.** ``|ln(x_run / x_paper)|`` of the varied parameter (ratios alike: 90 to 100 µm is as
near as 360 to 400 µm), with the case's *target* u*s from its configuration (the value naming
the case in Table 2), not the computed one: that carries the run's sampling noise and the
fidelity's bias, and would let noise pick between runs at one target (cases 2, 9, 10 all 0.54).
Pairs (paper case, run) are assigned greedily from the nearest up, sorted by the distance along
the varied parameter, then the held one, the place in the figure, the run's case number (none
last) and its label: deterministic whatever the order of the study's runs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Iterable, Sequence

from .data import ReportContext, RunData
from .reference import CASES_SOIL, CASES_WIND, paper_table2

__all__ = ["BY_U_STAR_S", "BY_MU1", "HELD_TOLERANCE", "PanelRun", "Panel", "nearest_runs",
           "panel_runs", "wind_and_soil"]

#: the figure varies u*s (Fig. 9 rows, panels (a) of Figs. 6, 7, 10–12)
BY_U_STAR_S = "u*s"
#: the figure varies µ1 (panels (b) of Figs. 6, 7, 10–12)
BY_MU1 = "µ1"

#: relative departure of the held parameter within which a run stands in for a paper case: wide
#: enough for the paper's µ1 series (u*s 0.53–0.57 m s⁻¹), narrow enough to keep 0.41 m s⁻¹ out
HELD_TOLERANCE = 0.10


@dataclass(frozen=True)
class PanelRun:
    """The run drawn in the place of the paper's case ``paper_case``."""
    paper_case: int
    run: RunData
    by: str                 # BY_U_STAR_S or BY_MU1
    substitute: bool        # True: the run is another case, the nearest the study has

    def stand_in(self) -> str:
        """"(nearest to the paper's case N by u*s)" for a substitute, "" for the case itself."""
        return f"(nearest to the paper's case {self.paper_case} by {self.by})" if self.substitute else ""

    @property
    def key(self) -> str:
        """The name of the run's data in ``FigureResult.data``: ``caseN`` for the paper's case,
        ``<label>_for_caseN`` for a substitute."""
        return (f"{self.run.label}_for_case{self.paper_case}" if self.substitute
                else f"case{self.paper_case}")


@dataclass
class Panel:
    """The runs of one panel (row or axes) in the order of the paper's cases, and the notes on
    the study's own runs that could not be drawn (no archive, a quantity missing)."""
    runs: list[PanelRun]
    notes: list[str]


def _log_distance(a: float, b: float) -> float:
    if not (math.isfinite(a) and math.isfinite(b) and a > 0 and b > 0):
        return math.nan
    return abs(math.log(a / b))


def nearest_runs(slots: Sequence[int], candidates: Iterable[RunData], by: str,
                 tolerance: float = HELD_TOLERANCE) -> dict[int, RunData]:
    """Assign each paper case of ``slots`` at most one of ``candidates`` (each candidate at most
    once), nearest first along ``by`` (module docstring: distance, eligibility and ties).
    Returns ``{paper case: run}`` for the cases that got one."""
    vary, held = (0, 1) if by == BY_U_STAR_S else (1, 0)
    pairs = []
    cands = list(candidates)
    for place, n in enumerate(slots):
        row = paper_table2().get(n, {})      # (u*s [m s-1], µ1 [m]) of the paper's case
        paper = (float(row.get("u_star_s", math.nan)), float(row.get("mu1_um", math.nan)) * 1e-6)
        for j, r in enumerate(cands):
            mine = (r.u_star_s_target, r.mu1)
            d_held = _log_distance(mine[held], paper[held])
            d_vary = _log_distance(mine[vary], paper[vary])
            if (not (math.isfinite(d_vary) and math.isfinite(d_held))
                    or abs(mine[held] / paper[held] - 1.0) > tolerance):
                continue
            case_rank = (0, r.case) if r.case is not None else (1, 0)
            pairs.append(((d_vary, d_held, place, case_rank, r.label), n, j))
    pairs.sort(key=lambda p: p[0])
    out: dict[int, RunData] = {}
    used: set[int] = set()
    for _, n, j in pairs:
        if n not in out and j not in used:
            out[n] = cands[j]
            used.add(j)
    return out


def _pool(ctx: ReportContext) -> list[RunData]:
    """The runs that may stand in: one per case number (``by_case``'s), every run without one."""
    reps = (ctx.by_case(r.case) if r.case is not None else r for r in ctx.runs.values())
    return list({id(rep): rep for rep in reps if rep is not None}.values())


def panel_runs(ctx: ReportContext, slots: Sequence[int], by: str,
               usable: Callable[[RunData], str | None] | None = None) -> Panel:
    """The runs of a panel for the paper's cases ``slots`` varying ``by``.

    ``usable(run)`` returns None if the run can be drawn, else the reason it cannot (e.g. a
    quantity missing); the study's own run of a case that cannot be drawn is noted with that
    reason and its place is open to a substitute. A case the study does not hold is not noted:
    its place goes to the nearest run, or is dropped."""
    def why_not(r: RunData) -> str | None:
        if not r.ok:
            return r.status
        return usable(r) if usable is not None else None

    held = {n: r for n in slots if (r := ctx.by_case(n)) is not None}
    own = {n: r for n, r in held.items() if why_not(r) is None}
    notes = [f"case {n}: {why_not(r)}" for n, r in held.items() if n not in own]
    taken = {id(r) for r in own.values()}
    # a case the study holds but cannot draw does not stand in for another either
    cands = [r for r in _pool(ctx) if id(r) not in taken and why_not(r) is None]
    open_slots = [n for n in slots if n not in own]
    chosen = {**own, **nearest_runs(open_slots, cands, by)}
    return Panel([PanelRun(n, chosen[n], by, n not in own) for n in slots if n in chosen], notes)


def wind_and_soil(ctx: ReportContext, usable: Callable[[RunData], str | None]
                  ) -> list[tuple[Panel, tuple[int, ...], bool, str]]:
    """[(panel, its paper cases, whether µ1 varies, its name)] of the two panels of Figs. 6, 7,
    10, 11 and 12."""
    return [(panel_runs(ctx, CASES_WIND, BY_U_STAR_S, usable), CASES_WIND, False, "cases 1–6"),
            (panel_runs(ctx, CASES_SOIL, BY_MU1, usable), CASES_SOIL, True, "cases 2, 7–10")]
