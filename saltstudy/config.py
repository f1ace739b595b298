"""Validated, frozen configuration models for cases, fidelities, studies and resolved scenes.

A *case* (``cases/caseNN.toml``) fixes the physics of one run of Dupont et al. (2013, Table 2):
wind, soil, splash constants, physics switches, Q and the seed. A *fidelity*
(``workflows/fidelities/NAME.toml``) fixes only what costs: domain, grid, time-step policy,
durations, sampling and the parcel-count knob. A *study* (``workflows/NAME.toml``) names which cases
run at which fidelities; the rungs and variants only it runs sit in the folder named for it
(``workflows/NAME/``). A :class:`Scene` is one case resolved against one fidelity: everything the
solver needs, and nothing else.

All lengths in m, times in s, velocities in m s^-1, densities in kg m^-3, angles in degrees.
Defaults carry over the paper's values (sections 2.1-2.4, Appendix A); see ``data/dupont2013.toml``.
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any, Literal

from pydantic import (BaseModel, ConfigDict, Field, PrivateAttr, ValidationError, field_validator,
                      model_validator)

from .config_files import (ConfigError, case_path, deep_merge, list_case_numbers, locate_fidelity,
                           locate_study, own_fidelity_folder, project_root, read_toml)

__all__ = [
    "Air", "SoilMode", "Soil", "Splash", "Threshold", "Forcing", "Surface", "Physics", "Particles",
    "Case", "GridSpec", "TimeStepping", "SpinUp", "Sampling", "Outputs", "Fidelity", "SceneSpec",
    "Study", "Scene", "RunSpec", "ConfigError", "content_hash", "project_root", "load_case",
    "load_fidelity", "load_study", "resolve_scene", "case_path", "list_case_numbers", "deep_merge",
    "PAPER_AREA_M2", "study_runs", "study_file", "study_fidelity_folder", "validate_model",
    "validate_file",
]

# Horizontal area of the paper's domain (20 m x 15 m, section 2.4): the initial release of 10 000
# parcels is per this area.
PAPER_AREA_M2 = 20.0 * 15.0


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid", validate_default=True)

    def replace(self, **changes: Any) -> Any:
        """A validated copy with ``changes`` deep-merged in (a section takes a dict of the fields
        that change, a list is replaced whole): ``case.replace(forcing={"u_star_s": 0.47})``.
        Raises ConfigError naming the field (pydantic's ``model_copy(update=...)`` validates
        nothing)."""
        new = validate_model(type(self), deep_merge(self.model_dump(), changes),
                             f"{type(self).__name__}.replace")
        for name, value in (self.__pydantic_private__ or {}).items():   # a study's file
            setattr(new, name, value)
        return new


def content_hash(model: BaseModel | dict[str, Any], length: int = 16) -> str:
    """Stable SHA-256 of a model's JSON dump (independent of PYTHONHASHSEED and key order)."""
    data = model.model_dump(mode="json") if isinstance(model, BaseModel) else model
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:length]


# --------------------------------------------------------------------------------------------
# Case: the physics
# --------------------------------------------------------------------------------------------
class Air(_Frozen):
    """Air properties (neutral, dry). Paper: Boussinesq fluid, section 2.1."""
    rho: float = Field(1.2, gt=0, description="air density rho [kg m^-3]")
    nu: float = Field(1.5e-5, gt=0, description="molecular kinematic viscosity nu [m^2 s^-1]")
    g: float = Field(9.81, gt=0, description="gravity g [m s^-2]")
    kappa: float = Field(0.40, gt=0, lt=1, description="von Karman constant (paper: 0.40)")


class SoilMode(_Frozen):
    """One lognormal mode of the soil mass-size distribution (paper eq. 5)."""
    mass_fraction: float = Field(1.0, gt=0, le=1, description="m_j, mass fraction of the mode [-]")
    mu: float = Field(2.0e-4, gt=0, lt=0.01, description="mu_j, mass median diameter [m]")
    sigma: float = Field(1.2, gt=1.0, lt=5.0, description="sigma_j, geometric standard deviation [-] (> 1)")


class Soil(_Frozen):
    """Erodible bed: lognormal modes of the mass-size distribution and grain density."""
    modes: tuple[SoilMode, ...] = Field((SoilMode(),), min_length=1)
    rho_p: float = Field(2650.0, gt=0, description="grain density rho_p [kg m^-3] (quartz)")

    @model_validator(mode="after")
    def _fractions_sum_to_one(self) -> "Soil":
        total = sum(m.mass_fraction for m in self.modes)
        if abs(total - 1.0) > 1e-6:
            raise ValueError(f"mass fractions of the soil modes must sum to 1 (got {total:g})")
        return self

    @property
    def mean_diameter(self) -> float:
        """<d_p> = sum_j m_j mu_j [m], the mean soil diameter of eq. 8."""
        return sum(m.mass_fraction * m.mu for m in self.modes)


