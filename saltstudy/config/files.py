"""Where the configuration files are, and reading them (layout: docs/USAGE.md, "Studies")."""
from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any


class ConfigError(ValueError):
    """A configuration file could not be read or is invalid. ``str()`` names file, field and reason."""


def project_root() -> Path:
    """Directory holding ``cases/`` and ``workflows/``: $SALTSTUDY_HOME, else the checkout, else cwd."""
    env, here = os.environ.get("SALTSTUDY_HOME"), Path(__file__).resolve().parents[2]
    return Path(env) if env else here if (here / "cases").is_dir() else Path.cwd()


def read_toml(path: Path) -> dict[str, Any]:
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path}: not valid TOML ({exc})") from None
    except OSError as exc:   # a directory, no permission
        raise ConfigError(f"{path}: cannot be read ({exc.strerror or exc})") from None


def case_path(number: int, root: Path | None = None) -> Path:
    return (root or project_root()) / "cases" / f"case{number:02d}.toml"


def list_case_numbers(root: Path | None = None) -> list[int]:
    d = (root or project_root()) / "cases"
    return [int(p.stem[4:]) for p in sorted(d.glob("case*.toml")) if p.stem[4:].isdigit()]


def _known(folder: Path | None) -> str:
    names = sorted(x.stem for x in folder.glob("*.toml")) if folder is not None else []
    return ", ".join(names) or "none"


def locate_fidelity(ref: str | Path, root: Path | None, own: Path | None = None) -> Path:
    """The file of a fidelity reference: a ``.toml`` path; ``STUDY/NAME`` (``workflows/STUDY/``);
    or a NAME in ``own`` (a study's folder, or the file naming it as ``based_on``), else in
    ``workflows/fidelities/``."""
    p = Path(ref).expanduser()
    if p.suffix == ".toml" or p.is_file():
        return p
    workflows = (root or project_root()) / "workflows"
    if "/" in str(ref):
        candidate = workflows / f"{ref}.toml"
        if not candidate.is_file():
            raise ConfigError(f"fidelity '{ref}': unknown (no {candidate})")
        return candidate
    shared = workflows / "fidelities"
    for folder in (own, shared):
        if folder is not None and (folder / f"{ref}.toml").is_file():
            return folder / f"{ref}.toml"
    where = f"{own}: {_known(own)}; " if own is not None else ""
    raise ConfigError(f"fidelity '{ref}': unknown (known: {where}{shared}: {_known(shared)})")


def locate_study(ref: str | Path, root: Path | None) -> Path:
    """A study file from a name (``workflows/NAME.toml``), a folder under workflows/ holding one of
    its name (``investigations/knobs``), or a path."""
    p = Path(ref).expanduser()
    if p.suffix == ".toml" or p.is_file():
        return p
    if p.is_dir() and (p / f"{p.name}.toml").is_file():
        return p / f"{p.name}.toml"
    workflows = (root or project_root()) / "workflows"
    for candidate in (workflows / f"{ref}.toml", workflows / p / f"{p.name}.toml"):
        if candidate.is_file():
            return candidate
    raise ConfigError(f"study '{ref}': unknown (known: {_known(workflows)}; a study in a folder of "
                      f"its own under workflows/ by that folder, e.g. investigations/knobs)")


def own_fidelity_folder(study_file: Path) -> Path:
    """The folder of a study's own fidelities: the file's folder if named for it
    (``knobs/knobs.toml``), else the folder of its name beside it (``convergence/``)."""
    folder = study_file.parent
    return folder if folder.name == study_file.stem else folder / study_file.stem
