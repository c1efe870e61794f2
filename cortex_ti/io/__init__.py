"""Files: trajectories, run summaries, stores and ParaView export.

Owns the trajectory files (``trajectory``, their public face: the layout in ``layout``, the
writer in ``writer``, atomic, flushed frame by frame, resumable; the readers in ``readers``: a
:class:`~cortex_ti.io.trajectory.Trajectory` answers for itself: its scene, a frame's normals,
the frame nearest a time; :class:`~cortex_ti.io.trajectory.ResumeState` in ``resume`` is where an
interrupted run continues; the commit marker and mesh segments in ``frames``),
small atomic writers and readers of JSON, xarray
stores and Snakemake benchmark files (``files``), the exclusive claim of an output (``lock``) and the rule for
files already there (``claim``), and the VTU/PVD export (``export``, atomic). May import
``scene`` (to read a stored scene) and, for files older than the stored normals, ``surface``.
"""

from .files import PARTIAL_SUFFIX, read_benchmark, write_dataset, write_json
from .trajectory import (
    FRAME_VARIABLES,
    ResumeState,
    Trajectory,
    TrajectoryWriter,
    last_frame,
    load_trajectory,
    open_trajectory,
    partial_path,
)

__all__ = [
    "PARTIAL_SUFFIX",
    "FRAME_VARIABLES",
    "Trajectory",
    "TrajectoryWriter",
    "ResumeState",
    "last_frame",
    "load_trajectory",
    "open_trajectory",
    "partial_path",
    "read_benchmark",
    "write_dataset",
    "write_json",
]