class Splash(_Frozen):
    """Splash constants, paper eqs. 6-9 (section 2.3)."""
    p_reb_max: float = Field(0.95, gt=0, le=1, description="asymptotic rebound probability, eq. 6")
    gamma_reb: float = Field(2.0, gt=0, description="gamma_reb [s m^-1], eq. 6")
    reb_speed_mean: float = Field(0.6, gt=0, description="<v_reb>/v_imp, eq. 7")
    reb_speed_std: float = Field(0.25, ge=0, description="sigma_reb/v_imp, eq. 7")
    reb_angle_v_mean: float = Field(30.0, gt=0, lt=90, description="<alpha_vreb> [deg]")
    reb_angle_v_std: float = Field(15.0, ge=0, description="sigma of alpha_vreb [deg]")
    reb_angle_h_mean: float = Field(0.0, ge=-90, le=90, description="<alpha_hreb> [deg]")
    reb_angle_h_std: float = Field(10.0, ge=0, description="sigma of alpha_hreb [deg]")
    a_ej: float = Field(0.03, gt=0, description="a of eq. 8 (Kok & Renno 2009 range 0.01-0.05)")
    ej_speed_mean: float = Field(0.08, gt=0, description="<v_ej>/v_imp, eq. 9 (Rice et al. 1995)")
    ej_angle_v_mean: float = Field(60.0, gt=0, lt=90, description="<alpha_vej> [deg]")
    ej_angle_v_std: float = Field(15.0, ge=0, description="sigma of alpha_vej [deg]")
    ej_angle_h_mean: float = Field(0.0, ge=-90, le=90, description="<alpha_hej> [deg]")
    ej_angle_h_std: float = Field(10.0, ge=0, description="sigma of alpha_hej [deg]")
    impact_layer: float = Field(5.0e-4, gt=0, lt=0.01, description="impact layer depth [m] (0.5 mm)")
    detection_step: float = Field(
        0.0, ge=0, lt=0.01, description="[s] 0: a grain's crossing of the impact layer's top is "
        "located exactly and its rebound and ejecta leave from there; > 0: the bed is met as a code "
        "stepping by this much meets it (the paper's model steps by 0.2 ms, its section 2.4): the "
        "grain is splashed where it is found inside the layer, its rebound and ejecta start there, "
        "and one still inside after the next such step is splashed again at its launch velocity "
        "(solver/grains/splash_kernels.py)")
    ejection_rounding: Literal["stochastic", "floor", "nearest"] = Field(
        "stochastic", description="how eq. 8's N_ej = a v_imp / sqrt(g <d>) becomes a whole number "
        "of ejected parcels, which the paper does not say: 'stochastic' rounding (floor plus one "
        "with probability the fraction: the mean is eq. 8's), its 'floor' (no ejecta below "
        "N_ej = 1, v_imp = 1.48 m/s for 200 um grains), or the 'nearest' integer")
    impact_speed: Literal["magnitude", "normal"] = Field(
        "magnitude", description="the v_imp of eqs. 6 and 8 (rebound probability, number of "
        "ejecta), which the paper calls the impact velocity: the impact speed |u_p| ('magnitude', "
        "as Anderson & Haff 1991 and Kok & Renno 2009 use it), or its component normal to the bed "
        "|w_p| ('normal'); eqs. 7 and 9 (rebound and ejection speeds) take |u_p| either way")
    launch_height: Literal["layer_top", "bed"] = Field(
        "layer_top", description="where a rebound and the ejecta leave from: the impact layer's top, "
        "where the impactor met it ('layer_top'), or the bed z = 0 ('bed'), from which a grain "
        "rises through the layer under gravity and, if it cannot leave it, meets the bed again "
        "at the top of its hop at its speed there (solver/grains/splash_kernels.py)")

    @model_validator(mode="after")
    def _one_bed(self) -> "Splash":
        if self.launch_height == "bed" and self.detection_step > 0:
            raise ValueError("launch_height: 'bed' launches every grain from z = 0, detection_step "
                             "> 0 from where it was found inside the layer; choose one")
        return self


class Threshold(_Frozen):
    """Shao & Lu (2000) threshold constants as used by the paper (section 3.1)."""
    A_N: float = Field(0.0123, gt=0)
    gamma: float = Field(3.0e-4, ge=0, description="cohesion constant gamma [kg s^-2]")


