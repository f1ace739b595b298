"""Grain-size distribution by height band compared with the bed (paper section 3.2 [39], Fig. 5).

``size_hist (time, z, d_bin)`` holds Q-weighted grain *counts* per layer and diameter bin. A
height band collects the layers whose centre lies in ``[edge_i, edge_{i+1})``; its distribution
is the *mass* fraction per bin, ``n d^3 / sum(n d^3)`` with d the bin centre (the constant
``rho_p pi/6`` cancels), summed over the sampling window. NaN for a band without grains.

The bed's ``psd_bed`` is the soil's lognormal mass-size distribution (eq. 5) over each bin,
renormalised over the same bins. :func:`threshold_statistics`: the soil's threshold u*t (Shao and
Lu 2000) at its mass-mean diameter, the scale of the figures' and Table 2's u*s/u*t.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from .reading import Frame, time_sum
from .schema import Variables

__all__ = ["DEFAULT_BAND_EDGES", "band_edges_for", "band_mass_fractions",
           "bed_mass_fractions", "SizeStatistics", "size_statistics", "threshold_u_star",
           "threshold_statistics"]

log = logging.getLogger(__name__)

#: band edges [m]: resolved near the bed where the distribution changes most (clipped to Lz)
DEFAULT_BAND_EDGES = (0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0)


def band_edges_for(z_top: float, edges=DEFAULT_BAND_EDGES) -> np.ndarray:
    """The default edges below ``z_top`` (the top edge clipped to it)."""
    e = [x for x in edges if x < z_top] or [0.0]
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


def bed_mass_fractions(soil_dict: dict | None, edges: np.ndarray) -> tuple[np.ndarray, str]:
    """(psd_bed, source) for the soil of the case (a dict as in ``Case.soil``)."""
    if not soil_dict:
        return np.full(len(edges) - 1, np.nan), "unknown soil"
    from ..config import Soil
    from ..physics.soil import bin_mass_fractions
    f = np.asarray(bin_mass_fractions(Soil.model_validate(soil_dict), np.asarray(edges)),
                   dtype=np.float64)
    tot = np.nansum(f)
    return (f / tot if tot > 0 else np.full(f.size, np.nan)), "saltstudy.physics.soil.bin_mass_fractions"


@dataclass(frozen=True, eq=False)
class SizeStatistics:
    #: Q-weighted grain counts per layer and diameter bin, summed over the samples (nz, d_bin)
    hist_z: np.ndarray
    #: edges of the height bands [m]
    band_edges: np.ndarray
    variables: Variables


def size_statistics(fr: Frame, s: dict) -> SizeStatistics:
    """The mass-size distribution of the airborne grains by height band and of the bed
    (section 3.2 [39], Fig. 5). Without the archive's bin edges they are rebuilt around the bin
    centres."""
    d_bin, nz = fr.d_bin, fr.nz
    hist = s.get("size_hist")
    d_edges = s.get("d_edges")
    if d_edges is None or d_edges.size != d_bin.size + 1:
        if d_bin.size >= 2:
            mid = 0.5 * (d_bin[1:] + d_bin[:-1])
            d_edges = np.concatenate([[d_bin[0] - (mid[0] - d_bin[0])], mid,
                                      [d_bin[-1] + (d_bin[-1] - mid[-1])]])
        else:
            d_edges = np.array([0.5, 1.5]) * (d_bin[0] if d_bin.size else 1e-4)
    hist_z = time_sum(hist, nz) if hist is not None and hist.ndim == 3 else np.zeros((nz, d_bin.size))
    band_edges = band_edges_for(float(fr.z_w[-1]))
    psd_air = band_mass_fractions(hist_z, fr.z, d_bin, band_edges) if d_bin.size else \
        np.full((band_edges.size - 1, 0), np.nan)
    psd_bed, bed_src = bed_mass_fractions(fr.info.get("soil"), d_edges)
    V = Variables()
    V.put("psd_air", ("z_band", "d_bin"), psd_air, weighting="mass (count x d_bin^3)")
    V.put("psd_bed", ("d_bin",), psd_bed, source=bed_src)
    V.put("z_band_edges", ("z_band_edge",), band_edges)
    V.put("d_edges", ("d_edge",), d_edges)
    return SizeStatistics(hist_z, band_edges, V)


def threshold_u_star(info: dict, rho: float, rho_p: float, g: float) -> float:
    """u*t of the soil's mass-mean diameter (``physics.threshold``) for the case's threshold
    constants (``info``: :func:`saltstudy.analysis.reading.case_info`); NaN if it cannot be had."""
    soil = info.get("soil") or {}
    modes = soil.get("modes") or [{}]
    d_mean = sum(float(m.get("mass_fraction", 1.0)) * float(m.get("mu", 2e-4)) for m in modes)
    th = info.get("threshold") or {}
    from ..physics.threshold import threshold_friction_velocity
    try:
        return float(threshold_friction_velocity(d_mean, rho_p, rho, g, float(th.get("A_N", 0.0123)),
                                                 float(th.get("gamma", 3.0e-4))))
    except Exception as exc:  # noqa: BLE001 - a scalar for the report, never fatal
        log.warning("u_star_t failed: %s", exc)
        return math.nan


def threshold_statistics(fr: Frame) -> Variables:
    """``u_star_t`` of the case (:func:`threshold_u_star`)."""
    V = Variables()
    V.put("u_star_t", (), threshold_u_star(fr.info, fr.rho, fr.rho_p, fr.g))
    return V
