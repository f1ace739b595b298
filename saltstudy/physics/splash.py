"""Splash laws at the bed, paper eqs. 6-9 (section 2.3).

Scalar laws are numba-jitted so the solver's bed kernel uses the same code as the tests.
"""
from __future__ import annotations

import math

from .._jit import jit

__all__ = ["rebound_probability", "ejection_number_mean"]


@jit
def rebound_probability(v_imp: float, p_reb_max: float, gamma_reb: float) -> float:
    """P_reb = p_max (1 - exp(-gamma_reb v_imp)), eq. 6 (Anderson & Haff 1991); p_max = 0.95."""
    return p_reb_max * (1.0 - math.exp(-gamma_reb * v_imp))


@jit
def ejection_number_mean(v_imp: float, a_ej: float, g: float, d_mean: float) -> float:
    """Mean number of ejecta N_ej = a v_imp / sqrt(g <d_p>), eq. 8 (Kok & Renno 2009)."""
    return a_ej * v_imp / math.sqrt(g * d_mean)