class Forcing(_Frozen):
    """Drive: the flow is held at friction velocity ``u_star_s`` above the saltation layer."""
    u_star_s: float = Field(..., gt=0, lt=5.0, description="target friction velocity u*s [m s^-1]")
    z_ref: float = Field(2.0, gt=0, description="height where u* is read and held [m] (paper: 2 m)")
    controller_timescale: float = Field(
        20.0, gt=0, description="relaxation time of the driving-velocity controller [s]")
    drive: Literal["top", "pressure_gradient"] = Field(
        "top", description="top (default, the paper's set-up): base-state wind through the Rayleigh "
        "layer with a slow u* controller, constant stress below it (on domains a few metres deep its "
        "core is Couette-like, kappa z/u* dU/dz ~ 0.6 at 0.5-1.5 m); pressure_gradient: mean body "
        "force, the stress falls linearly from rho u*s^2 at the bed and the log law holds in the lower "
        "third (solver/flow/forcing.py), but a run must spin up for a few hundred seconds to reach it")


class Surface(_Frozen):
    """Rigid bed: log-law stress at the first level."""
    z0: float = Field(1.0e-5, gt=0, lt=0.1, description="roughness length z0 [m] (paper: 10 um)")
    stress_level: Literal["first", "second"] = Field(
        "first", description="the wind the bulk drag law reads: the first level's, with "
        "C_d = [kappa / ln(z_1/z0)]^2 ('first', the paper's bulk law at the first level), or the "
        "second level's, with C_d = [kappa / ln(z_2/z0)]^2 ('second': the wind whose log law the "
        "first cell's grains see, the paper's [12])")
    stress_instant: Literal["stage", "step_start"] = Field(
        "stage", description="when the bed stress is evaluated: from each RK3 stage's wind "
        "('stage'), or once per step from the wind before the grains' drag of that step "
        "('step_start', as a model that forms its surface flux before the particle forcing)")


class Closure(_Frozen):
    """Turbulence closure: the SGS model and its options."""
    model: Literal["deardorff", "dynamic"] = Field(
        "deardorff", description="SGS model: 'deardorff', the paper's 1.5-order prognostic TKE closure "
        "with a fixed c_m (solver/closures/sgs.py); 'dynamic', the plane-averaged scale-dependent dynamic "
        "Smagorinsky model of Porte-Agel et al. (2000) and Bou-Zeid et al. (2005), with the SGS TKE of "
        "the paper's eq. A1 diagnosed in local equilibrium, grain sink included (solver/closures/dynamic.py)")
    dynamic_interval: int = Field(
        5, ge=1, le=100, description="steps between updates of the dynamic coefficient [-]")
    near_wall: bool = Field(
        False, description="near-wall mean-field eddy viscosity (solver/closures/nearwall.py): a mixing-length "
        "closure of the mean shear where the horizontal grid cannot resolve the wall eddies. Not in "
        "the paper; off by default: in the grain layer it pins the air's non-dimensional shear to 1 "
        "and quadruples z0s (case 2, reports/grainlayer/FINDINGS.md)")
    delta: Literal["scotti", "geometric"] = Field(
        "scotti", description="SGS filter width: (dx dy dz)^(1/3) times the anisotropy factor of "
        "Scotti, Meneveau & Lilly (1993) for flat cells ('scotti'), or without it ('geometric', "
        "Deardorff 1980) (solver/closures/sgs.py)")
    viscosity: Literal["isotropic", "anisotropic"] = Field(
        "isotropic", description="SGS eddy viscosity: one, with the filter length ('isotropic'), or "
        "a horizontal one with sqrt(dx dy) and a vertical one with dz ('anisotropic', the nu_th and "
        "nu_tv of the paper's eq. A1) (solver/closures/sgs.py)")
    two_part: bool = Field(
        False, description="the two-part model of Sullivan, McWilliams & Moeng (1994): the fluctuating "
        "eddy viscosity scaled by the isotropy factor gamma(z) and a mean-field viscosity that holds the "
        "log law at the first level (solver/closures/twopart.py); a departure from the paper's closure, on top "
        "of either model; excludes near_wall (both are mean-field terms)")
    near_wall_layer: tuple[float, float] = Field(
        (1.0, 3.0), description="(a, b): the near-wall term acts fully below a dx and fades to zero "
        "at b dx (dx: the horizontal grid spacing) [-]")

    @field_validator("near_wall_layer")
    @classmethod
    def _layer(cls, v: tuple[float, float]) -> tuple[float, float]:
        a, b = v
        if not (0.0 <= a < b):
            raise ValueError(f"near_wall_layer = {v}: need 0 <= a < b")
        return v

    @model_validator(mode="after")
    def _one_viscosity_when_dynamic(self) -> "Closure":
        if self.model == "dynamic" and self.viscosity != "isotropic":
            raise ValueError("viscosity: the dynamic model has one eddy viscosity; "
                             "'anisotropic' goes with model = 'deardorff'")
        if self.two_part and self.near_wall:
            raise ValueError("two_part: the two-part model carries its own mean-field viscosity; "
                             "set near_wall = false with it")
        return self


