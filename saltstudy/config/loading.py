"""Reading cases, fidelities and studies from their files, validated, with errors that name the file,
the field and the reason; a study expanded into its runs."""
from __future__ import annotations

import os
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from .base import deep_merge, validate_model
from .case import Case
from .fidelity import Fidelity
from .files import (ConfigError, case_path, locate_fidelity, locate_study, own_fidelity_folder,
                    read_toml)
from .study import RunSpec, Scene, SceneSpec, Study


def load_case(ref: int | str | Path, overrides: dict[str, Any] | None = None,
              root: Path | None = None) -> Case:
    """Load a case by number or path, apply ``overrides`` (deep-merged), validate."""
    if isinstance(ref, int) or (isinstance(ref, str) and ref.isdigit()):
        path = case_path(int(ref), root)
        if not path.exists():
            raise ConfigError(f"case {int(ref)}: unknown case (no {path})")
    else:
        path = Path(ref)
    data = read_toml(path)
    if overrides:
        data = deep_merge(data, overrides)
    return validate_model(Case, data, str(path))


def _fidelity_data(ref: str | Path, root: Path | None, own: Path | None = None,
                   chain: tuple[Path, ...] = ()) -> tuple[Path, dict]:
    """Raw TOML of a fidelity with its ``based_on`` parent deep-merged underneath (the file wins);
    the parent is looked up beside the file, then (or if that is it) in workflows/fidelities/."""
    path = locate_fidelity(ref, root, own)
    data = read_toml(path)
    if "q_multiplier" in data and "parcels_per_m2" in data:
        raise ConfigError(f"{path}: q_multiplier: the parcel weight is given by q_multiplier or by "
                          "parcels_per_m2, not both")
    base = data.pop("based_on", None)
    if base is None:
        return path, data
    if not isinstance(base, str):
        raise ConfigError(f"{path}: based_on: must be the name of another fidelity, or STUDY/NAME "
                          f"(got {base!r})")
    here = (*chain, path.resolve())
    try:
        parent_path = locate_fidelity(base, root, path.parent)
        if parent_path.resolve() == here[-1] and "/" not in base:
            parent_path = locate_fidelity(base, root, None)
        if parent_path.resolve() in here:
            names = " -> ".join(x.stem for x in (*here, parent_path))
            raise ConfigError(f"circular ({names})")
        _, parent = _fidelity_data(parent_path, root, None, here)
    except ConfigError as exc:
        raise ConfigError(f"{path}: based_on: {exc}") from None
    parent.pop("name", None)
    # the file's own choice of parcel weight replaces its parent's, whichever way it is given
    for mine, other in (("q_multiplier", "parcels_per_m2"), ("parcels_per_m2", "q_multiplier")):
        if mine in data:
            parent.pop(other, None)
    return path, deep_merge(parent, data)


def load_fidelity(ref: str | Path, root: Path | None = None, own: Path | None = None) -> Fidelity:
    """Load a fidelity by name (``own``: a study's folder, looked in first), ``STUDY/NAME`` or path
    (files.locate_fidelity); a file may start ``based_on`` another and list only what differs
    (docs/USAGE.md, "Fidelities")."""
    path, data = _fidelity_data(ref, root, own)
    data.setdefault("name", path.stem)
    return validate_model(Fidelity, data, str(path))


def load_study(ref: str | Path, root: Path | None = None) -> Study:
    """Load a study by name, folder under workflows/ or path; a scene's relative case file is made
    absolute against the study file's directory."""
    path = locate_study(ref, root)
    data = read_toml(path)
    data.setdefault("name", path.stem)
    scenes = data.get("scenes")
    if isinstance(scenes, list):
        data["scenes"] = [_scene_case_from(path, s) for s in scenes]
    study = validate_model(Study, data, str(path))
    study._file = Path(os.path.abspath(path))
    table = ladder_table_path(study)
    if table is not None and not table.is_file():
        raise ConfigError(f"{path}: ladder_table: no file {table}")
    return study


def study_file(study: Study) -> Path | None:
    """The file ``study`` was loaded from (None for a study built in code)."""
    return study._file


def ladder_table_path(study: Study) -> Path | None:
    """The study's ``ladder_table`` made absolute against its file's folder (None if unset)."""
    if study.ladder_table is None:
        return None
    p = Path(study.ladder_table).expanduser()
    return p if p.is_absolute() or study._file is None else Path(os.path.abspath(study._file.parent / p))


