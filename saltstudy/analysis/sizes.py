"""Grain-size distribution by height band compared with the bed (paper section 3.2 [39], Fig. 5).

``size_hist (time, z, d_bin)`` holds Q-weighted grain *counts* per layer and diameter bin. A
height band collects the layers whose centre lies in ``[edge_i, edge_{i+1})``; its distribution
is the *mass* fraction per bin, ``n d^3 / sum(n d^3)`` with d the bin centre (the constant
``rho_p pi/6`` cancels), summed over the sampling window. NaN for a band without grains.

The bed distribution ``psd_bed`` is the soil's lognormal mass-size distribution (eq. 5)
integrated over each bin, renormalised over the bins so that both sum to one over the same
bins. It comes from ``saltstudy.physics.soil.bin_mass_fractions(soil, edges)`` when that
exists; otherwise from :func:`lognormal_bin_fractions` here (the same integral).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["DEFAULT_BAND_EDGES", "band_edges_for", "band_mass_fractions", "lognormal_bin_fractions",
           "bed_mass_fractions"]

#: band edges [m]: resolved near the bed where the distribution changes most (clipped to Lz)
DEFAULT_BAND_EDGES = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)


def band_edges_for(z_top: float, edges=DEFAULT_BAND_EDGES) -> np.ndarray:
    """The default edges below ``z_top`` (the top edge clipped to it)."""
    e = [x for x in edges if x < z_top]
    if len(e) < 1:
        e = [0.0]
    if len(e) < len(edges):
        e.append(float(z_top))
    return np.asarray(e, dtype=np.float64)


def band_mass_fractions(hist_z: np.ndarray, z: np.ndarray, d_bin: np.ndarray,
                        edges: np.ndarray) -> np.ndarray:
    """Mass fractions (n_band, n_bin) from counts ``hist_z (nz, n_bin)`` (time-summed)."""
    h = np.nan_to_num(np.asarray(hist_z, dtype=np.float64))
    z = np.asarray(z, dtype=np.float64)
    d3 = np.asarray(d_bin, dtype=np.float64) ** 3
    nb = len(edges) - 1
    out = np.full((nb, d3.size), np.nan)
    for i in range(nb):
        sel = (z >= edges[i]) & (z < edges[i + 1])
        mass = (h[sel] * d3).sum(axis=0)
        tot = mass.sum()
        if tot > 0:
            out[i] = mass / tot
    return out


def lognormal_bin_fractions(modes, edges: np.ndarray) -> np.ndarray:
    """Mass fraction of a multimodal lognormal (eq. 5) in each bin, renormalised over the bins.

    ``modes``: iterable of (mass_fraction, mu [m], sigma) - mu the mass median diameter.
    """
    edges = np.asarray(edges, dtype=np.float64)
    frac = np.zeros(edges.size - 1)
    for m, mu, sigma in modes:
        s = math.log(sigma)
        with np.errstate(divide="ignore"):
            t = (np.log(np.maximum(edges, 1e-300)) - math.log(mu)) / (s * math.sqrt(2.0))
        cdf = 0.5 * (1.0 + np.array([math.erf(v) for v in t]))
        frac += m * np.diff(cdf)
    tot = frac.sum()
    return frac / tot if tot > 0 else np.full(frac.size, np.nan)


def bed_mass_fractions(soil_dict: dict | None, edges: np.ndarray) -> tuple[np.ndarray, str]:
    """(psd_bed, source) for the soil of the case (a dict as in ``Case.soil``)."""
    if not soil_dict:
        return np.full(len(edges) - 1, np.nan), "unknown soil"
    try:
        from ..config import Soil
        from ..physics import soil as soil_mod  # written by the physics engineer
        soil = Soil.model_validate(soil_dict)
        f = np.asarray(soil_mod.bin_mass_fractions(soil, np.asarray(edges)), dtype=np.float64)
        tot = np.nansum(f)
        if f.shape == (len(edges) - 1,) and tot > 0:
            return f / tot, "saltstudy.physics.soil.bin_mass_fractions"
    except (ImportError, AttributeError):
        pass
    modes = [(m.get("mass_fraction", 1.0), m.get("mu", 2e-4), m.get("sigma", 1.2))
             for m in soil_dict.get("modes", [{}])]
    return lognormal_bin_fractions(modes, edges), "saltstudy.analysis.sizes.lognormal_bin_fractions"
