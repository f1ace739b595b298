"""Another git revision of this checkout's package, importable beside it, for the benchmarks'
``--against REV``: REV's ``saltstudy/``, ``cases/`` and ``workflows/`` are extracted (``git
archive``) under ``~/.cache/saltstudy/compare/<sha>/`` with the package renamed
``saltstudy_<sha12>``, and that folder is put on ``sys.path``. Both packages then run in one
process, so rounds can alternate between them: on a machine whose speed drifts by tens of per
cent between invocations, alternating in one process resolves a few."""
from __future__ import annotations

import io
import os
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

__all__ = ["RevisionError", "revision_package"]


class RevisionError(ValueError):
    """--against names no revision of this checkout (or there is no git checkout)."""


def revision_package(rev: str) -> str:
    """Import name of the ``saltstudy`` package of git revision ``rev`` of this checkout,
    extracted (with its ``cases/`` and ``workflows/``) under ~/.cache/saltstudy/compare/<sha>/
    and put on sys.path."""
    root = Path(__file__).resolve().parents[2]
    try:
        sha = subprocess.run(["git", "-C", str(root), "rev-parse", "--verify", rev + "^{commit}"],
                             capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError) as e:
        raise RevisionError(f"{rev!r} is not a git revision of {root}") from e
    name = f"saltstudy_{sha[:12]}"
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "saltstudy" / \
        "compare" / sha[:12]
    if not base.exists():  # extracted whole into a temporary folder, then renamed into place
        tar = subprocess.run(["git", "-C", str(root), "archive", sha, "saltstudy", "cases",
                              "workflows"], capture_output=True, check=True).stdout
        tmp = base.with_name(base.name + f".tmp{os.getpid()}")
        with tarfile.open(fileobj=io.BytesIO(tar)) as tf:
            # the "data" filter (no links out, no absolute paths) exists from Python 3.11.4
            safe = {"filter": "data"} if hasattr(tarfile, "data_filter") else {}
            tf.extractall(tmp, **safe)
        (tmp / "saltstudy").rename(tmp / name)
        try:
            tmp.rename(base)
        except OSError:  # another process got there first
            shutil.rmtree(tmp, ignore_errors=True)
    if str(base) not in sys.path:
        sys.path.insert(0, str(base))
    return name
