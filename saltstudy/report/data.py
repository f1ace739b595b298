"""Loading analysis archives for the report: one :class:`RunData` per run label; a missing or
unreadable archive gives ``ds = None`` and a ``status`` saying why (drawn and tabled as missing).
"""
from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..ncio import open_dataset

__all__ = ["RunData", "ReportContext", "load_runs", "case_number_of", "paper_case_of"]

_CASE_RE = re.compile(r"^case(\d+)(?:@(.+))?$")


def case_number_of(label: str) -> int | None:
    m = _CASE_RE.match(label)
    return int(m.group(1)) if m else None


_UNREADABLE = object()

#: what a run may change and still be the paper's case: its name, its description, and the seed
#: (another realization of the same case)
_FREE_IN_A_PAPER_CASE = ("name", "description", "seed")


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) \
            and not isinstance(a, bool) and not isinstance(b, bool):
        return math.isclose(a, b, rel_tol=1e-9, abs_tol=0.0)
    return a == b


def paper_case_of(case: dict) -> Any:
    """The paper's case (Table 2) that ``case`` (``config.Case`` JSON as archived) is, unchanged:
    its row's u*s, µ1 and Q, every other setting the package's default (name, description and
    seed aside). None if it is no paper case; ``_UNREADABLE`` if ``config.Case`` cannot read it."""
    from ..config import Case
    from .reference import paper_table2
    try:
        mine = Case.model_validate(case).model_dump(mode="json")
    except Exception:  # noqa: BLE001 - fields config.Case does not know
        return _UNREADABLE
    row = paper_table2().get(int(mine["number"]))
    if row is None:
        return None
    paper = Case.model_validate({
        "number": mine["number"], "forcing": {"u_star_s": row["u_star_s"]},
        "soil": {"modes": [{"mu": row["mu1_um"] * 1e-6}]}, "particles": {"Q": row["Q"]},
    }).model_dump(mode="json")
    for k in _FREE_IN_A_PAPER_CASE:
        mine.pop(k, None)
        paper.pop(k, None)
    return int(mine["number"]) if _same(mine, paper) else None


@dataclass
class RunData:
    """One run: its label, case number, archive and what was read from it."""
    label: str
    case: int | None
    path: Path | None
    ds: xr.Dataset | None = None
    status: str = "ok"             # ok | no archive | unreadable: ...
    fidelity: str | None = None
    wall_time_s: float = math.nan
    scene: dict = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.ds is not None

    @property
    def plain_case(self) -> bool:
        """``caseNN``: a case of Table 2 run as is (not a ladder rung, not a scene)."""
        m = _CASE_RE.match(self.label)
        return bool(m) and m.group(2) is None

    @property
    def paper_case(self) -> int | None:
        """The paper's case this run is, unchanged (:func:`paper_case_of`); None for a case of
        one's own; the label's case number when ``config.Case`` cannot read the archived case."""
        case = self.scene.get("case") if isinstance(self.scene, dict) else None
        if isinstance(case, dict) and case:
            n = paper_case_of(case)
            if n is not _UNREADABLE:
                return n
        return case_number_of(self.label)

    def scalar(self, name: str) -> float:
        """A 0-d variable (SI units, as every analysis.nc); NaN if absent or the run is missing."""
        v = self.var(name)
        return float(v.values) if v is not None and v.ndim == 0 else math.nan

    def attr(self, name: str, default: float = math.nan) -> float:
        if self.ds is None:
            return default
        try:
            return float(self.ds.attrs.get(name, default))
        except (TypeError, ValueError):
            return default

    def has(self, *names: str) -> bool:
        return self.ds is not None and all(n in self.ds.variables for n in names)

    def var(self, name: str) -> xr.DataArray | None:
        return self.ds[name] if self.has(name) else None

    @property
    def rho(self) -> float:
        return self.attr("rho", 1.2)

    @property
    def u_star_s_target(self) -> float:
        """The case's u*s [m s-1] as configured (what the drive holds at the reference height),
        else the archive's ``u_star_target``; NaN if neither is known."""
        v = (self.scene.get("case", {}).get("forcing", {}) or {}).get("u_star_s")
        try:
            return float(v)
        except (TypeError, ValueError):
            return self.attr("u_star_target")

    @property
    def mu1(self) -> float:
        """Median diameter of the dominant soil mode [m] (from the archive's resolved scene)."""
        modes = self.scene.get("case", {}).get("soil", {}).get("modes") or []
        dominant = max(modes, key=lambda m: m.get("mass_fraction", 1.0)) if modes else {}
        return float(dominant.get("mu", math.nan))

    def damping_depth(self) -> float:
        """Depth of the Rayleigh layer of the run [m] (none with the pressure-gradient drive)."""
        if self.scene.get("case", {}).get("forcing", {}).get("drive", "top") != "top":
            return 0.0
        return float(self.scene.get("fidelity", {}).get("grid", {}).get("damping_depth", 0.0))

    def z_ref(self) -> tuple[float, str]:
        """(height, why) where Fig. 2 reads u_ref: the paper's 2 m, or min(forcing.z_ref,
        (Lz - damping_depth)/2) where the solver holds u* (docs/ARCHITECTURE.md, "Forcing")."""
        grid = self.scene.get("fidelity", {}).get("grid", {})
        lz = float(grid.get("Lz", self.attr("Lz", math.nan)))
        damp = self.damping_depth()
        zr = float(self.scene.get("case", {}).get("forcing", {}).get("z_ref", 2.0))
        z = min(2.0, zr)
        why = "2 m (paper)"
        if math.isfinite(lz) and 0.5 * (lz - damp) < z:
            z = 0.5 * (lz - damp)
            why = f"{z:.2g} m: highest height below half the undamped depth (domain {lz:g} m)"
        return z, why


