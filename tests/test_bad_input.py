"""Bad input, broadly: property-based tests over case, fidelity and study files, and over the
archives a cache may hold.

Every numeric field of the configuration models with a bound (pydantic's ``gt``/``ge``/``lt``/
``le``) is found by walking the models, so a field added later is covered without a list here. A
value beyond its bound, or of another type, makes ``saltstudy validate`` and ``run-all`` (through a
study that runs the file) exit 2 naming the field; a value within bounds never crashes them
(exit 0 or 2, never a traceback). An archive that is truncated, not ours, or ours but of another
key or kind is never taken as complete (``ncio.is_complete``: the tasks then recompute it).
"""
from __future__ import annotations

import json
import math
import shutil
import tomllib
import typing
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from annotated_types import Ge, Gt, Le, Lt
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel
from typer.testing import CliRunner

from saltstudy.cli import app
from fault_campaign import make_home
from saltstudy.config import Case, Fidelity, Study
from saltstudy.ncio import is_complete, write_dataset

SETTINGS = settings(deadline=None, max_examples=15,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


# ------------------------------------------------------------------------------------------
# TOML out of Python values (inline tables: any nesting on one line per top-level key)
def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return _toml_string(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_toml_string(k)} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(v)


def to_toml(data: dict) -> str:
    return "".join(f"{_toml_string(k)} = {_toml_value(v)}\n" for k, v in data.items())


def _toml_string(s: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters escaped."""
    return '"' + "".join(f"\\{c}" if c in '"\\' else f"\\u{ord(c):04x}"
                         if ord(c) < 0x20 or ord(c) == 0x7F else c for c in s) + '"'


def test_the_toml_writer_round_trips():
    data = {"a": 1, "b": {"c": [1.5, -2e-05], "d": {"e": "x\"y\\\x7f\U00010000"}},
            "f": [{"g": True}], "h": math.inf}
    assert tomllib.loads(to_toml(data)) == data


# ------------------------------------------------------------------------------------------
# the models' bounded numeric fields
Bounds = dict[str, float]


def bounded_fields(model: type[BaseModel], prefix: tuple = ()) -> list[tuple[tuple, type, Bounds]]:
    """(path, int or float, bounds) of every numeric field with a bound, through nested models
    (a tuple of models: its first element)."""
    out = []
    for name, f in model.model_fields.items():
        ann = f.annotation
        args = typing.get_args(ann)
        sub = next((a for a in (ann, *args) if isinstance(a, type) and issubclass(a, BaseModel)), None)
        if sub is not None:
            out += bounded_fields(sub, prefix + ((name, 0) if typing.get_origin(ann) is tuple
                                                 else (name,)))
            continue
        base = next((a for a in (ann, *args) if a in (int, float)), None)
        bounds = {type(m).__name__.lower(): float(getattr(m, type(m).__name__.lower()))
                  for m in f.metadata if isinstance(m, (Gt, Ge, Lt, Le))}
        if base is not None and bounds and typing.get_origin(ann) is not typing.Literal:
            out.append((prefix + (name,), base, bounds))
    return out


def beyond(kind: type, bounds: Bounds) -> st.SearchStrategy:
    """A value that breaks one of ``bounds``."""
    options = []
    if "gt" in bounds:
        options.append(st.floats(max_value=bounds["gt"], allow_nan=False))
    if "ge" in bounds:
        options.append(st.floats(max_value=bounds["ge"], exclude_max=True, allow_nan=False))
    if "lt" in bounds:
        options.append(st.floats(min_value=bounds["lt"], allow_nan=False))
    if "le" in bounds:
        options.append(st.floats(min_value=bounds["le"], exclude_min=True, allow_nan=False))
    if kind is int:
        ints = {"gt": lambda b: st.integers(max_value=math.floor(b)),
                "ge": lambda b: st.integers(max_value=math.ceil(b) - 1),
                "lt": lambda b: st.integers(min_value=math.ceil(b)),
                "le": lambda b: st.integers(min_value=math.floor(b) + 1)}
        return st.one_of([ints[k](b) for k, b in bounds.items()])
    return st.one_of(*options, st.just(math.nan))


def within(kind: type, bounds: Bounds) -> st.SearchStrategy:
    """A value inside ``bounds`` (finite)."""
    lo = bounds.get("gt", bounds.get("ge"))
    hi = bounds.get("lt", bounds.get("le"))
    if kind is int:
        lo_i = None if lo is None else int(math.floor(lo)) + (1 if "gt" in bounds else 0)
        hi_i = None if hi is None else int(math.ceil(hi)) - (1 if "lt" in bounds else 0)
        return st.integers(min_value=lo_i, max_value=hi_i)
    return st.floats(min_value=lo, max_value=hi, exclude_min="gt" in bounds,
                     exclude_max="lt" in bounds, allow_nan=False, allow_infinity=False)


def put(data: dict, path: tuple, value) -> dict:
    """A deep copy of ``data`` with ``value`` at ``path`` (tables and a first list entry made as
    needed)."""
    data = json.loads(json.dumps(data))
    node = data
    for i, key in enumerate(path[:-1]):
        nxt = path[i + 1]
        if isinstance(key, int):
            node = node[key]
            continue
        if isinstance(nxt, int):
            node = node.setdefault(key, [{}])
        else:
            node = node.setdefault(key, {})
    node[path[-1]] = value
    return data


CASE_FIELDS = bounded_fields(Case)
FIDELITY_FIELDS = bounded_fields(Fidelity)


def test_the_walk_finds_the_bounded_fields():
    names = {".".join(map(str, p)) for p, _, _ in CASE_FIELDS + FIDELITY_FIELDS}
    assert {"forcing.u_star_s", "particles.Q", "soil.modes.0.sigma", "air.kappa",
            "grid.nx", "grid.Lz", "time.cfl", "sampling.count"} <= names


@pytest.fixture
def home(tmp_path, monkeypatch):
    """A copy of the project's cases and workflows; the cache at ``tmp_path/out``."""
    h = make_home(tmp_path / "home")
    monkeypatch.setenv("SALTSTUDY_HOME", str(h))
    monkeypatch.setenv("SALTSTUDY_OUT", str(tmp_path / "out"))
    return h


def _invoke(*args: str):
    return CliRunner().invoke(app, [str(a) for a in args])


def _study_running(home: Path, case_file: Path, fidelity: str = "smoke") -> Path:
    s = home / "workflows" / "probe.toml"
    s.write_text(f'fidelity = "{fidelity}"\ncases = [2]\nreport = false\n'
                 f'[[scenes]]\nlabel = "probe"\ncase = "{case_file}"\n')
    return s


def _numeric(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _field_named(output: str, path: tuple) -> bool:
    return ".".join(map(str, path)) in output


# ------------------------------------------------------------------------------------------
@SETTINGS
@given(field=st.sampled_from(CASE_FIELDS), data=st.data())
def test_a_case_value_beyond_its_bound_exits_2_naming_the_field(home, tmp_path, field, data):
    path, kind, bounds = field
    value = data.draw(beyond(kind, bounds), label=".".join(map(str, path)))
    case = put(tomllib.loads((home / "cases" / "case02.toml").read_text()), path, value)
    bad = tmp_path / "bad_case.toml"
    bad.write_text(to_toml(case))
    r = _invoke("validate", bad)
    assert r.exit_code == 2 and _field_named(r.output, path), (value, r.output)
    r = _invoke("run-all", "--study", _study_running(home, bad))
    assert r.exit_code == 2 and _field_named(r.output, path), (value, r.output)
    assert "scenes.probe.case" in r.output
    assert not (tmp_path / "out").exists()


@SETTINGS
@given(field=st.sampled_from(CASE_FIELDS + FIDELITY_FIELDS),
       value=st.one_of(st.text(max_size=5).filter(lambda s: not _numeric(s)),
                       st.lists(st.integers(), max_size=2),
                       st.dictionaries(st.sampled_from("ab"), st.integers(), max_size=1)))
def test_a_value_of_another_type_exits_2_naming_the_field(home, tmp_path, field, value):
    """Text that is not a number, a list, a table where a number belongs (pydantic's lax mode
    reads the text "0.5" as the number it spells, on purpose)."""
    path, kind, bounds = field
    is_case = field in CASE_FIELDS
    src = home / ("cases/case02.toml" if is_case else "workflows/fidelities/smoke.toml")
    bad = tmp_path / ("bad_case.toml" if is_case else "bad_fidelity.toml")
    bad.write_text(to_toml(put(tomllib.loads(src.read_text()), path, value)))
    r = _invoke("validate", bad)
    assert r.exit_code == 2 and _field_named(r.output, path), (value, r.output)


@SETTINGS
@given(field=st.sampled_from(FIDELITY_FIELDS), data=st.data())
def test_a_fidelity_value_beyond_its_bound_exits_2_naming_the_field(home, tmp_path, field, data):
    path, kind, bounds = field
    value = data.draw(beyond(kind, bounds), label=".".join(map(str, path)))
    fid = put(tomllib.loads((home / "workflows/fidelities/smoke.toml").read_text()), path, value)
    (home / "workflows/fidelities/badfid.toml").write_text(to_toml(fid))
    r = _invoke("validate", home / "workflows/fidelities/badfid.toml")
    assert r.exit_code == 2 and _field_named(r.output, path), (value, r.output)
    s = home / "workflows" / "probe.toml"
    s.write_text('fidelity = "badfid"\ncases = [2]\nreport = false\n')
    r = _invoke("run-all", "--study", s)
    assert r.exit_code == 2 and _field_named(r.output, path), (value, r.output)
    assert not (tmp_path / "out").exists()


@SETTINGS
@given(is_case=st.booleans(), data=st.data())
def test_values_within_their_bounds_never_crash_validation(home, tmp_path, is_case, data):
    """One to three fields of a case or a fidelity set within their bounds: exit 0 (valid) or 2
    (a rule across fields, named); never a traceback. A valid file then resolves in a study
    without a crash either (``status`` builds every scene and key)."""
    fields = data.draw(st.lists(st.sampled_from(CASE_FIELDS if is_case else FIDELITY_FIELDS),
                                min_size=1, max_size=3, unique_by=lambda f: f[0]))
    src = home / ("cases/case02.toml" if is_case else "workflows/fidelities/smoke.toml")
    content = tomllib.loads(src.read_text())
    for path, kind, bounds in fields:
        content = put(content, path, data.draw(within(kind, bounds), label=".".join(map(str, path))))
    target = tmp_path / "probe_case.toml" if is_case else home / "workflows/fidelities/probe.toml"
    target.write_text(to_toml(content))
    r = _invoke("validate", target)
    assert r.exit_code in (0, 2), (r.output, r.exception)
    if r.exit_code == 2:
        assert r.output.startswith("error: "), r.output
        return
    study = (_study_running(home, target) if is_case else
             _write(home / "workflows" / "probe.toml", 'fidelity = "probe"\ncases = [2]\n'))
    r = _invoke("status", "--study", study)
    assert r.exit_code in (0, 2), (r.output, r.exception)


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


STUDY_VALUES = st.one_of(st.integers(-3, 12), st.text(max_size=6), st.booleans(),
                         st.lists(st.integers(-3, 12), max_size=3), st.floats(allow_nan=True),
                         st.lists(st.text(max_size=4), max_size=2))


@SETTINGS
@given(entries=st.dictionaries(st.sampled_from(sorted(Study.model_fields) + ["bogus"]),
                               STUDY_VALUES, min_size=1, max_size=4))
def test_any_study_file_validates_or_exits_2(home, tmp_path, entries):
    """Studies of arbitrary entries: ``validate`` exits 0 or 2; when it refuses, ``run-all``
    refuses with the same message and touches nothing."""
    s = home / "workflows" / "probe.toml"
    s.write_text(to_toml(entries))
    r = _invoke("validate", s)
    assert r.exit_code in (0, 2), (entries, r.output, r.exception)
    if r.exit_code == 2:
        first = r.output.splitlines()[0]
        r2 = _invoke("run-all", "--study", s)
        assert r2.exit_code == 2 and first in r2.output, (entries, r.output, r2.output)
        assert not (tmp_path / "out").exists()
    else:
        r2 = _invoke("status", "--study", s)
        assert r2.exit_code in (0, 2), (entries, r2.output, r2.exception)


# ------------------------------------------------------------------------------------------
# archives in the cache
KEY_A, KEY_B = "a" * 20, "b" * 20


@pytest.fixture(scope="module")
def archive(tmp_path_factory) -> Path:
    """A small archive written as the package writes one, at ``<key>/samples.nc``."""
    d = tmp_path_factory.mktemp("cache")
    ds = xr.Dataset({"u": (("time", "z"), np.arange(600.0).reshape(20, 30),
                           {"units": "m s-1", "long_name": "u"})},
                    attrs={"cache_key": KEY_A})
    return write_dataset(ds, d / "saltation" / KEY_A / "samples.nc")


def test_an_archive_is_complete_where_it_was_written_only(archive, tmp_path):
    assert is_complete(archive)
    for where in (f"saltation/{KEY_B}/samples.nc", f"saltation/{KEY_A}/analysis.nc",
                  f"analysis/{KEY_B}/analysis.nc"):
        p = tmp_path / where
        p.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(archive, p)
        assert not is_complete(p), where
    same = tmp_path / "elsewhere" / f"saltation/{KEY_A}/samples.nc"    # a moved cache keeps it
    same.parent.mkdir(parents=True)
    shutil.copy(archive, same)
    assert is_complete(same)


def test_a_netcdf_that_is_not_ours_is_not_complete(tmp_path):
    p = tmp_path / KEY_A / "samples.nc"
    p.parent.mkdir()
    xr.Dataset({"u": (("x",), np.zeros(3))}, attrs={"title": "someone else's"}).to_netcdf(p)
    assert not is_complete(p)
    p.write_text("not NetCDF at all\n")
    assert not is_complete(p)


@SETTINGS
@given(fraction=st.floats(0.0, 1.0, exclude_max=True))
def test_a_truncated_archive_is_not_complete(archive, tmp_path, fraction):
    data = archive.read_bytes()
    p = tmp_path / "trunc" / KEY_A / "samples.nc"
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_bytes(data[: int(fraction * len(data))])
    assert not is_complete(p)
