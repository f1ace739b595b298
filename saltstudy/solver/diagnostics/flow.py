"""Flow records the workflow writes into samples.nc / spinup.nc (see docs/ARCHITECTURE.md).

Functions take a ``Model`` and return numpy arrays (no I/O). Stresses are kinematic [m^2 s^-2] with
the sign of u'w' (negative for a drag on a positive wind); u* = sqrt(|total stress|).
"""
from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..._jit import pjit
from ...physics.laws import invert_log_law_shape, log_law_profile, log_law_shape, regress_log_law
from ..closures.sgs import sgs_stress_uw_profile, strain_sq_at

#: the physics' log laws are re-exported: the model and the probes read them here
__all__ = ["flow_profiles", "flow_planes", "cell_centred_velocity", "u_star_at", "stress_profile",
           "resolved_tke_volume_mean", "log_law_shape", "log_law_profile", "fit_log_law"]


def fit_log_law(z, U, kappa: float, H: float | None = None, z_min: float | None = None,
                z_max: float | None = None, z_eval=()) -> dict:
    """Least-squares fit of U = (u*_0/kappa) [F(z) - F(z0)] over z_min <= z <= z_max, F the plain
    log law (H None) or, H the depth of a pressure-gradient drive, ``log_law_shape``. Returns
    ``u_star0`` [m s^-1], ``z0`` [m], ``u_star_at`` (at ``z_eval`` [m]), ``rms`` [m s^-1], ``n``."""
    a, b, F, Us = regress_log_law(z, U, z_min, z_max, H)
    if Us.size < 2:
        raise ValueError(f"fit_log_law: fewer than 2 levels in [{z_min}, {z_max}] m")
    u0 = kappa * a
    z0 = invert_log_law_shape(-b / a, H) if a > 0 else math.nan
    ze = np.atleast_1d(np.asarray(z_eval, dtype=np.float64))
    us = u0 * (np.ones_like(ze) if H is None else np.sqrt(np.clip(1.0 - ze / H, 0.0, 1.0)))
    rms = float(np.sqrt(np.mean((a * F + b - Us) ** 2)))
    return {"u_star0": float(u0), "z0": float(z0), "u_star_at": us, "z_eval": ze, "rms": rms,
            "n": int(Us.size)}


def _f64(a: np.ndarray) -> np.ndarray:
    """A field in float64 (a single-precision flow's records are computed in double)."""
    return np.asarray(a, dtype=np.float64)


def _nu(model) -> np.ndarray:
    clo = model.stepper.closure
    return clo.cml[None, None, :] * np.sqrt(np.maximum(_f64(model.state.e), 0.0)) + clo.nu_mol


def cell_centred_velocity(model):
    """(u_c, v_c, w_c), each (nx, ny, nz) [m s^-1]: two-point means onto the cell centres."""
    u, v, w = (_f64(a) for a in (model.state.u, model.state.v, model.state.w))
    uc = 0.5 * (u + np.roll(u, -1, axis=0))
    vc = 0.5 * (v + np.roll(v, -1, axis=1))
    wc = 0.5 * (w[..., :-1] + w[..., 1:])
    return uc, vc, wc


def _resolved_uw(model) -> np.ndarray:
    """<u'w'> resolved on the faces (nz+1,), with the advection scheme's face means."""
    s = model.state
    u, w = _f64(s.u), _f64(s.w)
    wx = 0.5 * (w + np.roll(w, 1, axis=0))[..., 1:-1]
    uz = 0.5 * (u[..., 1:] + u[..., :-1])
    out = np.zeros(s.grid.nz + 1)
    out[1:-1] = (wx * uz).mean(axis=(0, 1)) - wx.mean(axis=(0, 1)) * uz.mean(axis=(0, 1))
    return out


def _sgs_uw(model) -> np.ndarray:
    s, st = model.state, model.stepper
    taux, tauy = np.empty(s.u.shape[:2]), np.empty(s.u.shape[:2])
    st.bed_stress_into(s.u, s.v, taux, tauy)
    return sgs_stress_uw_profile(s.u, s.w, _nu(model), st.closure.rv, taux, s.grid.dz_f,
                                 1.0 / s.grid.dx)


def stress_profile(model) -> tuple[np.ndarray, np.ndarray]:
    """(uw_res, uw_sgs) on the faces z_w (nz+1,) [m^2 s^-2]."""
    return _resolved_uw(model), _sgs_uw(model)