@dataclass
class ReportContext:
    """All runs of a study, with the paper's case groupings resolved to runs."""
    study: str
    runs: dict[str, RunData]
    meta: dict[str, Any] = field(default_factory=dict)

    def by_case(self, n: int) -> RunData | None:
        """The run that stands for case ``n`` in the paper's figures: a plain ``caseNN`` label,
        else the ladder's rung with the largest wall time among the archives present (else the
        last listed), else the case's first scene with an archive."""
        plain = [r for r in self.runs.values() if r.case == n and r.plain_case]
        if plain:
            return plain[0]
        rungs = [r for r in self.runs.values() if r.case == n and case_number_of(r.label) == n]
        if not rungs:
            scenes = [r for r in self.runs.values() if r.case == n]
            return next((r for r in scenes if r.ok), scenes[0] if scenes else None)
        present = [r for r in rungs if r.ok]
        if present:
            timed = [r for r in present if math.isfinite(r.wall_time_s)]
            return max(timed, key=lambda r: r.wall_time_s) if timed else present[-1]
        return rungs[-1]

    def missing_note(self, n: int) -> str | None:
        """Why the study's run of case ``n`` has no data, for a figure; None if it has data or
        the study holds no run of case ``n``."""
        r = self.by_case(n)
        return f"case {n}: {r.status}" if r is not None and not r.ok else None

    def scatter_runs(self) -> list[RunData]:
        """Runs for the scatter figures (3, 4, 8, 13): every case (one per number) plus any
        other run with an archive (scenes), labelled by their label."""
        out: list[RunData] = []
        for r in self.runs.values():
            rep = self.by_case(r.case) if case_number_of(r.label) is not None else r
            if rep is not None and rep.ok and all(rep is not o for o in out):
                out.append(rep)
        return out


def _load_one(label: str, path: Path | None, case_hint: int | None) -> RunData:
    case = case_hint if case_hint is not None else case_number_of(label)
    path = Path(path) if path is not None else None
    if path is None or not path.is_file():
        return RunData(label, case, path, status="no archive")
    try:
        ds = open_dataset(path)
    except Exception as exc:  # unreadable/corrupt: drawn as missing, reason kept
        return RunData(label, case, path, status=f"unreadable ({type(exc).__name__})")
    scene = json.loads(ds.attrs.get("case_json") or "{}")
    if case is None:
        c = ds.attrs.get("case_number", scene.get("case", {}).get("number"))
        case = int(c) if c is not None else None
    fid = ds.attrs.get("fidelity") or scene.get("fidelity", {}).get("name")
    return RunData(label, case, path, ds=ds, fidelity=str(fid) if fid else None,
                   wall_time_s=float(ds.attrs.get("wall_time_s", math.nan)), scene=scene)


def load_runs(runs: dict[str, str | Path | None], meta: dict[str, Any] | None = None
              ) -> dict[str, RunData]:
    """Read every archive (under the NetCDF lock). ``meta`` may give ``case_numbers``,
    ``fidelities`` and ``wall_times`` per label; these win over the archives' attributes.
    Runs already read (all :class:`RunData`) are returned as they are."""
    if runs and all(isinstance(v, RunData) for v in runs.values()):
        return dict(runs)  # type: ignore[arg-type]
    cases, fids, walls = ((meta or {}).get(k) or {}
                          for k in ("case_numbers", "fidelities", "wall_times"))
    out: dict[str, RunData] = {}
    for label, path in runs.items():
        hint = cases.get(label)
        r = _load_one(label, path, int(hint) if hint is not None else None)
        if label in fids and fids[label]:
            r.fidelity = str(fids[label])
        if label in walls and math.isfinite(walls[label]):
            r.wall_time_s = float(walls[label])
        out[label] = r
    return out


def profile(run: RunData, name: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(z, values) of a profile on ``z``; None if absent."""
    v = run.var(name)
    if v is None or v.ndim != 1:
        return None
    dim = v.dims[0]
    z = run.ds[dim].values if dim in run.ds.coords else np.arange(v.size, dtype=float)
    return np.asarray(z, float), np.asarray(v.values, float)
