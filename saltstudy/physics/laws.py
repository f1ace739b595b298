"""Semi-empirical saltation laws of the paper's Fig. 3 (z0s) and Fig. 8 (G_tot), and the log law.

Every law takes ``u_star`` and the threshold ``u_star_t`` [m s^-1] first, then keyword-only
parameters shared within a family (:data:`Z0S_LAWS`, :data:`GTOT_LAWS`: ``name -> Law(func,
citation)``): z0s laws ``(z0=1e-5, g=9.81) -> [m]``; G_tot laws ``(d=200e-6, rho=1.2,
rho_p=2650, g=9.81, nu=1.5e-5) -> [kg m^-1 s^-1]`` (Bagnold, Lettau & Lettau: also ``D``).
Below threshold they return 0 or z0; Charnock and Bagnold have no threshold. All printed forms
are dimensionally consistent except Owen's terminal velocity (:func:`owen_terminal_velocity`).
"""
from __future__ import annotations

import math
from typing import Callable, NamedTuple

import numpy as np

from .drag import terminal_velocity
from .soil import scalar_or_array

#: Reference diameter D of Bagnold (1937) and Lettau & Lettau (1978) [m]
D_REF = 250e-6


class Law(NamedTuple):
    """A semi-empirical law: the callable and its citation (unpacks as ``func, citation``)."""
    func: Callable
    citation: str


def _ratio(u_star, u_star_t):
    u = np.asarray(u_star, dtype=float)
    if np.any(u <= 0):
        raise ValueError("u_star must be positive")
    return u, u_star_t / u


def log_law_u(z, u_star, z0, kappa=0.40):
    """Mean wind of the neutral log law u(z) = (u*/kappa) ln(z / z0) [m s^-1]; z, z0 [m], u* [m s^-1]."""
    z = np.asarray(z, dtype=float)
    return scalar_or_array(u_star / kappa * np.log(z / z0))


# ---- Fig. 3: saltation roughness length z0s [m] ----


def log_law_shape(z, H: float | None = None) -> np.ndarray:
    """F(z) with U(z) = (u*_0/kappa) [F(z) - F(z0)] the local-equilibrium mean profile [-].

    H = None: F = ln z. H given (pressure-gradient drive, free-slip lid at H, u*(z) = u*_0
    sqrt(1 - z/H)): F(z) = 2 s + ln(z/H) - 2 ln(1 + s), s = sqrt(1 - z/H) (no cancellation for
    z << H); F(H) = 0. Valid for 0 < z <= H.
    """
    z = np.asarray(z, dtype=np.float64)
    if H is None:
        return np.log(z)
    s = np.sqrt(np.clip(1.0 - z / H, 0.0, 1.0))
    return 2.0 * s + np.log(z / H) - 2.0 * np.log1p(s)


def log_law_profile(z, u_star0: float, z0: float, kappa: float, H: float | None = None) -> np.ndarray:
    """U(z) = (u*_0/kappa) [F(z) - F(z0)] [m s^-1] (see ``log_law_shape``); U = 0 below z0."""
    z = np.asarray(z, dtype=np.float64)
    zz = np.maximum(z, z0)
    return u_star0 / kappa * (log_law_shape(zz, H) - log_law_shape(np.float64(z0), H))


def invert_log_law_shape(c: float, H: float | None) -> float:
    """z [m] with F(z) = c (F is strictly increasing on (0, H])."""
    if H is None:
        return math.exp(c)
    if c >= 0.0:
        return H                        # F(H) = 0 is the maximum
    lo, hi = math.log(1e-300), math.log(H)
    for _ in range(200):                # bisection in ln z
        mid = 0.5 * (lo + hi)
        if float(log_law_shape(math.exp(mid), H)) < c:
            lo = mid
        else:
            hi = mid
    return math.exp(0.5 * (lo + hi))