def study_fidelity_folder(study: Study) -> Path | None:
    """The folder of a study's own fidelities; None for a study built in code."""
    return own_fidelity_folder(study._file) if study._file is not None else None


def _scene_case_from(study_path: Path, scene: Any) -> Any:
    """``scene`` with a case file path made absolute against the study file's directory."""
    if not isinstance(scene, dict):
        return scene
    ref = scene.get("case")
    if not isinstance(ref, str) or not ref.strip() or ref.strip().isdigit():
        return scene
    p = Path(ref).expanduser()
    if not p.is_absolute():
        p = Path(os.path.abspath(study_path.parent / p))
    return {**scene, "case": str(p)}


def resolve_scene(case: Case, fidelity: Fidelity, label: str | None = None) -> Scene:
    """One case at one fidelity. With ``fidelity.parcels_per_m2`` the scene's fidelity carries the
    case's own weight, ``q_multiplier = count / parcels_per_m2`` (``parcel_weight``)."""
    if fidelity.parcels_per_m2 is not None:
        fid = fidelity.model_dump()
        fid["q_multiplier"] = parcel_weight(case, fidelity.parcels_per_m2)
        fidelity = validate_model(Fidelity, fid, f"fidelity '{fidelity.name}'")
    source = fidelity.spinup.tiled_from
    spinup_fidelity = None
    if source is not None:
        spinup_fidelity = load_fidelity(source)
        if spinup_fidelity.spinup.tiled_from is not None:
            raise ConfigError(f"fidelity '{fidelity.name}': spinup.tiled_from = '{source}' is "
                              f"itself tiled from '{spinup_fidelity.spinup.tiled_from}'; name "
                              "a fidelity with a spin-up of its own")
    scene = Scene(label=label or case.label, case=case, fidelity=fidelity,
                  spinup_fidelity=spinup_fidelity)
    check_equilibrium_roughness(scene)
    return scene


def airborne_counts() -> tuple[dict[int, float], str]:
    """Airborne parcels per m2 at each paper case's Q, and their source (data/airborne_counts)."""
    text = resources.files("saltstudy").joinpath("data/airborne_counts.toml").read_text("utf-8")
    data = tomllib.loads(text)
    return {int(k): float(v) for k, v in data["count_at_Q"].items()}, str(data["source"])


def parcel_weight(case: Case, parcels_per_m2: float) -> float:
    """The multiple of the case's Q leaving about ``parcels_per_m2`` airborne per m2 [1]; a
    ConfigError for a case whose physics differs from its numbered file's (no measured count)."""
    counts, source = airborne_counts()
    where = "fidelity.parcels_per_m2"
    if case.number not in counts:
        raise ConfigError(f"{where}: no airborne count for case {case.number} ({source} holds "
                          f"cases {sorted(counts)}); give the fidelity a q_multiplier instead")
    physics = {"name", "description", "seed"}
    stock = load_case(case.number).model_dump(mode="json", exclude=physics)
    if case.model_dump(mode="json", exclude=physics) != stock:
        raise ConfigError(f"{where}: case {case.number}'s physics differs from "
                          f"cases/case{case.number:02d}.toml, for which the airborne count was "
                          "measured; give the fidelity a q_multiplier instead")
    return counts[case.number] / parcels_per_m2


def roughness_table() -> tuple[dict[int, float], float, str]:
    """z0s [m] per stock case, the Charnock constant C [1] for other physics, and their source
    (data/equilibrium_roughness.toml)."""
    text = resources.files("saltstudy").joinpath("data/equilibrium_roughness.toml").read_text("utf-8")
    data = tomllib.loads(text)
    return ({int(k): float(v) for k, v in data.get("z0s", {}).items()},
            float(data["charnock_c"]), str(data["source"]))


def equilibrium_roughness(case: Case) -> float:
    """z0s [m] of the mean wind the model's column settles to over a saltating bed of ``case``'s
    physics, for ``spinup.equilibrium_roughness``: the value read from the case's own runs
    (data/equilibrium_roughness.toml) when its physics is a stock case's that has one (matched on
    the physics, so a case renumbered only to take another start keeps its own), else Charnock's
    form C u*s^2 / g with the model's own C from the same file; never below the bed's z0 (below
    the fluid threshold there is no saltation layer to lower the wind)."""
    values, charnock_c, _ = roughness_table()
    other = {"name", "description", "seed", "number"}
    mine = case.model_dump(mode="json", exclude=other)
    for n, z0s in values.items():
        if load_case(n).model_dump(mode="json", exclude=other) == mine:
            return z0s
    u = case.forcing.u_star_s
    return max(charnock_c * u * u / case.air.g, case.surface.z0)


