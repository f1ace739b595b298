"""Grain momentum flux tau_p (eq. 10), saltation height z_m, mass flux G (eq. 11), G_tot, sigma_G.

Inputs: the Q-weighted layer sums of each 3-D sample (``samples.nc``, the grains whose centre
lies between ``z_w[k]`` and ``z_w[k+1]``): ``pm = sum Q m_p``, ``pmu``, ``pmw``, ``pmuw``.

tau_p (eq. 10, section 3.2 [37])
    ``tau_p(z) = < Q/(Lx Ly dz) sum_p m_p u'_p w'_p >``, primes the deviations from the
    mass-weighted mean grain velocity of the level over all samples (``U = P_u/P_m``, ``W =
    P_w/P_m``, ``P_*`` the sums over the samples): the sum of ``m (u-U)(w-W)`` is exactly
    ``P_uw - P_u P_w / P_m``, over ``N_samples Lx Ly dz`` for the time mean. **Sign**: rising
    grains are slow (u' < 0, w' > 0), descending ones fast, so ``sum m u'w' < 0``; as in Fig. 6
    the downward flux is positive: ``tau_p = -(P_uw - P_u P_w/P_m)/(N Lx Ly dz)`` [Pa].

z_m (section 3.2 [37])
    Where tau_p, going up from the bed, first drops below 0.1 % of ``rho u*s^2``, interpolated
    in ``ln tau_p`` (tau_p decays exponentially); NaN if it starts below or never drops below.

tau_p(0): the grain-borne share of the momentum flux at the bed (section 3.2 [40], Fig. 6: "about
50% of the above flow momentum flux in case 6", its lowest point the 0-1 cm cell)
    A layer mean depends on the layer's thickness where the profile is steep, so ``tau_p_bed``
    (:func:`bed_value`) is ``A`` of the exponential ``A exp(-z/H)`` (after Owen 1964) whose exact
    *layer means* fit eq. 10's over the layers with their top at or below ``BED_FIT_FRACTION`` z_m
    (~1.5 e-folding heights on any grid; at least two layers): within ~3 % on a 1 cm and a 2 cm
    first level for two-exponential profiles whose lowest layer means differ by 15-20 %.
    ``tau_p_surface_fraction = tau_p_bed / (rho u*^2)``, u* the stress at the reference height
    (carried to the bed for the pressure-gradient drive); ``tau_p_paper_cell_fraction``: the
    fit's mean over the paper's 0-1 cm cell. By the budget (:func:`budget_bed_fraction`): a steady
    layer's total stress is the same at every height, so ``tau_p(0) / tau_total = 1 - tau_air(0) /
    tau_total``.

G, G_tot (eq. 11, section 3.2 [41]-[42])
    ``G(z) = <pmu>/(Lx Ly dz)`` [kg m-2 s-1]; ``G_tot = sum_k G_k dz_k`` [kg m-1 s-1];
    ``z_m_flux995``: the height below which 99.5 % of G_tot lies (exact: piecewise linear).

sigma_G (section 4.3 [55])
    "sigma_G = sqrt(<G_tot'^2>)" of "the instantaneous flux" (the prime lost in the typeset
    text): the standard deviation over the sampling window of ``G_tot_series``, a temporal
    variability. The spread of the local column flux (the streamers' contrast) is ``sigma_G_local``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import paper_grid
from .reading import PLANE_CHUNK, Frame
from .schema import Variables

__all__ = ["tau_p_profile", "mass_flux_profile", "total_flux", "first_drop_height", "z_m_from_tau",
           "flux_height", "sigma_series", "Z_M_FRACTION",
           "FLUX_FRACTION", "decay_height", "pooled_mean_std", "bed_value", "BedValue",
           "BED_FIT_FRACTION", "budget_bed_fraction", "GrainProfiles", "grain_profiles",
           "bed_share_statistics", "mass_flux_statistics"]

#: tau_p threshold defining z_m, as a fraction of rho u*s^2 (paper: 0.1 %)
Z_M_FRACTION = 1.0e-3
#: fraction of G_tot below z_m_flux995
FLUX_FRACTION = 0.995
#: the exponential giving tau_p at the bed is fitted to the layers below this fraction of z_m
BED_FIT_FRACTION = 0.25


def _time_sum(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    return np.nansum(a, axis=0) if a.ndim == 2 else a


def tau_p_profile(pm: np.ndarray, pmu: np.ndarray, pmw: np.ndarray, pmuw: np.ndarray,
                  dz: np.ndarray, Lx: float, Ly: float) -> np.ndarray:
    """tau_p(z) [Pa], positive downward (module docstring). Arrays (time, z) or time-summed (z)."""
    pm = np.asarray(pm, dtype=np.float64)
    n_t = pm.shape[0] if pm.ndim == 2 else 1
    Pm, Pu, Pw, Puw = (_time_sum(a) for a in (pm, pmu, pmw, pmuw))
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_part = np.where(Pm > 0, Pu * Pw / np.where(Pm > 0, Pm, 1.0), 0.0)
    cov = Puw - mean_part
    if n_t == 0:
        return np.full(np.shape(dz), np.nan)
    return -cov / (n_t * Lx * Ly * np.asarray(dz, dtype=np.float64))


@dataclass(frozen=True)
class BedValue:
    """Bed value of an exponential fitted to layer means: ``value`` at z = 0, e-folding
    ``height`` (negative for a profile growing with height), ``n_layers`` used."""
    value: float
    height: float
    n_layers: int

    def layer_mean(self, top: float) -> float:
        """Mean of the fitted exponential over ``0 <= z <= top``."""
        if not (math.isfinite(self.value) and top > 0):
            return math.nan
        b = 1.0 / self.height if math.isfinite(self.height) else 0.0
        return float(self.value * math.exp(_log_layer_mean(b, np.zeros(1), np.array([top]))[0]))


def _log_layer_mean(b: float, a: np.ndarray, h: np.ndarray) -> np.ndarray:
    """ln of the mean of exp(-b z) over the layers [a, a + h] (b may be 0 or negative)."""
    x = b * h
    small = np.abs(x) < 1e-8
    xs = np.where(small, 1.0, x)
    shape = np.where(small, -0.5 * x, np.log(np.where(small, 1.0, -np.expm1(-xs) / xs)))
    return -b * a + shape


def bed_value(z_w: np.ndarray, layer_mean: np.ndarray, z_top: float = math.nan,
              min_layers: int = 2) -> BedValue:
    """Value at z = 0 of ``A exp(-z/H)`` whose layer means fit ``layer_mean`` (layer k between
    ``z_w[k]`` and ``z_w[k+1]``) in the log, least squares, over the contiguous positive layers
    from the bed whose top face is at or below ``z_top`` (at least ``min_layers``; the lowest
    ``min_layers`` when ``z_top`` is NaN). Two layers determine the exponential exactly. NaN
    with fewer positive layers from the bed than ``min_layers``."""
    z_w, f = (np.asarray(v, dtype=np.float64) for v in (z_w, layer_mean))
    nan = BedValue(math.nan, math.nan, 0)
    n_pos = 0
    while n_pos < f.size and np.isfinite(f[n_pos]) and f[n_pos] > 0:
        n_pos += 1
    if n_pos < min_layers or z_w.size < f.size + 1:
        return nan
    n = min_layers
    if math.isfinite(z_top):
        tol = 1e-9 * max(1.0, abs(z_top))
        n = max(n, int(np.sum(z_w[1:n_pos + 1] <= z_top + tol)))
    n = min(n, n_pos)
    a = z_w[:n]
    h = np.diff(z_w[:n + 1])
    y = np.log(f[:n])
    h0 = float(h[0])
    if not h0 > 0:
        return nan

    def cost(b: float) -> tuple[float, float]:
        g = _log_layer_mean(b, a, h)
        ln_A = float(np.mean(y - g))
        return float(np.sum((y - ln_A - g) ** 2)), ln_A

    # decay rates from a growth over 1/4 of the fitted depth to an e-folding of h0/200; a coarse
    # scan, then a golden-section search around the best point
    depth = float(a[-1] + h[-1])
    grid = np.concatenate([-np.geomspace(4.0 / depth, 1e-3 / depth, 40), [0.0],
                           np.geomspace(1e-3 / depth, 200.0 / h0, 400)])
    costs = np.array([cost(b)[0] for b in grid])
    i = int(np.argmin(costs))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    phi = 0.5 * (math.sqrt(5.0) - 1.0)
    c, d = hi - phi * (hi - lo), lo + phi * (hi - lo)
    fc, fd = cost(c)[0], cost(d)[0]
    for _ in range(200):
        if fc < fd:
            hi, d, fd = d, c, fc
            c = hi - phi * (hi - lo)
            fc = cost(c)[0]
        else:
            lo, c, fc = c, d, fd
            d = lo + phi * (hi - lo)
            fd = cost(d)[0]
        if hi - lo <= 1e-13 * max(abs(lo), abs(hi), 1.0 / depth):
            break
    b = 0.5 * (lo + hi)
    _, ln_A = cost(b)
    return BedValue(float(math.exp(ln_A)), float(1.0 / b) if b != 0 else math.inf, int(n))


def budget_bed_fraction(uw_bed: float, uw_total: float) -> float:
    """``1 - tau_air(0) / tau_total`` from kinematic stresses (negative for a downward flux):
    the grain-borne share at the bed in a steady layer (module docstring)."""
    if not (math.isfinite(uw_bed) and math.isfinite(uw_total)) or uw_total == 0:
        return math.nan
    return 1.0 - uw_bed / uw_total


def mass_flux_profile(pmu: np.ndarray, dz: np.ndarray, Lx: float, Ly: float) -> np.ndarray:
    """G(z) = <pmu>/(Lx Ly dz) [kg m-2 s-1] (eq. 11, horizontally and time averaged)."""
    pmu = np.asarray(pmu, dtype=np.float64)
    mean = np.nanmean(pmu, axis=0) if pmu.ndim == 2 and pmu.shape[0] > 0 else (
        pmu if pmu.ndim == 1 else np.full(np.shape(dz), np.nan))
    return mean / (Lx * Ly * np.asarray(dz, dtype=np.float64))


def total_flux(G: np.ndarray, dz: np.ndarray) -> float:
    """G_tot = sum_k G_k dz_k [kg m-1 s-1]."""
    G = np.asarray(G, dtype=np.float64)
    if not np.any(np.isfinite(G)):
        return math.nan
    return float(np.nansum(G * np.asarray(dz, dtype=np.float64)))


def first_drop_height(z: np.ndarray, f: np.ndarray, threshold: float) -> float:
    """Lowest height where ``f`` (on levels ``z``, ``f(z[0]) >= threshold``) falls below
    ``threshold``: interpolated in ln f where both values are positive (exact for an exponential),
    else linearly; NaN when undefined."""
    z, f = (np.asarray(v, dtype=np.float64) for v in (z, f))
    if (not (math.isfinite(threshold) and threshold > 0) or f.size == 0 or not np.isfinite(f[0])
            or f[0] < threshold):
        return math.nan
    for k in range(1, f.size):
        if not np.isfinite(f[k]):
            continue
        if f[k] < threshold:
            f0, f1 = f[k - 1], f[k]
            if f0 > 0 and f1 > 0:
                s = (math.log(threshold) - math.log(f0)) / (math.log(f1) - math.log(f0))
            else:
                s = (threshold - f0) / (f1 - f0)
            return float(z[k - 1] + s * (z[k] - z[k - 1]))
    return math.nan


def z_m_from_tau(z: np.ndarray, tau_p: np.ndarray, rho: float, u_star: float,
                 fraction: float = Z_M_FRACTION) -> float:
    """z_m: first height where tau_p < fraction * rho u*^2 (section 3.2 [37])."""
    if not (math.isfinite(u_star) and u_star > 0):
        return math.nan
    return first_drop_height(z, tau_p, fraction * rho * u_star ** 2)


def flux_height(z_w: np.ndarray, G: np.ndarray, fraction: float = FLUX_FRACTION) -> float:
    """Height below which ``fraction`` of the integrated flux lies, exact (G the layer means
    between the faces ``z_w``: the cumulative flux is linear in a layer); NaN for a total <= 0."""
    z_w = np.asarray(z_w, dtype=np.float64)
    G = np.nan_to_num(np.asarray(G, dtype=np.float64))
    cum = np.concatenate([[0.0], np.cumsum(G * np.diff(z_w))])
    total = cum[-1]
    if not (total > 0):
        return math.nan
    target = fraction * total
    k = int(np.argmax(cum >= target))
    if k == 0:
        return float(z_w[0])
    c0, c1 = cum[k - 1], cum[k]
    s = (target - c0) / (c1 - c0) if c1 != c0 else 0.0
    return float(z_w[k - 1] + s * (z_w[k] - z_w[k - 1]))


def decay_height(z: np.ndarray, G: np.ndarray, z_top: float, min_points: int = 3) -> float:
    """e-folding height H of ``G ~ exp(-z/H)`` (section 3.2 [41]): regression of ln G on z for
    ``z <= z_top``, G > 0; NaN with fewer than ``min_points`` levels or a non-decaying fit."""
    z, G = (np.asarray(v, dtype=np.float64) for v in (z, G))
    sel = (z <= z_top) & np.isfinite(G) & (G > 0)
    if sel.sum() < min_points:
        return math.nan
    slope, _ = np.polyfit(z[sel], np.log(G[sel]), 1)
    return float(-1.0 / slope) if slope < 0 else math.nan


def sigma_series(t: np.ndarray, G_tot: np.ndarray, t0: float, t1: float) -> tuple[float, float]:
    """(mean, population standard deviation) of the total flux over ``t0 <= t <= t1``: the
    paper's sigma_G (module docstring); NaN with fewer than two finite values."""
    G_tot, t = np.asarray(G_tot, dtype=np.float64), np.asarray(t, dtype=np.float64)
    eps = 1e-9 * max(1.0, abs(t1))
    sel = (t >= t0 - eps) & (t <= t1 + eps) & np.isfinite(G_tot)
    if sel.sum() < 2:
        return (float(G_tot[sel].mean()) if sel.any() else math.nan), math.nan
    return float(G_tot[sel].mean()), float(G_tot[sel].std())