class Physics(_Frozen):
    """Process switches. Defaults are the paper's choices; a switched-off process is not constructed."""
    saltation: bool = Field(True, description="Lagrangian grains (off: flow only)")
    two_way_coupling: bool = Field(True, description="grain drag acts back on the air (eq. 2)")
    tke_particle_sink: bool = Field(True, description="SGS TKE sink by grain drag (eq. A1)")
    aerodynamic_entrainment: bool = Field(False, description="lift-off by the wind (off in the paper)")
    sgs_particle_velocity: bool = Field(False, description="stochastic SGS grain velocity (off in the paper)")
    temperature: bool = Field(False, description="potential-temperature equation (neutral: not needed)")

    @model_validator(mode="after")
    def _consistent(self) -> "Physics":
        if self.temperature:
            raise ValueError("temperature: a potential-temperature equation is not implemented; "
                             "the scenes of this study are neutral")
        if not self.saltation and (self.aerodynamic_entrainment or self.sgs_particle_velocity):
            raise ValueError("aerodynamic_entrainment/sgs_particle_velocity need saltation = true")
        return self


class Particles(_Frozen):
    """Computational parcels (each stands for Q real grains; paper section 2.1 and 2.4)."""
    Q: float = Field(..., gt=0, description="real grains per computational parcel [-]")
    n_initial: int = Field(10_000, gt=0, description="parcels released at activation, per 300 m^2")
    release_depth: float = Field(0.3, gt=0, description="release layer depth above the bed [m]")
    near_bed_wind: Literal["paper", "cell-drag", "first-level", "blend"] = Field(
        "paper", description="horizontal wind a grain sees in the first grid cell, and where its "
        "drag goes (solver/grains/interp.py). 'paper' (the paper's [12]): anywhere below the cell's top "
        "face z_f[1], the log law from the second level, ln(z/z0)/ln(z_c[1]/z0) u(z_c[1]), and "
        "the drag (momentum and TKE sink) goes back to the second level; trilinear above. "
        "'cell-drag' (the same wind, eq. 2's sum over the particles in each cell read literally): "
        "the drag of a first-cell grain goes to the first level, which it does not read. "
        "'first-level' ([12] in the indexing of the paper's model, ARPS, which counts a level "
        "below the ground): below the first level z_c[0] the log law from the first level, the drag "
        "there; trilinear above. 'blend' (a departure from the paper): that log law of the second "
        "level only below the first level z_c[0], with the drag on the first level, which the "
        "grain never read, and trilinear between the first two levels from z_c[0] up, so the seen "
        "wind jumps at z_c[0] by the first level's departure from the log law")


class Case(_Frozen):
    """One case of the study (one row of the paper's Table 2)."""
    number: int = Field(..., ge=0, description="case number (Table 2)")
    name: str = ""
    description: str = ""
    seed: int = Field(20130527, ge=0, description="random seed (flow perturbations and splash)")
    air: Air = Air()
    soil: Soil = Soil()
    splash: Splash = Splash()
    threshold: Threshold = Threshold()
    forcing: Forcing
    surface: Surface = Surface()
    closure: Closure = Closure()
    physics: Physics = Physics()
    particles: Particles

    @property
    def label(self) -> str:
        return self.name or f"case{self.number:02d}"


# --------------------------------------------------------------------------------------------
# Fidelity: the cost
# --------------------------------------------------------------------------------------------
class GridSpec(_Frozen):
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


