"""The ten cases as validated schemas; bad input rejected with the field and the reason."""
from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from saltstudy.cli import app
from saltstudy.config import (Case, ConfigError, content_hash, list_case_numbers, load_case,
                              load_fidelity, load_study, project_root, resolve_scene, study_runs)

# Table 2 of Dupont et al. (2013): u*s [m/s], mu1 [um], Q. Reference values for the check only.
TABLE2 = {1: (0.41, 200, 200), 2: (0.54, 200, 600), 3: (0.65, 200, 1000), 4: (0.75, 200, 1400),
          5: (0.93, 200, 3000), 6: (1.10, 200, 4500), 7: (0.57, 90, 28000), 8: (0.53, 100, 15000),
          9: (0.54, 300, 200), 10: (0.54, 400, 50)}

runner = CliRunner()


def test_ten_cases_match_table2():
    assert list_case_numbers() == list(range(1, 11))
    for n, (us, mu, Q) in TABLE2.items():
        c = load_case(n)
        assert c.forcing.u_star_s == pytest.approx(us)
        assert c.soil.modes[0].mu == pytest.approx(mu * 1e-6)
        assert c.soil.modes[0].sigma == pytest.approx(1.2)
        assert c.particles.Q == pytest.approx(Q)
        assert c.surface.z0 == pytest.approx(1e-5)


def test_case_files_hold_only_differences():
    # defaults are not repeated in the files: z0, sigma, splash constants come from the models
    for p in (project_root() / "cases").glob("case*.toml"):
        code = "\n".join(ln.split("#")[0] for ln in p.read_text().splitlines())
        assert "z0" not in code and "sigma" not in code and "[splash]" not in code and "seed" not in code


def test_cli_cases_list_shows_ten_rows():
    res = runner.invoke(app, ["cases", "list"])
    assert res.exit_code == 0, res.output
    rows = [ln for ln in res.output.splitlines()[1:] if ln.strip()]
    assert len(rows) == 10
    for ln, (n, (us, mu, Q)) in zip(rows, TABLE2.items()):
        f = ln.split()
        assert int(f[0]) == n and float(f[1]) == pytest.approx(us) and float(f[2]) == mu
        assert float(f[4]) == Q