def pooled_mean_std(chunks) -> tuple[float, float]:
    """(mean, standard deviation) of all finite values of an iterable of arrays, combined chunk
    by chunk (Chan et al.'s pairwise update), so a large record need not be in memory at once:
    ``sigma_G_local`` of the G_col planes; NaN for fewer than two values."""
    n, mean, m2 = 0, 0.0, 0.0
    for c in chunks:
        a = np.asarray(c, dtype=np.float64)
        a = a[np.isfinite(a)]
        if a.size == 0:
            continue
        nb, mb = a.size, float(a.mean())
        m2b = float(((a - mb) ** 2).sum())
        delta = mb - mean
        tot = n + nb
        mean += delta * nb / tot
        m2 += m2b + delta * delta * n * nb / tot
        n = tot
    if n < 2:
        return (mean if n else math.nan), math.nan
    return mean, math.sqrt(m2 / n)


@dataclass(frozen=True, eq=False)
class GrainProfiles:
    """The grains' momentum and mass flux over the sampling window, and the saltation height."""
    tau_p: np.ndarray
    G: np.ndarray
    #: G_tot at each 3-D sample [kg m-1 s-1]
    G_tot_sample: np.ndarray
    #: airborne grain mass per unit bed area, mean over the samples [kg m-2]
    airborne_mass: float
    z_m: float
    variables: Variables


