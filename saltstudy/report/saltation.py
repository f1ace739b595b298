"""Whether a run holds saltation, and its airborne grains in the paper's terms.

**No sustained saltation.** The model has no aerodynamic entrainment (as the paper): after the
release at activation, grains stay aloft only by rebounding and splashing others out. A run is
``no sustained saltation`` when the case's u*s is below the fluid threshold u*t of Shao & Lu
(2000) (``u_star_t``), or when fewer parcels are aloft on average over the sampling window
(``n_parcels_mean``) than were released: the splash does not replace the grains that land (in
sustained saltation the count grows far past the release: ≈ 60 times in the paper's case 2,
6 × 10⁵ against 10⁴ parcels, [31]). The report then shows these numbers, not its statistics.

**Airborne parcels at the case's Q.** A fidelity with ``q_multiplier`` M carries parcels of Q M
grains: ``n_parcels_per_m2_at_Q = n_parcels_mean × M / (Lx Ly)`` [m⁻²], beside the paper's
≈ 2,000 per m² (6 × 10⁵ parcels on its 20 m × 15 m bed in case 2, [31], Fig. 1; every case's Q
chosen for a similar number, [28]).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..analysis.paper_grid import PAPER_PARCELS_PER_M2
from ..config import PAPER_AREA_M2
from .data import RunData

__all__ = ["SUSTAINED", "NO_SALTATION", "UNDEFINED", "SaltationState", "saltation_state",
           "q_multiplier", "bed_area", "parcels_per_m2_at_Q", "n_parcels_per_m2_at_Q",
           "n_parcels_released", "PAPER_PARCELS_PER_M2", "PAPER_PARCELS_SOURCE", "STATE_UNITS"]

SUSTAINED = "sustained"
NO_SALTATION = "no sustained saltation"
UNDEFINED = "undefined"

#: where the paper's number of parcels per m² comes from
PAPER_PARCELS_SOURCE = "Dupont et al. 2013 [28], [31]"

#: units of the numbers of a :class:`SaltationState`
STATE_UNITS = {"u_star_s": "m s-1", "u_star_t": "m s-1", "n_parcels_released": "1",
               "n_parcels_mean": "1", "n_parcels_end": "1"}


def _case(run: RunData) -> dict:
    return run.scene.get("case") or {}


def q_multiplier(run: RunData) -> float:
    """M [1]: the run's parcels hold M times the case's Q grains. From the archive's parcel weight
    (attribute ``Q``) over the case's Q, else the fidelity's ``q_multiplier``, else 1."""
    q_run, q_case = run.attr("Q"), float((_case(run).get("particles") or {}).get("Q", math.nan))
    if math.isfinite(q_run) and math.isfinite(q_case) and q_run > 0 and q_case > 0:
        return q_run / q_case
    return float((run.scene.get("fidelity") or {}).get("q_multiplier", 1.0))


def bed_area(run: RunData) -> float:
    """Lx Ly [m²] of the run's domain (archive attributes, else the archived grid); NaN if unknown."""
    grid = (run.scene.get("fidelity") or {}).get("grid") or {}
    lx, ly = (run.attr(k, float(grid.get(k, math.nan))) for k in ("Lx", "Ly"))
    return lx * ly if lx > 0 and ly > 0 else math.nan


def parcels_per_m2_at_Q(run: RunData, n):
    """Parcel count(s) ``n`` of the run as parcels of the case's Q per m² of bed [m⁻²]."""
    return np.asarray(n, dtype=float) * q_multiplier(run) / bed_area(run)


def n_parcels_per_m2_at_Q(run: RunData) -> float:
    """Mean airborne parcels over the sampling window per m² of bed, at the case's Q [m⁻²]."""
    return float(parcels_per_m2_at_Q(run, run.scalar("n_parcels_mean")))


def n_parcels_released(run: RunData) -> float:
    """Parcels released at activation [1]: the case's ``n_initial`` per 300 m², scaled to the
    bed and divided by M (``config.Scene.n_initial``); NaN if the area is unknown."""
    n0 = float((_case(run).get("particles") or {}).get("n_initial", 10_000))
    n = n0 * bed_area(run) / PAPER_AREA_M2 / q_multiplier(run)
    return float(max(1, round(n))) if math.isfinite(n) else math.nan


@dataclass
class SaltationState:
    """Whether a run holds saltation (module docstring) and the numbers that say so."""
    status: str                  # SUSTAINED | NO_SALTATION | UNDEFINED
    reason: str
    u_star_s: float = math.nan   # the case's u*s [m s-1]
    u_star_t: float = math.nan   # fluid threshold [m s-1]
    n_parcels_released: float = math.nan   # [1]
    n_parcels_mean: float = math.nan       # over the sampling window [1]
    n_parcels_end: float = math.nan        # last record of the run [1]

    def to_json(self) -> dict:
        return {**asdict(self), "units": dict(STATE_UNITS)}


def _g(v: float) -> str:
    """A count: whole above 100, three significant digits below."""
    return "?" if not math.isfinite(v) else f"{v:.0f}" if abs(v) >= 100 else f"{v:.3g}"


def _ms(v: float) -> str:
    return f"{v:.3f}" if math.isfinite(v) else "?"


def saltation_state(run: RunData) -> SaltationState:
    """The run's :class:`SaltationState` (criterion: module docstring)."""
    if not run.ok:
        return SaltationState(UNDEFINED, run.status)
    us, ut = run.u_star_s_target, run.scalar("u_star_t")
    released, mean = n_parcels_released(run), run.scalar("n_parcels_mean")
    series = run.var("n_parcels")
    vals = np.asarray(series.values if series is not None else [], dtype=float)
    vals = vals[np.isfinite(vals)]
    end = float(vals[-1]) if vals.size else math.nan
    nums = dict(u_star_s=us, u_star_t=ut, n_parcels_released=released, n_parcels_mean=mean,
                n_parcels_end=end)
    below = math.isfinite(us) and math.isfinite(ut) and us < ut
    dies = math.isfinite(mean) and math.isfinite(released) and mean < released
    wind = (f"u*s = {_ms(us)} m s-1 {'below' if below else 'at or above'} the fluid threshold "
            f"u*t = {_ms(ut)} m s-1 (Shao & Lu 2000)")
    count = (f"{_g(mean)} parcels aloft on average over the sampling window against "
             f"{_g(released)} released at activation ({_g(end)} at the end of the run)")
    if below or dies:
        why = [wind] if below else []
        if dies:
            why.append(count + ": the splash does not replace the grains that land")
        elif math.isfinite(mean):
            why.append(count)
        return SaltationState(NO_SALTATION, "; ".join(why), **nums)
    if not (math.isfinite(us) and math.isfinite(ut) and math.isfinite(mean) and math.isfinite(released)):
        return SaltationState(UNDEFINED, f"{wind}; {count}", **nums)
    return SaltationState(SUSTAINED, f"{wind}; {count}", **nums)
