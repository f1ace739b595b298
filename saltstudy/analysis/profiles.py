"""Mean wind profiles, the log-law fit (u*s, z0s) and the stress friction velocity.

Section 3.1 [33]-[34]: with grains a log profile and constant stress hold above the saltation
layer, with ``u*s`` and ``z0s``; the paper reads u* from the stress, ``u*^2 = |<u'w'>|`` at 2 m
(the flux on the faces ``z_w``), and z0 from a regression of ``<u> = (u*/kappa) ln(z/z0)`` over
``[max(0.3 m, z_m), top]`` (:func:`fit_range`). Under the pressure-gradient drive, whose stress
falls linearly to the lid, the stress u* is carried to the bed: ``u*_0^2 = u*(z_ref)^2 / (1 -
z_ref/H)``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..physics.laws import invert_log_law_shape, regress_log_law, z0_at_fixed_u_star
from .reading import Frame, time_mean
from .schema import Variables

__all__ = ["LogFit", "faces_to_centres", "log_law_fit", "fit_range", "stress_u_star",
           "FIT_Z_FLOOR", "MIN_FIT_POINTS", "WindProfiles", "wind_profiles",
           "case_fit_range", "log_law_statistics", "spinup_reference"]

#: lowest height of the log-law fit [m]: the paper finds the log law "above about z = 0.30 m"
#: with grains (section 3.1 [34]); the fit never starts below the saltation height z_m either.
FIT_Z_FLOOR = 0.3
#: fewer levels than this in the fit range give NaN (a two-parameter fit needs redundancy)
MIN_FIT_POINTS = 3


@dataclass(frozen=True)
class LogFit:
    """Result of a log-law regression. All NaN when undefined."""
    u_star: float
    z0: float
    n_points: int
    r2: float
    z_min: float
    z_max: float


def faces_to_centres(a_w: np.ndarray) -> np.ndarray:
    """Values on the nz+1 faces (last axis) -> the nz cell centres (mean of the two faces)."""
    a_w = np.asarray(a_w, dtype=np.float64)
    return 0.5 * (a_w[..., :-1] + a_w[..., 1:])


def fit_range(z_m: float, Lz: float, damping_depth: float,
              z_floor: float = FIT_Z_FLOOR, drive: str = "top") -> tuple[float, float]:
    """Height range [z_min, z_max] of the log-law fit: ``z_min = max(z_floor, z_m)``, above the
    grains' layer; ``z_max = (Lz - damping_depth) / 2`` for the top drive (above it the lid and
    the Rayleigh layer bend the profile), ``Lz / 3`` for the pressure gradient (outer-layer
    effects grow above the local-equilibrium profile of the linear stress)."""
    z_lo = float(z_floor) if z_m is None or not math.isfinite(z_m) else max(z_floor, float(z_m))
    return float(z_lo), (float(Lz) / 3.0 if drive == "pressure_gradient"
                         else 0.5 * (float(Lz) - float(damping_depth)))


def log_law_fit(z: np.ndarray, u: np.ndarray, z_min: float, z_max: float, kappa: float,
                min_points: int = MIN_FIT_POINTS, H: float | None = None) -> LogFit:
    """Regress ``u = (u*/kappa) ln(z/z0)`` on ``z_min <= z <= z_max``; NaN with fewer than
    ``min_points`` levels or a slope not positive. With ``H`` (a pressure-gradient drive's
    domain height) ln z is the linear-stress shape (``physics.laws.log_law_shape``), u* at the bed."""
    a, b, lz, uu = regress_log_law(z, u, z_min, z_max, H)
    n = int(uu.size)
    nan = LogFit(math.nan, math.nan, n, math.nan, float(z_min), float(z_max))
    if n < min_points or not (a > 0 and math.isfinite(a) and math.isfinite(b)):
        return nan
    resid = uu - (a * lz + b)
    ss_tot = float(np.sum((uu - uu.mean()) ** 2))
    r2 = 1.0 - float(np.sum(resid ** 2)) / ss_tot if ss_tot > 0 else math.nan
    return LogFit(float(kappa * a), float(invert_log_law_shape(-b / a, H)), n, r2, float(z_min),
                  float(z_max))


def stress_u_star(z: np.ndarray, uw: np.ndarray, z_ref: float) -> float:
    """``u* = sqrt|<u'w'>(z_ref)|`` (paper section 3.1 [33]), ``uw`` kinematic [m2 s-2] linearly
    interpolated; NaN outside its finite levels."""
    z, uw = np.asarray(z, dtype=np.float64), np.asarray(uw, dtype=np.float64)
    ok = np.isfinite(uw)
    if ok.sum() < 1 or not math.isfinite(z_ref) or z_ref < z[ok].min() or z_ref > z[ok].max():
        return math.nan
    return math.sqrt(abs(float(np.interp(z_ref, z[ok], uw[ok]))))


@dataclass(frozen=True, eq=False)
class WindProfiles:
    """The wind with grains over the sampling window (cell centres unless said)."""
    u_mean: np.ndarray
    #: total momentum flux (resolved + SGS) of each sample on the faces, None if not recorded
    uw_w: np.ndarray | None
    #: its time mean on the faces
    uw_mean_w: np.ndarray
    uw_flux: np.ndarray
    #: the SGS part of the momentum flux, time mean at the centres
    uw_sgs_c: np.ndarray
    tke_res: np.ndarray
    tke: np.ndarray
    #: sqrt|<u'w'>| at z_ref_eff
    u_star_stress: float
    #: the stress u* at the bed (equal to u_star_stress but for the pressure-gradient drive)
    u0_stress: float
    variables: Variables


def wind_profiles(fr: Frame, s: dict) -> WindProfiles:
    """The mean wind, momentum flux and TKE profiles with grains and the stress u* (section 3.1)."""
    nz = fr.nz
    u_mean = time_mean(s.get("u_mean"), nz)
    uw_w = (s["uw_res"].astype(np.float64) + s["uw_sgs"].astype(np.float64)
            if s.get("uw_res") is not None and s.get("uw_sgs") is not None else None)
    uw_mean_w = time_mean(uw_w, nz + 1)
    uw_flux = faces_to_centres(uw_mean_w)
    uw_sgs_c = faces_to_centres(time_mean(s.get("uw_sgs"), nz + 1))
    tke_res = time_mean(s.get("tke_res"), nz)
    tke = tke_res + time_mean(s.get("e_sgs"), nz)
    u_star_stress = stress_u_star(fr.z_w, uw_mean_w, fr.z_ref_eff)
    # the surface value of the stress u*: the linear stress of the pressure-gradient drive is
    # u*_0^2 (1 - z/H) at z_ref
    u0_stress = u_star_stress / math.sqrt(1.0 - fr.z_ref_eff / fr.H) if fr.H else u_star_stress
    V = Variables()
    V.put("u_mean", ("z",), u_mean)
    V.put("uw_flux", ("z",), uw_flux)
    V.put("tke", ("z",), tke)
    V.put("tke_resolved", ("z",), tke_res)
    return WindProfiles(u_mean, uw_w, uw_mean_w, uw_flux, uw_sgs_c, tke_res, tke, u_star_stress,
                        u0_stress, V)


def case_fit_range(fr: Frame, z_m: float) -> tuple[float, float]:
    """:func:`fit_range` with the case's domain height, damping depth and drive."""
    return fit_range(z_m, fr.Lz, fr.info["damping_depth"], drive=fr.info["drive"])


