"""Exclusive claim of a run's output, taken before anything is truncated.

A run that writes ``OUT`` holds an advisory lock (:func:`fcntl.flock`) on ``OUT.lock`` from before
it touches ``OUT.partial`` until it has renamed it to ``OUT``; a second run (another terminal, a
notebook, a requeued job whose old copy is still alive) is refused with one line naming the run
that holds it (process id, host, start time: written into the lock file). The lock goes with the
process, so a killed run leaves no stale claim: a leftover ``OUT.lock`` is simply taken over, and
a finished run deletes it.

Claims are counted per process: the command line claims the output before the first solve, and
the :class:`~cortex_ti.io.trajectory.TrajectoryWriter` it creates later takes the same claim again
(a second ``flock`` on another descriptor of the same file would refuse the process itself).

The command line's policy on files already there is :mod:`cortex_ti.io.claim`'s.

The locking is written by hand (two dozen lines around ``fcntl.flock``): the lock-file packages on
PyPI (``filelock``, ``fasteners``) do not tell who holds a lock, and the message must name the run.
"""

from __future__ import annotations

import datetime as _dt
import errno
import os
import socket
import sys
from pathlib import Path

from ..errors import CortexError

__all__ = ["LOCK_SUFFIX", "OutputBusy", "OutputClaim", "lock_path"]

#: Suffix of the lock file beside an output being written.
LOCK_SUFFIX = ".lock"

_HELD: dict[str, OutputClaim] = {}


class OutputBusy(CortexError):
    """Another run is writing the same output."""


def lock_path(path: str | os.PathLike) -> Path:
    """The lock file of an output: ``<path>.lock``."""
    return Path(os.fspath(path) + LOCK_SUFFIX)


def _key(path: Path) -> str:
    return os.path.realpath(path)


def _holder(fd: int) -> str:
    """Who holds the lock, as written into the lock file by :meth:`OutputClaim._take`."""
    try:
        text = os.pread(fd, 4096, 0).decode("utf-8", "replace").strip()
    except OSError:
        text = ""
    return text or "another process"


class OutputClaim:
    """The exclusive claim of one output path by this process (see the module docstring)."""

    def __init__(self, path: Path, fd: int):
        self.path = path
        self.lock = lock_path(path)
        self._fd = fd
        self._count = 1

    @classmethod
    def acquire(cls, path: str | os.PathLike) -> OutputClaim:
        """Claim ``path`` (again, if this process holds it already); refuse with :class:`OutputBusy`
        if another process does. The output's folder is created if needed."""
        path = Path(os.fspath(path))
        path.parent.mkdir(parents=True, exist_ok=True)
        held = _HELD.get(_key(path))
        if held is not None:
            held._count += 1
            return held
        claim = cls(path, cls._take(path))
        _HELD[_key(path)] = claim
        return claim

    @staticmethod
    def _take(path: Path) -> int:
        import fcntl

        lock = lock_path(path)
        while True:
            fd = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                    os.close(fd)
                    raise
                who = _holder(fd)
                os.close(fd)
                raise OutputBusy(
                    f"'{path}' is being written by another run ({who}); wait for it to end or choose another output"
                ) from None
            # the holder before us may have deleted the lock file between our open and our lock:
            # then we hold a lock on a file nobody else sees, so take the one at the path again
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(lock))
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        started = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
        note = f"pid {os.getpid()} on {socket.gethostname()}, since {started}: {' '.join(sys.argv)[:200]}\n"
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, note.encode(), 0)
        except OSError:
            pass  # a full disk: the lock holds all the same, only its note is missing
        return fd

    def release(self) -> None:
        """Drop one hold; the last one deletes the lock file and unlocks."""
        self._count -= 1
        if self._count > 0 or self._fd < 0:
            return
        _HELD.pop(_key(self.path), None)
        fd, self._fd = self._fd, -1
        try:
            self.lock.unlink(missing_ok=True)  # while still locked: see _take
        except OSError:
            pass
        finally:
            os.close(fd)

    def __enter__(self) -> OutputClaim:
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def __repr__(self) -> str:
        return f"<OutputClaim '{self.path}' x{self._count}>"
