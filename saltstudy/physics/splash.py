"""Splash laws at the bed, paper eqs. 6-9 (section 2.3).

numba functions drawing from a :class:`numpy.random.Generator`, called alike by the grain kernels
(solver/grains/splash_kernels.py), the steady-layer probe and the tests; the splash constants come
as one float vector (:func:`splash_constants`, indices ``SP_*``). Conventions the paper leaves open:

* Rebound (eq. 6): Bernoulli with P_reb = p_max (1 - exp(-gamma_reb v_imp)).
* Rebound speed (eq. 7): N(0.6 v_imp, 0.25 v_imp) with negative draws redrawn (P = 0.82 %), so
  its mean is 0.60564 v_imp (``tests/physics_expectations.py`` gives the moments).
* Vertical launch angles (rebound N(30, 15), ejection N(60, 15) deg) are redrawn outside (0, 180)
  deg (rebound mean 30.83 deg); horizontal angles N(0, 10) deg relative to the impactor's
  direction, never truncated.
* Ejecta number (eq. 8): N = a v_imp / sqrt(g <d_p>) rounded stochastically, floor(N) +
  Bernoulli(N - floor(N)): mean exactly N, least variance.
* Ejection speed (eq. 9): exponential with mean 0.08 v_imp (Rice et al. 1995); diameters from the
  soil's mass distribution (eq. 5). Every impact ejects, rebound or not (Kok & Renno 2009).
* ``splash.impact_speed = "normal"`` gives eqs. 6 and 8 |w| instead of |u_p| (:func:`law_speed`).

Draws per impact, in order: the rebound's Bernoulli; if it rebounds, its speed, vertical and
horizontal angle; the number of ejecta; per ejectum its diameter, speed and two angles.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import jit
from .soil import draw_diameter

#: indices into the splash constants vector (:func:`splash_constants`; angles in radians)
SP_PMAX, SP_GAMMA, SP_REB_M, SP_REB_S, SP_RAV_M, SP_RAV_S, SP_RAH_M, SP_RAH_S = range(8)
SP_A, SP_EJ_M, SP_EAV_M, SP_EAV_S, SP_EAH_M, SP_EAH_S = range(8, 14)
SP_IMPACT_LAYER, SP_G, SP_DMEAN, SP_RHO_P = range(14, 18)
SP_NORMAL = 18  # 1: eqs. 6 and 8 take the normal impact speed |w| (config.Splash.impact_speed)


def splash_constants(splash, soil, g: float) -> np.ndarray:
    """The vector the laws take: a config.Splash's constants (angles in radians), the soil's
    <d_p> and rho_p, and g [m s^-2]."""
    r = math.radians
    return np.array([
        splash.p_reb_max, splash.gamma_reb, splash.reb_speed_mean, splash.reb_speed_std,
        r(splash.reb_angle_v_mean), r(splash.reb_angle_v_std), r(splash.reb_angle_h_mean),
        r(splash.reb_angle_h_std), splash.a_ej, splash.ej_speed_mean, r(splash.ej_angle_v_mean),
        r(splash.ej_angle_v_std), r(splash.ej_angle_h_mean), r(splash.ej_angle_h_std),
        splash.impact_layer, g, soil.mean_diameter, soil.rho_p,
        1.0 if splash.impact_speed == "normal" else 0.0,
    ], dtype=np.float64)


# ---- The laws, one process each (numba) ----
@jit
def rebound_probability(v_imp: float, p_reb_max: float, gamma_reb: float) -> float:
    """P_reb = p_max (1 - exp(-gamma_reb v_imp)), eq. 6 (Anderson & Haff 1991); p_max = 0.95."""
    return p_reb_max * (1.0 - math.exp(-gamma_reb * v_imp))


@jit
def ejection_number_mean(v_imp: float, a_ej: float, g: float, d_mean: float) -> float:
    """Mean number of ejecta N_ej = a v_imp / sqrt(g <d_p>), eq. 8 (Kok & Renno 2009)."""
    return a_ej * v_imp / math.sqrt(g * d_mean)


@jit
def rebound_speed(rng, v_imp, ratio_mean, ratio_std):
    """v_reb [m s^-1] ~ N(<r> v_imp, s_r v_imp) redrawn while negative (eq. 7, module doc)."""
    vr = -1.0
    for _ in range(1000):
        vr = rng.normal(ratio_mean * v_imp, ratio_std * v_imp)
        if vr >= 0.0:
            break
    if vr < 0.0:
        vr = 0.0
    return vr


@jit
def launch_angle(rng, mean, std):
    """A vertical launch angle [rad] ~ N(mean, std) redrawn until it lies in (0, pi)."""
    for _ in range(1000):
        a = rng.normal(mean, std)
        if 0.0 < a < math.pi:
            return a
    return mean


@jit
def ejecta_number(rng, nbar) -> int:
    """eq. 8's mean ``nbar`` as a whole number by stochastic rounding (module doc)."""
    n0 = int(math.floor(nbar))
    if rng.random() < nbar - n0:
        n0 += 1
    return n0