def grain_profiles(fr: Frame, s: dict, u0_stress: float) -> GrainProfiles:
    """tau_p (eq. 10) and G (eq. 11) from the layer sums, and z_m where tau_p first falls below
    0.1 % of rho u*^2 with ``u0_stress`` the stress u* (sections 3.1, 3.2)."""
    pm, pmu, pmw, pmuw = (s.get(k) for k in ("pm", "pmu", "pmw", "pmuw"))
    if pm is not None and pm.ndim == 2 and pm.shape[0] > 0:
        tau_p = tau_p_profile(pm, pmu, pmw, pmuw, fr.dz, fr.Lx, fr.Ly)
        G = mass_flux_profile(pmu, fr.dz, fr.Lx, fr.Ly)
        G_tot_sample = np.nansum(np.asarray(pmu, dtype=np.float64), axis=1) / fr.bed_area
        airborne_mass = float(np.mean(np.nansum(np.asarray(pm, dtype=np.float64), axis=1))) / fr.bed_area
    else:
        tau_p = np.full(fr.nz, np.nan)
        G = np.full(fr.nz, np.nan)
        G_tot_sample = np.full(fr.n_t, np.nan)
        airborne_mass = math.nan
    # z_m against the flow's momentum flux above the layer, rho u*s^2 with the u*s read the
    # paper's way (the total stress at the reference height, its [33]), the u*s that leads Table 2
    z_m = z_m_from_tau(fr.z, tau_p, fr.rho, u0_stress)
    V = Variables()
    V.put("tau_p", ("z",), tau_p, sign="positive for a downward flux of streamwise momentum")
    V.put("z_m", (), z_m, definition="tau_p first below 0.1 % of rho u_star_s_stress^2 (log "
          "interpolation)")
    return GrainProfiles(tau_p, G, G_tot_sample, airborne_mass, z_m, V)


