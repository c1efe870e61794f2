"""Files: trajectories, run summaries, stores and ParaView export.

Owns the trajectory layout and its writer (atomic, flushed frame by frame, resumable) and
reader (``trajectory``: a :class:`~cortex_ti.io.trajectory.Trajectory` answers for itself: its
scene, a frame's normals, the frame nearest a time; :class:`~cortex_ti.io.trajectory.ResumeState`
is where an interrupted run continues), small atomic writers and readers of JSON, xarray
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
