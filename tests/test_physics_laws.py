"""Semi-empirical z0s (Fig. 3) and G_tot (Fig. 8) laws: known numbers, dimensions, monotonicity."""
from __future__ import annotations

import inspect
import math
from functools import partial

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from saltstudy.physics.drag import terminal_velocity
from saltstudy.physics.laws import (D_REF, GTOT_LAWS, RAUPACH_A, Z0S_LAWS, Law, bagnold1937_flux,
                                    charnock_z0s, kawamura_white_flux, lettau1978_flux,
                                    log_law_profile, log_law_u, owen1964_flux,
                                    owen_terminal_velocity, raupach1991_z0s, sherman1992_z0s,
                                    sorensen2004_flux, z0_at_fixed_u_star)

UT = 0.262          # Shao & Lu u*t for 200 um
BASE = dict(d=200e-6, rho=1.2, rho_p=2650.0, g=9.81, nu=1.5e-5)


def test_registries_are_name_to_callable_and_citation():
    assert set(Z0S_LAWS) == {"charnock_rasmussen1985", "charnock_farrell1999", "charnock_owen1964",
                             "raupach1991", "sherman1992"}
    assert set(GTOT_LAWS) == {"bagnold1937", "owen1964", "kawamura_white", "lettau1978", "sorensen2004"}
    for law in [*Z0S_LAWS.values(), *GTOT_LAWS.values()]:
        func, citation = law
        assert isinstance(law, Law) and callable(func) and isinstance(citation, str) and citation


# ------------------------------------------------------------------------ known numbers
def test_z0s_known_numbers():
    u = 0.5
    assert charnock_z0s(u, C_c=0.08) == pytest.approx(0.08 * 0.25 / 9.81)
    assert Z0S_LAWS["charnock_farrell1999"].func(u, UT) == pytest.approx(0.24 * 0.25 / 9.81)
    assert Z0S_LAWS["charnock_owen1964"].func(u, UT) == pytest.approx(0.02 * 0.25 / 9.81)
    assert RAUPACH_A == pytest.approx(8 * 0.63 ** 2 * math.exp(-0.577216), rel=1e-12)
    assert RAUPACH_A == pytest.approx(1.78275, abs=1e-5)
    r = UT / u
    assert raupach1991_z0s(u, UT, z0=1e-5) == pytest.approx((RAUPACH_A * 0.25 / 19.62) ** (1 - r) * 1e-5 ** r)
    assert sherman1992_z0s(u, UT, z0=1e-5) == pytest.approx(0.132 * (u - UT) ** 2 / 9.81 + 1e-5)
    # at and below threshold the threshold laws give the bed roughness
    for f in (raupach1991_z0s, sherman1992_z0s):
        assert f(UT, UT, z0=1e-5) == pytest.approx(1e-5, rel=1e-12)
        assert f(0.8 * UT, UT, z0=1e-5) == pytest.approx(1e-5, rel=1e-12)


def test_gtot_known_numbers():
    u = 0.5
    r = UT / u
    q = 1.2 * u ** 3 / 9.81                                     # rho u*^3 / g [kg m^-1 s^-1]
    assert bagnold1937_flux(u, d=D_REF) == pytest.approx(1.5 * q)
    assert bagnold1937_flux(u, d=4 * D_REF) == pytest.approx(3.0 * q)
    wt = 1.66 * math.sqrt(2650 / 1.2 * 9.81 * 200e-6)         # 3.455 m/s
    assert owen1964_flux(u, UT) == pytest.approx((0.25 + wt / (3 * u)) * q * (1 - r * r))
    assert kawamura_white_flux(u, UT) == pytest.approx(2.61 * q * (1 - r) * (1 + r) ** 2)
    assert lettau1978_flux(u, UT, d=D_REF) == pytest.approx(4.2 * q * (1 - r))
    assert sorensen2004_flux(u, UT) == pytest.approx(q * (1 - r * r) * (3.0 * r + 3.9 * r * r))
    for f in (owen1964_flux, kawamura_white_flux, lettau1978_flux, sorensen2004_flux):
        assert f(UT, UT) == 0.0 and f(0.5 * UT, UT) == 0.0


def test_owen_terminal_velocity_forms():
    d, rho_p, rho, g = 200e-6, 2650.0, 1.2, 9.81
    consistent = owen_terminal_velocity(d, rho_p, rho, g)
    printed = owen_terminal_velocity(d, rho_p, rho, g, form="printed")
    physical = owen_terminal_velocity(d, rho_p, rho, g, form="terminal")
    assert consistent == pytest.approx(3.4553, abs=1e-4)
    assert printed == pytest.approx(consistent * math.sqrt(rho), rel=1e-12)
    assert physical == pytest.approx(terminal_velocity(d, rho_p, rho, 1.5e-5, g))
    assert physical == pytest.approx(1.482, abs=1e-3)
    # 1.66 sqrt(sigma_p g d) is the Newton-regime fall speed sqrt(4 sigma_p g d / (3 C_D)), C_D = 0.484
    assert consistent == pytest.approx(math.sqrt(4 * rho_p / rho * g * d / (3 * 0.4838)), rel=1e-3)
    with pytest.raises(ValueError):
        owen_terminal_velocity(d, rho_p, rho, g, form="nonsense")


def test_log_law():
    assert log_law_u(1e-5, 0.4, 1e-5) == 0.0
    assert log_law_u(math.e * 1e-5, 0.4, 1e-5, kappa=0.4) == pytest.approx(1.0)
    np.testing.assert_allclose(log_law_u(np.array([0.1, 1.0]), 0.5, 1e-4),
                               0.5 / 0.4 * np.log([1e3, 1e4]))


