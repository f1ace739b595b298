"""The fidelity: what a run costs, never its physics: domain and grid, time stepping and its numerics,
spin-up, saltation length, sampling, the parcel weight, the column relaxation, checkpoints."""
from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from .base import Frozen


class GridSpec(Frozen):
    """Domain and grid. Uniform in x, y; stretched cubically in the level index in z."""
    Lx: float = Field(..., gt=0, description="domain length [m]")
    Ly: float = Field(..., gt=0, description="domain width [m]")
    Lz: float = Field(..., gt=0, description="domain height [m]")
    nx: int = Field(..., ge=4)
    ny: int = Field(..., ge=4)
    nz: int = Field(..., ge=4)
    dz_bottom: float = Field(0.01, gt=0, description="first level thickness [m]")
    dz_top: float | None = Field(None, gt=0, description="top level thickness [m] (None: free)")
    damping_depth: float = Field(3.0, ge=0, description="Rayleigh damping layer depth [m]")
    damping_timescale: float = Field(5.0, gt=0, description="Rayleigh damping time at the lid [s]")

    @model_validator(mode="after")
    def _fits(self) -> "GridSpec":
        if self.damping_depth >= self.Lz:
            raise ValueError(f"damping_depth ({self.damping_depth} m) must be less than the domain "
                             f"height Lz ({self.Lz} m)")
        if self.dz_bottom * self.nz >= self.Lz:
            raise ValueError(f"dz_bottom*nz ({self.dz_bottom * self.nz:g} m) must be below Lz "
                             f"({self.Lz} m) for a grid stretched upwards")
        if self.dz_top is not None and self.dz_top < self.dz_bottom:
            raise ValueError("dz_top must not be smaller than dz_bottom")
        return self

    @property
    def dx(self) -> float:
        return self.Lx / self.nx

    @property
    def dy(self) -> float:
        return self.Ly / self.ny

    @property
    def n_cells(self) -> int:
        return self.nx * self.ny * self.nz


class TimeStepping(Frozen):
    """Adaptive step of the RK3 flow step: min(CFL limit, diffusion limit, dt_max), and the flow's
    numerics (solver/flow/stepper.py)."""
    cfl: float = Field(0.8, gt=0, le=1.5, description="advective Courant number")
    diffusion_number: float = Field(
        0.4, gt=0, le=0.5, description="explicit diffusion limit: dt <= diffusion_number / "
        "max 2 nu (dx^-2 + dy^-2 [+ dz^-2 when the vertical diffusion is explicit])")
    dt_max: float = Field(0.05, gt=0, description="largest step [s]")
    dt_fixed: float | None = Field(None, gt=0, description="fixed step [s] (None: adaptive)")
    vertical_diffusion: Literal["explicit", "implicit"] = Field(
        "implicit", description="vertical SGS diffusion: 'explicit' in the RK3 stages (limited by "
        "the thinnest levels), or 'implicit', a tridiagonal solve per column and stage")
    implicit_weight: float = Field(
        0.5, ge=0.5, le=1.0, description="theta of the implicit vertical diffusion: 0.5 "
        "Crank-Nicolson, 1 backward Euler (damps the stiff modes at once)")
    advection_order: Literal[2, 4] = Field(
        2, description="horizontal order of the advection and the projection: 2, or 4 (Morinishi "
        "et al. 1998; the paper's ARPS advects momentum at fourth order); vertical: second order")
    precision: Literal["double", "single"] = Field(
        "double", description="the flow's fields and stencils in float64, or float32 ('single'); "
        "the pressure solve and the grains stay float64 (docs/BENCHMARKS.md)")