def log_law_statistics(fr: Frame, s: dict, wind: WindProfiles, z_m: float) -> Variables:
    """u*s and z0s from the log-law fit above the saltation layer (section 3.1 [34]), z0s with
    u* held at the stress value, and the fit's sampling error from the single samples."""
    z, kappa, H = fr.z, fr.kappa, fr.H
    fit = log_law_fit(z, wind.u_mean, *case_fit_range(fr, z_m), kappa, H=H)
    # z0s with u* fixed at the stress value (the paper's u* at the reference height)
    z0s_stress = z0_at_fixed_u_star(z, wind.u_mean, wind.u0_stress, kappa, fit.z_min, fit.z_max, H)
    V = Variables()
    V.put("u_star_s", (), fit.u_star,
          fit_range=f"[{fit.z_min:g}, {fit.z_max:g}] m, {fit.n_points} levels")
    V.put("z0s", (), fit.z0)
    V.put("u_star_s_stress", (), wind.u_star_stress)
    V.put("z0s_stress", (), z0s_stress)
    V.put("z_ref_eff", (), fr.z_ref_eff)
    V.put("fit_r2", (), fit.r2)
    V.put("fit_n", (), fit.n_points)
    V.put("fit_z_min", (), fit.z_min)
    V.put("fit_z_max", (), fit.z_max)
    # the sampling error of u*s, from the scatter of the same fit on each sample's profile: large
    # eddies (turnover H/u* ~ 4-11 s) make single samples scatter by 5-15 %
    n_t = fr.n_t
    u_prof = s.get("u_mean")
    u_star_i = np.full(n_t, np.nan)
    if u_prof is not None and u_prof.ndim == 2 and u_prof.shape[0] == n_t:
        u_star_i = np.array([log_law_fit(z, row, fit.z_min, fit.z_max, kappa, H=H).u_star
                             for row in np.asarray(u_prof, dtype=np.float64)])
    ok_i = u_star_i[np.isfinite(u_star_i)]
    V.put("u_star_s_samples", ("time_sample",), u_star_i)
    V.put("u_star_s_se", (), float(np.std(ok_i, ddof=1) / math.sqrt(ok_i.size)) if ok_i.size >= 2
          else math.nan)
    return V


