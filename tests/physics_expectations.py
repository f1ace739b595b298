"""The laws' analytic expectations that the tests hold the package's draws and solvers to: the
soil's size distribution (eq. 5), the Stokes and Clift fall speeds (eqs. 3-4), and the splash
laws' moments (eqs. 6-9, physics/splash.py's conventions)."""
from __future__ import annotations

import math

import numpy as np

from saltstudy.physics.drag import CLIFT_EXPONENT, clift_factor, particle_response_time
from saltstudy.physics.soil import _modes, mass_cdf, scalar_or_array
from saltstudy.physics.splash import ejection_number_mean, rebound_probability

#: the open interval [deg] outside which physics.splash.launch_angle redraws a vertical angle
ANGLE_V_BOUNDS_DEG = (0.0, 180.0)


# ---- Soil (eq. 5) ----
def mass_density_dlnd(d, soil):
    """dM/dln d [-] (mass fraction per unit ln d) at diameter(s) ``d`` [m], eq. (5). Integrates to 1."""
    x = np.log(np.asarray(d, dtype=float))[..., None]
    m, mu, s = _modes(soil)
    dens = m / (math.sqrt(2.0 * math.pi) * s) * np.exp(-((x - np.log(mu)) ** 2) / (2.0 * s * s))
    return scalar_or_array(dens.sum(axis=-1))


def number_density_dlnd(d, soil):
    """dN/dln d [-], the normalised number pdf in ln d of the same soil: mode j weighted by
    m_j / (mu_j^3 exp(-4.5 ln^2 sigma_j)), centred on its count median."""
    x = np.log(np.asarray(d, dtype=float))[..., None]
    m, mu, s = _modes(soil)
    w = m / (mu ** 3 * np.exp(-4.5 * s * s))
    w = w / w.sum()
    cmed = np.log(mu) - 3.0 * s * s
    dens = w / (math.sqrt(2.0 * math.pi) * s) * np.exp(-((x - cmed) ** 2) / (2.0 * s * s))
    return scalar_or_array(dens.sum(axis=-1))


def count_median(soil) -> float:
    """Count median diameter [m] of a single-mode soil, mu exp(-3 ln^2 sigma)."""
    if len(soil.modes) != 1:
        raise ValueError("count_median is defined here for one mode only")
    mode = soil.modes[0]
    return mode.mu * math.exp(-3.0 * math.log(mode.sigma) ** 2)


def mass_median(soil, rtol: float = 1e-12) -> float:
    """Mass median diameter [m]: d with mass_cdf(d) = 1/2 (bisection in ln d; = mu for one mode)."""
    m, mu, s = _modes(soil)
    if len(m) == 1:
        return float(mu[0])
    lo = float(np.min(np.log(mu) - 8.0 * s))
    hi = float(np.max(np.log(mu) + 8.0 * s))
    while hi - lo > rtol:
        mid = 0.5 * (lo + hi)
        if mass_cdf(math.exp(mid), soil) < 0.5:
            lo = mid
        else:
            hi = mid
    return math.exp(0.5 * (lo + hi))


def mass_weighted_moment(soil, k: float) -> float:
    """E_M[d^k] = sum_j m_j mu_j^k exp(k^2 ln^2 sigma_j / 2) [m^k], over :func:`sample_diameters`'s
    draws."""
    m, mu, s = _modes(soil)
    return float(np.sum(m * mu ** k * np.exp(0.5 * k * k * s * s)))


def diameter_bins(soil, nbins: int) -> np.ndarray:
    """``nbins + 1`` log-spaced bin edges [m] from min_j mu_j sigma_j^-4 to max_j mu_j sigma_j^4."""
    if nbins < 1:
        raise ValueError("nbins must be >= 1")
    m, mu, s = _modes(soil)
    lo = np.min(np.log(mu) - 4.0 * s)
    hi = np.max(np.log(mu) + 4.0 * s)
    return np.exp(np.linspace(lo, hi, nbins + 1))


# ---- Fall speed (eqs. 3-4) ----
def stokes_terminal_velocity(d, rho_p, rho, nu, g):
    """Stokes fall speed w_s = g T_p [m s^-1] (no buoyancy, f = 1); ``d`` [m] may be an array."""
    w = g * particle_response_time.py_func(np.asarray(d, dtype=float), rho_p, rho, nu)
    return float(w) if w.ndim == 0 else w


def terminal_velocity_residual(w, d, rho_p, rho, nu, g):
    """F(w) = f(w d / nu) w - g T_p [m s^-1]; zero at the terminal velocity (numpy, vectorised)."""
    w = np.asarray(w, dtype=float)
    d = np.asarray(d, dtype=float)
    re = w * d / nu
    return clift_factor.py_func(re ** CLIFT_EXPONENT) * w - g * particle_response_time.py_func(
        d, rho_p, rho, nu)


# ---- Truncated normal ----
def _phi(x: float) -> float:
    return 0.0 if math.isinf(x) else math.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)


