"""Who may write where: one process holds an out dir, one process at a time computes a task
(docs/USAGE.md, "Faults"). The lock is ``flock`` on the file, which holds the holder's record
(JSON); where ``flock`` is not shared between hosts, the holder touches the file every
:data:`HEARTBEAT_S` s and another host's record counts until untouched for :data:`STALE_AFTER` s.
"""
from __future__ import annotations

import errno
import fcntl
import json
import os
import platform
import shlex
import sys
import threading
import time
from pathlib import Path
from typing import Any, Callable

from .paths import read_json

LOCK_NAME = "saltstudy.lock"
TASK_LOCK_NAME = "task.lock"
#: [s] how often a holder touches its lock file (read by hosts that do not share flock)
HEARTBEAT_S = 15.0
#: [s] a record from another host untouched for this long belongs to a process that is gone
#: (eight heartbeats: an NFS client may cache a file's attributes for up to a minute)
STALE_AFTER = 120.0
POLL_S = 0.5


class Busy(RuntimeError):
    """The lock is held by another live process (``holder``: its record)."""

    def __init__(self, what: str, holder: dict[str, Any] | None):
        self.what, self.holder = what, holder or {}
        super().__init__(f"{what} is in use by {describe_holder(self.holder)}")


def describe_holder(rec: dict[str, Any]) -> str:
    """'saltstudy pid 123 on host, started 2024-01-01 12:00:00 (`saltstudy run-all ...`)'."""
    if not rec:
        return "another saltstudy process (its record is being written)"
    started = rec.get("started")
    when = (time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(started))
            if isinstance(started, (int, float)) else "?")
    return (f"saltstudy pid {rec.get('pid', '?')} on {rec.get('host', '?')}, started {when} "
            f"(`{rec.get('command', '?')}`)")


def _record(what: str) -> dict[str, Any]:
    return {"pid": os.getpid(), "host": platform.node(), "started": time.time(),
            "command": " ".join(shlex.quote(a) for a in [Path(sys.argv[0]).name, *sys.argv[1:]]),
            "cwd": os.getcwd(), "what": what}


def read_holder(path: Path) -> dict[str, Any] | None:
    """The record in a lock file, or None (no file, or empty or unreadable)."""
    rec = read_json(path)
    return rec if isinstance(rec, dict) else None


def pid_alive(pid: Any) -> bool:
    """True if a process with this pid exists on this host."""
    if not isinstance(pid, int):
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:     # exists, owned by someone else
        return True
    return True


def record_alive(rec: dict[str, Any] | None, path: Path) -> bool:
    """Judged from the record alone (a file system without shared flock): its process lives."""
    if not rec:
        return False
    if rec.get("host") == platform.node():
        return pid_alive(rec.get("pid"))
    try:
        touched = os.stat(path).st_mtime
    except OSError:
        return False
    return time.time() - touched < STALE_AFTER