def spinup_reference(fr: Frame, sp_coords: dict, sp: dict) -> Variables:
    """The particle-free spin-up on the case's levels (NaN where it has none): its wind, momentum
    flux and TKE profiles, ``u_star_0, z0_0`` from the log-law fit above 0.3 m and its stress u*
    at the case's reference height."""
    z, z_w, nz = fr.z, fr.z_w, fr.nz
    sp_z = np.asarray(sp_coords.get("z", z), dtype=np.float64)
    sp_zw = np.asarray(sp_coords.get("z_w", z_w), dtype=np.float64)

    def on_z(prof, zz):
        prof = np.asarray(prof, dtype=np.float64)
        if prof.shape != zz.shape:
            return np.full(nz, np.nan)
        if zz.shape == z.shape and np.allclose(zz, z):
            return prof
        return np.interp(z, zz, prof, left=np.nan, right=np.nan)

    def sp_get(name, n):
        a = sp.get(name)
        if a is None:
            return np.full(n, np.nan)
        a = np.asarray(a, dtype=np.float64)
        return a if a.ndim == 1 else time_mean(a, n)

    u_sp = on_z(sp_get("u_mean", sp_z.size), sp_z)
    uw_sp_w = sp_get("uw_res", sp_zw.size) + sp_get("uw_sgs", sp_zw.size)
    uw_sp = on_z(faces_to_centres(uw_sp_w), 0.5 * (sp_zw[1:] + sp_zw[:-1])) \
        if sp_zw.size >= 2 else np.full(nz, np.nan)
    tke_sp = on_z(sp_get("tke_res", sp_z.size) + sp_get("e_sgs", sp_z.size), sp_z)
    fit0 = log_law_fit(z, u_sp, *case_fit_range(fr, math.nan), fr.kappa, H=fr.H)
    V = Variables()
    V.put("u_star_0", (), fit0.u_star,
          fit_range=f"[{fit0.z_min:g}, {fit0.z_max:g}] m, {fit0.n_points} levels")
    V.put("z0_0", (), fit0.z0)
    V.put("fit_r2_0", (), fit0.r2)
    V.put("u_star_0_stress", (), stress_u_star(sp_zw, uw_sp_w, fr.z_ref_eff)
          if sp_zw.size == uw_sp_w.size else math.nan)
    V.put("u_mean_spinup", ("z",), u_sp)
    V.put("uw_flux_spinup", ("z",), uw_sp)
    V.put("tke_spinup", ("z",), tke_sp)
    return V
