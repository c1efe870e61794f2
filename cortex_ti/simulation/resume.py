"""Continuing a run: the finished file extended, the last frame's state, a dense scheme's step history.

An interrupted run continues from ``<output>.partial`` (:class:`cortex_ti.io.trajectory.ResumeState`)
on the mesh of its last frame (:func:`resumed_state`); a finished one with a later ``time.t_end`` is
first copied to its partial file (:func:`extend_finished`). A multistep scheme (bdf2) saves its step
history beside the partial file with every commit of frames (:func:`write_history`), so that the
resumed run is the uninterrupted one (:func:`read_history`).
"""

from __future__ import annotations

import logging
import os
import shutil
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..dynamics.state import State
from ..errors import CortexError
from ..io.files import OutputError, describe_os_error
from ..io.trajectory import ResumeState, partial_path

if TYPE_CHECKING:  # pragma: no cover
    from .core import Simulation

log = logging.getLogger(__name__)

__all__ = ["extend_finished", "history_path", "write_history", "read_history", "frame_fields", "resumed_state"]


def extend_finished(output: Path) -> bool:
    """``resume`` of a finished trajectory: copy ``output`` to its partial file (under a temporary
    name, then renamed) so that the run continues from its last frame; the finished file stays until
    the longer one replaces it. True if it copied."""
    partial = partial_path(output)
    if partial.exists() or not output.is_file():
        return False
    tmp = partial.with_name(partial.name + ".copy")
    try:
        shutil.copyfile(output, tmp)
        os.replace(tmp, partial)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(
            f"cannot copy '{output}' to '{partial}' to extend it ({describe_os_error(exc)}); '{output}' is unchanged"
        ) from None
    return True


def history_path(output: str | os.PathLike) -> Path:
    """Beside ``<output>.partial``: the step history of a dense scheme (bdf2) at its last frame."""
    return Path(os.fspath(partial_path(output)) + ".history.npz")


def write_history(output, scheme, dt: float, n_frames: int, frame_time: float) -> None:
    """Save ``scheme``'s step history (:meth:`~cortex_ti.dynamics.schemes.BDF2.checkpoint`), the
    step it proposes next and the frames of the partial file it belongs to, atomically (a
    temporary file renamed over the last one)."""
    path = history_path(output)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        np.savez(
            f,
            dt=np.array(float(dt)),
            n_frames=np.array(int(n_frames)),
            frame_time=np.array(frame_time),
            **scheme.checkpoint(),
        )
    os.replace(tmp, path)


def read_history(output, state: ResumeState) -> dict | None:
    """The saved step history that continues the partial file's last frame, or None (no file, or one
    of other frames: the run was killed between its frames and its history)."""
    path = history_path(output)
    if not path.exists():
        return None
    try:
        with np.load(path) as data:
            history = {k: data[k] for k in data.files}
    except (OSError, ValueError, KeyError) as exc:
        log.warning("cannot read %s (%s): restarting the scheme from the last frame", path, exc)
        return None
    if int(history["n_frames"]) != state.n_frames or float(history["frame_time"]) != state.time:
        log.info("%s belongs to other frames: restarting the scheme from the last frame", path)
        return None
    newest = history[f"{int(history['n']) - 1}__points"]
    if int(history["n"]) < 2 or newest.shape != np.shape(state.points):
        return None  # at the start (one state): the restart is the same computation
    return history


def frame_fields(sim: Simulation, stored: dict, active_stress: np.ndarray, where: str) -> dict:
    """``sim``'s fields at a stored frame: each from its variable in ``stored`` (variable name ->
    nodal values), a prescribed tension that is the whole tension from ``active_stress`` (a
    trajectory stores it only there; files written before the fields existed hold only that)."""
    fields = {}
    for spec in sim.fields:
        if spec.var in stored:
            fields[spec.name] = np.asarray(stored[spec.var], dtype=float)
        elif spec.name == "prescribed_tension":
            fields[spec.name] = np.asarray(active_stress, dtype=float)
        else:
            raise CortexError(f"{where} holds no values of the field {spec.var!r}")
    return fields


def resumed_state(sim: Simulation, resume: ResumeState) -> State:
    """The state of the last complete frame of an interrupted run: its points and every field
    (:func:`frame_fields`)."""
    fields = frame_fields(sim, resume.fields, resume.active_stress, f"cannot resume {resume.path}: it")
    points = np.asarray(resume.points, dtype=float)
    if resume.segment > 0:  # the run had remeshed: continue on the frame's mesh
        sim.continue_segment(points, resume.triangles, resume.reference, resume.segment)
    return State(points, fields, sim.mesh.faces)