def _Phi(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def truncated_normal_moments(mean: float, std: float, lower: float = -math.inf,
                             upper: float = math.inf) -> tuple[float, float]:
    """(mean, standard deviation) of N(mean, std^2) restricted to (lower, upper) (Johnson, Kotz &
    Balakrishnan 1994, ch. 10)."""
    if std == 0.0:
        if not lower < mean < upper:
            raise ValueError("degenerate normal outside the truncation interval")
        return float(mean), 0.0
    a = (lower - mean) / std
    b = (upper - mean) / std
    Z = _Phi(b) - _Phi(a)
    if Z <= 0.0:
        raise ValueError("truncation interval has zero probability")
    pa, pb = _phi(a), _phi(b)
    apa = 0.0 if math.isinf(a) else a * pa
    bpb = 0.0 if math.isinf(b) else b * pb
    m = mean + std * (pa - pb) / Z
    var = std * std * (1.0 + (apa - bpb) / Z - ((pa - pb) / Z) ** 2)
    return m, math.sqrt(max(var, 0.0))


def rebound_speed_ratio_moments(splash) -> tuple[float, float]:
    """(mean, std) of v_reb / v_imp: N(0.6, 0.25) truncated to > 0 -> (0.60564, 0.24307)."""
    return truncated_normal_moments(splash.reb_speed_mean, splash.reb_speed_std, 0.0, math.inf)


def vertical_angle_moments(mean_deg: float, std_deg: float) -> tuple[float, float]:
    """(mean, std) [deg] of a vertical launch angle N(mean, std) restricted to ANGLE_V_BOUNDS_DEG."""
    return truncated_normal_moments(mean_deg, std_deg, *ANGLE_V_BOUNDS_DEG)


# ---- Analytic expectations (numpy, vectorised over v_imp; the laws element-wise) ----
_rebound_probability = np.vectorize(rebound_probability, otypes=[float])
_ejection_number_mean = np.vectorize(ejection_number_mean, otypes=[float])


def mean_rebound_fraction(v_imp, splash):
    """Expected fraction of impacts that rebound, P_reb(v_imp) of eq. 6 [-]."""
    return scalar_or_array(_rebound_probability(v_imp, splash.p_reb_max, splash.gamma_reb))


def mean_rebound_speed(v_imp, splash):
    """E[v_reb] [m s^-1] = 0.60564 v_imp (truncated normal of eq. 7)."""
    return scalar_or_array(rebound_speed_ratio_moments(splash)[0] * np.asarray(v_imp, dtype=float))


def std_rebound_speed(v_imp, splash):
    """Standard deviation of v_reb [m s^-1] = 0.24307 v_imp (truncated normal of eq. 7)."""
    return scalar_or_array(rebound_speed_ratio_moments(splash)[1] * np.asarray(v_imp, dtype=float))


def mean_ejecta_number(v_imp, splash, g: float, d_mean: float):
    """E[N_ej] = a v_imp / sqrt(g <d_p>) [-] (eq. 8; exact for stochastic rounding)."""
    return scalar_or_array(_ejection_number_mean(v_imp, splash.a_ej, g, d_mean))


def mean_ejecta_speed(v_imp, splash):
    """E[v_ej] = 0.08 v_imp [m s^-1] (eq. 9)."""
    return scalar_or_array(splash.ej_speed_mean * np.asarray(v_imp, dtype=float))


def mean_splash_energy_terms(v_imp, d_imp, soil, splash, g: float,
                             ejecta_require_rebound: bool = False):
    """(rebound, ejecta) expected kinetic energies per impact over the impact's [-]:
    rebound = P_reb(v) E[r^2], ejecta = N(v) (E_M[d^3] / d_imp^3) 2 c_ej^2 (mass-drawn diameters,
    exponential speeds). ``ejecta_require_rebound``: ejecta only when the impactor rebounds.
    """
    p = np.asarray(mean_rebound_fraction(v_imp, splash))
    rm, rs = rebound_speed_ratio_moments(splash)
    rebound = p * (rm * rm + rs * rs)
    n_ej = np.asarray(mean_ejecta_number(v_imp, splash, g, soil.mean_diameter))
    if ejecta_require_rebound:
        n_ej = n_ej * p
    mass_ratio = mass_weighted_moment(soil, 3.0) / d_imp ** 3
    ejecta = n_ej * mass_ratio * 2.0 * splash.ej_speed_mean ** 2
    return scalar_or_array(rebound), scalar_or_array(ejecta)


def mean_splash_energy_ratio(v_imp, d_imp, soil, splash, g: float,
                             ejecta_require_rebound: bool = False):
    """E[KE_rebound + KE_ejecta] / KE_impact [-], which the paper (section 2.3, para. 24) keeps
    <= 1 on average."""
    reb, ej = mean_splash_energy_terms(v_imp, d_imp, soil, splash, g, ejecta_require_rebound)
    return scalar_or_array(np.asarray(reb) + np.asarray(ej))