def bed_share_statistics(fr: Frame, tau_p: np.ndarray, z_m: float, u0_stress: float,
                         uw_mean_w: np.ndarray) -> Variables:
    """tau_p at the bed over the total stress at the reference height (section 3.2 [40], Fig. 6):
    from the exponential fitted to the lowest layers, over the paper's first level, and by the
    momentum budget (``uw_mean_w``: the air's mean momentum flux on the faces)."""
    bed = bed_value(fr.z_w, tau_p, BED_FIT_FRACTION * z_m)
    rho_u2_stress = fr.rho * u0_stress ** 2 if math.isfinite(u0_stress) else math.nan
    ok_norm = rho_u2_stress > 0
    V = Variables()
    V.put("tau_p_bed", (), bed.value, layers_fitted=bed.n_layers)
    V.put("tau_p_bed_decay_height", (), bed.height)
    V.put("tau_p_surface_fraction", (), bed.value / rho_u2_stress if ok_norm else math.nan,
          definition="tau_p_bed / (rho u_star_s_stress^2) (saltstudy.analysis.flux)")
    V.put("tau_p_paper_cell_fraction", (),
          bed.layer_mean(paper_grid.PAPER_FIRST_LAYER) / rho_u2_stress if ok_norm else math.nan)
    V.put("tau_p_surface_fraction_budget", (), budget_bed_fraction(
        float(uw_mean_w[0]), -u0_stress ** 2) if uw_mean_w.size == fr.nz + 1 else math.nan)
    return V