@jit
def ejection_speed(rng, v_imp, ratio_mean):
    """v_ej [m s^-1], exponential with mean <v_ej>/v_imp times v_imp (eq. 9)."""
    return rng.exponential(ratio_mean * v_imp)


@jit
def launch_velocity(speed, av, phi):
    """(u, v, w) [m s^-1] of a grain leaving at ``speed``, elevation av, heading phi [rad]."""
    c = speed * math.cos(av)
    return c * math.cos(phi), c * math.sin(phi), speed * math.sin(av)


@jit
def law_speed(v_imp, wp, sp):
    """The speed eqs. 6 and 8 take: the impact speed, or its normal component (SP_NORMAL)."""
    return abs(wp) if sp[SP_NORMAL] != 0.0 else v_imp


@jit
def draw_rebound(rng, v_law, v_imp, sp):
    """Rebound draw (eqs. 6-7): (rebounds, v_reb, alpha_v, alpha_h [rad]); eq. 6 takes ``v_law``
    (:func:`law_speed`), eq. 7 scales ``v_imp``."""
    p = rebound_probability(v_law, sp[SP_PMAX], sp[SP_GAMMA])
    if rng.random() >= p:
        return False, 0.0, 0.0, 0.0
    vr = rebound_speed(rng, v_imp, sp[SP_REB_M], sp[SP_REB_S])
    av = launch_angle(rng, sp[SP_RAV_M], sp[SP_RAV_S])
    ah = rng.normal(sp[SP_RAH_M], sp[SP_RAH_S])
    return True, vr, av, ah


@jit
def draw_ejecta_number(rng, v_law, sp) -> int:
    """N_ej of eq. 8 at the speed ``v_law`` as a whole number."""
    return ejecta_number(rng, ejection_number_mean(v_law, sp[SP_A], sp[SP_G], sp[SP_DMEAN]))


@jit
def draw_impact(rng, v_law, v_imp, sp):
    """An impact's outcome (eqs. 6-8): (rebounds, v_reb, alpha_v, alpha_h, number of ejecta)."""
    reb, vr, av, ah = draw_rebound(rng, v_law, v_imp, sp)
    return reb, vr, av, ah, draw_ejecta_number(rng, v_law, sp)


@jit
def draw_ejectum(rng, v_imp, sp, cum, mu, lnsig):
    """One ejectum: (d [m] (eq. 5, soil.soil_arrays), v_ej (eq. 9), alpha_v, alpha_h [rad])."""
    dq = draw_diameter(rng, cum, mu, lnsig)
    ve = ejection_speed(rng, v_imp, sp[SP_EJ_M])
    av = launch_angle(rng, sp[SP_EAV_M], sp[SP_EAV_S])
    ah = rng.normal(sp[SP_EAH_M], sp[SP_EAH_S])
    return dq, ve, av, ah


@jit
def ejecta_max(v_imp, sp) -> int:
    """The most ejecta an impact at speed v_imp can draw (bounds the normal-speed reading too)."""
    return int(math.floor(ejection_number_mean(v_imp, sp[SP_A], sp[SP_G], sp[SP_DMEAN]))) + 1


@jit
def splash_impacts(rng, ui, vi, wi, di, sp, cum, mu, lnsig):
    """Splash a batch of impacts (ui, vi, wi [m s^-1], wi <= 0, di [m]) in the module doc's draw
    order: the launches (u, v, w, d) per rebound and ejectum, and their impacts' indices."""
    n = ui.shape[0]
    room = n
    for i in range(n):
        room += ejecta_max(math.sqrt(ui[i] * ui[i] + vi[i] * vi[i] + wi[i] * wi[i]), sp)
    launch = np.empty((room, 4))
    parent = np.empty(room, dtype=np.int64)
    m = 0
    for i in range(n):
        up = ui[i]
        vp = vi[i]
        wp = wi[i]
        v_imp = math.sqrt(up * up + vp * vp + wp * wp)
        phi = math.atan2(vp, up) if (up != 0.0 or vp != 0.0) else 0.0
        reb, vr, av, ah, nej = draw_impact(rng, law_speed(v_imp, wp, sp), v_imp, sp)
        if reb:
            launch[m, 0], launch[m, 1], launch[m, 2] = launch_velocity(vr, av, phi + ah)
            launch[m, 3] = di[i]
            parent[m] = i
            m += 1
        for _ in range(nej):
            dq, ve, av, ah = draw_ejectum(rng, v_imp, sp, cum, mu, lnsig)
            launch[m, 0], launch[m, 1], launch[m, 2] = launch_velocity(ve, av, phi + ah)
            launch[m, 3] = dq
            parent[m] = i
            m += 1
    return launch[:m], parent[:m]
