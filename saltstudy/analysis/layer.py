"""The saltation layer's anatomy: where the airborne grains are and how they hit the bed.

By height band (``BAND_NAMES``), mean over the 3-D samples of the layer sums ``pn``, ``pm``,
``pmu``, ``pmuf``: ``band_parcels_per_m2_at_Q`` (grains aloft per m^2 over the case's Q: the
paper's count, ~2,000 in each case, [28], [31]), ``band_mass_per_m2``, ``band_flux`` (the band's
share of G_tot), ``band_speed = sum m u_p / sum m`` and ``band_wind_seen = sum m u_f / sum m``.

From the impact record (samples.nc's cumulative counts differenced over the sampling window;
solver/grains/splash_kernels.py): impact speeds and angles, the replacement number (rebounds +
ejecta per impact; 1 in a steady layer), and the hops a splash launched: flight time, length and
the height g t^2 / 8 of a ballistic hop of that flight time (an upper bound: drag shortens the
rise more than the fall).
"""
from __future__ import annotations

import math

import numpy as np

from .reading import Frame, attr_float
from .schema import Variables

__all__ = ["BAND_NAMES", "band_edges_for", "band_anatomy", "window_counts", "impact_statistics",
           "anatomy_statistics", "impact_record_statistics", "IMPACT_DIMS"]

#: the height bands: the first grid cell (to z_f[1]), from there to 5 cm, above 5 cm
BAND_NAMES = ("first cell", "first cell - 5 cm", "above 5 cm")


def band_edges_for(z_w: np.ndarray) -> np.ndarray:
    """Band edges [m]: 0, the first cell's top z_w[1], 5 cm (or z_w[1] if that is higher), top."""
    top1 = float(z_w[1])
    return np.array([0.0, top1, max(0.05, top1), float(z_w[-1])])


def band_anatomy(z: np.ndarray, z_w: np.ndarray, pn, pm, pmu, pmuf, Q_case: float, area: float
                 ) -> dict[str, np.ndarray]:
    """Per band (module doc), means over the samples; the layer sums are (samples, nz)."""
    edges = band_edges_for(z_w)
    nb = edges.size - 1
    out = {k: np.full(nb, np.nan) for k in ("band_parcels_per_m2_at_Q", "band_mass_per_m2",
                                             "band_flux", "band_speed", "band_wind_seen")}
    out["band_edges"] = edges
    if pn is None or pm is None or pmu is None:
        return out
    band = np.clip(np.searchsorted(edges, z, side="right") - 1, 0, nb - 1)   # by the layer's centre

    def per_band(a):
        a = np.asarray(a, dtype=np.float64)
        a = a.mean(axis=0) if a.ndim == 2 else a
        return np.bincount(band, weights=np.nan_to_num(a), minlength=nb)[:nb]

    n, m, mu = per_band(pn), per_band(pm), per_band(pmu)
    out["band_parcels_per_m2_at_Q"] = n / area / Q_case
    out["band_mass_per_m2"] = m / area
    out["band_flux"] = mu / area
    with np.errstate(invalid="ignore", divide="ignore"):
        out["band_speed"] = np.where(m > 0, mu / m, np.nan)
        if pmuf is not None:
            out["band_wind_seen"] = np.where(m > 0, per_band(pmuf) / m, np.nan)
    return out


def window_counts(cumulative) -> np.ndarray | None:
    """Counts over the sampling window from cumulative counts at the samples (last minus first),
    or None if there are fewer than two samples."""
    a = None if cumulative is None else np.asarray(cumulative, dtype=np.float64)
    return a[-1] - a[0] if a is not None and a.ndim >= 1 and a.shape[0] >= 2 else None


def _mean_of(hist: np.ndarray, edges: np.ndarray) -> float:
    tot = float(hist.sum())
    if tot <= 0:
        return math.nan
    centres = 0.5 * (edges[:-1] + edges[1:])
    return float(np.sum(centres * hist) / tot)


def _median_of(hist: np.ndarray, edges: np.ndarray) -> float:
    tot = float(hist.sum())
    if tot <= 0:
        return math.nan
    c = np.cumsum(hist) / tot
    i = int(np.searchsorted(c, 0.5))
    lo = c[i - 1] if i > 0 else 0.0
    f = (0.5 - lo) / (c[i] - lo) if c[i] > lo else 0.5
    return float(edges[i] + f * (edges[i + 1] - edges[i]))


#: the dimension of each distribution of :func:`impact_statistics`, and its scalars
IMPACT_DIMS = {"impact_speed_pdf": ("v_imp",), "replacement_by_speed": ("v_imp",),
               "impacts_by_speed": ("v_imp",), "impact_angle_pdf": ("impact_angle",),
               "hop_time_pdf": ("hop_time",), "hop_length_pdf": ("hop_length",)}
IMPACT_SCALARS = ("impact_speed_mean", "impact_speed_median", "impact_angle_mean",
                  "replacement_mean", "rebound_fraction", "ejecta_per_impact", "hop_time_mean",
                  "hop_time_median", "hop_length_mean", "hop_length_median",
                  "hop_height_ballistic_median")


