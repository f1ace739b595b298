"""Pure physical laws: threshold, drag, splash, soil size distribution, semi-empirical laws.

The laws the grain kernels call (drag, splash draws, diameter draw) are numba functions here, once,
shared by the kernels, the steady-layer probe and the tests; the rest is numpy.
"""
from .drag import (drag_correction, particle_response_time, particle_reynolds,
                   stokes_terminal_velocity, terminal_velocity)
from .laws import GTOT_LAWS, Z0S_LAWS, Law, log_law_u
from .soil import (bin_mass_fractions, diameter_bins, draw_diameter, mass_density_dlnd,
                   mass_median, number_density_dlnd, sample_diameters)
from .splash import (ejection_number_mean, mean_ejecta_number, mean_ejecta_speed,
                     mean_rebound_fraction, mean_rebound_speed, mean_splash_energy_ratio,
                     rebound_probability, splash_impacts, truncated_normal_moments)
from .threshold import threshold_for_soil, threshold_friction_velocity

__all__ = [
    "drag_correction", "particle_response_time", "particle_reynolds", "stokes_terminal_velocity",
    "terminal_velocity", "GTOT_LAWS", "Z0S_LAWS", "Law", "log_law_u", "bin_mass_fractions",
    "diameter_bins", "draw_diameter", "mass_density_dlnd", "mass_median", "number_density_dlnd",
    "sample_diameters", "ejection_number_mean", "mean_ejecta_number", "mean_ejecta_speed",
    "mean_rebound_fraction", "mean_rebound_speed", "mean_splash_energy_ratio",
    "rebound_probability", "splash_impacts", "truncated_normal_moments",
    "threshold_for_soil", "threshold_friction_velocity",
]