class TimeStepping(_Frozen):
    """Adaptive time step: Delta t = min(CFL limit, diffusion limit, dt_max), and how the vertical
    SGS diffusion is integrated (numerics: a case means the same with either)."""
    scheme: Literal["rk3"] = "rk3"
    cfl: float = Field(0.8, gt=0, le=1.5, description="advective Courant number")
    diffusion_number: float = Field(
        0.4, gt=0, le=0.5, description="explicit diffusion limit: dt <= diffusion_number / "
        "max 2 nu (dx^-2 + dy^-2 [+ dz^-2 when the vertical diffusion is explicit])")
    dt_max: float = Field(0.05, gt=0, description="largest step [s]")
    dt_fixed: float | None = Field(None, gt=0, description="fixed step [s] (None: adaptive)")
    vertical_diffusion: Literal["explicit", "implicit"] = Field(
        "implicit", description="vertical SGS diffusion of u, v, w, e (and the SGS dissipation): "
        "'explicit' in the RK3 stages, its limit from the thinnest levels; 'implicit', a "
        "tridiagonal solve per column in each stage (solver/flow/vertical_diffusion.py), no vertical "
        "diffusion limit")
    implicit_weight: float = Field(
        0.5, ge=0.5, le=1.0, description="theta of the implicit vertical diffusion: 0.5 "
        "Crank-Nicolson in each stage (second order), 1 backward Euler (first order, damps the "
        "stiff modes at once)")
    advection_order: Literal[2, 4] = Field(
        2, description="horizontal order of the advection (momentum and SGS TKE) and of the "
        "projection's divergence and gradient: 2, or 4 (Morinishi et al. 1998, fully conservative; "
        "the paper's model ARPS advects momentum at fourth order); an integer because it is the "
        "order of the differences; the vertical stays second order (solver/flow/advection.py)")


class SpinUp(_Frozen):
    """Flow-only spin-up. Stops once steady (see solver.spinup) or at ``t_max``."""
    t_min: float = Field(..., ge=0, description="shortest spin-up [s]")
    t_max: float = Field(..., gt=0, description="longest spin-up [s]")
    window: float = Field(..., gt=0, description="averaging window of the steadiness test [s]")
    tolerance: float = Field(0.03, gt=0, description="relative change of u* and resolved TKE "
                                                    "between consecutive windows")
    u_star_ref: float | None = Field(
        None, gt=0, lt=5.0,
        description="spin up once at this friction velocity [m s^-1] and rescale the flow to each "
                    "case's u*s by Reynolds-number similarity (solver.similarity); None: spin up "
                    "at the case's own u*s. t_min, t_max and window are then times at u_star_ref")
    stagger: float = Field(
        0.0, ge=0, le=60.0,
        description="[s] case n starts its saltation from the spin-up continued particle-free for "
                    "(n - 1) x stagger more seconds (a chain shared by the cases), so that cases "
                    "sharing one spin-up start at different phases of its slow swings instead of "
                    "one; 0: every case starts from the spin-up's end")

    @model_validator(mode="after")
    def _order(self) -> "SpinUp":
        if self.t_min > self.t_max:
            raise ValueError("t_min must not exceed t_max")
        return self


class Sampling(_Frozen):
    """When statistics are taken, in seconds after saltation activation."""
    start: float = Field(..., ge=0, description="first 3-D sample [s after activation]")
    interval: float = Field(..., gt=0, description="time between 3-D samples [s]")
    count: int = Field(..., ge=1, description="number of 3-D samples")
    plane_interval: float = Field(0.1, gt=0, description="time between 2-D C_p, u(0.1 m) fields [s]")
    series_interval: float = Field(0.05, gt=0, description="time between series records [s]")

    @property
    def end(self) -> float:
        return self.start + (self.count - 1) * self.interval


class Relaxation(_Frozen):
    """Column relaxation after activation (solver/flow/relaxation.py): a uniform body force
    -K (tau_bed - u*s^2) / Lz that brings the particle-free column to the saltation equilibrium
    about (1 + K) times faster, switched off before sampling; and a top drive that answers the
    stress at z_ref (``stress_gain``). Both off by default: cost knobs for a short window, not the
    paper's physics."""
    gain: float = Field(0.0, ge=0, le=20, description="K [-]: 0 switches the relaxation off")
    timescale: float = Field(1.0, gt=0, description="running-mean time of the bed stress [s]")
    until: float = Field(0.0, ge=0, description="active until this time after activation [s]")
    stress_gain: float = Field(
        0.0, ge=0, le=10.0, description="K_p [-]: through the whole saltation run the top drive feeds "
        "u*s^2 - K_p (tau(z_ref) - u*s^2) instead of u*s^2, so a column out of balance returns to "
        "tau(z_ref) = u*s^2 about (1 + K_p) times faster, with the same fixed point "
        "(solver/flow/forcing.py); 0 switches it off")
    stress_timescale: float = Field(
        2.0, gt=0, le=60.0, description="T_s [s]: running-mean time of tau(z_ref) and lag of the drive "
        "when stress_gain > 0")


class Outputs(_Frozen):
    """What a run writes beyond what analysis needs."""
    full_snapshots: bool = Field(False, description="write full 3-D u, v, w, e at sampling times")
    animation: bool = Field(False, description="keep every C_p plane for an animation")


