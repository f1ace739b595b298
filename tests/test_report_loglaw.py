"""The log-law report: summary of probe windows against the acceptance bands, on synthetic probes
whose verdict is known by construction."""
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.report.loglaw import build_loglaw_report, summarise_probe

HEIGHTS = [0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 4.0]


def _probe(phi_of_z, fit_u=1.0, z0=1e-5, paper_u=1.0, kx0=0.1, n_windows=3, peak_index=6):
    hs = np.asarray(HEIGHTS)
    z = np.geomspace(0.01, 3.0, 30)
    ny = 48
    power = np.ones(ny // 2 + 1)
    power[peak_index] = 5.0
    wins = []
    for w in range(n_windows):
        jitter = 0.01 * (-1) ** w       # windows scatter; the mean is phi_of_z
        wins.append({"t": 100.0 * (w + 1),
                     "fit": {"2.00": {"u_star_ratio": fit_u + jitter, "z0": z0}},
                     "paper": {"u_star_ratio": paper_u, "z0": z0},
                     "phi": (phi_of_z(hs) + jitter).tolist(),
                     "kx0_share": kx0,
                     "phi_profile": {"z": z.tolist(), "phi": phi_of_z(z).tolist()},
                     "u_spanwise": {"z": 0.1, "power": power.tolist()},
                     "wall_s": 10.0 * (w + 1)})
    return {"grid": [64, ny, 48], "L": [10.0, 7.5, 6.0], "heights": HEIGHTS, "windows": wins}


def test_a_log_law_passes_and_a_dip_fails():
    good = summarise_probe(_probe(lambda z: np.ones_like(z)))
    assert good["all_pass"]
    dip = summarise_probe(_probe(lambda z: 1.0 - 0.3 * np.exp(-((np.log(z) - np.log(0.9)) / 0.5) ** 2)))
    assert not dip["all_pass"]
    failed = [k for k, v in dip["checks"].items() if not v["pass"]]
    assert failed == ["phi 0.2-1.5 m in [0.85, 1.15]"]
    assert dip["checks"][failed[0]]["value"] == pytest.approx(0.7, abs=0.02)


@pytest.mark.parametrize("kw, name", [({"fit_u": 0.9}, "free fit u*/target within 5 %"),
                                      ({"z0": 3e-5}, "free fit z0 within x2 of target"),
                                      ({"paper_u": 1.07}, "paper's reading u*/target within 5 %"),
                                      ({"kx0": 0.4}, "x-uniform share of u'w' at 0.8 m <= 0.3")])
def test_each_criterion_fails_on_its_own(kw, name):
    s = summarise_probe(_probe(lambda z: np.ones_like(z), **kw))
    assert [k for k, v in s["checks"].items() if not v["pass"]] == [name]


def test_only_the_last_windows_count_and_the_peak_is_the_strongest_mode():
    data = _probe(lambda z: np.ones_like(z))
    data["windows"][0]["phi"] = [0.2] * len(HEIGHTS)          # a spin-up window, left out
    s = summarise_probe(data, n_last=2)
    assert s["windows_used"] == [200.0, 300.0]
    assert s["all_pass"]
    # the premultiplied peak (m P(m)) of a flat spectrum with a bump at mode 6: the bump (and of
    # P itself too)
    assert s["u_spanwise"]["peak_wavelength"] == pytest.approx(7.5 / 6)
    assert s["u_spanwise"]["peak_wavelength_raw"] == pytest.approx(7.5 / 6)
    assert s["u_spanwise"]["peak_over_dy"] == pytest.approx(48 / 6)
    assert math.isclose(s["fit_u_star_ratio"], 1.0)


def test_report_command_writes_the_table_and_figures(tmp_path):
    (tmp_path / "good.json").write_text(json.dumps(_probe(lambda z: np.ones_like(z))))
    (tmp_path / "low.json").write_text(json.dumps(_probe(lambda z: 0.7 * np.ones_like(z))))
    res = CliRunner().invoke(app, ["probe", "loglaw-report", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert "good: all pass" in res.output and "low: fails" in res.output
    for f in ("summary.json", "summary.md", "phi.png", "spanwise.png"):
        assert (tmp_path / f).stat().st_size > 0
    table = (tmp_path / "summary.md").read_text()
    assert "| good |" in table and "FAIL" in table
    assert json.loads((tmp_path / "summary.json").read_text())["probes"]["low"]["all_pass"] is False


def test_report_of_an_empty_directory_is_a_clear_error(tmp_path):
    res = CliRunner().invoke(app, ["probe", "loglaw-report", str(tmp_path)])
    assert res.exit_code == 2
    assert "no probe results" in res.output
