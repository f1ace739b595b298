"""The saltation layer's anatomy (analysis/layer.py) on synthetic layer sums and impact counts."""
from __future__ import annotations

import math

import numpy as np
import pytest

from saltstudy.analysis import layer


def test_bands_split_the_column_and_convert_to_the_cases_parcels():
    """Grains in the first cell, at 3 cm and at 20 cm: each band holds its own, per m2 at the
    case's Q; mass, flux and speeds are the band's sums and ratios."""
    z_w = np.array([0.0, 0.01, 0.022, 0.036, 0.06, 0.1, 0.3])
    z = 0.5 * (z_w[1:] + z_w[:-1])
    nz = z.size
    pn = np.zeros((2, nz))
    pm = np.zeros((2, nz))
    pmu = np.zeros((2, nz))
    pmuf = np.zeros((2, nz))
    pn[:, 0], pn[:, 2], pn[:, 5] = 6000.0, 3000.0, 1000.0     # real grains in the layer
    pm[:] = pn * 1e-8
    pmu[:] = pm * np.array([0.7, 0, 1.5, 0, 0, 3.0])
    pmuf[:] = pm * np.array([1.9, 0, 3.0, 0, 0, 5.0])
    area, Q = 2.0, 10.0
    out = layer.band_anatomy(z, z_w, pn, pm, pmu, pmuf, Q, area)
    assert out["band_edges"] == pytest.approx([0.0, 0.01, 0.05, 0.3])
    assert out["band_parcels_per_m2_at_Q"] == pytest.approx([300.0, 150.0, 50.0])
    assert out["band_mass_per_m2"] == pytest.approx([3e-5, 1.5e-5, 5e-6])
    assert out["band_speed"] == pytest.approx([0.7, 1.5, 3.0])
    assert out["band_wind_seen"] == pytest.approx([1.9, 3.0, 5.0])
    assert out["band_flux"].sum() == pytest.approx(float(pmu[0].sum()) / area)


def test_impact_statistics_over_the_window():
    """Cumulative counts at three samples: the window's counts are last minus first; the mean
    replacement is (rebounds + ejecta) / impacts; the hop medians fall in the right bins; an
    archive with no record gives NaN."""
    ve = np.arange(81) * 0.1
    ae = np.arange(46) * 2.0
    te = np.arange(301) * 0.005
    le = np.arange(301) * 0.01
    H = np.zeros((3, 80, 45))
    O = np.zeros((3, 80, 3))
    T = np.zeros((3, 300))
    L = np.zeros((3, 300))
    H[:, 7, 6] = [100, 250, 400]        # 300 impacts at 0.7-0.8 m/s, 12-14 deg in the window
    O[:, 7] = [[100, 70, 50], [250, 175, 95], [400, 280, 140]]
    T[:, 8] = [10, 35, 60]              # 50 hops of 40-45 ms
    L[:, 3] = [10, 35, 60]              # 3-4 cm
    st = layer.impact_statistics(H, O, T, L, ve, ae, te, le)
    assert st["impact_speed_mean"] == pytest.approx(0.75)
    assert st["impact_angle_mean"] == pytest.approx(13.0)
    assert st["impacts_by_speed"][7] == 300
    assert st["replacement_mean"] == pytest.approx((210 + 90) / 300)
    assert st["rebound_fraction"] == pytest.approx(0.7)
    assert st["replacement_by_speed"][7] == pytest.approx(1.0)
    assert 0.040 <= st["hop_time_median"] <= 0.045
    assert 0.03 <= st["hop_length_median"] <= 0.04
    assert st["hop_height_ballistic_median"] == pytest.approx(9.81 * st["hop_time_median"] ** 2 / 8)
    assert np.nansum(st["impact_speed_pdf"] * np.diff(ve)) == pytest.approx(1.0)
    none = layer.impact_statistics(None, None, None, None, np.zeros(1), np.zeros(1), np.zeros(1),
                                   np.zeros(1))
    assert math.isnan(none["replacement_mean"]) and none["impact_speed_pdf"].size == 0
