"""Splash laws at the bed, paper eqs. 6-9 (section 2.3).

Scalar laws are numba-jitted so the solver's bed kernel uses the same code as the tests. The numpy
samplers below draw whole batches from a :class:`numpy.random.Generator` with the constants of a
:class:`saltstudy.config.Splash`; the analytic expectations next to them are what the tests and the
solver's energy check compare with.

Conventions (the paper leaves these open; chosen here and documented):

* Rebound speed (eq. 7): v_reb = r v_imp with r ~ N(<r>, s_r) = N(0.6, 0.25) *truncated to r > 0 by
  redrawing* the non-positive draws (a rebound must leave the bed). Redrawing samples exactly the
  truncated normal, whose mean is <r> + s_r phi(a)/(1 - Phi(a)) with a = -<r>/s_r (= -2.4): 0.60564,
  not 0.6 (see :func:`truncated_normal_moments`, :func:`rebound_speed_ratio_moments`). The
  probability of a redraw is Phi(-2.4) = 0.82 %.
* Vertical launch angles (rebound N(30, 15) deg, ejection N(60, 15) deg) are likewise redrawn when
  outside (0, 180) deg: a launch must point upward (angles above 90 deg point upwind, allowed). This
  moves the rebound mean angle to 30.83 deg (P(redraw) = Phi(-2) = 2.3 %) and the ejection mean by
  < 0.002 deg. Horizontal angles are plain normal draws (N(0, 10) deg), never truncated.
* Ejecta number (eq. 8): the mean N = a v_imp / sqrt(g <d_p>) is a real number; the integer drawn is
  floor(N) + Bernoulli(N - floor(N)) ("stochastic rounding"): its mean is exactly N and its variance
  f (1 - f), f = N - floor(N), the smallest possible for an integer with mean N.
* Ejection speed (eq. 9): exponential with mean 0.08 v_imp (Rice et al. 1995), untruncated.
* Samplers draw speed and angles for *every* entry (whether it rebounds or not) so that the random
  stream does not depend on the outcomes; callers select with the returned mask.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import jit

__all__ = [
    "rebound_probability", "ejection_number_mean",
    "sample_rebound", "sample_ejecta_number", "sample_ejection", "sample_truncated_normal",
    "truncated_normal_moments", "rebound_speed_ratio_moments", "vertical_angle_moments",
    "mean_rebound_fraction", "mean_rebound_speed", "std_rebound_speed", "mean_ejecta_number",
    "mean_ejecta_speed", "mean_splash_energy_terms", "mean_splash_energy_ratio",
    "ANGLE_V_BOUNDS_DEG",
]

#: vertical launch angles outside this open interval [deg] are redrawn
ANGLE_V_BOUNDS_DEG = (0.0, 180.0)


# --------------------------------------------------------------------------------------------
# Scalar laws (numba; called from solver kernels)
# --------------------------------------------------------------------------------------------
@jit
def rebound_probability(v_imp: float, p_reb_max: float, gamma_reb: float) -> float:
    """P_reb = p_max (1 - exp(-gamma_reb v_imp)), eq. 6 (Anderson & Haff 1991); p_max = 0.95."""
    return p_reb_max * (1.0 - math.exp(-gamma_reb * v_imp))


@jit
def ejection_number_mean(v_imp: float, a_ej: float, g: float, d_mean: float) -> float:
    """Mean number of ejecta N_ej = a v_imp / sqrt(g <d_p>), eq. 8 (Kok & Renno 2009)."""
    return a_ej * v_imp / math.sqrt(g * d_mean)


# --------------------------------------------------------------------------------------------
# Truncated normal
# --------------------------------------------------------------------------------------------
def _phi(x: float) -> float:
    return 0.0 if math.isinf(x) else math.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)


def _Phi(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def truncated_normal_moments(mean: float, std: float, lower: float = -math.inf,
                             upper: float = math.inf) -> tuple[float, float]:
    """(mean, standard deviation) of N(mean, std^2) restricted to (lower, upper).

    With a = (lower - mean)/std, b = (upper - mean)/std, Z = Phi(b) - Phi(a) (Johnson, Kotz &
    Balakrishnan 1994, ch. 10):
    E = mean + std (phi(a) - phi(b)) / Z,
    Var = std^2 [1 + (a phi(a) - b phi(b)) / Z - ((phi(a) - phi(b)) / Z)^2].
    """
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


def sample_truncated_normal(mean: float, std: float, rng: np.random.Generator, n: int,
                            lower: float = -math.inf, upper: float = math.inf,
                            max_rounds: int = 10_000) -> np.ndarray:
    """``n`` draws of N(mean, std^2) restricted to the open interval (lower, upper), by redrawing."""
    x = rng.normal(mean, std, n)
    bad = ~((x > lower) & (x < upper))
    rounds = 0
    while bad.any():
        rounds += 1
        if rounds > max_rounds:
            raise RuntimeError("sample_truncated_normal: acceptance probability too small")
        k = int(bad.sum())
        x[bad] = rng.normal(mean, std, k)
        bad = ~((x > lower) & (x < upper))
    return x


def rebound_speed_ratio_moments(splash) -> tuple[float, float]:
    """(mean, std) of v_reb / v_imp: N(0.6, 0.25) truncated to > 0 -> (0.60564, 0.24307)."""
    return truncated_normal_moments(splash.reb_speed_mean, splash.reb_speed_std, 0.0, math.inf)


def vertical_angle_moments(mean_deg: float, std_deg: float) -> tuple[float, float]:
    """(mean, std) [deg] of a vertical launch angle N(mean, std) restricted to ANGLE_V_BOUNDS_DEG."""
    return truncated_normal_moments(mean_deg, std_deg, *ANGLE_V_BOUNDS_DEG)


# --------------------------------------------------------------------------------------------
# Samplers (numpy)
# --------------------------------------------------------------------------------------------
def _speeds(v_imp, n):
    v = np.asarray(v_imp, dtype=float)
    if n is None:
        v = np.atleast_1d(v).ravel()
        n = v.size
    else:
        v = np.broadcast_to(v, (n,))
    if np.any(v < 0):
        raise ValueError("impact speeds must be >= 0")
    return v, n


def sample_rebound(v_imp, splash, rng: np.random.Generator, n: int | None = None):
    """Draw rebound outcomes for impacts at speed(s) ``v_imp`` [m s^-1] (scalar with ``n``, or array).

    Returns ``(rebounded, speed, angle_v_deg, angle_h_deg)``, each of length n:
    ``rebounded`` bool with P = P_reb(v_imp) (eq. 6); ``speed`` [m s^-1] = r v_imp with r from the
    truncated normal of eq. 7 (see module docstring); ``angle_v_deg`` N(30, 15) deg restricted to
    (0, 180); ``angle_h_deg`` N(0, 10) deg. Speed and angles are drawn for every entry.
    """
    v, n = _speeds(v_imp, n)
    p = splash.p_reb_max * (1.0 - np.exp(-splash.gamma_reb * v))
    rebounded = rng.random(n) < p
    r = sample_truncated_normal(splash.reb_speed_mean, splash.reb_speed_std, rng, n, 0.0, math.inf)
    angle_v = sample_truncated_normal(splash.reb_angle_v_mean, splash.reb_angle_v_std, rng, n,
                                      *ANGLE_V_BOUNDS_DEG)
    angle_h = rng.normal(splash.reb_angle_h_mean, splash.reb_angle_h_std, n)
    return rebounded, r * v, angle_v, angle_h


def sample_ejecta_number(v_imp, splash, g: float, d_mean: float, rng: np.random.Generator,
                         n: int | None = None) -> np.ndarray:
    """Integer numbers of ejecta (int64) per impact: floor(N) + Bernoulli(N - floor(N)), N of eq. 8.

    ``g`` [m s^-2], ``d_mean`` = <d_p> [m] (``Soil.mean_diameter``).
    """
    v, n = _speeds(v_imp, n)
    mean = splash.a_ej * v / math.sqrt(g * d_mean)
    base = np.floor(mean)
    extra = rng.random(n) < (mean - base)
    return base.astype(np.int64) + extra.astype(np.int64)


def sample_ejection(v_imp, splash, rng: np.random.Generator, n: int | None = None):
    """Draw ``n`` ejecta launched by impacts at ``v_imp`` [m s^-1].

    Returns ``(speed, angle_v_deg, angle_h_deg)``: speed exponential with mean 0.08 v_imp (eq. 9),
    angle_v N(60, 15) deg restricted to (0, 180), angle_h N(0, 10) deg. Diameters are drawn separately
    with :func:`saltstudy.physics.soil.sample_diameters`.
    """
    v, n = _speeds(v_imp, n)
    speed = rng.exponential(1.0, n) * (splash.ej_speed_mean * v)
    angle_v = sample_truncated_normal(splash.ej_angle_v_mean, splash.ej_angle_v_std, rng, n,
                                      *ANGLE_V_BOUNDS_DEG)
    angle_h = rng.normal(splash.ej_angle_h_mean, splash.ej_angle_h_std, n)
    return speed, angle_v, angle_h


# --------------------------------------------------------------------------------------------
# Analytic expectations (numpy, vectorised over v_imp)
# --------------------------------------------------------------------------------------------
def _r(x):
    return float(x) if np.ndim(x) == 0 else x


def mean_rebound_fraction(v_imp, splash):
    """Expected fraction of impacts that rebound, P_reb(v_imp) of eq. 6 [-]."""
    v = np.asarray(v_imp, dtype=float)
    return _r(splash.p_reb_max * (1.0 - np.exp(-splash.gamma_reb * v)))


def mean_rebound_speed(v_imp, splash):
    """E[v_reb] [m s^-1] = 0.60564 v_imp (truncated normal of eq. 7)."""
    return _r(rebound_speed_ratio_moments(splash)[0] * np.asarray(v_imp, dtype=float))


def std_rebound_speed(v_imp, splash):
    """Standard deviation of v_reb [m s^-1] = 0.24307 v_imp (truncated normal of eq. 7)."""
    return _r(rebound_speed_ratio_moments(splash)[1] * np.asarray(v_imp, dtype=float))


def mean_ejecta_number(v_imp, splash, g: float, d_mean: float):
    """E[N_ej] = a v_imp / sqrt(g <d_p>) [-] (eq. 8; exact for stochastic rounding)."""
    return _r(splash.a_ej * np.asarray(v_imp, dtype=float) / math.sqrt(g * d_mean))


def mean_ejecta_speed(v_imp, splash):
    """E[v_ej] = 0.08 v_imp [m s^-1] (eq. 9)."""
    return _r(splash.ej_speed_mean * np.asarray(v_imp, dtype=float))


def mean_splash_energy_terms(v_imp, d_imp, soil, splash, g: float,
                             ejecta_require_rebound: bool = False):
    """(rebound, ejecta) expected kinetic energies per impact, each divided by the impact KE [-].

    rebound = P_reb(v) E[r^2],                 r = v_reb / v_imp (truncated normal, eq. 7)
    ejecta  = N(v) (E_M[d^3] / d_imp^3) E[v_ej^2] / v^2 = N(v) (E_M[d^3] / d_imp^3) 2 c_ej^2,
    with E_M[d^3] = sum_j m_j mu_j^3 exp(4.5 ln^2 sigma_j) (ejecta diameters drawn from the mass
    distribution, as the paper does), E[v_ej^2] = 2 <v_ej>^2 for an exponential law, c_ej = 0.08 and
    N(v) = a v / sqrt(g <d_p>). Grain density cancels. With ``ejecta_require_rebound`` the ejecta
    term is multiplied by P_reb (ejection only when the impactor rebounds). ``v_imp`` [m s^-1] may be
    an array; ``d_imp`` [m] the impacting grain's diameter.
    """
    from .soil import mass_weighted_moment

    v = np.asarray(v_imp, dtype=float)
    p = splash.p_reb_max * (1.0 - np.exp(-splash.gamma_reb * v))
    rm, rs = rebound_speed_ratio_moments(splash)
    rebound = p * (rm * rm + rs * rs)
    n_ej = splash.a_ej * v / math.sqrt(g * soil.mean_diameter)
    if ejecta_require_rebound:
        n_ej = n_ej * p
    mass_ratio = mass_weighted_moment(soil, 3.0) / d_imp ** 3
    ejecta = n_ej * mass_ratio * 2.0 * splash.ej_speed_mean ** 2
    return _r(rebound), _r(ejecta)


def mean_splash_energy_ratio(v_imp, d_imp, soil, splash, g: float,
                             ejecta_require_rebound: bool = False):
    """E[(KE_rebound + KE_ejecta)] / KE_impact [-] for one impact (see :func:`mean_splash_energy_terms`).

    The paper (section 2.3, para. 24) checks that this stays <= 1 on average.
    """
    reb, ej = mean_splash_energy_terms(v_imp, d_imp, soil, splash, g, ejecta_require_rebound)
    return _r(np.asarray(reb) + np.asarray(ej))