class Fidelity(_Frozen):
    """Cost knobs only: the same physics at every fidelity."""
    name: str
    description: str = ""
    grid: GridSpec
    time: TimeStepping = TimeStepping()
    spinup: SpinUp
    saltation_duration: float = Field(..., gt=0, description="saltation run length [s]")
    sampling: Sampling
    q_multiplier: float = Field(1.0, gt=0, description="Q is multiplied by this (fewer parcels)")
    checkpoint_interval_wall: float = Field(120.0, gt=0, description="wall-clock s between checkpoints")
    saltation_dt_fixed: float | None = Field(
        None, gt=0, description="fixed step of the saltation phase only [s] (None: adaptive); the "
        "stability study's deliberately too large step, run from a spin-up made with a stable one")
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


# --------------------------------------------------------------------------------------------
# Study
# --------------------------------------------------------------------------------------------
class SceneSpec(_Frozen):
    """An extra run of a study: a case with overrides (e.g. an extreme scene)."""
    label: str = Field(..., pattern=r"^[A-Za-z0-9_.\-]+$")
    case: int | str = Field(
        ..., description="a case number (cases/caseNN.toml) or the path of a case file; a relative "
        "path is relative to the directory of the study file (load_study makes it absolute)")
    fidelity: str | None = None
    overrides: dict[str, Any] = Field(default_factory=dict)
    expect: Literal["complete", "blow-up"] = Field(
        "complete", description="'blow-up': the scene must stop with a solver blow-up (a stability "
        "study's deliberately unstable step); run-all then fails if it completes instead")

    @field_validator("case")
    @classmethod
    def _case_ref(cls, v: int | str) -> int | str:
        if isinstance(v, int) and v < 0:
            raise ValueError(f"case = {v}: a case number is >= 0")
        if isinstance(v, str) and not v.strip():
            raise ValueError("case: an empty path; give a case number or a case file")
        return v


class Study(_Frozen):
    """Which cases run at which fidelities."""
    name: str = Field(..., pattern=r"^[A-Za-z0-9_.\-]+$")
    description: str = ""
    fidelity: str | None = Field(None, description="default fidelity of the study")
    fidelities: tuple[str, ...] = Field((), description="a ladder: every case runs at each")
    reference: str | None = Field(None, description="the fidelity of fidelities that the convergence "
                                  "report compares the others with (default: the last listed)")
    cases: tuple[int, ...] = ()
    ladder_cases: dict[str, tuple[int, ...]] = Field(
        default_factory=dict, description="a rung of fidelities that only some of cases run (a rung "
        "too costly for all): fidelity -> cases; every other rung runs every case")
    scenes: tuple[SceneSpec, ...] = ()
    report: bool = True
    flux_law: Literal["creyssels2009"] | None = Field(
        None, description="a measured flux law the report holds each run's G_tot against, at the "
        "run's own stress u* (report/fluxlaw.py): 'creyssels2009', the wind tunnel of Creyssels et "
        "al. (2009) for 242 um grains of 2500 kg m^-3")
    # the file load_study read (absolute; None for a study built in code): where the study's own
    # fidelities are looked up (study_fidelity_folder). Private: not part of what the study means.
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


class Scene(_Frozen):
    """One case resolved at one fidelity: everything one run needs."""
    label: str
    case: Case
    fidelity: Fidelity

    # Derived, cost-adjusted parcel settings.
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
        """Depth of the Rayleigh layer the model builds [m]: the fidelity's with the top drive,
        none with the pressure-gradient drive."""
        return self.fidelity.grid.damping_depth if self.case.forcing.drive == "top" else 0.0

    def spinup_scene(self) -> "Scene":
        """The scene the particle-free spin-up runs: this one, or with ``fidelity.spinup.u_star_ref``
        set, this one at that friction velocity (rescaled to u*s at activation)."""
        u_ref = self.fidelity.spinup.u_star_ref
        if u_ref is None or u_ref == self.case.forcing.u_star_s:
            return self
        forcing = self.case.forcing.model_copy(update={"u_star_s": float(u_ref)})
        return self.model_copy(update={"case": self.case.model_copy(update={"forcing": forcing})})

    @property
    def spinup_scale(self) -> float:
        """u*s / the spin-up's u* [1]: the similarity factor applied to the spun-up flow."""
        return self.case.forcing.u_star_s / self.spinup_scene().case.forcing.u_star_s

    def spinup_slice(self) -> dict[str, Any]:
        """What determines the particle-free spin-up (cases sharing it share one spin-up)."""
        c, f = self.spinup_scene().case, self.fidelity
        return {
            "air": c.air.model_dump(mode="json"),
            # when the bed stress is taken matters only beside the grains' drag
            "surface": c.surface.model_dump(mode="json", exclude={"stress_instant"}),
            "closure": c.closure.model_dump(mode="json"),
            "forcing": c.forcing.model_dump(mode="json"),
            "seed": c.seed,
            "grid": f.grid.model_dump(mode="json"),
            "time": f.time.model_dump(mode="json"),
            # where a case starts along the shared spin-up is the start's, not the spin-up's
            "spinup": f.spinup.model_dump(mode="json", exclude={"stagger"}),
        }

    @property
    def start_links(self) -> int:
        """Links of ``fidelity.spinup.stagger`` seconds between the spin-up's end and this case's
        start: case number - 1 when staggered, else 0."""
        st = self.fidelity.spinup.stagger
        return max(0, int(self.case.number) - 1) if st > 0 else 0


