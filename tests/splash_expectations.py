"""The splash laws' analytic expectations (paper eqs. 6-9, physics/splash.py's conventions), which
the tests hold the kernels' draws to: truncated-normal moments and the per-impact means."""
from __future__ import annotations

import math

import numpy as np

from saltstudy.physics.soil import mass_weighted_moment, scalar_or_array
from saltstudy.physics.splash import ejection_number_mean, rebound_probability

#: the open interval [deg] outside which physics.splash.launch_angle redraws a vertical angle
ANGLE_V_BOUNDS_DEG = (0.0, 180.0)


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
