"""The study (which cases run at which fidelities, and extra scenes), the scene (one case resolved at
one fidelity: everything one run needs) and a study's runs."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, PrivateAttr, field_validator, model_validator

from .base import PAPER_AREA_M2, Frozen
from .case import Case
from .fidelity import Fidelity


class SceneSpec(Frozen):
    """An extra run of a study: a case with overrides (e.g. an extreme scene)."""
    label: str = Field(..., pattern=r"^[A-Za-z0-9_.\-]+$")
    case: int | str = Field(..., description="a case number or file (relative to the study's)")
    fidelity: str | None = None
    overrides: dict[str, Any] = Field(default_factory=dict)
    expect: Literal["complete", "blow-up"] = Field(
        "complete", description="'blow-up': run-all fails if the scene completes")

    @field_validator("case")
    @classmethod
    def _case_ref(cls, v: int | str) -> int | str:
        if isinstance(v, int) and v < 0:
            raise ValueError(f"case = {v}: a case number is >= 0")
        if isinstance(v, str) and not v.strip():
            raise ValueError("case: an empty path; give a case number or a case file")
        return v


class Study(Frozen):
    """Which cases run at which fidelities."""
    name: str = Field(..., pattern=r"^[A-Za-z0-9_.\-]+$")
    description: str = ""
    fidelity: str | None = Field(None, description="default fidelity of the study")
    fidelities: tuple[str, ...] = Field((), description="a ladder: every case runs at each")
    reference: str | None = Field(None, description="the convergence report's reference fidelity "
                                  "(default: the last listed)")
    cases: tuple[int, ...] = ()
    ladder_cases: dict[str, tuple[int, ...]] = Field(
        default_factory=dict, description="fidelity -> the cases that rung runs (default: all)")
    scenes: tuple[SceneSpec, ...] = ()
    report: bool = True
    flux_law: Literal["creyssels2009"] | None = Field(
        None, description="a measured flux law the report compares G_tot with (report/fluxlaw.py)")
    ladder_table: str | None = Field(
        None, description="an earlier convergence table (convergence.json, relative to the study "
        "file's folder) whose rungs this study's runs top: its report compares each case's rungs "
        "with the study's run of that case (report/convergence.py)")
    # the file load_study read (None for a study built in code), private: its fidelity folder
    _file: Path | None = PrivateAttr(None)

    @model_validator(mode="after")
    def _consistent(self) -> "Study":
        if not self.cases and not self.scenes:
            raise ValueError("a study needs at least one entry in cases or scenes")
        if self.cases and not (self.fidelity or self.fidelities):
            raise ValueError("fidelity: a study with cases needs a fidelity (or fidelities)")
        for s in self.scenes:
            if not (s.fidelity or self.fidelity):
                raise ValueError(f"scenes.{s.label}.fidelity: no fidelity for this scene")
        if self.reference is not None and self.reference not in self.fidelities:
            raise ValueError(f"reference: {self.reference!r} is not one of fidelities "
                             f"{list(self.fidelities)}")
        for fname, subset in self.ladder_cases.items():
            if fname not in self.fidelities:
                raise ValueError(f"ladder_cases.{fname}: not one of fidelities {list(self.fidelities)}")
            extra = sorted(set(subset) - set(self.cases))
            if extra:
                raise ValueError(f"ladder_cases.{fname}: cases {extra} are not in cases {list(self.cases)}")
        return self


class Scene(Frozen):
    """One case resolved at one fidelity: everything one run needs."""
    label: str
    case: Case
    fidelity: Fidelity
    #: the fidelity named by ``fidelity.spinup.tiled_from``, whose spin-up this scene starts from
    spinup_fidelity: Fidelity | None = None

    @property
    def Q(self) -> float:
        """Real grains per parcel after the fidelity's ``q_multiplier``."""
        return self.case.particles.Q * self.fidelity.q_multiplier

    @property
    def n_initial(self) -> int:
        """Parcels released at activation: the paper's 10 000 per 300 m^2, at equal released mass."""
        g = self.fidelity.grid
        n = self.case.particles.n_initial * (g.Lx * g.Ly) / PAPER_AREA_M2 / self.fidelity.q_multiplier
        return max(1, int(round(n)))

    @property
    def damping_depth(self) -> float:
        """Depth of the Rayleigh layer [m]: the fidelity's with the top drive, else none."""
        return self.fidelity.grid.damping_depth if self.case.forcing.drive == "top" else 0.0

    def spinup_scene(self) -> "Scene":
        """The scene the spin-up runs: this one (or this case at ``spinup_fidelity``), at that
        fidelity's ``spinup.u_star_ref`` if set."""
        scene = self
        if self.spinup_fidelity is not None:
            scene = Scene(label=self.label, case=self.case, fidelity=self.spinup_fidelity)
        u_ref = scene.fidelity.spinup.u_star_ref
        if u_ref is None or u_ref == self.case.forcing.u_star_s:
            return scene
        forcing = self.case.forcing.model_copy(update={"u_star_s": float(u_ref)})
        return scene.model_copy(update={"case": self.case.model_copy(update={"forcing": forcing})})

    def spinup_slice(self) -> dict[str, Any]:
        """What determines the particle-free spin-up (cases sharing it share one spin-up)."""
        sp = self.spinup_scene()
        c, f = sp.case, sp.fidelity
        return {
            **{k: getattr(c, k).model_dump(mode="json")
               for k in ("air", "surface", "closure", "forcing")},
            **{k: getattr(f, k).model_dump(mode="json") for k in ("grid", "time")}, "seed": c.seed,
            # where a case starts along the shared spin-up is the start's, not the spin-up's
            "spinup": f.spinup.model_dump(mode="json", exclude={"stagger", "tiled_from",
                                                                "equilibrium_roughness"}),
        }

    @property
    def start_links(self) -> int:
        """Stagger links between the spin-up's end and this case's start (case number - 1)."""
        st = self.fidelity.spinup.stagger
        return max(0, int(self.case.number) - 1) if st > 0 else 0


class RunSpec(BaseModel):
    """One run in a study: label and resolved scene."""
    model_config = ConfigDict(frozen=True)
    label: str
    scene: Scene
