"""`saltstudy probe coherence`: the spanwise co-spectrum and coherence of C_p and u on synthetic
planes with a known shared pattern, and the command on a small archive."""
from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.instruments.coherence_probe import spanwise_cospectrum

NT, NX, NY, DY = 64, 12, 40, 0.1


def _shared(mode: int, amp_a: float, amp_b: float, noise: float, seed: int = 1):
    """Two plane series sharing a spanwise wave of ``mode`` cycles over the width, moving in
    phase, each with its own white noise of standard deviation ``noise``."""
    rng = np.random.default_rng(seed)
    y = np.arange(NY) * DY
    phase = rng.uniform(0, 2 * np.pi, (NT, NX, 1))
    wave = np.sin(2 * np.pi * mode * y[None, None, :] / (NY * DY) + phase)
    a = 5.0 + amp_a * wave + noise * rng.standard_normal((NT, NX, NY))
    b = -2.0 + amp_b * wave + noise * rng.standard_normal((NT, NX, NY))
    return a, b


def test_the_cospectrum_integrates_to_the_covariance_and_peaks_at_the_shared_wave():
    a, b = _shared(mode=5, amp_a=1.0, amp_b=0.5, noise=0.3)
    r = spanwise_cospectrum(a, b, DY, n_blocks=8)
    Ly = NY * DY
    da = a - a.mean(axis=(1, 2), keepdims=True)
    db = b - b.mean(axis=(1, 2), keepdims=True)
    assert r["Co"].sum() / Ly == pytest.approx((da * db).mean(), rel=1e-10)
    assert r["S_a"].sum() / Ly == pytest.approx((da ** 2).mean(), rel=1e-10)
    assert int(np.argmax(r["Co"])) == 5
    # the wave's covariance amp_a amp_b / 2 = 0.25 sits in mode 5
    assert r["Co"][5] / Ly == pytest.approx(0.25, rel=0.05)
    # coherence: the wave's share at its mode (power 0.5 against noise 0.09 / 20 per one-sided
    # mode for a), none elsewhere beyond the estimate's bias of ~1/(NT NX)
    assert r["coherence2"][5] > 0.9
    others = np.delete(r["coherence2"][1:], 4)
    assert np.max(others) < 0.05
    assert np.all(np.isfinite(r["Co_se"])) and r["Co_se"][5] > 0


def test_independent_fields_have_no_coherence_and_a_cospectrum_inside_its_error():
    rng = np.random.default_rng(3)
    a = rng.standard_normal((NT, NX, NY))
    b = rng.standard_normal((NT, NX, NY))
    r = spanwise_cospectrum(a, b, DY)
    assert np.max(r["coherence2"][1:]) < 0.05
    # a zero co-spectrum read with its block error: within 4 standard errors everywhere
    assert np.all(np.abs(r["Co"][1:]) < 4 * r["Co_se"][1:])


def test_planes_of_different_shapes_are_refused():
    with pytest.raises(ValueError, match="equal"):
        spanwise_cospectrum(np.zeros((4, 3, 8)), np.zeros((4, 3, 6)), DY)


def _archive(path, mode=4):
    a, b = _shared(mode=mode, amp_a=1.0, amp_b=0.8, noise=0.2)
    u = np.stack([b, 0.0 * b + np.random.default_rng(9).standard_normal(b.shape)], axis=-1)
    xr.Dataset({"C_p": (("time_plane", "x", "y"), a),
                "u_plane": (("time_plane", "x", "y", "z_plane"), u)},
               coords={"y": (np.arange(NY) + 0.5) * DY, "x": (np.arange(NX) + 0.5) * DY,
                       "z_plane": [0.1, 0.4], "time_plane": np.arange(NT) * 0.2}
               ).to_netcdf(path)


def test_the_command_reads_each_height_of_an_archive(tmp_path):
    _archive(tmp_path / "samples.nc", mode=4)
    res = CliRunner().invoke(app, ["probe", "coherence", str(tmp_path), "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    lam = NY * DY / 4
    assert [h["z"] for h in out["heights"]] == [0.1, 0.4]
    locked, unrelated = out["heights"]
    assert locked["peak_kCo_m"] == pytest.approx(lam)
    assert max(locked["coherence2"]) > 0.9
    assert max(unrelated["coherence2"]) < 0.05
    assert out["peak_kS_c_m"] == pytest.approx(lam)
    text = CliRunner().invoke(app, ["probe", "coherence", str(tmp_path / "samples.nc")])
    assert text.exit_code == 0 and "coherence^2" in text.output


def test_a_lag_finds_a_field_that_follows_the_wind_late(tmp_path):
    """C_p repeats u's spanwise wave three planes (0.6 s) later, with a new random phase every
    plane: unrelated at zero lag, locked at 0.6 s."""
    rng = np.random.default_rng(4)
    y = np.arange(NY) * DY
    phase = rng.uniform(0, 2 * np.pi, (NT + 3, NX, 1))
    wave = np.sin(2 * np.pi * 4 * y[None, None, :] / (NY * DY) + phase)
    u = wave[3:] + 0.2 * rng.standard_normal((NT, NX, NY))
    c = wave[:NT] + 0.2 * rng.standard_normal((NT, NX, NY))   # c(t) = wave(t - 3 planes)
    xr.Dataset({"C_p": (("time_plane", "x", "y"), c),
                "u_plane": (("time_plane", "x", "y", "z_plane"), u[..., None])},
               coords={"y": (np.arange(NY) + 0.5) * DY, "z_plane": [0.1],
                       "time_plane": np.arange(NT) * 0.2}).to_netcdf(tmp_path / "samples.nc")
    runs = {lag: json.loads(CliRunner().invoke(app, ["probe", "coherence", str(tmp_path), "--json",
                                                     "--lag", str(lag)]).stdout)
            for lag in (0.0, 0.6)}
    assert max(runs[0.0]["heights"][0]["coherence2"]) < 0.05
    assert runs[0.6]["lag_s"] == pytest.approx(0.6)
    assert runs[0.6]["heights"][0]["coherence2"][3] > 0.9          # mode 4 (index 3 from mode 1)
    res = CliRunner().invoke(app, ["probe", "coherence", str(tmp_path), "--lag", "100"])
    assert res.exit_code == 2 and "lag" in res.output


def test_the_command_names_what_an_archive_lacks(tmp_path):
    xr.Dataset({"C_p": (("time_plane", "x", "y"), np.zeros((2, 3, 4)))}).to_netcdf(tmp_path / "s.nc")
    res = CliRunner().invoke(app, ["probe", "coherence", str(tmp_path / "s.nc")])
    assert res.exit_code == 2 and "u_plane" in res.output
    res = CliRunner().invoke(app, ["probe", "coherence", str(tmp_path / "none.nc")])
    assert res.exit_code == 2 and "no such file" in res.output
    res = CliRunner().invoke(app, ["probe", "coherence", str(tmp_path / "s.nc"), "--blocks", "1"])
    assert res.exit_code == 2 and "--blocks" in res.output
