"""Where an interrupted run continues: :class:`ResumeState`, the last committed frame of its
``.partial`` file (:mod:`cortex_ti.io.trajectory` describes the file).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .layout import partial_path
from .readers import last_frame


@dataclass(frozen=True)
class ResumeState:
    """Where an interrupted run continues: the last flushed frame of its ``.partial`` file."""

    path: Path  # the partial file
    n_frames: int
    time: float
    points: np.ndarray  # (N, 3)
    active_stress: np.ndarray  # (N,) the tension carried by the nodes
    dt: float | None  # the step the integrator was about to take (None if not stored)
    fields: dict = field(default_factory=dict)  # every other (time, node) variable of the frame
    segment: int = 0  # the mesh segment of the frame (0: the initial mesh)
    triangles: np.ndarray | None = None  # the frame's mesh
    reference: np.ndarray | None = None  # the segment's ALE reference nodes (None in segment 0)

    @classmethod
    def read(cls, output: str | os.PathLike) -> ResumeState | None:
        """The state of ``<output>.partial``, or None if there is none or it holds no frame."""
        partial = partial_path(output)
        if not partial.exists():
            return None
        last = last_frame(partial)
        if not last["n_frames"]:
            return None
        dt = last["extra"].get("dt")
        n = np.shape(last["points"])[0]
        nodal = {k: np.asarray(v, dtype=float) for k, v in last["extra"].items() if np.shape(v) == (n,)}
        return cls(
            path=partial,
            n_frames=last["n_frames"],
            time=float(last["time"]),
            points=np.asarray(last["points"], dtype=float),
            active_stress=np.asarray(last["active_stress"], dtype=float),
            dt=None if dt is None else float(dt),
            fields=nodal,
            segment=int(last["segment"]),
            triangles=last["triangles"],
            reference=last["reference_points"],
        )