def u_star_at(model, z: float) -> float:
    """sqrt|resolved + SGS u-w stress| at height z [m s^-1] (the air's alone)."""
    res, sgs = stress_profile(model)
    tot = float(np.interp(z, model.state.grid.z_f, res + sgs))
    return math.sqrt(abs(tot))


@pjit
def _sgs_profiles(e, u, v, w, nu, rv, rdx, rdy, rdzc, rdzf, rlog, ceps_l):
    nx, ny, nz = e.shape
    eps = np.zeros((nx, nz))
    tr = np.zeros((nx, nz))
    for ii in prange(nx):
        i = np.int64(ii)
        im = (i - 1) % nx
        ip = (i + 1) % nx
        for j in range(ny):
            jm = (j - 1) % ny
            jp = (j + 1) % ny
            for k in range(nz):
                ek = max(e[i, j, k], 0.0)
                eps[i, k] += ceps_l[k] * ek * math.sqrt(ek)
                sh, sv = strain_sq_at(u, v, w, i, j, k, im, ip, jm, jp, k < nz - 1, k > 0, rdx, rdy,
                                      rdzc, rdzf, rlog)
                tr[i, k] += nu[i, j, k] * (sh + rv[k] * sv)
    return eps.sum(axis=0) / (nx * ny), tr.sum(axis=0) / (nx * ny)


def flow_profiles(model) -> dict:
    """Horizontal-mean profiles of the flow and its SGS terms (docs/ARCHITECTURE.md) [SI]."""
    s, clo, g = model.state, model.stepper.closure, model.state.grid
    uc, vc, wc = cell_centred_velocity(model)
    um = uc.mean(axis=(0, 1))
    vm = vc.mean(axis=(0, 1))
    wm = wc.mean(axis=(0, 1))
    tke = 0.5 * (((uc - um) ** 2).mean(axis=(0, 1)) + ((vc - vm) ** 2).mean(axis=(0, 1))
                 + ((wc - wm) ** 2).mean(axis=(0, 1)))
    res, sgs = stress_profile(model)
    nu = _nu(model)
    eps, transfer = _sgs_profiles(s.e, s.u, s.v, s.w, nu, clo.rv, 1.0 / g.dx, 1.0 / g.dy, g.rdz_c,
                                  g.rdz_f, clo.rlog, clo.ceps_l)
    return {"z": g.z_c.copy(), "z_w": g.z_f.copy(), "u": _f64(s.u).mean(axis=(0, 1)),
            "v": _f64(s.v).mean(axis=(0, 1)),
            "uw_res": res, "uw_sgs": sgs, "tke_res": tke, "e_sgs": _f64(s.e).mean(axis=(0, 1)),
            "eps_sgs": eps, "sgs_transfer": transfer}


def flow_planes(model, heights) -> dict:
    """u_plane (nx, ny, len(heights)) [m s^-1], linear in z, the log law below z_c[0]."""
    s, g = model.state, model.state.grid
    heights = np.atleast_1d(np.asarray(heights, dtype=np.float64))
    u = _f64(s.u)
    uc = 0.5 * (u + np.roll(u, -1, axis=0))
    zc = g.z_c
    z0 = model.stepper.z0
    out = np.empty((g.nx, g.ny, heights.size))
    for n, h in enumerate(heights):
        if h <= zc[0]:
            hh = max(h, z0)
            out[..., n] = uc[..., 0] * math.log(hh / z0) / math.log(zc[0] / z0)
        elif h >= zc[-1]:
            out[..., n] = uc[..., -1]
        else:
            k = int(np.searchsorted(zc, h) - 1)
            a = (h - zc[k]) / (zc[k + 1] - zc[k])
            out[..., n] = (1 - a) * uc[..., k] + a * uc[..., k + 1]
    return {"u_plane": out, "z_plane": heights}


def resolved_tke_volume_mean(model) -> float:
    """Volume-weighted mean of 1/2 <u_i'u_i'> over the free region below the damping layer [m^2 s^-2]."""
    g = model.state.grid
    uc, vc, wc = cell_centred_velocity(model)
    tke = 0.5 * (uc.var(axis=(0, 1)) + vc.var(axis=(0, 1)) + wc.var(axis=(0, 1)))
    free = g.z_c < g.Lz - model.damping_depth
    if not free.any():
        free[:] = True
    wgt = g.dz_c * free
    return float(np.sum(tke * wgt) / np.sum(wgt))