def mass_flux_statistics(fr: Frame, s: dict, G: np.ndarray, z_m: float,
                         airborne_mass: float) -> Variables:
    """G_tot, its heights (z_m_flux995, the decay height below z_m) and its variability: sigma_G
    of the total-flux series over the sampling window (section 4.3 [55]) and the spread of the
    local column flux over the planes of the window (sigma_G_local)."""
    V = Variables()
    V.put("G", ("z",), G)
    V.put("G_tot", (), total_flux(G, fr.dz))
    V.put("airborne_mass_per_m2", (), airborne_mass)
    V.put("z_m_flux995", (), flux_height(fr.z_w, G))
    V.put("G_decay_height", (), decay_height(fr.z, G, z_m))
    G_series = s.get("G_tot_series")
    g_mean, sigma_G = (sigma_series(fr.t_series, G_series, fr.t0, fr.t1)
                       if G_series is not None and fr.t_series.size == G_series.size
                       else (math.nan, math.nan))
    V.put("G_tot_window_mean", (), g_mean)
    V.put("sigma_G", (), sigma_G, definition="std over the sampling window of the total-flux "
          "series G_tot_series (see saltstudy.analysis.flux)")
    V.put("sigma_G_over_G_tot", (), sigma_G / g_mean
          if g_mean and math.isfinite(g_mean) and g_mean > 0 else math.nan)
    G_col = s.get("G_col")
    pmask = fr.plane_mask
    idx = np.flatnonzero(pmask)
    m_loc, s_loc = (pooled_mean_std(G_col[idx[i:i + PLANE_CHUNK]]
                                    for i in range(0, idx.size, PLANE_CHUNK))
                    if G_col is not None and G_col.ndim == 3 and G_col.shape[0] == pmask.size
                    and pmask.any() else (math.nan, math.nan))
    V.put("sigma_G_local", (), s_loc)
    V.put("sigma_G_local_over_mean", (), s_loc / m_loc
          if m_loc and math.isfinite(m_loc) and m_loc > 0 else math.nan)
    return V
