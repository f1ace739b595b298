"""Soil grain-size distribution: multimodal lognormal mass-size distribution (paper eq. 5;
Marticorena & Bergametti 1995):

    dM/dln d = sum_j  m_j / (sqrt(2 pi) ln sigma_j)  exp( -(ln d - ln mu_j)^2 / (2 ln^2 sigma_j) )

m_j the mass fraction, mu_j the mass median diameter [m], sigma_j the geometric standard deviation.
A mode's number distribution is lognormal with count median mu_j exp(-3 ln^2 sigma_j)
(Hatch-Choate). Diameters in m; :func:`draw_diameter` is the numba draw the kernels share.
"""
from __future__ import annotations

import math

import numpy as np

from .._jit import jit

_erf = np.vectorize(math.erf, otypes=[float])


def norm_cdf(x):
    """Standard normal CDF Phi(x) (numpy, vectorised; no scipy)."""
    out = 0.5 * (1.0 + _erf(np.asarray(x, dtype=float) / math.sqrt(2.0)))
    return float(out) if out.ndim == 0 else out


def _modes(soil):
    m = np.array([mode.mass_fraction for mode in soil.modes], dtype=float)
    mu = np.array([mode.mu for mode in soil.modes], dtype=float)
    s = np.log(np.array([mode.sigma for mode in soil.modes], dtype=float))
    return m, mu, s


def scalar_or_array(a):
    """A float for a 0-d input, else the array: the laws' outputs follow their inputs' shape."""
    return float(a) if np.ndim(a) == 0 else a


def mass_cdf(d, soil):
    """Mass fraction of grains smaller than ``d`` [m]: sum_j m_j Phi(ln(d/mu_j)/ln sigma_j)."""
    with np.errstate(divide="ignore"):
        x = np.log(np.asarray(d, dtype=float))[..., None]
    m, mu, s = _modes(soil)
    return scalar_or_array((m * norm_cdf((x - np.log(mu)) / s)).sum(axis=-1))


def soil_arrays(soil) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(cumulative mass fractions, mu_j, ln sigma_j), as :func:`draw_diameter` takes them."""
    m, mu, lns = _modes(soil)
    cum = np.cumsum(m) / m.sum()
    cum[-1] = 1.0
    return cum, mu, lns


@jit
def draw_diameter(rng, cum, mu, lnsig) -> float:
    """A diameter [m] from the *mass* distribution of eq. (5), as the paper draws ejecta (section
    2.3, para. 24): mode j with probability m_j (one uniform draw, none for one mode), then
    d = mu_j exp(ln sigma_j Z), Z ~ N(0, 1)."""
    j = 0
    if cum.shape[0] > 1:
        r = rng.random()
        while j < cum.shape[0] - 1 and r >= cum[j]:
            j += 1
    return mu[j] * math.exp(lnsig[j] * rng.normal(0.0, 1.0))


@jit
def _draw_diameters(rng, cum, mu, lnsig, out):
    for i in range(out.shape[0]):
        out[i] = draw_diameter(rng, cum, mu, lnsig)


def sample_diameters(soil, rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` diameters [m] drawn from the mass distribution of eq. (5) (:func:`draw_diameter`)."""
    out = np.empty(int(n))
    _draw_diameters(rng, *soil_arrays(soil), out)
    return out


def bin_mass_fractions(soil, edges) -> np.ndarray:
    """Mass fraction [-] of the soil in each bin [edges[i], edges[i+1]) (exact, unnormalised)."""
    edges = np.asarray(edges, dtype=float)
    if edges.ndim != 1 or edges.size < 2 or np.any(np.diff(edges) <= 0):
        raise ValueError("edges must be a 1-D increasing array of at least 2 values")
    return np.diff(mass_cdf(edges, soil))