def check_equilibrium_roughness(scene: Scene) -> None:
    """A start lowered by (u*s / kappa) ln(z0s / z0) must leave the first level's wind positive:
    a ConfigError naming the field when z0s reaches the first level's height."""
    if not scene.fidelity.spinup.equilibrium_roughness:
        return
    z0s = equilibrium_roughness(scene.case)
    z1 = 0.5 * scene.fidelity.grid.dz_bottom
    if z0s >= z1:
        raise ConfigError(f"fidelity.spinup.equilibrium_roughness: z0s = {z0s:.2e} m for "
                          f"{scene.label} (u*s = {scene.case.forcing.u_star_s} m/s) reaches the "
                          f"first level (z = {z1:g} m), where the lowered wind would reverse; "
                          "leave it false for this case (the column relaxation then speeds the "
                          "approach to the equilibrium)")


def _scene_case(study: Study, scene: SceneSpec, root: Path | None) -> Case:
    """The case of a study's scene, overrides applied; errors name ``scenes.<label>.case`` or
    ``.overrides``."""
    where = f"study '{study.name}': scenes.{scene.label}"
    ref = scene.case
    if isinstance(ref, str) and not ref.strip().isdigit():
        p = Path(ref).expanduser()
        if not p.exists():
            raise ConfigError(f"{where}.case: no such case file {p}")
        if not p.is_file():
            raise ConfigError(f"{where}.case: {p} is not a file")
    try:
        case = load_case(ref, root=root)
    except ConfigError as exc:
        raise ConfigError(f"{where}.case: {exc}") from None
    if not scene.overrides:
        return case
    try:
        return load_case(ref, overrides=scene.overrides, root=root)
    except ConfigError as exc:
        raise ConfigError(f"{where}.overrides: {exc}") from None


def study_runs(study: Study, root: Path | None = None) -> list[RunSpec]:
    """Expand a study into its runs (each a resolved scene). Raises ConfigError on bad references."""
    runs: list[RunSpec] = []
    ladder = list(study.fidelities) or [study.fidelity]
    own = study_fidelity_folder(study)
    fid_cache: dict[str, Fidelity] = {}

    def fid(name: str, field: str) -> Fidelity:
        if name not in fid_cache:
            try:
                fid_cache[name] = load_fidelity(name, root, own)
            except ConfigError as exc:
                raise ConfigError(f"study '{study.name}': {field}: {exc}") from None
        return fid_cache[name]

    if len(ladder) > 1:
        for fname in ladder:
            if "/" in fname:      # a rung's name is part of its runs' labels (case02@NAME)
                raise ConfigError(
                    f"study '{study.name}': fidelities: '{fname}': a rung is a NAME, of the study's "
                    f"own folder or of workflows/fidelities/ (a file there may be based_on = \"{fname}\")")
    for n in study.cases:
        case = load_case(n, root=root)
        for fname in ladder:
            if n not in study.ladder_cases.get(fname, study.cases):
                continue
            label = case.label if len(ladder) == 1 else f"{case.label}@{fname}"
            field = "fidelities" if study.fidelities else "fidelity"
            runs.append(RunSpec(label=label, scene=resolve_scene(case, fid(fname, field), label)))
    for s in study.scenes:
        case = _scene_case(study, s, root)
        case = case.model_validate({**case.model_dump(), "name": s.label})
        field = f"scenes.{s.label}.fidelity" if s.fidelity else "fidelity"
        scene = resolve_scene(case, fid(s.fidelity or study.fidelity, field), s.label)
        runs.append(RunSpec(label=s.label, scene=scene))
    labels = [r.label for r in runs]
    dup = {x for x in labels if labels.count(x) > 1}
    if dup:
        raise ConfigError(f"study '{study.name}': duplicate run labels {sorted(dup)}")
    return runs


def validate_file(path: Path) -> str:
    """Validate a case, fidelity or study file; return what it is. Raises ConfigError."""
    data = read_toml(path)
    if "forcing" in data or "particles" in data or "number" in data:
        load_case(path)
        return "case"
    if "grid" in data or "based_on" in data:
        load_fidelity(path)
        return "fidelity"
    study = load_study(path)
    study_runs(study)
    return "study"