class DirLock:
    """An exclusive lock on the file ``path`` naming its holder (module doc)."""

    def __init__(self, path: Path, what: str):
        self.path, self.what = Path(path), what
        self._fd: int | None = None
        self._stop = threading.Event()
        self._beat: threading.Thread | None = None
        #: the record of a process that held the lock and is gone (taken over), if any
        self.taken_over: dict[str, Any] | None = None
        #: [s] how long :meth:`acquire` waited for another holder
        self.waited_s = 0.0

    def _try_once(self) -> tuple[bool, dict[str, Any] | None]:
        """(acquired, the holder's record: {} if unreadable; None if the file was replaced
        meanwhile: try again at once)."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        got = False
        try:
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                shared_locks = True
            except BlockingIOError:
                return False, self._holder_record() or {}
            except OSError as exc:
                if exc.errno not in (errno.ENOLCK, errno.EOPNOTSUPP, errno.EINVAL):
                    raise
                shared_locks = False      # no flock here: the record decides
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if not same:                  # released (removed) between our open and our lock
                return False, None
            old = read_holder(self.path)
            if old and old.get("pid") != os.getpid() and (
                    not shared_locks or old.get("host") != platform.node()) \
                    and record_alive(old, self.path):
                return False, old
            os.ftruncate(fd, 0)
            os.pwrite(fd, json.dumps(_record(self.what)).encode(), 0)
            self._fd, self.taken_over, got = fd, old or None, True
            return True, None
        finally:
            if not got:
                os.close(fd)

    def _holder_record(self) -> dict[str, Any] | None:
        """The holder's record; it writes it just after taking the lock, so give it a moment."""
        for _ in range(10):
            rec = read_holder(self.path)
            if rec:
                return rec
            time.sleep(0.05)
        return None

    def acquire(self, wait: bool = False, on_wait: Callable[[dict[str, Any] | None], None] | None = None,
                timeout: float | None = None) -> "DirLock":
        """Take the lock; if another live process holds it, raise :class:`Busy`, or with ``wait``
        call ``on_wait(holder)`` once and poll until it is free (``timeout`` s at most)."""
        if self._fd is not None:
            raise RuntimeError(f"{self.path}: already held by this object")
        t0 = time.monotonic()
        told = False
        while True:
            got, holder = self._try_once()
            if got:
                break
            if holder is None:          # between two holders: try again at once
                continue
            if not wait or (timeout is not None and time.monotonic() - t0 > timeout):
                raise Busy(self.what, holder)
            if not told and on_wait is not None:
                on_wait(holder)
                told = True
            time.sleep(POLL_S)
        self.waited_s = time.monotonic() - t0 if told else 0.0
        self._stop.clear()
        self._beat = threading.Thread(target=self._heartbeat, daemon=True,
                                      name=f"saltstudy-lock-{self.path.name}")
        self._beat.start()
        return self

    def _heartbeat(self) -> None:
        while not self._stop.wait(HEARTBEAT_S):
            try:
                os.utime(self.path)
            except OSError:
                pass

    def release(self) -> None:
        """Remove the file, then let the lock go (a waiter that opened the old file sees it is
        gone and takes the new one)."""
        if self._fd is None:
            return
        self._stop.set()
        try:
            self.path.unlink(missing_ok=True)
        finally:
            fd, self._fd = self._fd, None
            os.close(fd)


class _Held:
    """This process's counted hold on an out dir (the command line and the run it starts)."""

    def __init__(self, lock: DirLock):
        self.lock, self.count = lock, 1

    def __enter__(self) -> DirLock:
        return self.lock

    def __exit__(self, *exc: Any) -> None:
        self.release()

    def release(self) -> None:
        self.count -= 1
        if self.count == 0:
            _HELD.pop(str(self.lock.path), None)
            self.lock.release()


_HELD: dict[str, _Held] = {}
_HELD_LOCK = threading.Lock()


def _waiting(log: Callable[[str], None] | None, what: str):
    """The ``on_wait`` of :meth:`DirLock.acquire` that logs ``[wait] <what> <holder>; waiting``."""
    return None if log is None else (
        lambda holder: log(f"[wait] {what} {describe_holder(holder or {})}; waiting for it"))


def hold_out_dir(out_dir: Path, wait: bool = False, log: Callable[[str], None] | None = None,
                 timeout: float | None = None) -> _Held:
    """Take ``<out>/saltstudy.lock`` (refuse with :class:`Busy`, or wait) for a ``with`` block; a
    process that holds it already holds it once more. Logs a take-over."""
    path = Path(os.path.abspath(Path(out_dir) / LOCK_NAME))
    with _HELD_LOCK:
        held = _HELD.get(str(path))
        if held is not None:
            held.count += 1
            return held
    lock = DirLock(path, f"out dir {out_dir}")
    lock.acquire(wait=wait, on_wait=_waiting(log, f"out dir {out_dir} is in use by"),
                 timeout=timeout)
    if lock.taken_over and log is not None:
        log(f"[lock] taking over {lock.path}: it was held by {describe_holder(lock.taken_over)}, "
            "which is gone")
    held = _Held(lock)
    with _HELD_LOCK:
        _HELD[str(path)] = held
    return held


def claim_task(directory: Path, name: str, log: Callable[[str], None] | None = None) -> DirLock:
    """Take ``<task dir>/task.lock``, waiting for another process that computes the task."""
    return DirLock(Path(directory) / TASK_LOCK_NAME, name).acquire(
        wait=True, on_wait=_waiting(log, f"{name} is being computed by"))