class RunSpec(BaseModel):
    """One run in a study: label and resolved scene."""
    model_config = ConfigDict(frozen=True)
    label: str
    scene: Scene


# --------------------------------------------------------------------------------------------
# Loading
# --------------------------------------------------------------------------------------------
def _format_errors(err: ValidationError, source: str) -> str:
    lines = [f"{source}: invalid configuration"]
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "extra_forbidden":
            msg = "unknown key (not a field of this section)"
        lines.append(f"  {loc}: {msg}")
    return "\n".join(lines)


def validate_model(cls: type[BaseModel], data: dict[str, Any], source: str) -> Any:
    try:
        return cls.model_validate(data)
    except ValidationError as err:
        raise ConfigError(_format_errors(err, source)) from None


def load_case(ref: int | str | Path, overrides: dict[str, Any] | None = None,
              root: Path | None = None) -> Case:
    """Load a case by number or path, apply ``overrides`` (deep-merged), validate."""
    if isinstance(ref, int) or (isinstance(ref, str) and ref.isdigit()):
        path = case_path(int(ref), root)
        if not path.exists():
            raise ConfigError(f"case {int(ref)}: unknown case (no {path})")
    else:
        path = Path(ref)
    data = read_toml(path)
    if overrides:
        data = deep_merge(data, overrides)
    return validate_model(Case, data, str(path))


def _fidelity_data(ref: str | Path, root: Path | None, own: Path | None = None,
                   chain: tuple[Path, ...] = ()) -> tuple[Path, dict]:
    """Raw TOML of a fidelity with its ``based_on`` parent deep-merged underneath (the file wins).
    A parent's name is looked up beside the file first, then in workflows/fidelities/: a study's
    own ``smoke.toml`` may be ``based_on = "smoke"``, the shared one."""
    path = locate_fidelity(ref, root, own)
    data = read_toml(path)
    base = data.pop("based_on", None)
    if base is None:
        return path, data
    if not isinstance(base, str):
        raise ConfigError(f"{path}: based_on: must be the name of another fidelity, or STUDY/NAME "
                          f"(got {base!r})")
    here = (*chain, path.resolve())
    try:
        parent_path = locate_fidelity(base, root, path.parent)
        if parent_path.resolve() == here[-1] and "/" not in base:
            parent_path = locate_fidelity(base, root, None)
        if parent_path.resolve() in here:
            names = " -> ".join(x.stem for x in (*here, parent_path))
            raise ConfigError(f"circular ({names})")
        _, parent = _fidelity_data(parent_path, root, None, here)
    except ConfigError as exc:
        raise ConfigError(f"{path}: based_on: {exc}") from None
    parent.pop("name", None)
    return path, deep_merge(parent, data)


def _load_fidelity(ref: str | Path, root: Path | None, own: Path | None) -> Fidelity:
    path, data = _fidelity_data(ref, root, own)
    data.setdefault("name", path.stem)
    return validate_model(Fidelity, data, str(path))


def load_fidelity(ref: str | Path, root: Path | None = None) -> Fidelity:
    """Load a fidelity by name (``workflows/fidelities/NAME.toml``), by ``STUDY/NAME`` (a study's
    own fidelity, ``workflows/STUDY/NAME.toml``) or by path. A file may start from another with
    ``based_on = "NAME"`` (a file beside it, else workflows/fidelities/) or ``"STUDY/NAME"`` and
    list only what differs (sections are deep-merged, the file wins)."""
    return _load_fidelity(ref, root, None)


def load_study(ref: str | Path, root: Path | None = None) -> Study:
    """Load a study by name, by its folder under workflows/ or by path. A scene's ``case`` that is a
    relative file path is taken relative to the directory of the study file and stored absolute,
    so that the study means the same case file from any working directory; an absolute path
    (``~`` expanded) is kept as is. The study's fidelity names resolve first among its own
    fidelities (:func:`study_fidelity_folder`), then in workflows/fidelities/."""
    path = locate_study(ref, root)
    data = read_toml(path)
    data.setdefault("name", path.stem)
    scenes = data.get("scenes")
    if isinstance(scenes, list):
        data["scenes"] = [_scene_case_from(path, s) for s in scenes]
    study = validate_model(Study, data, str(path))
    study._file = Path(os.path.abspath(path))
    return study


