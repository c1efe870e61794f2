"""How many frames of a trajectory file are complete: the committed-frame count and the mesh segments
(the layout of :mod:`cortex_ti.io.trajectory`). A module of its own, below both the writer and the
output rule (:func:`cortex_ti.io.claim.check_output` counts a partial file's frames), so that
neither imports the other in a circle.
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

from ..errors import CortexError

__all__ = ["COMMIT_ATTR", "SEGMENTS_ATTR", "SEGMENT_GROUP", "committed_frames"]

#: Global attribute: the number of complete frames (written after each frame's values are on disk).
COMMIT_ATTR = "committed_frames"
#: Global attribute: the number of mesh segments (root + groups ``mesh_<k>``) with a committed frame.
SEGMENTS_ATTR = "mesh_segments"
#: Group of segment k >= 1.
SEGMENT_GROUP = "mesh_{}"


def _committed(h5) -> int:
    """The number of complete frames of an open file: its ``committed_frames`` attribute, or for a file
    written before it existed the leading frames with finite, increasing times."""
    n_time = int(h5["time"].shape[0]) if "time" in h5 else 0
    if COMMIT_ATTR in h5.attrs:
        # a scalar as this package writes it; a one-element array where xarray wrote the attributes
        return min(int(np.asarray(h5.attrs[COMMIT_ATTR]).reshape(-1)[0]), n_time)
    t = np.asarray(h5["time"][...], dtype=float) if n_time else np.zeros(0)
    ok = np.isfinite(t)
    ok[1:] &= np.diff(t) > 0.0
    bad = np.flatnonzero(~ok)
    return int(bad[0]) if bad.size else n_time


def _open_h5(file: Path):
    """``h5py.File(file, "r")`` without HDF5's lock (a running writer holds it), or with it when this
    process has the file open already (HDF5 refuses two opens with different locking flags)."""
    try:
        return h5py.File(file, "r", locking=False)
    except OSError as exc:
        if "locking flag" not in str(exc):
            raise
        return h5py.File(file, "r")


def _segments(h5) -> list:
    """The committed segments of an open file: ``[(group, committed frames), ...]``, the root first."""
    count = int(np.asarray(h5.attrs.get(SEGMENTS_ATTR, 1)).reshape(-1)[0])
    out = [(h5, _committed(h5))]
    for k in range(1, count):
        group = h5[SEGMENT_GROUP.format(k)]
        out.append((group, _committed(group)))
    return out


def committed_frames(path: str | os.PathLike) -> tuple[int, float | None]:
    """``(number of complete frames, time of the last)`` of a trajectory file (``None``: no frame),
    over all its mesh segments."""
    file = Path(os.fspath(path))
    try:
        with _open_h5(file) as h5:
            if "time" not in h5 or "points" not in h5:
                raise CortexError(f"'{file}' is not a trajectory (no time and points)")
            segs = [(g, n) for g, n in _segments(h5) if n]
            total = sum(n for _, n in segs)
            return total, (float(segs[-1][0]["time"][segs[-1][1] - 1]) if segs else None)
    except (OSError, KeyError, ValueError, RuntimeError) as exc:
        raise CortexError(f"cannot read trajectory '{file}': {exc}") from None
