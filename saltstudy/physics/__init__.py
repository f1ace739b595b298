"""Pure physical laws: threshold, drag, splash, soil size distribution, semi-empirical laws.

The scalar laws used inside solver kernels (``drag_correction``, ``particle_response_time``,
``particle_reynolds``, ``rebound_probability``, ``ejection_number_mean``) are numba-jitted; the
rest is numpy. ``drag_correction`` is the reference law; the parcel kernels evaluate it with the
power inlined (``solver.grains.coupling.drag_rate``, ``solver.numerics.elementary.pow_0687``, within 3 ulp).
"""
from .drag import (drag_correction, particle_response_time, particle_reynolds,
                   stokes_terminal_velocity, terminal_velocity)
from .laws import GTOT_LAWS, Z0S_LAWS, Law, log_law_u
from .soil import (bin_mass_fractions, diameter_bins, mass_density_dlnd, mass_median,
                   number_density_dlnd, sample_diameters)
from .splash import (ejection_number_mean, mean_ejecta_number, mean_ejecta_speed,
                     mean_rebound_fraction, mean_rebound_speed, mean_splash_energy_ratio,
                     rebound_probability, sample_ejecta_number, sample_ejection, sample_rebound,
                     truncated_normal_moments)
from .threshold import threshold_for_soil, threshold_friction_velocity

__all__ = [
    "drag_correction", "particle_response_time", "particle_reynolds", "stokes_terminal_velocity",
    "terminal_velocity", "GTOT_LAWS", "Z0S_LAWS", "Law", "log_law_u", "bin_mass_fractions",
    "diameter_bins", "mass_density_dlnd", "mass_median", "number_density_dlnd", "sample_diameters",
    "ejection_number_mean", "mean_ejecta_number", "mean_ejecta_speed", "mean_rebound_fraction",
    "mean_rebound_speed", "mean_splash_energy_ratio", "rebound_probability",
    "sample_ejecta_number", "sample_ejection", "sample_rebound", "truncated_normal_moments",
    "threshold_for_soil", "threshold_friction_velocity",
]
