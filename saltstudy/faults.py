"""The package's write points: the full-disk error, and a test hook that stops the process at one.

Every file the package writes goes through a few writers (``ncio.write_dataset``, the workflow's
checkpoint and JSON writers, the report's staging), each calling :func:`point` named
``<file name>:<moment>`` at ``write`` (before the temporary file), ``tmp`` (complete, not yet
renamed) and ``done`` (renamed). The hook ``SALTSTUDY_FAULT`` (``kill|stop|enospc GLOB K`` at the
K-th matching point, or ``trace FILE``) is read at every call: docs/USAGE.md, "Faults". Child
processes that compile kernels (``workflow/warmup.py``) are started without it.
"""
from __future__ import annotations

import errno
import fnmatch
import os
import shutil
import signal
import threading
import time
from pathlib import Path
from typing import Callable

FAULT_ENV = "SALTSTUDY_FAULT"

_LOCK = threading.Lock()
_COUNTS: dict[str, int] = {}
_ARMED: str | None = None


def point(name: str) -> None:
    """A write point named ``name`` is reached (module doc); does nothing unless the hook is set."""
    global _ARMED
    spec = os.environ.get(FAULT_ENV)
    if not spec:
        return
    action, _, rest = spec.strip().partition(" ")
    if action == "trace":
        with _LOCK, open(rest.strip(), "a", encoding="utf-8") as fh:
            fh.write(f"{time.time():.6f} {os.getpid()} {name}\n")
        return
    try:
        pattern, k = rest.split()
        k_th = int(k)
    except ValueError:
        raise ValueError(f"{FAULT_ENV}={spec!r}: expected 'kill|stop|enospc GLOB K' or "
                         "'trace FILE'") from None
    if not fnmatch.fnmatchcase(name, pattern):
        return
    with _LOCK:
        if _ARMED != spec:          # another spec set by a test: count afresh
            _ARMED = spec
            _COUNTS.clear()
        _COUNTS[pattern] = n = _COUNTS.get(pattern, 0) + 1
    if n != k_th:
        return
    if action == "kill":
        os.kill(os.getpid(), signal.SIGKILL)
    elif action == "stop":
        os.kill(os.getpid(), signal.SIGSTOP)
    elif action == "enospc":
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC) + f" (test hook at {name})")
    else:
        raise ValueError(f"{FAULT_ENV}={spec!r}: unknown action '{action}'")


def format_bytes(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000.0


class DiskFull(OSError):
    """No space left for an output (``errno.ENOSPC``): names the file, its size, the free space."""

    def __init__(self, path: str | os.PathLike, needed: int | None, free: int | None):
        self.path, self.needed, self.free = Path(path), needed, free
        need = f"about {format_bytes(needed)}" if needed else "an unknown size"
        have = f"{format_bytes(free)} free" if free is not None else "free space unknown"
        message = (f"no space left on the device of {self.path.parent}: writing {self.path.name} "
                   f"needs {need}, {have}. Free space there (or use another --out) and rerun: "
                   "what was completed is kept, and a run resumes from its last checkpoint")
        super().__init__(errno.ENOSPC, message, str(path))

    def __str__(self) -> str:
        return self.strerror

    def __reduce__(self):       # picklable across dask workers
        return (DiskFull, (self.path, self.needed, self.free))


def _free(directory: Path) -> int | None:
    try:
        return shutil.disk_usage(directory).free
    except OSError:
        return None


def disk_full(path: str | os.PathLike, needed: int | None, exc: BaseException) -> DiskFull | None:
    """The :class:`DiskFull` to raise instead of ``exc`` (writing ``path``) if ``exc`` says ENOSPC
    or (HDF5 says 'HDF error' for a full disk) less than ``needed`` bytes are free; else None."""
    path = Path(path)
    if isinstance(exc, DiskFull):
        return exc
    free = _free(path.parent)
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return DiskFull(path, needed, free)
    if needed and free is not None and free < needed:
        return DiskFull(path, needed, free)
    return None


def write_atomic(path: str | os.PathLike, write: Callable[[Path], None], needed: int | None = None,
                 sync: bool = True) -> Path:
    """``write(tmp)`` writes ``<name>.<pid>.tmp`` beside ``path``, then renamed (fsync'ed if
    ``sync``) with the module doc's write points; on failure the temporary file is removed and a
    full disk raises :class:`DiskFull` (``needed``: the expected size in bytes)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f"{path.name}.{os.getpid()}.tmp")
    try:
        point(f"{path.name}:write")
        write(tmp)
        if sync:
            with open(tmp, "rb") as fh:
                os.fsync(fh.fileno())
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        full = disk_full(path, needed, exc) if isinstance(exc, Exception) else None
        if full is not None:
            raise full from exc
        raise
    point(f"{path.name}:tmp")
    os.replace(tmp, path)
    point(f"{path.name}:done")
    return path
