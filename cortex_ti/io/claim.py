"""The command line's policy on a run's output: :func:`claim_output` (the exclusive claim of
:mod:`cortex_ti.io.lock`, with the path checked first) and :func:`check_output`, the rule for
files already there (``--resume``, ``--force``).

The lock itself lives in :mod:`cortex_ti.io.lock`, which the trajectory writer imports too; its
names are re-exported here (``from cortex_ti.io.claim import OutputClaim`` keeps working).

:func:`check_output` is the rule on files already there (``--resume``, ``--force``), for every door:
the command line calls it before Taichi starts, and :meth:`Simulation.run
<cortex_ti.simulation.core.Simulation.run>`, the axisymmetric model's run and :func:`cortex_ti.run`
(``resume=``, ``force=``) call it holding the claim, so a script cannot overwrite or delete what the
command line would refuse to.

"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import CortexError
from .files import PARTIAL_SUFFIX, OutputError, describe_os_error, refuse_file_parent
from .frames import committed_frames
from .lock import LOCK_SUFFIX, OutputBusy, OutputClaim, lock_path

__all__ = ["LOCK_SUFFIX", "OutputBusy", "OutputClaim", "claim_output", "check_output", "lock_path"]


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
