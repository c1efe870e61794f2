"""Trajectory files: one netCDF4/HDF5 file per run.

Layout (written with ``h5netcdf``; open with ``xarray.open_dataset(path,
engine="h5netcdf")`` or :func:`open_trajectory`)::

    dimensions:  time (unlimited), node, xyz = 3, face, corner = 3
    variables:   time(time)                  [t_a]       coordinate
                 points(time, node, xyz)     [R0]
                 velocity(time, node, xyz)   [R0/t_a]
                 active_stress(time, node)   [zeta_0]
                 pressure(time)              [zeta_0/R0] NaN without incompressibility
                 triangles(face, corner)     int32, 0-based node indices
                 ... extra per-frame variables declared by the caller
    attributes:  effects, scene, cortex_ti_version, created, + caller's

Every variable carries ``units`` and ``long_name``.

A run that remeshes (``mesh.remesh``) writes each later mesh as a *segment*: the HDF5 group
``mesh_<k>`` (k = 1, 2, ...) with the same layout (its own ``node``/``face`` dimensions, ``triangles``,
``time`` and the per-frame variables, its own ``committed_frames``) plus ``reference_points(node, xyz)``
(the nodes right after the remeshing, what the ALE motion relaxes toward). The root holds segment 0
unchanged, and its attribute ``mesh_segments`` counts the segments whose first frame is committed
(absent: one segment). A file without remeshing is the layout above, as before.
:func:`open_trajectory` and :func:`load_trajectory` give one dataset either way; for several
segments (:func:`merge_segments`) the node and face dimensions are padded to the largest mesh
(NaN, triangles -1) and ``mesh_id(time)``, ``n_nodes(mesh)``, ``n_faces(mesh)``,
``triangles(mesh, face, corner)`` say which mesh each frame has (:func:`frame_mesh`).

Crash safety: frames go to ``<path>.partial`` and are flushed to disk as they
come (a run commits the frames of each time step together), so a killed run
leaves a readable partial file of the frames written so far (and can be
resumed); :meth:`TrajectoryWriter.finish` renames it atomically to ``<path>``,
so the final path never holds a half-written file.

* The writer claims ``<path>`` exclusively (:mod:`cortex_ti.io.lock`) before it creates or opens
  the partial file: a second writer of the same path is refused before anything is truncated.
* A frame is *committed* last: its values are written and flushed, then the global attribute
  ``committed_frames`` is set to the new count and flushed again. Readers here
  (:func:`load_trajectory`, :func:`last_frame`, :class:`Trajectory`, :class:`ResumeState`) take only
  the committed frames; a resumed writer drops an uncommitted one.
* Before each frame the file's space for it is reserved (:func:`os.posix_fallocate`: the largest
  chunk of every variable plus room for HDF5's metadata), so a full disk or a file-size limit stops
  the run with the file untouched and readable, rather than half-way through an HDF5 write (HDF5 is
  not journaled); the run ends with one line (:class:`~cortex_ti.io.files.OutputError`) saying
  which file, why, and how many frames were kept.
* ``SIGINT`` and ``SIGTERM`` are held back while a frame is written and committed, and delivered
  right after.

Where each job lives: the layout and its checks in :mod:`~cortex_ti.io.layout`, the writer in
:mod:`~cortex_ti.io.writer`, the readers and :class:`Trajectory` in :mod:`~cortex_ti.io.readers`,
:class:`ResumeState` in :mod:`~cortex_ti.io.resume`, the commit marker and the mesh segments in
:mod:`~cortex_ti.io.frames`. This module is their one public face: import from here (or from
:mod:`cortex_ti.io`).
"""

from __future__ import annotations

from .frames import COMMIT_ATTR, SEGMENTS_ATTR, committed_frames
from .layout import FIELD_PREFIX, FRAME_VARIABLES, partial_path
from .readers import (
    Trajectory,
    frame_mesh,
    last_frame,
    load_trajectory,
    merge_segments,
    open_trajectory,
    read_divisions,
)
from .resume import ResumeState
from .writer import TrajectoryWriter

__all__ = [
    "FRAME_VARIABLES",
    "TrajectoryWriter",
    "Trajectory",
    "read_divisions",
    "ResumeState",
    "open_trajectory",
    "load_trajectory",
    "last_frame",
    "partial_path",
    "committed_frames",
    "COMMIT_ATTR",
    "FIELD_PREFIX",
    "SEGMENTS_ATTR",
    "merge_segments",
    "frame_mesh",
]
