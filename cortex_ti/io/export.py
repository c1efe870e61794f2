"""ParaView-ready export of a trajectory: one VTU per frame (meshio) and a .pvd time series.

meshio's XDMF time-series writer stores the points once, but our nodes move every
frame, so each frame is its own VTU file; the small ``.pvd`` collection that tells
ParaView their times is written here (a dozen lines of XML: no library needed).
"""

from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from ..errors import CortexError
from .trajectory import Trajectory


def export_vtu_series(path, out_dir=None, every: int = 1) -> Path:
    """Write ``<out_dir>/frame_00000.vtu ...`` and ``<out_dir>/<stem>.pvd``; return the .pvd path.

    Point data per frame: ``velocity`` (3-vector), ``speed`` |v|, ``normal_speed`` v . n
    (n the solver's normal of the frame, :meth:`Trajectory.normals`) and ``active_stress``.
    """
    path = Path(path)
    if every < 1:
        raise CortexError(f"--every must be >= 1, got {every}")
    out_dir = Path(out_dir) if out_dir else path.with_suffix("")
    out_dir.mkdir(parents=True, exist_ok=True)
    entries = []
    with Trajectory(path, lazy=True) as tr:
        ds = tr.ds
        tri = ds["triangles"].values.astype(np.int64)
        times = ds["time"].values
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
            tmp = out_dir / (name + ".tmp.vtu")
            meshio.write(tmp, meshio.Mesh(pts, [("triangle", tri)], point_data=data), file_format="vtu")
            os.replace(tmp, out_dir / name)
            entries.append((float(times[k]), name))
    pvd = out_dir / (path.stem + ".pvd")
    lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">', "  <Collection>"]
    lines += [f'    <DataSet timestep="{t!r}" part="0" file={quoteattr(n)}/>' for t, n in entries]
    lines += ["  </Collection>", "</VTKFile>", ""]
    tmp = pvd.with_suffix(".pvd.tmp")
    tmp.write_text("\n".join(lines))
    os.replace(tmp, pvd)
    return pvd
