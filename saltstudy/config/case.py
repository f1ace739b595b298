"""The case: the physics of one run (one row of the paper's Table 2): air, soil, splash constants,
threshold, drive, bed, closure, process switches and parcels. Defaults are the paper's (sections
2.1-2.4, Appendix A; ``data/dupont2013.toml``)."""
from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from .base import Frozen


class Air(Frozen):
    """Air properties (neutral, dry). Paper: Boussinesq fluid, section 2.1."""
    rho: float = Field(1.2, gt=0, description="air density rho [kg m^-3]")
    nu: float = Field(1.5e-5, gt=0, description="molecular kinematic viscosity nu [m^2 s^-1]")
    g: float = Field(9.81, gt=0, description="gravity g [m s^-2]")
    kappa: float = Field(0.40, gt=0, lt=1, description="von Karman constant (paper: 0.40)")


class SoilMode(Frozen):
    """One lognormal mode of the soil mass-size distribution (paper eq. 5)."""
    mass_fraction: float = Field(1.0, gt=0, le=1, description="m_j, mass fraction of the mode [-]")
    mu: float = Field(2.0e-4, gt=0, lt=0.01, description="mu_j, mass median diameter [m]")
    sigma: float = Field(1.2, gt=1.0, lt=5.0, description="sigma_j, geometric standard deviation [-] (> 1)")


class Soil(Frozen):
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


class Splash(Frozen):
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
    impact_speed: Literal["magnitude", "normal"] = Field(
        "magnitude", description="v_imp of eqs. 6 and 8: the impact speed |u_p| ('magnitude', as "
        "Anderson & Haff 1991 and Kok & Renno 2009) or its normal part |w_p|; eqs. 7, 9 take |u_p|")


class Threshold(Frozen):
    """Shao & Lu (2000) threshold constants as used by the paper (section 3.1)."""
    A_N: float = Field(0.0123, gt=0)
    gamma: float = Field(3.0e-4, ge=0, description="cohesion constant gamma [kg s^-2]")


class Forcing(Frozen):
    """Drive: the flow is held at friction velocity ``u_star_s`` above the saltation layer."""
    u_star_s: float = Field(..., gt=0, lt=5.0, description="target friction velocity u*s [m s^-1]")
    z_ref: float = Field(2.0, gt=0, description="height where u* is read and held [m] (paper: 2 m)")
    controller_timescale: float = Field(
        20.0, gt=0, description="relaxation time of the driving-velocity controller [s]")
    drive: Literal["top", "pressure_gradient"] = Field(
        "top", description="top (the paper's): base-state wind through the Rayleigh layer with a "
        "u* controller, constant stress below; pressure_gradient: mean body force, linear stress, "
        "log law in the lower third after a few hundred seconds (solver/flow/forcing.py)")


class Surface(Frozen):
    """Rigid bed: the paper's bulk drag law C_d = [kappa / ln(z_1/z0)]^2 at the first level."""
    z0: float = Field(1.0e-5, gt=0, lt=0.1, description="roughness length z0 [m] (paper: 10 um)")


class Closure(Frozen):
    """Turbulence closure: the SGS model and its options."""
    model: Literal["deardorff", "dynamic"] = Field(
        "deardorff", description="'deardorff': the paper's 1.5-order TKE closure; 'dynamic': the "
        "scale-dependent dynamic Smagorinsky model (Porte-Agel et al. 2000, Bou-Zeid et al. 2005) "
        "with eq. A1's SGS TKE in local equilibrium (solver/closures/)")
    dynamic_interval: int = Field(
        5, ge=1, le=100, description="steps between updates of the dynamic coefficient [-]")
    delta: Literal["scotti", "geometric"] = Field(
        "scotti", description="filter width (dx dy dz)^(1/3) with the flat-cell factor of Scotti, "
        "Meneveau & Lilly (1993) or without it ('geometric', Deardorff 1980)")
    viscosity: Literal["isotropic", "anisotropic"] = Field(
        "isotropic", description="one eddy viscosity, or eq. A1's horizontal and vertical pair "
        "nu_th, nu_tv ('anisotropic')")

    @model_validator(mode="after")
    def _one_viscosity_when_dynamic(self) -> "Closure":
        if self.model == "dynamic" and self.viscosity != "isotropic":
            raise ValueError("viscosity: the dynamic model has one eddy viscosity; "
                             "'anisotropic' goes with model = 'deardorff'")
        return self


class Physics(Frozen):
    """Process switches. Defaults are the paper's choices; a switched-off process is not constructed."""
    saltation: bool = Field(True, description="Lagrangian grains (off: flow only)")
    two_way_coupling: bool = Field(True, description="grain drag acts back on the air (eq. 2)")
    tke_particle_sink: bool = Field(True, description="SGS TKE sink by grain drag (eq. A1)")


class Particles(Frozen):
    """Computational parcels (each stands for Q real grains; paper section 2.1 and 2.4)."""
    Q: float = Field(..., gt=0, description="real grains per computational parcel [-]")
    n_initial: int = Field(10_000, gt=0, description="parcels released at activation, per 300 m^2")
    release_depth: float = Field(0.3, gt=0, description="release layer depth above the bed [m]")


class Case(Frozen):
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