def study_file(study: Study) -> Path | None:
    """The file ``study`` was loaded from (None for a study built in code)."""
    return study._file


def study_fidelity_folder(study: Study) -> Path | None:
    """The folder of a study's own fidelities (config_files.own_fidelity_folder); None for a study
    built in code."""
    return own_fidelity_folder(study._file) if study._file is not None else None


def _scene_case_from(study_path: Path, scene: Any) -> Any:
    """``scene`` with a case file path made absolute against the study file's directory."""
    if not isinstance(scene, dict):
        return scene
    ref = scene.get("case")
    if not isinstance(ref, str) or not ref.strip() or ref.strip().isdigit():
        return scene
    p = Path(ref).expanduser()
    if not p.is_absolute():
        p = Path(os.path.abspath(study_path.parent / p))
    return {**scene, "case": str(p)}


def resolve_scene(case: Case, fidelity: Fidelity, label: str | None = None) -> Scene:
    return Scene(label=label or case.label, case=case, fidelity=fidelity)


def _scene_case(study: Study, scene: SceneSpec, root: Path | None) -> Case:
    """The case of a study's scene, its overrides applied. A reference that names no valid case
    is a ConfigError naming ``scenes.<label>.case``; overrides that make the case invalid, one
    naming ``scenes.<label>.overrides``."""
    where = f"study '{study.name}': scenes.{scene.label}"
    ref = scene.case
    if isinstance(ref, str) and not ref.strip().isdigit():
        p = Path(ref).expanduser()
        if not p.exists():
            raise ConfigError(f"{where}.case: no such case file {p}")
        if not p.is_file():
            raise ConfigError(f"{where}.case: {p} is not a file")
    try:
        case = load_case(ref, root=root)
    except ConfigError as exc:
        raise ConfigError(f"{where}.case: {exc}") from None
    if not scene.overrides:
        return case
    try:
        return load_case(ref, overrides=scene.overrides, root=root)
    except ConfigError as exc:
        raise ConfigError(f"{where}.overrides: {exc}") from None


def study_runs(study: Study, root: Path | None = None) -> list[RunSpec]:
    """Expand a study into its runs (each a resolved scene). Raises ConfigError on bad references."""
    runs: list[RunSpec] = []
    ladder = list(study.fidelities) or [study.fidelity]
    own = study_fidelity_folder(study)
    fid_cache: dict[str, Fidelity] = {}

    def fid(name: str, field: str) -> Fidelity:
        if name not in fid_cache:
            try:
                fid_cache[name] = _load_fidelity(name, root, own)
            except ConfigError as exc:
                raise ConfigError(f"study '{study.name}': {field}: {exc}") from None
        return fid_cache[name]

    if len(ladder) > 1:
        for fname in ladder:
            if "/" in fname:      # a rung's name is part of its runs' labels (case02@NAME)
                raise ConfigError(
                    f"study '{study.name}': fidelities: '{fname}': a rung is a NAME, of the study's "
                    f"own folder or of workflows/fidelities/ (a file there may be based_on = \"{fname}\")")
    for n in study.cases:
        case = load_case(n, root=root)
        for fname in ladder:
            if n not in study.ladder_cases.get(fname, study.cases):
                continue
            label = case.label if len(ladder) == 1 else f"{case.label}@{fname}"
            field = "fidelities" if study.fidelities else "fidelity"
            runs.append(RunSpec(label=label, scene=resolve_scene(case, fid(fname, field), label)))
    for s in study.scenes:
        case = _scene_case(study, s, root)
        case = case.model_validate({**case.model_dump(), "name": s.label})
        field = f"scenes.{s.label}.fidelity" if s.fidelity else "fidelity"
        scene = resolve_scene(case, fid(s.fidelity or study.fidelity, field), s.label)
        runs.append(RunSpec(label=s.label, scene=scene))
    labels = [r.label for r in runs]
    dup = {x for x in labels if labels.count(x) > 1}
    if dup:
        raise ConfigError(f"study '{study.name}': duplicate run labels {sorted(dup)}")
    return runs


def validate_file(path: Path) -> str:
    """Validate a case, fidelity or study file; return what it is. Raises ConfigError."""
    data = read_toml(path)
    if "forcing" in data or "particles" in data or "number" in data:
        load_case(path)
        return "case"
    if "grid" in data or "based_on" in data:
        load_fidelity(path)
        return "fidelity"
    study = load_study(path)
    study_runs(study)
    return "study"
