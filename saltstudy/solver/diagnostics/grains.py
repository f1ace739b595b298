"""Grain records for samples.nc (ARCHITECTURE.md): planes, layer profiles, size histograms, counters.

Functions take a ``Model`` and return dicts of numpy arrays, Q-weighted, SI. A parcel belongs to
the grid cell (layer) holding it.
"""
from __future__ import annotations

import numpy as np

from ..grains.particles import Saltation


def grain_component(model) -> Saltation | None:
    return next((c for c in model.components if c.name == "saltation"), None)


def _layers(s: Saltation) -> np.ndarray:
    g = s.grid
    return np.clip(np.searchsorted(g.z_f, s.z, side="right") - 1, 0, g.nz - 1)


def grain_planes(model) -> dict:
    """C_p [grains m^-2], C_p_above (z >= z_f[1]) and G_col [kg m^-1 s^-1] on (x, y)."""
    g = model.state.grid
    s = grain_component(model)
    cp = np.zeros((g.nx, g.ny))
    ca = np.zeros((g.nx, g.ny))
    gc = np.zeros((g.nx, g.ny))
    if s is not None and s.n:
        i = np.floor(s.x / g.dx).astype(np.int64) % g.nx
        j = np.floor(s.y / g.dy).astype(np.int64) % g.ny
        np.add.at(cp, (i, j), s.Q)
        up = s.z >= g.z_f[1]
        np.add.at(ca, (i[up], j[up]), s.Q)
        np.add.at(gc, (i, j), s.Q * s.mass * s.u)
    a = g.dx * g.dy
    return {"C_p": cp / a, "C_p_above": ca / a, "G_col": gc / a}


def grain_profiles(model) -> dict:
    """Per-layer sums on z (nz,) - see ARCHITECTURE.md for names and units."""
    g = model.state.grid
    s = grain_component(model)
    names = ["pm", "pmu", "pmv", "pmw", "pmuu", "pmuw", "pmww", "pmvv", "pn", "pdrag", "pmuf_up",
             "pmuf", "pmuf_uf", "pmup_up"]
    out = {k: np.zeros(g.nz) for k in names}
    if s is None or s.n == 0:
        return out
    k = _layers(s)
    qm = s.Q * s.mass
    u, v, w = s.u, s.v, s.w
    uf, vf, wf = s.fluid_at_parcels(model.state)
    rel = np.sqrt((uf - u) ** 2 + (vf - v) ** 2 + (wf - w) ** 2)
    tp = s.rho_p * s.d ** 2 / (18 * s.rho * s.nu)
    f = 1.0 + 0.15 * (rel * s.d / s.nu) ** 0.687
    vals = {"pm": qm, "pmu": qm * u, "pmv": qm * v, "pmw": qm * w, "pmuu": qm * u * u,
            "pmuw": qm * u * w, "pmww": qm * w * w, "pmvv": qm * v * v,
            "pn": np.full(s.n, s.Q), "pdrag": qm * f / tp,
            "pmuf_up": qm * (uf * u + vf * v + wf * w), "pmuf": qm * uf,
            "pmuf_uf": qm * (uf * uf + vf * vf + wf * wf), "pmup_up": qm * (u * u + v * v + w * w)}
    for name, val in vals.items():
        out[name] = np.bincount(k, weights=val, minlength=g.nz)[: g.nz]
    return out


def grain_size_hist(model, d_edges) -> np.ndarray:
    """(nz, nbins) Q-weighted grain counts by layer and diameter bin (edges in m)."""
    g = model.state.grid
    d_edges = np.asarray(d_edges, dtype=np.float64)
    nb = d_edges.size - 1
    out = np.zeros((g.nz, nb))
    s = grain_component(model)
    if s is None or s.n == 0:
        return out
    b = np.searchsorted(d_edges, s.d, side="right") - 1
    ok = (b >= 0) & (b < nb)
    np.add.at(out, (_layers(s)[ok], b[ok]), s.Q)
    return out


def grain_counters(model) -> dict:
    """Cumulative counters since activation; G_tot = sum Q m_p u_p / (Lx Ly) [kg m^-1 s^-1]."""
    g = model.state.grid
    s = grain_component(model)
    if s is None:
        return {**dict.fromkeys(("n_parcels", "n_impacts", "n_rebounds", "n_ejections",
                                 "n_depositions"), 0),
                **dict.fromkeys(("G_tot", "E_impact", "E_splash", "bed_px", "bed_pz"), 0.0),
                "momentum_to_air": np.zeros(3)}
    c = s.counters()
    c["G_tot"] = float(np.sum(s.Q * s.mass * s.u) / (g.Lx * g.Ly)) if s.n else 0.0
    return c


def impact_bins() -> dict:
    """Bin edges of the impact record: speed [m s^-1], angle [deg], hop time [s], length [m]."""
    from ..grains import splash_kernels as sk
    return {"v_imp_edges": np.arange(sk.N_SPEED_BINS + 1) * sk.IMPACT_SPEED_BIN,
            "angle_edges": np.arange(sk.N_ANGLE_BINS + 1) * sk.IMPACT_ANGLE_BIN,
            "hop_time_edges": np.arange(sk.N_HOP_BINS + 1) * sk.HOP_TIME_BIN,
            "hop_length_edges": np.arange(sk.N_HOP_BINS + 1) * sk.HOP_LENGTH_BIN}


def impact_record(model) -> dict:
    """Cumulative impact counts since activation (parcels); zeros without grains."""
    from ..grains import splash_kernels as sk
    s = grain_component(model)
    if s is None:
        return {k: a[0] for k, a in zip(sk.IMPACT_RECORD, sk.impact_log_arrays(1))}
    return s.impact_record()