def _fit_levels(z, U, z_min, z_max, H):
    """(z, U) as float arrays and the mask of the finite levels in [z_min, z_max], 0 < z (< H)."""
    z = np.asarray(z, dtype=np.float64)
    U = np.asarray(U, dtype=np.float64)
    sel = np.isfinite(U) & (z > 0)
    if z_min is not None:
        sel &= z >= z_min
    if z_max is not None:
        sel &= z <= z_max
    if H is not None:
        sel &= z < H
    return z, U, sel


def regress_log_law(z, U, z_min: float | None = None, z_max: float | None = None,
                    H: float | None = None):
    """Least squares of U = a F(z) + b, F = ``log_law_shape(z, H)``, over the levels of
    :func:`_fit_levels`: u*_0 = kappa a [m s^-1], z0 = ``invert_log_law_shape(-b/a, H)`` [m].
    Returns (a, b, F, U_used); a and b NaN with fewer than 2 levels."""
    z, U, sel = _fit_levels(z, U, z_min, z_max, H)
    F = log_law_shape(z[sel], H)
    Us = U[sel]
    if Us.size < 2:
        return math.nan, math.nan, F, Us
    A = np.vstack([F, np.ones_like(F)]).T
    (a, b), *_ = np.linalg.lstsq(A, Us, rcond=None)
    return float(a), float(b), F, Us


def z0_at_fixed_u_star(z, U, u_star0: float, kappa: float, z_min: float | None = None,
                       z_max: float | None = None, H: float | None = None) -> float:
    """Least-squares z0 [m] of U = (u*_0/kappa) [F(z) - F(z0)] with u*_0 given: F(z0) = mean(F -
    kappa U / u*_0). The paper's roughness regression (Dupont et al. 2013, section 3.1 [33]).
    NaN with no level or u*_0 <= 0."""
    z, U, sel = _fit_levels(z, U, z_min, z_max, H)
    if not sel.any() or not (math.isfinite(u_star0) and u_star0 > 0):
        return math.nan
    F = log_law_shape(z[sel], H)
    return invert_log_law_shape(float(np.mean(F - kappa * U[sel] / u_star0)), H)


def charnock_z0s(u_star, u_star_t=None, *, z0=1.0e-5, g=9.81, C_c=0.08):
    """Charnock-type z0s = C_c u*s^2 / g [m] (Charnock 1955; Sherman & Farrell 2008); C_c = 0.08
    (Rasmussen et al. 1985), 0.24 (Farrell 1999), 0.02 (Owen 1964). No threshold."""
    u = np.asarray(u_star, dtype=float)
    return scalar_or_array(C_c * u * u / g)


#: A = b_r alpha^2 exp(-eta / G_r) with b_r = 8, alpha = 0.63, eta = 0.577216 (Euler's constant),
#: G_r = 1 (Raupach 1991; Shao 2008) = 1.78275
RAUPACH_A = 8.0 * 0.63 ** 2 * math.exp(-0.577216 / 1.0)


def raupach1991_z0s(u_star, u_star_t, *, z0=1.0e-5, g=9.81, A=RAUPACH_A):
    """Raupach (1991) z0s = (A u*s^2 / (2 g))^(1 - r) z0^r [m], r = u*t / u*s (Shao 2008); z0
    at and below threshold."""
    u, r = _ratio(u_star, u_star_t)
    r = np.minimum(r, 1.0)
    return scalar_or_array((A * u * u / (2.0 * g)) ** (1.0 - r) * z0 ** r)


def sherman1992_z0s(u_star, u_star_t, *, z0=1.0e-5, g=9.81, C_m=0.132):
    """Sherman (1992) modified Charnock z0s = C_m (u*s - u*t)^2 / g + z0 [m]; z0 below threshold."""
    u = np.asarray(u_star, dtype=float)
    excess = np.maximum(u - u_star_t, 0.0)
    return scalar_or_array(C_m * excess * excess / g + z0)


