"""The archives follow the CF conventions (saltstudy/ncio.py, ``cf_attributes``): every archive
declares them, the grid's coordinates carry their axes, the wind its standard names, and the IOOS
compliance checker finds nothing beyond the two findings the archives' contract keeps:

* the time coordinates are seconds since an event of the run (the activation): CF's time axis
  takes a calendar epoch, which xarray would decode into dates, so ``time`` has no
  ``standard_name = "time"`` (section 5.1);
* the 3-D fields are (time, x, y, z), the layout the solver writes and the analysis reads; CF
  recommends (t, z, y, x) (section 2.4, a recommendation).

The archives are those of docs/examples/own_scene.py at half the smoke fidelity (conftest.py)."""
from __future__ import annotations

import re
import warnings
from pathlib import Path

import netCDF4
import numpy as np
import pytest
import xarray as xr

from saltstudy.ncio import CF_VERSION, write_dataset

KEPT = (r"Coordinate variable 'time' should have standard_name='time'",
        r"spatio-temporal dimensions are not in the recommended order T, Z, Y, X")


def _archives(out: Path) -> dict[str, list[Path]]:
    return {name: sorted(out.glob(f"*/*/{name}")) for name in ("spinup.nc", "samples.nc", "analysis.nc")}


def test_every_archive_declares_cf_and_its_axes(own_scene):
    found = _archives(own_scene["out"])
    assert [len(v) for v in found.values()] == [1, 2, 2]    # one shared spin-up, two runs
    for name, paths in found.items():
        for p in paths:
            with netCDF4.Dataset(p) as nc:
                assert nc.getncattr("Conventions") == CF_VERSION, p
                history = nc.getncattr("history").splitlines()
                # an analysis keeps the line of the samples it was made from
                assert [h.rsplit(": ", 1)[1] for h in history] == \
                    (["samples.nc", "analysis.nc"] if name == "analysis.nc" else [name])
                assert "doi:10.1002/jgrd.50528" in nc.getncattr("references")
                for dim in nc.dimensions:
                    if dim in nc.variables:          # a coordinate has no missing values
                        assert "_FillValue" not in nc[dim].ncattrs(), (p, dim)
                axes = {v: nc[v].getncattr("axis") for v in nc.variables if "axis" in nc[v].ncattrs()}
                assert axes["x"] == "X" and axes["y"] == "Y" and axes["z"] == "Z", p
                for v, a in axes.items():
                    if a == "Z":
                        assert nc[v].positive == "up" and nc[v].standard_name == "height"
                assert not any(v.startswith("time") for v in axes)
                if name != "analysis.nc":
                    winds = {v: nc[v].standard_name for v in ("u", "v", "w")}
                    assert winds == {"u": "x_wind", "v": "y_wind", "w": "upward_air_velocity"}
    with netCDF4.Dataset(found["spinup.nc"][0]) as nc:
        assert "standard_name" not in nc["p"].ncattrs() and "p/rho" in nc["p"].long_name
        assert nc["e"].standard_name == "specific_turbulent_kinetic_energy_of_air"


def _findings(path: Path) -> list[str]:
    """The compliance checker's CF 1.10 messages on ``path`` that the contract does not keep."""
    from compliance_checker.runner import CheckSuite

    suite = CheckSuite()
    with warnings.catch_warnings():     # the suite's other plugins announce their deprecation
        warnings.simplefilter("ignore", DeprecationWarning)
        suite.load_all_available_checkers()
    results, errors = suite.run_all(suite.load_dataset(str(path)), ["cf:1.10"], skip_checks=[])["cf:1.10"]
    assert not errors, errors
    out: list[str] = []

    def walk(rs):
        for r in rs:
            passed = r.value is True or (isinstance(r.value, tuple) and r.value[0] == r.value[1])
            if not passed:
                out.extend(f"{r.name}: {m}" for m in r.msgs if not any(re.search(k, m) for k in KEPT))
            walk(r.children or [])

    walk(results)
    return out


def test_the_cf_checker_finds_nothing_the_contract_does_not_keep(own_scene):
    assert _findings(_archives(own_scene["out"])["spinup.nc"][0]) == []


@pytest.mark.slow
@pytest.mark.parametrize("name", ["samples.nc", "analysis.nc"])
def test_the_cf_checker_on_the_saltation_archives(own_scene, name):
    """The checker's cost grows with the square of an archive's variables: on the example's
    case 2 ~35 s for samples.nc, ~30 s for analysis.nc (~160 variables), against ~3 s for
    spinup.nc (``pytest tests/test_cf_archives.py -m slow --durations=5``)."""
    assert _findings(_archives(own_scene["out"])[name][0]) == []


def test_the_checker_finds_what_cf_attributes_adds(tmp_path):
    """A small field written as xarray writes it, and through write_dataset: the checker's
    findings on the first are what cf_attributes adds."""
    ds = xr.Dataset({"u": (("z", "y", "x"), np.ones((3, 2, 4), dtype=np.float32),
                           {"units": "m s-1", "long_name": "streamwise velocity"})},
                    coords={n: (n, np.arange(k, dtype=float), {"units": "m", "long_name": n})
                            for n, k in (("x", 4), ("y", 2), ("z", 3))},
                    attrs={"title": "a test field"})
    ds.to_netcdf(tmp_path / "plain.nc")
    plain = " ".join(_findings(tmp_path / "plain.nc"))
    assert "_FillValue" in plain and "Conventions" in plain
    assert _findings(write_dataset(ds, tmp_path / "cf.nc")) == []
