"""ParaView-ready export of a trajectory: one VTU per frame (meshio) and a .pvd time series.

meshio's XDMF time-series writer stores the points once, but our nodes move every
frame, so each frame is its own VTU file; the small ``.pvd`` collection that tells
ParaView their times is written here (a dozen lines of XML: no library needed).

The export is atomic: the files are written into a temporary folder beside the target, which is
renamed to the target when complete; the target must be new or empty (or ``force``, which
replaces it). A failed export (an unreadable trajectory, a full disk) leaves nothing behind.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from ..errors import CortexError
from .files import OutputError, describe_os_error, refuse_file_parent
from .trajectory import Trajectory


def _target(out_dir: Path, force: bool) -> None:
    """Refuse a target that is a file, or a folder with files in it (without ``force``)."""
    if out_dir.exists() and not out_dir.is_dir():
        raise CortexError(f"export folder '{out_dir}' is a file")
    refuse_file_parent(out_dir, "the export folder")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not force:
        raise CortexError(f"export folder '{out_dir}' exists and is not empty; choose a new folder or pass --force "
                          "to replace it")


def _put_in_place(tmp: Path, out_dir: Path) -> None:
    """Rename the finished folder ``tmp`` to ``out_dir``, replacing what is there."""
    old = None
    if out_dir.exists():
        old = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.old-", dir=out_dir.parent))
        os.replace(out_dir, old / "x")
    os.replace(tmp, out_dir)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def export_vtu_series(path, out_dir=None, every: int = 1, force: bool = False) -> Path:
    """Write ``<out_dir>/frame_00000.vtu ...`` and ``<out_dir>/<stem>.pvd``; return the .pvd path.

    Point data per frame: ``velocity`` (3-vector), ``speed`` |v|, ``normal_speed`` v . n
    (n the solver's normal of the frame, :meth:`Trajectory.normals`) and ``active_stress``.
    ``out_dir`` (default: the trajectory's path without its suffix) must be new or empty, unless
    ``force``; it appears complete or not at all.
    """
    path = Path(path)
    if every < 1:
        raise CortexError(f"--every must be >= 1, got {every}")
    out_dir = Path(out_dir) if out_dir else path.with_suffix("")
    _target(out_dir, force)
    with Trajectory(path, lazy=True) as tr:      # opened first: an unreadable file costs no folder
        return _export(tr, path, out_dir, every)


def _export(tr: Trajectory, path: Path, out_dir: Path, every: int) -> Path:
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out_dir.name}.tmp-", dir=out_dir.parent))
    except OSError as exc:
        raise OutputError(f"cannot write the export folder '{out_dir}': {describe_os_error(exc)}") from None
    try:
        pvd_name = path.stem + ".pvd"
        _write_series(tr, tmp, every, pvd_name)
        _put_in_place(tmp, out_dir)
    except OSError as exc:
        raise OutputError(f"exporting '{path}' to '{out_dir}' failed ({describe_os_error(exc)}); nothing was "
                          "written") from None
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return out_dir / pvd_name


def _write_series(tr: Trajectory, out_dir: Path, every: int, pvd_name: str) -> None:
    ds = tr.ds
    tri = ds["triangles"].values.astype(np.int64)
    times = ds["time"].values
    entries = []
    for k in range(0, len(times), every):
        pts = ds["points"].isel(time=k).values
        vel = ds["velocity"].isel(time=k).values
        normals = tr.normals(k)
        data = {
            "velocity": vel,
            "speed": np.linalg.norm(vel, axis=1),
            "normal_speed": np.einsum("nc,nc->n", vel, normals),
            "active_stress": ds["active_stress"].isel(time=k).values,
        }
        name = f"frame_{k:05d}.vtu"
        meshio.write(out_dir / name, meshio.Mesh(pts, [("triangle", tri)], point_data=data), file_format="vtu")
        entries.append((float(times[k]), name))
    lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">', "  <Collection>"]
    lines += [f'    <DataSet timestep="{t!r}" part="0" file={quoteattr(n)}/>' for t, n in entries]
    lines += ["  </Collection>", "</VTKFile>", ""]
    (out_dir / pvd_name).write_text("\n".join(lines))