# ---- Fig. 8: total saltation flux G_tot [kg m^-1 s^-1] ----
def bagnold1937_flux(u_star, u_star_t=None, *, d=200e-6, rho=1.2, rho_p=2650.0, g=9.81, nu=1.5e-5,
                     D=D_REF, c=1.5):
    """Bagnold (1937) G = c sqrt(d/D) rho u*^3 / g [kg m^-1 s^-1], c = 1.5, D = 250 um [m]; no
    threshold."""
    u = np.asarray(u_star, dtype=float)
    return scalar_or_array(c * np.sqrt(d / D) * rho * u ** 3 / g)


def owen_terminal_velocity(d, rho_p, rho, g, nu=1.5e-5, form="consistent"):
    """Terminal fall speed in Owen's flux coefficient [m s^-1] (downward positive). The paper's
    w_t = -1.66 sqrt(rho_p g d) has units sqrt(Pa). ``form``:

    * ``"consistent"`` (default): 1.66 sqrt((rho_p / rho) g d), the density ratio of Shao (2008)
      in place of rho_p (inferred): the Newton-regime fall speed with C_D = 0.48, 1.095 times
      below the printed value in SI numbers for rho = 1.2; 3.46 m/s for 200 um.
    * ``"terminal"``: the fall speed of the paper's drag law (eq. 4), 1.48 m/s for 200 um: what
      Owen (1964) defines, physically the right number.
    * ``"printed"``: 1.66 sqrt(rho_p g d) in SI numbers (3.79 for 200 um), inconsistent.
    """
    d = np.asarray(d, dtype=float)
    if form == "consistent":
        return scalar_or_array(1.66 * np.sqrt(rho_p / rho * g * d))
    if form == "terminal":
        return scalar_or_array(terminal_velocity(d, rho_p, rho, nu, g))
    if form == "printed":
        return scalar_or_array(1.66 * np.sqrt(rho_p * g * d))
    raise ValueError(f"unknown form {form!r}: use 'consistent', 'terminal' or 'printed'")


def owen1964_flux(u_star, u_star_t, *, d=200e-6, rho=1.2, rho_p=2650.0, g=9.81, nu=1.5e-5,
                  w_t_form="consistent"):
    """Owen (1964) G = c rho u*^3 (1 - u*t^2/u*^2) / g [kg m^-1 s^-1], c = 0.25 + |w_t| / (3 u*),
    |w_t| from :func:`owen_terminal_velocity` (``w_t_form``); zero at and below threshold."""
    u, r = _ratio(u_star, u_star_t)
    wt = owen_terminal_velocity(d, rho_p, rho, g, nu, form=w_t_form)
    c = 0.25 + wt / (3.0 * u)
    return scalar_or_array(np.where(r < 1.0, c * rho * u ** 3 * (1.0 - r * r) / g, 0.0))


def kawamura_white_flux(u_star, u_star_t, *, d=200e-6, rho=1.2, rho_p=2650.0, g=9.81, nu=1.5e-5,
                        c=2.61):
    """Kawamura (1951) / White (1979) G = c rho u*^3 (1 + r)(1 - r^2) / g, r = u*t/u*, c = 2.61."""
    u, r = _ratio(u_star, u_star_t)
    return scalar_or_array(np.where(r < 1.0, c * rho * u ** 3 * (1.0 + r) * (1.0 - r * r) / g, 0.0))


def lettau1978_flux(u_star, u_star_t, *, d=200e-6, rho=1.2, rho_p=2650.0, g=9.81, nu=1.5e-5,
                    D=D_REF, c=4.2):
    """Lettau & Lettau (1978) G = c sqrt(d/D) rho u*^3 (1 - u*t/u*) / g, c = 4.2, D = 250 um."""
    u, r = _ratio(u_star, u_star_t)
    flux = c * np.sqrt(d / D) * rho * u ** 3 * (1.0 - r) / g
    return scalar_or_array(np.where(r < 1.0, flux, 0.0))