def impact_statistics(impact_hist, impact_outcomes, hop_time_hist, hop_length_hist,
                      v_edges: np.ndarray, angle_edges: np.ndarray, t_edges: np.ndarray,
                      l_edges: np.ndarray, g: float = 9.81) -> dict[str, object]:
    """Impact and hop statistics over the sampling window (module doc) from the cumulative counts
    of samples.nc (first axis: the samples). Scalars NaN and arrays NaN where nothing was
    recorded."""
    nv = max(v_edges.size - 1, 0)
    edges = {"v_imp": v_edges, "impact_angle": angle_edges, "hop_time": t_edges,
             "hop_length": l_edges}
    out: dict[str, object] = {name: np.full(max(edges[dims[0]].size - 1, 0), np.nan)
                              for name, dims in IMPACT_DIMS.items()}
    out["impacts_by_speed"] = np.zeros(nv)
    out.update(dict.fromkeys(IMPACT_SCALARS, math.nan))
    if nv == 0:     # an archive without the impact record
        return out
    H = window_counts(impact_hist)
    O = window_counts(impact_outcomes)
    if H is not None and H.sum() > 0:
        sv = H.sum(axis=1)
        sa = H.sum(axis=0)
        out["impact_speed_pdf"] = sv / sv.sum() / np.diff(v_edges)
        out["impact_angle_pdf"] = sa / sa.sum() / np.diff(angle_edges)
        out["impact_speed_mean"] = _mean_of(sv, v_edges)
        out["impact_speed_median"] = _median_of(sv, v_edges)
        out["impact_angle_mean"] = _mean_of(sa, angle_edges)
    if O is not None and O[:, 0].sum() > 0:
        imp = O[:, 0]
        out["impacts_by_speed"] = imp
        with np.errstate(invalid="ignore", divide="ignore"):
            out["replacement_by_speed"] = np.where(imp > 0, (O[:, 1] + O[:, 2]) / imp, np.nan)
        out["replacement_mean"] = float((O[:, 1].sum() + O[:, 2].sum()) / imp.sum())
        out["rebound_fraction"] = float(O[:, 1].sum() / imp.sum())
        out["ejecta_per_impact"] = float(O[:, 2].sum() / imp.sum())
    T = window_counts(hop_time_hist)
    Lh = window_counts(hop_length_hist)
    if T is not None and T.sum() > 0:
        out["hop_time_pdf"] = T / T.sum() / np.diff(t_edges)
        out["hop_time_mean"] = _mean_of(T, t_edges)
        tm = _median_of(T, t_edges)
        out["hop_time_median"] = tm
        out["hop_height_ballistic_median"] = g * tm * tm / 8.0
    if Lh is not None and Lh.sum() > 0:
        out["hop_length_pdf"] = Lh / Lh.sum() / np.diff(l_edges)
        out["hop_length_mean"] = _mean_of(Lh, l_edges)
        out["hop_length_median"] = _median_of(Lh, l_edges)
    return out


def anatomy_statistics(fr: Frame, s: dict) -> tuple[np.ndarray, Variables]:
    """(band edges, variables): the band anatomy of the case's layer, the first cell's share of
    the airborne grains and the grains per m2 (at the case's Q) above it."""
    q_case = fr.info["Q_case"] if math.isfinite(fr.info["Q_case"]) else attr_float(fr.attrs, "Q", 1.0)
    anat = band_anatomy(fr.z, fr.z_w, s.get("pn"), s.get("pm"), s.get("pmu"), s.get("pmuf"),
                        q_case, fr.bed_area)
    band_e = anat.pop("band_edges")
    V = Variables()
    V.put("band_edges", ("height_band_edge",), band_e)
    for name, val in anat.items():
        V.put(name, ("height_band",), val)
    nb = anat["band_parcels_per_m2_at_Q"]
    V.put("first_cell_parcel_fraction", (), float(nb[0] / np.nansum(nb))
          if np.nansum(nb) > 0 else math.nan)
    V.put("n_parcels_per_m2_at_Q_above_first_cell", (), float(np.nansum(nb[1:]))
          if np.isfinite(nb).any() else math.nan)
    return band_e, V


def impact_record_statistics(fr: Frame, s: dict) -> tuple[dict[str, np.ndarray], Variables]:
    """(bin centres of the impact record's coordinates, variables): the impact and hop
    statistics over the sampling window."""
    # the impact record's bins are the archive's coordinates (their lower edges, equal widths)
    def edges(name):
        lo = np.asarray(fr.coords.get(name, np.zeros(0)), dtype=np.float64)
        return np.append(lo, lo[-1] + (lo[1] - lo[0])) if lo.size >= 2 else np.zeros(1)

    bins = {k: edges(k) for k in ("v_imp", "impact_angle", "hop_time", "hop_length")}
    imp = impact_statistics(s.get("impact_hist"), s.get("impact_outcomes"), s.get("hop_time_hist"),
                            s.get("hop_length_hist"), *bins.values(), fr.g)
    V = Variables()
    for name, val in imp.items():
        V.put(name, IMPACT_DIMS.get(name, ()), val)
    return {k: 0.5 * (e[1:] + e[:-1]) for k, e in bins.items()}, V