def test_cli_cases_show_json_parses():
    res = runner.invoke(app, ["cases", "show", "7", "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.output)
    assert data["number"] == 7 and data["particles"]["Q"] == 28000
    assert Case.model_validate(data) == load_case(7)


def test_hash_is_stable_and_content_based():
    a, b = load_case(2), load_case(2)
    assert content_hash(a) == content_hash(b)
    assert content_hash(a) != content_hash(load_case(9))
    # the same content written in another key order hashes the same
    assert content_hash(Case.model_validate(json.loads(json.dumps(a.model_dump(mode="json"))))) == content_hash(a)


def test_models_are_frozen():
    c = load_case(1)
    with pytest.raises(Exception):
        c.forcing.u_star_s = 2.0  # type: ignore[misc]


def test_paper_fidelity_is_the_papers_setup():
    f = load_fidelity("paper")
    g = f.grid
    assert (g.nx, g.ny, g.nz, g.Lx, g.Ly, g.Lz) == (200, 150, 100, 20.0, 15.0, 12.0)
    assert g.dz_bottom == 0.01 and g.dz_top == 0.23 and g.damping_depth == 3.0
    assert f.saltation_duration == 600.0 and f.sampling.start == 200.0 and f.sampling.interval == 20.0
    assert f.sampling.end == 600.0 and f.q_multiplier == 1.0


def test_scene_scales_release_with_area_and_q():
    c = load_case(2)
    paper = resolve_scene(c, load_fidelity("paper"))
    # the paper fidelity weighs parcels for a count per m2: fewer, heavier parcels, the same mass
    w = paper.fidelity.q_multiplier
    assert w > 1 and paper.Q == pytest.approx(600 * w)
    assert paper.n_initial == round(10_000 / w)
    red = resolve_scene(c, load_fidelity("reduced"))
    g = red.fidelity.grid
    # released mass per unit area is the paper's at every fidelity (to the rounding of one parcel)
    assert red.n_initial * red.Q / (g.Lx * g.Ly) == pytest.approx(10_000 * 600 / 300.0,
                                                                  abs=0.5 * red.Q / (g.Lx * g.Ly))


@pytest.mark.parametrize("name, fidelity", [("smoke", "smoke"), ("reduced", "reduced"),
                                            ("paper", "paper")])
def test_studies_resolve(name, fidelity):
    runs = study_runs(load_study(name))
    assert [r.scene.case.number for r in runs] == list(range(1, 11))
    assert all(r.scene.fidelity.name == fidelity for r in runs)


def test_laptop_fidelity_has_the_papers_first_level_and_implicit_vertical_diffusion():
    """`reduced` is the 1 cm grid with the implicit scheme (the default); the convergence ladder's
    laptop rungs (convergence/reduced-2cm and those based on it) keep a 2 cm level and the
    explicit scheme they were measured with."""
    red, old = load_fidelity("reduced"), load_fidelity("convergence/reduced-2cm")
    assert red.grid.dz_bottom == pytest.approx(0.01) and red.time.vertical_diffusion == "implicit"
    assert old.grid.dz_bottom == pytest.approx(0.02) and old.time.vertical_diffusion == "explicit"
    assert load_fidelity("convergence/reduced-q4-dz").time.vertical_diffusion == "explicit"
    assert load_fidelity("smoke").time.vertical_diffusion == "implicit"


def _write_case(tmp_path: Path, body: str) -> Path:
    p = tmp_path / "bad.toml"
    p.write_text(body)
    return p


GOOD = 'number = 99\n[forcing]\nu_star_s = 0.5\n[particles]\nQ = 100\n'


@pytest.mark.parametrize("body, field, reason", [
    ('number = 99\n[forcing]\nu_star_s = 0.5\n[particles]\nQ = 100\n[soil]\nmodes = [{ mu = -2e-4 }]\n',
     "soil.modes.0.mu", "greater than 0"),
    ('number = 99\n[forcing]\nu_star_s = 0.5\n[particles]\nQ = 100\n[soil]\nmodes = [{ mu = 2e-4, sigma = 1.0 }]\n',
     "soil.modes.0.sigma", "greater than 1"),
    ('number = 99\n[forcing]\nu_star_s = 0.5\n[particles]\nQ = 0\n', "particles.Q", "greater than 0"),
    ('number = 99\n[forcing]\nu_star_s = 0.5\nwind_direction = 3\n[particles]\nQ = 100\n',
     "forcing.wind_direction", "unknown key"),
    ('number = 99\n[forcing]\nu_star_s = 0.5\n', "particles", "Field required"),
])
def test_bad_case_rejected_with_field_and_reason(tmp_path, body, field, reason):
    p = _write_case(tmp_path, body)
    with pytest.raises(ConfigError) as exc:
        load_case(p)
    assert field in str(exc.value) and reason in str(exc.value)
    res = runner.invoke(app, ["validate", str(p)])
    assert res.exit_code == 2
    assert field in res.output and reason in res.output


def test_domain_shallower_than_damping_layer_rejected(tmp_path):
    src = (project_root() / "workflows" / "fidelities" / "smoke.toml").read_text()
    p = tmp_path / "thin.toml"
    p.write_text(src.replace("damping_depth = 1.0", "damping_depth = 4.5"))
    res = runner.invoke(app, ["validate", str(p)])
    assert res.exit_code == 2
    assert "damping_depth" in res.output and "less than the domain height" in res.output


def test_below_threshold_case_is_valid(tmp_path):
    p = _write_case(tmp_path, GOOD.replace("0.5", "0.1"))
    res = runner.invoke(app, ["validate", str(p)])
    assert res.exit_code == 0, res.output
    assert "valid case" in res.output


STUDIES = Path(__file__).resolve().parent / "studies"      # the smoke-size studies the tests run


def test_good_files_validate():
    """Every case, every study and fidelity under workflows/ (the user's, their rungs, the
    investigations) and the tests' own studies."""
    root = project_root()
    files = [*root.glob("cases/*.toml"), *root.glob("workflows/**/*.toml"), *STUDIES.glob("**/*.toml")]
    assert len(files) > 40
    for p in files:
        res = runner.invoke(app, ["validate", str(p)])
        assert res.exit_code == 0, (p, res.output)


def test_bad_study_reference(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('fidelity = "smoke"\ncases = [1, 42]\n')
    res = runner.invoke(app, ["validate", str(p)])
    assert res.exit_code == 2 and "case 42" in res.output
    p.write_text('fidelity = "nonexistent"\ncases = [1]\n')
    res = runner.invoke(app, ["validate", str(p)])
    assert res.exit_code == 2 and "fidelity 'nonexistent'" in res.output


def test_study_reference_must_be_one_of_its_fidelities(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('fidelities = ["smoke", "quick"]\nreference = "paper"\ncases = [2]\n')
    res = runner.invoke(app, ["validate", str(p)])
    assert res.exit_code == 2 and "reference" in res.output and "not one of fidelities" in res.output
    p.write_text('fidelities = ["smoke", "quick"]\nreference = "smoke"\ncases = [2]\n')
    res = runner.invoke(app, ["validate", str(p)])
    assert res.exit_code == 0, res.output


def test_ladder_cases_restrict_a_costly_rung(tmp_path):
    from saltstudy.config import load_study, study_runs
    p = tmp_path / "s.toml"
    p.write_text('fidelities = ["smoke", "quick"]\ncases = [1, 2, 6]\n'
                 '[ladder_cases]\n"quick" = [2]\n')
    labels = [r.label for r in study_runs(load_study(p))]
    assert labels == ["case01@smoke", "case02@smoke", "case02@quick", "case06@smoke"]
    for body, words in (('[ladder_cases]\n"paper" = [2]\n', ("ladder_cases.paper", "not one of fidelities")),
                        ('[ladder_cases]\n"smoke" = [3]\n', ("ladder_cases.smoke", "[3]", "not in cases"))):
        p.write_text('fidelities = ["smoke", "quick"]\ncases = [1, 2]\n' + body)
        res = runner.invoke(app, ["validate", str(p)])
        assert res.exit_code == 2 and all(w in res.output for w in words), res.output


def test_overrides_are_validated():
    with pytest.raises(ConfigError) as exc:
        load_case(2, overrides={"soil": {"modes": [{"mu": 2e-4, "sigma": 0.5}]}})
    assert "sigma" in str(exc.value)
    c = load_case(2, overrides={"forcing": {"u_star_s": 1.5}})
    assert c.forcing.u_star_s == 1.5 and c.particles.Q == 600


def test_fidelity_based_on_inherits_and_the_file_wins():
    red = load_fidelity("stability/reduced-short").model_dump()
    mx = load_fidelity("stability/reduced-short-maxcfl").model_dump()
    assert mx["time"]["cfl"] == 1.5 != red["time"]["cfl"]
    assert mx["name"] == "reduced-short-maxcfl"
    for key in ("grid", "sampling", "relaxation", "spinup", "saltation_duration", "q_multiplier"):
        assert mx[key] == red[key], key
    assert {k: v for k, v in mx["time"].items() if k != "cfl"} == \
        {k: v for k, v in red["time"].items() if k != "cfl"}


def _write_fidelity(root, name, text):
    d = root / "workflows" / "fidelities"
    d.mkdir(parents=True, exist_ok=True)
    (d / f"{name}.toml").write_text(text)


@pytest.mark.parametrize("text, needle", [
    ('based_on = "nosuch"\n', "based_on: fidelity 'nosuch': unknown"),
    ('based_on = "b"\n', "based_on: circular"),
    ("based_on = 3\n", "based_on: must be the name of another fidelity"),
])
def test_fidelity_based_on_errors_name_the_field(tmp_path, text, needle):
    _write_fidelity(tmp_path, "a", text)
    _write_fidelity(tmp_path, "b", 'based_on = "a"\n')
    with pytest.raises(ConfigError, match=re.escape(needle)):
        load_fidelity("a", root=tmp_path)


def _own_fidelities_home(tmp_path: Path) -> Path:
    """A project with the shared smoke fidelity, a study `mine` whose own folder holds a `smoke`
    of its own and a rung based on it, and an investigation in a folder of its own."""
    root = tmp_path / "home"
    shutil.copytree(project_root() / "cases", root / "cases")
    smoke = (project_root() / "workflows" / "fidelities" / "smoke.toml").read_text()
    _write_fidelity(root, "smoke", smoke)
    wf = root / "workflows"
    (wf / "mine").mkdir()
    (wf / "mine" / "smoke.toml").write_text('based_on = "smoke"\nq_multiplier = 7.0\n')
    (wf / "mine" / "rung.toml").write_text('based_on = "smoke"\nsaltation_duration = 3.0\n')
    (wf / "mine.toml").write_text('fidelities = ["smoke", "rung"]\ncases = [2]\n'
                                   '[[scenes]]\nlabel = "plain"\ncase = 2\nfidelity = "quick"\n')
    _write_fidelity(root, "quick", smoke.replace("q_multiplier = 20.0", "q_multiplier = 3.0"))
    inv = wf / "investigations" / "probe"
    inv.mkdir(parents=True)
    (inv / "probe.toml").write_text('fidelity = "longer"\ncases = [6]\n')
    (inv / "longer.toml").write_text('based_on = "mine/rung"\nsaltation_duration = 4.0\n')
    return root


def test_a_study_resolves_its_own_fidelities_first(tmp_path):
    """Rule: a study's fidelity names resolve first in the folder named for it (NAME/ beside the
    study file, or the study file's own folder when it bears the name), then in
    workflows/fidelities/; a based_on name resolves beside its file first; STUDY/NAME names a
    study's own fidelity from anywhere."""
    root = _own_fidelities_home(tmp_path)
    runs = {r.label: r.scene.fidelity for r in study_runs(load_study("mine", root=root), root=root)}
    assert runs["case02@smoke"].q_multiplier == 7.0                  # the study's own smoke
    assert runs["case02@rung"].q_multiplier == 7.0                   # based on that smoke
    assert runs["case02@rung"].saltation_duration == 3.0
    assert runs["plain"].q_multiplier == 3.0                         # not its own: the shared one
    assert load_fidelity("smoke", root=root).q_multiplier == 20.0    # by name: the shared one
    assert load_fidelity("mine/rung", root=root).saltation_duration == 3.0
    assert load_fidelity("mine/rung", root=root).name == "rung"
    # an investigation by its folder; its fidelity beside it, based on another study's rung
    inv = load_study("investigations/probe", root=root)
    assert inv.name == "probe"
    (run,) = study_runs(inv, root=root)
    assert run.label == "case06" and run.scene.fidelity.saltation_duration == 4.0
    assert run.scene.fidelity.q_multiplier == 7.0
    assert load_study(root / "workflows" / "investigations" / "probe", root=root).name == "probe"


@pytest.mark.parametrize("body, needles", [
    ('fidelities = ["smoke", "nosuch"]\ncases = [2]\n',
     ("study 'mine': fidelities: fidelity 'nosuch': unknown", "rung, smoke")),
    ('fidelity = "smoke"\n[[scenes]]\nlabel = "s1"\ncase = 2\nfidelity = "nosuch"\n',
     ("scenes.s1.fidelity: fidelity 'nosuch': unknown",)),
    ('fidelity = "mine/nosuch"\ncases = [2]\n', ("fidelity: fidelity 'mine/nosuch': unknown",)),
    ('fidelities = ["smoke", "mine/rung"]\ncases = [2]\n',
     ("fidelities: 'mine/rung': a rung is a NAME",)),
])
def test_a_study_fidelity_that_resolves_to_nothing_names_the_field(tmp_path, body, needles):
    root = _own_fidelities_home(tmp_path)
    (root / "workflows" / "mine.toml").write_text(body)
    with pytest.raises(ConfigError) as exc:
        study_runs(load_study("mine", root=root), root=root)
    assert all(n in str(exc.value) for n in needles), str(exc.value)


def test_an_unknown_study_or_based_on_reference_names_what_was_looked_for(tmp_path):
    root = _own_fidelities_home(tmp_path)
    with pytest.raises(ConfigError, match=re.escape("study 'investigations/nosuch': unknown (known: mine")):
        load_study("investigations/nosuch", root=root)
    (root / "workflows" / "mine" / "bad.toml").write_text('based_on = "mine/nosuch"\n')
    with pytest.raises(ConfigError, match=re.escape("based_on: fidelity 'mine/nosuch': unknown (no ")):
        load_fidelity("mine/bad", root=root)


def _case_file(path: Path, u_star_s: float) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"number = 2\n[forcing]\nu_star_s = {u_star_s}\n[particles]\nQ = 600\n")
    return path


def test_scene_case_file_is_relative_to_the_study_file(tmp_path, monkeypatch):
    """Rule: a scene's relative case path is taken from the study file's directory, whatever the
    working directory; an absolute one is used as is."""
    own = _case_file(tmp_path / "studies" / "mine" / "breeze.toml", 0.33)
    other = _case_file(tmp_path / "elsewhere" / "gust.toml", 0.77)
    study = tmp_path / "studies" / "s.toml"
    study.write_text('fidelity = "smoke"\n'
                     '[[scenes]]\nlabel = "breeze"\ncase = "mine/breeze.toml"\n'
                     f'[[scenes]]\nlabel = "gust"\ncase = "{other}"\n'
                     '[[scenes]]\nlabel = "gale"\ncase = "mine/breeze.toml"\n'
                     'overrides = { forcing = { u_star_s = 1.2 } }\n')
    monkeypatch.chdir(tmp_path / "elsewhere")       # a gust.toml here must not be the one read
    (tmp_path / "elsewhere" / "mine").mkdir()
    _case_file(tmp_path / "elsewhere" / "mine" / "breeze.toml", 0.99)
    st = load_study(study)
    assert st.scenes[0].case == str(own)
    runs = {r.label: r.scene for r in study_runs(st)}
    assert runs["breeze"].case.forcing.u_star_s == 0.33
    assert runs["gust"].case.forcing.u_star_s == 0.77
    assert runs["gale"].case.forcing.u_star_s == 1.2 and runs["gale"].case.particles.Q == 600
    assert runs["breeze"].case.name == "breeze"
    res = runner.invoke(app, ["validate", str(study)])
    assert res.exit_code == 0, res.output


@pytest.mark.parametrize("case, overrides, needles", [
    ('"nowhere/mycase.toml"', "", ("scenes.mine.case", "no such case file", "nowhere/mycase.toml")),
    ('"sub"', "", ("scenes.mine.case", "is not a file")),
    ('"notacase.toml"', "", ("scenes.mine.case", "forcing", "Field required")),
    ("42", "", ("scenes.mine.case", "case 42", "unknown case")),
    ("-1", "", ("scenes.0.case", "a case number is >= 0")),
    ("2", "overrides = { forcing = { u_star_s = -1.0 } }",
     ("scenes.mine.overrides", "forcing.u_star_s", "greater than 0")),
])
def test_bad_scene_case_exits_2_naming_the_field(tmp_path, case, overrides, needles):
    (tmp_path / "sub").mkdir()
    (tmp_path / "notacase.toml").write_text("[particles]\nQ = 600\n")
    study = tmp_path / "s.toml"
    study.write_text(f'fidelity = "smoke"\n[[scenes]]\nlabel = "mine"\ncase = {case}\n{overrides}\n')
    for args in (["validate", str(study)],
                 ["run-all", "--study", str(study), "--out", str(tmp_path / "out"), "--quiet"]):
        res = runner.invoke(app, args)
        assert res.exit_code == 2, (args, res.output)
        assert all(n in res.output for n in needles), (args, res.output)
    assert not (tmp_path / "out").exists()          # rejected before the cache is touched


def test_parcel_weight_for_a_count_is_the_case_count_over_the_target(tmp_path):
    """fidelity.parcels_per_m2: each case's parcels weigh count_at_Q / target times its Q, the
    count read from data/airborne_counts.toml; the resolved scene carries that weight, and the
    same inputs give the same weight."""
    from saltstudy.config import airborne_counts, parcel_weight

    counts, source = airborne_counts()
    assert sorted(counts) == list(range(1, 11)) and "summary.json" in source
    f = tmp_path / "count.toml"
    f.write_text('based_on = "smoke"\nparcels_per_m2 = 2000.0\n')
    fid = load_fidelity(f)
    assert fid.parcels_per_m2 == 2000.0 and fid.q_multiplier == 1.0
    for n in (2, 7):
        sc = resolve_scene(load_case(n), fid)
        assert sc.fidelity.q_multiplier == counts[n] / 2000.0
        assert sc.Q == pytest.approx(load_case(n).particles.Q * counts[n] / 2000.0, rel=1e-15)
        assert resolve_scene(load_case(n), fid) == sc
    assert parcel_weight(load_case(2), 4000.0) == pytest.approx(0.5 * parcel_weight(load_case(2), 2000.0))
    # a file's own choice replaces its parent's; both in one file is an error naming the field
    g = tmp_path / "heavier.toml"
    g.write_text(f'based_on = "{f}"\nq_multiplier = 5.0\n')
    h = load_fidelity(g)
    assert h.parcels_per_m2 is None and h.q_multiplier == 5.0
    both = tmp_path / "both.toml"
    both.write_text('based_on = "smoke"\nparcels_per_m2 = 2000.0\nq_multiplier = 5.0\n')
    with pytest.raises(ConfigError, match="q_multiplier"):
        load_fidelity(both)


def test_parcel_weight_needs_the_count_of_the_case_as_it_stands(tmp_path):
    f = tmp_path / "count.toml"
    f.write_text('based_on = "smoke"\nparcels_per_m2 = 2000.0\n')
    fid = load_fidelity(f)
    windier = load_case(2, overrides={"forcing": {"u_star_s": 0.9}})
    with pytest.raises(ConfigError, match="parcels_per_m2.*physics differs"):
        resolve_scene(windier, fid)
    reseeded = load_case(2, overrides={"seed": 7})
    assert resolve_scene(reseeded, fid).fidelity.q_multiplier == resolve_scene(load_case(2), fid).fidelity.q_multiplier


def test_a_ladder_table_is_found_beside_the_study_or_named_missing(tmp_path):
    from saltstudy.config import ladder_table_path
    root = _own_fidelities_home(tmp_path)
    study = root / "workflows" / "mine.toml"
    study.write_text('fidelity = "smoke"\ncases = [2]\nladder_table = "tables/ladder.json"\n')
    with pytest.raises(ConfigError, match=re.escape("ladder_table: no file ")):
        load_study("mine", root=root)
    (root / "workflows" / "tables").mkdir()
    (root / "workflows" / "tables" / "ladder.json").write_text("{}")
    st = load_study("mine", root=root)
    assert ladder_table_path(st) == root / "workflows" / "tables" / "ladder.json"
    assert st.ladder_table == "tables/ladder.json"     # the study's record keeps what it said
