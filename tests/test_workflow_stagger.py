"""Staggered starts (``fidelity.spinup.stagger``): case n starts from the shared spin-up continued
for (n - 1) links of ``stagger`` seconds, a chain the cases share, with the real solver at smoke
size."""
from __future__ import annotations

import shutil

import numpy as np
import pytest
import xarray as xr
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.config import load_case, load_fidelity, load_study, project_root, resolve_scene
from saltstudy.ncio import is_complete
from saltstudy.workflow import keys
from saltstudy.workflow.paths import output_path
from saltstudy.workflow.status import study_status

STAGGER = 0.4
STUDY = 'description = "two staggered smoke cases"\nfidelity = "smoke-stagger"\ncases = [1, 3]\n'


@pytest.fixture
def home(tmp_path, monkeypatch):
    h = tmp_path / "home"
    for d in ("cases", "workflows"):
        shutil.copytree(project_root() / d, h / d)
    fid = (h / "workflows" / "fidelities" / "smoke.toml").read_text()
    fid = fid.replace("[spinup]\n", f"[spinup]\nstagger = {STAGGER}\n")
    (h / "workflows" / "fidelities" / "smoke-stagger.toml").write_text(fid)
    (h / "workflows" / "staggered.toml").write_text(STUDY)
    monkeypatch.setenv("SALTSTUDY_HOME", str(h))
    monkeypatch.setenv("SALTSTUDY_OUT", str(tmp_path / "out"))
    return h


def test_stagger_keys_share_the_spinup_and_chain_the_links(home):
    plain = resolve_scene(load_case(3), load_fidelity("smoke"))
    staggered = resolve_scene(load_case(3), load_fidelity("smoke-stagger"))
    first = resolve_scene(load_case(1), load_fidelity("smoke-stagger"))
    assert (plain.start_links, staggered.start_links, first.start_links) == (0, 2, 0)
    kp, ks, k1 = (keys.run_keys(s.label, s) for s in (plain, staggered, first))
    # the spin-up does not depend on where the cases start along it
    assert kp.spinup == ks.spinup == k1.spinup
    assert kp.links == k1.links == () and kp.start == kp.spinup
    assert len(ks.links) == 2 and len(set(ks.links)) == 2 and ks.start == ks.links[-1]
    assert ks.links[0] == keys.continuation_key(ks.spinup, STAGGER)
    # a later start is another run
    assert ks.saltation != kp.saltation and ks.analysis != kp.analysis


def test_staggered_study_runs_the_chain_once_and_starts_later(home, tmp_path):
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["run-all", "--study", "staggered", "--quiet"])
    assert r.exit_code == 0, r.output
    links = [ln for ln in r.output.splitlines() if ln.startswith("[start] continuation ")]
    assert len(links) == 2, r.output
    st = load_study("staggered")
    ks = keys.study_keys(st)
    k1, k3 = ks["case01"], ks["case03"]
    with xr.open_dataset(output_path(out, "spinup", k3.spinup)) as sp, \
            xr.open_dataset(output_path(out, "spinup", k3.start)) as link:
        t_spin = float(sp.attrs["restart__t"])
        assert float(link.attrs["restart__t"]) == pytest.approx(t_spin + 2 * STAGGER, abs=1e-9)
        # the particle-free reference profiles are the spin-up's; the u* history goes on
        np.testing.assert_array_equal(link["u_mean"].values, sp["u_mean"].values)
        th = link["time_hist"].values
        assert th.size > sp["time_hist"].size and th[-1] == pytest.approx(
            float(sp["time_hist"].values[-1]) + 2 * STAGGER, abs=1e-9)
        assert np.all(np.diff(th) > 0) and np.all(np.isfinite(link["u_star_hist"].values))
        assert 0 < float(link.attrs["wall_time_s"])
    with xr.open_dataset(output_path(out, "saltation", k1.saltation)) as s1, \
            xr.open_dataset(output_path(out, "saltation", k3.saltation)) as s3:
        assert float(s1.attrs["t_activation"]) == pytest.approx(t_spin, abs=1e-9)
        assert float(s3.attrs["t_activation"]) == pytest.approx(t_spin + 2 * STAGGER, abs=1e-9)
    rows = {(row.label, row.task): row for row in study_status(st, out)}
    assert rows[("case03", "start")].state == "done" and ("case01", "start") not in rows
    assert all(is_complete(output_path(out, "analysis", k.analysis)) for k in ks.values())
    # rerun: everything cached, the chain included
    r = CliRunner().invoke(app, ["run-all", "--study", "staggered", "--quiet"])
    assert r.exit_code == 0, r.output
    assert "all runs cached: no solver work" in r.output
    assert not [ln for ln in r.output.splitlines() if ln.startswith("[start] continuation ")]
