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

:func:`check_output` is the rule on files already there (``--resume``, ``--force``), for every door:
the command line calls it before Taichi starts, and :meth:`Simulation.run
<cortex_ti.simulation.core.Simulation.run>`, the axisymmetric model's run and :func:`cortex_ti.run`
(``resume=``, ``force=``) call it holding the claim, so a script cannot overwrite or delete what the
command line would refuse to.

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
from .files import PARTIAL_SUFFIX, OutputError, describe_os_error, refuse_file_parent

__all__ = ["LOCK_SUFFIX", "OutputBusy", "OutputClaim", "claim_output", "check_output", "lock_path"]

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


def claim_output(path: str | os.PathLike) -> OutputClaim:
    """:meth:`OutputClaim.acquire`, with the output path checked first (not a folder, its folder not a
    file) and an operating-system error as one :class:`~cortex_ti.io.files.OutputError`."""
    path = Path(os.fspath(path))
    if path.is_dir():
        raise CortexError(f"output '{path}' is a folder; name a file in it, e.g. '{path / 'run.h5'}'")
    refuse_file_parent(path, "the output")
    try:
        return OutputClaim.acquire(path)
    except OSError as exc:
        raise OutputError(f"cannot write the output '{path}': {describe_os_error(exc)}") from None


def _partial(path: Path) -> Path:
    return Path(os.fspath(path) + PARTIAL_SUFFIX)


#: Suffixes of files that are never a run's output (a scene, a config): refused even with ``force``.
NOT_OUTPUTS = (".yaml", ".yml", ".json")


def check_output(path: str | os.PathLike, resume: bool, force: bool) -> str:
    """The rule for files already at ``path``, for every door (call it holding the claim):

    * a scene or config file (:data:`NOT_OUTPUTS`) is never an output, not even with ``force``;
    * ``path`` exists: refused without ``--force`` or ``--resume`` (a finished trajectory is
      extended by ``--resume``; anything else there is never overwritten without ``--force``);
    * ``path.partial`` holds frames of an interrupted run: refused without ``--resume`` (continue
      it) or ``--force`` (start over); a partial file without any complete frame is replaced.

    With ``force`` the partial file is deleted here. Returns what the run will do: ``"new"``,
    ``"resume"`` (a partial file) or ``"extend"`` (a finished trajectory, no partial file).
    """
    from .trajectory import committed_frames

    path = Path(os.fspath(path))
    if path.suffix.lower() in NOT_OUTPUTS and (force or not path.exists()):  # else: 'exists', below
        raise CortexError(
            f"output '{path}' is named like a scene or config file ({path.suffix}); a trajectory is an HDF5 "
            f"file: name it e.g. '{path.with_suffix('.h5')}'"
        )
    partial = _partial(path)
    if force:
        partial.unlink(missing_ok=True)
        return "new"
    frames = (0, None)
    if partial.exists():
        try:
            frames = committed_frames(partial)
        except CortexError:
            raise CortexError(
                f"'{partial}' exists and is not a readable trajectory; pass --force to replace it"
            ) from None
    if path.exists():
        if not resume:
            raise CortexError(f"'{path}' exists; pass --force to replace it, or --resume to extend a finished run")
        try:
            committed_frames(path)
        except CortexError:
            raise CortexError(
                f"'{path}' exists and is not a trajectory; choose another output or pass --force to replace it"
            ) from None
        return "resume" if frames[0] else "extend"
    if frames[0] and not resume:
        n, t = frames
        raise CortexError(
            f"'{partial}' holds {n} frames (to t = {t:.6g}) of an interrupted run: continue it with "
            "--resume, or pass --force to start over"
        )
    return "resume" if frames[0] else "new"