@pytest.mark.parametrize("H", [None, 6.0])
def test_z0_at_fixed_u_star_recovers_the_profile_and_sees_a_slope_error(H):
    z = np.geomspace(0.05, 3.0, 30)
    U = log_law_profile(z, 0.41, 1e-5, 0.4, H)
    assert z0_at_fixed_u_star(z, U, 0.41, 0.4, 0.3, 2.0, H) == pytest.approx(1e-5, rel=1e-9)
    # u* held 10 % too high: the same profile needs a larger z0 (U = u*/kappa ln(z/z0))
    assert z0_at_fixed_u_star(z, U, 0.451, 0.4, 0.3, 2.0, H) > 2e-5
    assert math.isnan(z0_at_fixed_u_star(z, U, 0.41, 0.4, 5.0, 6.0, H))   # no level in range
    assert math.isnan(z0_at_fixed_u_star(z, U, 0.0, 0.4, 0.3, 2.0, H))


# ------------------------------------------------------------------------ dimensions
# Change of units: 1 m -> L, 1 kg -> M, 1 s -> T. A dimensionally consistent law must give the
# converted answer when fed converted inputs.
def _scaled_kwargs(func, kw, L, M, T):
    conv = dict(d=L, rho=M / L ** 3, rho_p=M / L ** 3, g=L / T ** 2, nu=L ** 2 / T, z0=L, D=L)
    out = {k: v * conv[k] for k, v in kw.items()}
    if "D" in inspect.signature(func).parameters:
        out["D"] = D_REF * L
    return out


def _dimension_ok(func, kw, out_factor, L, M, T, u=0.55):
    ref = func(u, UT, **kw)
    new = func(u * L / T, UT * L / T, **_scaled_kwargs(func, kw, L, M, T))
    return new == pytest.approx(ref * out_factor(L, M, T), rel=1e-9)


scales = dict(L=st.floats(1e-3, 1e3), M=st.floats(1e-3, 1e3), T=st.floats(1e-2, 1e2))


@settings(deadline=None, max_examples=40)
@given(**scales)
def test_z0s_laws_are_lengths(L, M, T):
    for name, (func, _) in Z0S_LAWS.items():
        assert _dimension_ok(func, dict(z0=1e-5, g=9.81), lambda L, M, T: L, L, M, T), name


@settings(deadline=None, max_examples=40)
@given(**scales)
def test_gtot_laws_are_mass_fluxes_per_width(L, M, T):
    for name, (func, _) in GTOT_LAWS.items():
        assert _dimension_ok(func, BASE, lambda L, M, T: M / (L * T), L, M, T), name
    owen_drag = partial(owen1964_flux, w_t_form="terminal")
    assert _dimension_ok(owen_drag, BASE, lambda L, M, T: M / (L * T), L, M, T)


def test_printed_owen_form_fails_the_dimension_check():
    """The check above can fail: Owen's w_t as printed (-1.66 sqrt(rho_p g d)) is not a velocity."""
    printed = partial(owen1964_flux, w_t_form="printed")
    assert not _dimension_ok(printed, BASE, lambda L, M, T: M / (L * T), 1.0, 10.0, 1.0)
    assert _dimension_ok(owen1964_flux, BASE, lambda L, M, T: M / (L * T), 1.0, 10.0, 1.0)


# ------------------------------------------------------------------------ monotonicity
@settings(deadline=None, max_examples=40)
@given(ut=st.floats(0.15, 0.5), d=st.floats(60e-6, 600e-6), z0=st.floats(1e-6, 1e-4))
def test_laws_increase_with_u_star_above_threshold(ut, d, z0):
    u = ut * np.linspace(1.001, 6.0, 400)
    for name, (func, _) in Z0S_LAWS.items():
        z = func(u, ut, z0=z0, g=9.81)
        assert np.all(np.diff(z) > 0), name
        assert np.all(z > 0), name
    kw = dict(BASE, d=d)
    for name, (func, _) in GTOT_LAWS.items():
        gt = func(u, ut, **kw)
        assert np.all(np.diff(gt) > 0), name
        assert np.all(gt > 0), name


def test_vectorised_equals_scalar():
    u = np.array([0.3, 0.54, 1.1])
    for name, (func, _) in {**Z0S_LAWS, **GTOT_LAWS}.items():
        arr = func(u, UT)
        assert arr.shape == (3,), name
        for ui, ai in zip(u, arr):
            assert func(float(ui), UT) == pytest.approx(ai, rel=1e-14), name


def test_creyssels_law_fits_its_measurements():
    """Creyssels et al. (2009): the quadratic law against their six fluxes (a check of the
    transcription: the law is the fit of these points, not a tuned value)."""
    from saltstudy.physics.laws import CREYSSELS2009_Q, CREYSSELS2009_U_STAR, creyssels2009_flux

    u = np.array(CREYSSELS2009_U_STAR)
    ratio = creyssels2009_flux(u) / np.array(CREYSSELS2009_Q)
    assert np.all(np.abs(ratio[2:] - 1) < 0.08)
    assert 0.8 < ratio[1] < 0.9
    assert creyssels2009_flux(0.2) == 0.0
    # dimensional form: rho/g (u*^2 - u*th^2) in kg m^-1 s^-1
    assert creyssels2009_flux(0.412) == pytest.approx(1.38 * 1.2 / 9.81 * (0.412 ** 2 - 0.206 ** 2))
