"""Another git revision of the package, importable beside it, for the benchmarks' ``--against
REV``: extracted (``git archive``) under ``~/.cache/saltstudy/compare/<sha>/`` as
``saltstudy_<sha12>``. Each round runs in a fresh process (``run_isolated``) building one side,
the sides alternating: in one process the side built first ran up to 16 % faster
(docs/BENCHMARKS.md).
"""
from __future__ import annotations

import io
import json
import os
import shutil
import statistics
import subprocess
import sys
import tarfile
from pathlib import Path


class RevisionError(ValueError):
    """--against names no revision of this checkout (or there is no git checkout)."""


def checkout_root() -> Path:
    """The folder holding this checkout's package (the git work tree)."""
    return Path(__file__).resolve().parents[2]


def revision_path(rev: str) -> tuple[str, str]:
    """(import name, folder on sys.path) of revision ``rev``'s package, extracted (module doc)."""
    root = checkout_root()
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
    return name, str(base)


_RESULT = "@@saltstudy-result@@"

#: the child's program: its JSON result after a marker line (compiling kernels may print)
_CHILD = (
    "import importlib, json, sys\n"
    "sys.path[:0] = json.loads(sys.argv[1])\n"
    "mod, fn = sys.argv[2].split(':')\n"
    "out = getattr(importlib.import_module(mod), fn)(**json.loads(sys.argv[3]))\n"
    f"sys.stdout.write('\\n{_RESULT}' + json.dumps(out) + '\\n')\n")


def run_isolated(target: str, kwargs: dict, paths: list[str] = (), prefix: list[str] = (),
                 env: dict | None = None) -> object:
    """``module:function`` called with ``kwargs`` in a fresh Python process (``paths`` and this
    checkout first on sys.path, the environment updated with ``env``, the command after ``prefix``,
    e.g. a profiler's); returns its JSON result, or raises with the child's stderr tail."""
    argv = [*prefix, sys.executable, "-c", _CHILD,
            json.dumps([*map(str, paths), str(checkout_root())]), target, json.dumps(kwargs)]
    res = subprocess.run(argv, capture_output=True, text=True,
                         env=None if env is None else {**os.environ, **env})
    if res.returncode != 0 or _RESULT not in res.stdout:
        tail = "\n".join(res.stderr.strip().splitlines()[-15:])
        raise RuntimeError(f"{target} failed in its process (exit {res.returncode}):\n{tail}")
    return json.loads(res.stdout.rsplit(_RESULT, 1)[1])


def alternate(rounds: int, sides, call) -> dict:
    """{side: [call(side) per round]}: every side once a round, the order reversed every other
    round."""
    sides = list(sides)
    per = {k: [] for k in sides}
    for r in range(rounds):
        for k in (sides if r % 2 == 0 else sides[::-1]):
            per[k].append(call(k))
    return per


def medians(per: dict, key: str | None = None) -> dict:
    """{side: median over the rounds, side_rounds: the rounds} of :func:`alternate`'s results
    (``key``: of that entry of each)."""
    out = {}
    for side, results in per.items():
        vals = [r[key] for r in results] if key else list(results)
        out[side], out[f"{side}_rounds"] = statistics.median(vals), vals
    return out