class SpinUp(Frozen):
    """Flow-only spin-up. Stops once steady (see solver.spinup) or at ``t_max``."""
    t_min: float = Field(..., ge=0, description="shortest spin-up [s]")
    t_max: float = Field(..., gt=0, description="longest spin-up [s]")
    window: float = Field(..., gt=0, description="averaging window of the steadiness test [s]")
    tolerance: float = Field(0.03, gt=0, description="relative change of u* and resolved TKE "
                                                    "between consecutive windows")
    u_star_ref: float | None = Field(
        None, gt=0, lt=5.0, description="spin up once at this u* [m s^-1] (times at it), rescale "
        "to each case's u*s by similarity (solver.similarity); None: at the case's own u*s")
    stagger: float = Field(
        0.0, ge=0, le=60.0, description="[s] case n starts from the spin-up continued "
        "(n - 1) x stagger more seconds, spreading the cases over its slow swings; 0: from its end")
    tiled_from: str | None = Field(
        None, description="a fidelity whose spin-up (and stagger) this grid starts from, tiled in "
        "x and y at the same spacing and interpolated in z (solver/tiling.py): a start for a grid "
        "whose own spin-up cannot be afforded; None: this fidelity's own spin-up")
    equilibrium_roughness: bool = Field(
        False, description="start saltation with the mean wind lowered at every level by "
        "(u*s / kappa) ln(z0s / z0), z0s the case's saltation-equilibrium roughness the model "
        "measured (data/equilibrium_roughness.toml): the column starts at the level it settles "
        "to over the saltating bed instead of the smooth bed's (docs/USAGE.md)")

    @model_validator(mode="after")
    def _order(self) -> "SpinUp":
        if self.t_min > self.t_max:
            raise ValueError("t_min must not exceed t_max")
        if self.tiled_from is not None and self.stagger > 0:
            raise ValueError("stagger: a start tiled from another fidelity's spin-up is not "
                             "staggered (its links would run on the source's grid); use 0")
        return self


class Sampling(Frozen):
    """When statistics are taken, in seconds after saltation activation."""
    start: float = Field(..., ge=0, description="first 3-D sample [s after activation]")
    interval: float = Field(..., gt=0, description="time between 3-D samples [s]")
    count: int = Field(..., ge=1, description="number of 3-D samples")
    plane_interval: float = Field(0.1, gt=0, description="time between 2-D C_p, u(0.1 m) fields [s]")
    series_interval: float = Field(0.05, gt=0, description="time between series records [s]")

    @property
    def end(self) -> float:
        return self.start + (self.count - 1) * self.interval


class Relaxation(Frozen):
    """Column relaxation after activation (solver/flow/relaxation.py): a body force -K (tau_bed -
    u*s^2) / Lz reaching the saltation equilibrium ~(1 + K) times faster, off before sampling; a
    cost knob, off by default."""
    gain: float = Field(0.0, ge=0, le=20, description="K [-]: 0 switches the relaxation off")
    timescale: float = Field(1.0, gt=0, description="running-mean time of the bed stress [s]")
    until: float = Field(0.0, ge=0, description="active until this time after activation [s]")


class Outputs(Frozen):
    """What a run writes beyond what analysis needs."""
    full_snapshots: bool = Field(False, description="write full 3-D u, v, w, e at sampling times")
    animation: bool = Field(False, description="keep every C_p plane for an animation")


class Fidelity(Frozen):
    """Cost knobs only: the same physics at every fidelity."""
    name: str
    description: str = ""
    grid: GridSpec
    time: TimeStepping = TimeStepping()
    spinup: SpinUp
    saltation_duration: float = Field(..., gt=0, description="saltation run length [s]")
    sampling: Sampling
    q_multiplier: float = Field(1.0, gt=0, description="Q is multiplied by this (fewer parcels)")
    parcels_per_m2: float | None = Field(
        None, gt=0, description="[m^-2] weigh each case's parcels for about this many airborne per "
        "m2, as the paper chose Q ([28]): q_multiplier from data/airborne_counts.toml "
        "(config/loading.py); None: q_multiplier as given")
    checkpoint_interval_wall: float = Field(120.0, gt=0, description="wall-clock s between checkpoints")
    saltation_dt_fixed: float | None = Field(
        None, gt=0, description="fixed step of the saltation phase only [s] (None: adaptive)")
    relaxation: Relaxation = Relaxation()
    outputs: Outputs = Outputs()

    @model_validator(mode="after")
    def _sampling_inside_run(self) -> "Fidelity":
        if self.sampling.end > self.saltation_duration + 1e-9:
            raise ValueError(f"sampling ends at {self.sampling.end:g} s, after the saltation run "
                             f"({self.saltation_duration:g} s)")
        if self.relaxation.gain > 0 and self.relaxation.until > self.sampling.start + 1e-9:
            raise ValueError(f"relaxation.until ({self.relaxation.until:g} s) must not exceed "
                             f"sampling.start ({self.sampling.start:g} s): the sampled flow must run free")
        return self