def sorensen2004_flux(u_star, u_star_t, *, d=200e-6, rho=1.2, rho_p=2650.0, g=9.81, nu=1.5e-5,
                      alpha=0.0, gamma=3.0, beta=3.9):
    """Sorensen (2004) G = rho u*^3 (1 - r^2)(alpha + gamma r + beta r^2) / g, r = u*t/u*, with
    Dupont et al. (2013, Fig. 8)'s constants; zero below threshold."""
    u, r = _ratio(u_star, u_star_t)
    shape = (1.0 - r * r) * (alpha + gamma * r + beta * r * r)
    return scalar_or_array(np.where(r < 1.0, rho * u ** 3 * shape / g, 0.0))


#: Creyssels et al. (2009, J. Fluid Mech. 625, 47), wind tunnel, grains of 242 um and
#: rho_p = 2500 kg m^-3: friction velocity [m s^-1] and total flux [kg m^-1 s^-1] (their Table 1 as
#: quoted in the grain-layer acceptance), and the flux's e-folding height [m], ~1 cm whatever u*
CREYSSELS2009_U_STAR = (0.242, 0.327, 0.412, 0.493, 0.575, 0.690)
CREYSSELS2009_Q = (5.2e-3, 12.7e-3, 20.8e-3, 31.6e-3, 48.3e-3, 78.6e-3)
CREYSSELS2009_DECAY_HEIGHT = 0.01


def creyssels2009_flux(u_star, *, rho=1.2, g=9.81, C=1.38, u_star_th=0.206):
    """Creyssels et al. (2009) Q = C (rho/g)(u*^2 - u*th^2) [kg m^-1 s^-1], C = 1.38, u*th = 0.206
    m/s; zero below u*th. Within 7 % of :data:`CREYSSELS2009_Q` from 0.41 to 0.69 m/s, half the
    measured flux at 0.24 m/s."""
    u = np.asarray(u_star, dtype=float)
    return scalar_or_array(np.where(u > u_star_th, C * rho / g * (u * u - u_star_th ** 2), 0.0))


def _charnock(C_c):
    def f(u_star, u_star_t=None, *, z0=1.0e-5, g=9.81):
        return charnock_z0s(u_star, u_star_t, z0=z0, g=g, C_c=C_c)
    f.__name__ = f"charnock_z0s_C{C_c:g}"
    f.__doc__ = f"Charnock z0s = {C_c:g} u*s^2 / g [m]."
    return f


Z0S_LAWS: dict[str, Law] = {
    "charnock_rasmussen1985": Law(_charnock(0.08), "Charnock, C_c = 0.08 (Rasmussen et al. 1985)"),
    "charnock_farrell1999": Law(_charnock(0.24), "Charnock, C_c = 0.24 (Farrell 1999)"),
    "charnock_owen1964": Law(_charnock(0.02), "Charnock, C_c = 0.02 (Owen 1964)"),
    "raupach1991": Law(raupach1991_z0s, "Raupach (1991); Shao (2008)"),
    "sherman1992": Law(sherman1992_z0s, "Sherman (1992), C_m = 0.132"),
}

GTOT_LAWS: dict[str, Law] = {
    "bagnold1937": Law(bagnold1937_flux, "Bagnold (1937), c = 1.5, D = 250 um"),
    "owen1964": Law(owen1964_flux, "Owen (1964), w_t = 1.66 sqrt((rho_p/rho) g d) "
                                   "(dimensionally consistent form)"),
    "kawamura_white": Law(kawamura_white_flux, "Kawamura (1951); White (1979), c = 2.61"),
    "lettau1978": Law(lettau1978_flux, "Lettau & Lettau (1978), c = 4.2, D = 250 um"),
    "sorensen2004": Law(sorensen2004_flux, "Sorensen (2004), alpha = 0, gamma = 3.0, beta = 3.9"),
}
