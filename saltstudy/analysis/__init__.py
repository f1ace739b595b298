"""Statistics of one case from its archives: ``samples.nc`` (+ ``spinup.nc``) -> ``analysis.nc``.

Entry point: :func:`saltstudy.analysis.analyse.analyse_case` (also ``saltstudy analyse``).
Each module defines its statistics in its docstring, with the paper's section and equation, and
holds the functions that compute them for one case (each returns its variables of analysis.nc):

* ``profiles``    - mean wind, momentum flux, TKE; log-law fit (u*s, z0s; u*0, z00); stress u*
* ``flux``        - tau_p (eq. 10) and its bed value, z_m, G (eq. 11), G_tot, z_m_flux995, sigma_G
* ``balance``     - the momentum balance at the bed, from the air's budget and the impact record
* ``streamers``   - parcel-count noise of C_p, C_p autocorrelation (lambda_x, lambda_y),
                    spanwise spectra (delta_y),
                    space-time correlation (streamer lifetime and speed)
* ``streamer_statistics`` - those readings applied to a case's planes, with the paper's noise
* ``correlation`` - R_cu (eq. 12), R_cu_upper, lagged correlation R_cu_lag
* ``stokes``      - eps_tot (eq. 13), T_eps, T_p, St
* ``sizes``       - grain-size distribution by height band and of the bed; the threshold u*t
* ``series``      - parcel count overshoot, equilibrium time, splash/impact energy ratio
* ``layer``       - the layer's anatomy by height band and the impact record
* ``paper_grid``  - the paper's column area and first level (for readings made as the paper's)
* ``reading``     - the archives read (lazily where large), the case's grid and sampling window
* ``schema``      - the contract of analysis.nc: every variable's units and meaning (``SPEC``)
* ``analyse``     - the assembly: the statistics in the order their definitions need

The package reads archives only (never the solver); it imports nothing heavy at import time.
"""


def analyse_case(*args, **kwargs):
    """See :func:`saltstudy.analysis.analyse.analyse_case`."""
    from .analyse import analyse_case as _impl
    return _impl(*args, **kwargs)


__all__ = ["analyse_case"]
