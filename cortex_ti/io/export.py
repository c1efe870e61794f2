"""ParaView-ready export of a trajectory, one run per file name so that runs exported into one
folder never mix.

Two formats (:data:`EXPORT_FORMATS`):

``vtkhdf`` (default)
    ONE file ``<stem>.vtkhdf`` with every frame as a time step (VTKHDF 2.x, an
    ``UnstructuredGrid`` of triangles; ParaView 5.12 and newer, VTK 9.3 and newer open it with
    its time steps). Written with h5py from the published layout (VTK's documentation, "VTKHDF
    format specification"): the points and point data of all frames one after the other, the
    triangles once, and the ``Steps`` group that tells where each frame's part begins. No
    library writes a time-dependent VTKHDF from arrays (meshio writes one frame; VTK's
    ``vtkHDFWriter`` needs a time-aware pipeline), hence the few lines here.
``pvd``
    ``<stem>.pvd`` and one ``<stem>_<k>.vtu`` per frame (meshio), all named after the run.

A remeshed run's frames each carry their own mesh (in VTKHDF each mesh is a part stored once, the
steps pointing at theirs; in a PVD series each ``.vtu`` has its frame's mesh).

Point data of every frame: ``velocity`` (3-vector), ``speed`` ``|v|``, ``normal_speed``
``v . n`` (n the solver's normal of the frame, :meth:`Trajectory.normals`) and
``active_stress``.
"""

from __future__ import annotations

import os
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from ..errors import CortexError
from .files import (
    PARTIAL_SUFFIX,
    OutputError,
    atomic_path,
    check_destination,
    describe_os_error,
    hdf5_os_error,
    refuse_file_parent,
    write_synced,
)
from .trajectory import Trajectory

__all__ = [
    "EXPORT_FORMATS",
    "VTK_QUADRATIC_TRIANGLE",
    "VTK_TRIANGLE",
    "export_path",
    "export_trajectory",
    "export_vtkhdf",
    "export_vtu_series",
]

#: Export formats: name -> file suffix.
EXPORT_FORMATS: dict[str, str] = {"vtkhdf": ".vtkhdf", "pvd": ".pvd"}

#: VTK's cell type number of a linear triangle.
VTK_TRIANGLE = 5
#: the six-node quadratic triangle (corners, then the midpoints of edges 01, 12, 20: the node order of
#: :func:`cortex_ti.surface.curved.p2_cells`), which ParaView draws curved
VTK_QUADRATIC_TRIANGLE = 22


def _cells(tr, triangles: np.ndarray) -> np.ndarray:
    """The cells to export for a mesh's triangles: the six-node curved cells of a run on curved cells
    (formulation ``rayleigh_p2``, read from the trajectory's scene), else the triangles themselves."""
    try:
        curved = tr.settings.numerics.formulation_entry.curved
    except (KeyError, CortexError):  # no stored scene, or one this version cannot read: the triangles
        curved = False
    if not curved:
        return np.asarray(triangles, dtype=np.int64)
    from ..surface.curved import p2_cells

    return p2_cells(np.asarray(triangles)).astype(np.int64)


#: VTKHDF version written: 2.0, the first with time steps (the layout used here has not changed since),
#: so that older readers (ParaView 5.12, VTK 9.3) take it too.
_VTKHDF_VERSION = (2, 0)


def _frames(path, every: int):
    """``(the trajectory opened lazily, the indices of the exported frames, all times)``."""
    if every < 1:
        raise CortexError(f"--every must be >= 1, got {every}")
    tr = Trajectory(path, lazy=True)
    ds = tr.ds
    times = np.asarray(ds["time"].values, dtype=float)
    if len(times) == 0:
        tr.close()
        raise CortexError(f"'{path}' has no frames (yet)")
    return tr, list(range(0, len(times), every)), times


def _point_data(tr: Trajectory, k: int) -> dict[str, np.ndarray]:
    vel = np.asarray(tr.nodal("velocity", k), dtype=float)
    return {
        "velocity": vel,
        "speed": np.linalg.norm(vel, axis=1),
        "normal_speed": np.einsum("nc,nc->n", vel, tr.normals(k)),
        "active_stress": np.asarray(tr.nodal("active_stress", k), dtype=float),
    }


def export_path(trajectory, output=None, fmt: str = "vtkhdf") -> Path:
    """Where :func:`export_trajectory` writes: ``output`` if it ends in the format's suffix, else
    ``<output or the trajectory's folder>/<stem><suffix>`` (``stem``: the trajectory's name
    without ``.h5``/``.partial``)."""
    if fmt not in EXPORT_FORMATS:
        raise CortexError(f"unknown export format '{fmt}'; choose one of: {', '.join(EXPORT_FORMATS)}")
    suffix = EXPORT_FORMATS[fmt]
    trajectory = Path(trajectory)
    if output is not None and Path(output).suffix.lower() == suffix:
        return Path(output)
    if output is not None and Path(output).suffix.lower() in {s for s in EXPORT_FORMATS.values()}:
        raise CortexError(f"-o '{output}' has the suffix of another format than --format {fmt} ({suffix})")
    name = trajectory.name
    for end in (".partial", ".h5", ".nc"):
        name = name.removesuffix(end)
    folder = Path(output) if output is not None else trajectory.parent
    return folder / (name + suffix)


def export_vtkhdf(path, output=None, every: int = 1) -> Path:
    """Write the trajectory ``path`` as one VTKHDF file with its frames as time steps.

    Returns the written path (see :func:`export_path`). The file is written under a temporary
    name and renamed when complete.
    """
    import h5py

    out = export_path(path, output, "vtkhdf")
    tr, ks, times = _frames(path, every)
    with tr:
        # the distinct meshes of the exported frames, each stored once as one "part"
        segment = np.asarray(tr.ds["mesh_id"].values)[ks] if tr.remeshed else np.zeros(len(ks), dtype=np.int64)
        used = sorted(set(segment.tolist()))
        part = {s: i for i, s in enumerate(used)}
        first = [tr.mesh(ks[int(np.argmax(segment == s))]) for s in used]
        tris = [_cells(tr, tri) for _, tri in first]
        width = tris[0].shape[1]  # 3 corners, or 6 nodes of a curved cell
        cell_type = VTK_TRIANGLE if width == 3 else VTK_QUADRATIC_TRIANGLE
        faces = np.array([len(t) for t in tris], dtype=np.int64)
        nodes = np.array([p.shape[0] for p, _ in first], dtype=np.int64)
        step_part = np.array([part[s] for s in segment.tolist()], dtype=np.int64)
        step_nodes = nodes[step_part]
        point_offsets = np.concatenate([[0], np.cumsum(step_nodes)[:-1]]).astype(np.int64)
        cell_start = np.concatenate([[0], np.cumsum(faces)[:-1]]).astype(np.int64)
        m, total = len(ks), int(step_nodes.sum())
        out, tmp = atomic_path(out)
        check_destination(out, _vtkhdf_bytes(total, int(faces.sum())))
        # Python does every write to the disk, so that a full disk or an I/O error is one OSError: the
        # file is built in memory (HDF5's core driver) and written out, or, too large for memory,
        # written through a Python file object (h5py's fileobj driver). HDF5 writing the file itself
        # fails half-way on a full disk, prints a traceback per object it cannot close and may crash.
        in_memory = _vtkhdf_bytes(total, int(faces.sum())) <= _IN_MEMORY
        fh = None
        try:
            fh = None if in_memory else open(tmp, "w+b")  # noqa: SIM115 (closed in finally)
            target = f"{tmp.name}.image" if in_memory else fh
            kwargs = {"driver": "core", "backing_store": False} if in_memory else {}
            with h5py.File(target, "w", **kwargs) as h5:
                root = h5.create_group("VTKHDF")
                root.attrs["Version"] = np.array(_VTKHDF_VERSION, dtype=np.int64)
                root.attrs.create("Type", np.bytes_("UnstructuredGrid"))
                # each mesh is one part, its sizes and triangles stored once; step j points at its
                # mesh's part (PartOffsets), cells (CellOffsets; its Offsets begin one entry later per
                # earlier part) and connectivity, and at its own points and point data (PointOffsets)
                root["NumberOfPoints"] = nodes
                root["NumberOfCells"] = faces
                root["NumberOfConnectivityIds"] = width * faces
                root["Types"] = np.full(int(faces.sum()), cell_type, dtype=np.uint8)
                root["Offsets"] = np.concatenate([np.arange(0, width * f + 1, width, dtype=np.int64) for f in faces])
                root["Connectivity"] = np.concatenate([t.reshape(-1) for t in tris])
                points = root.create_dataset("Points", (total, 3), dtype=np.float64)
                pdata = root.create_group("PointData")
                steps = root.create_group("Steps")
                steps.attrs["NSteps"] = np.int64(m)
                steps["Values"] = times[ks]
                steps["PartOffsets"] = step_part
                steps["NumberOfParts"] = np.ones(m, dtype=np.int64)
                steps["PointOffsets"] = point_offsets
                steps["CellOffsets"] = cell_start[step_part][:, None]
                steps["ConnectivityIdOffsets"] = width * cell_start[step_part][:, None]
                offsets = steps.create_group("PointDataOffsets")
                for j, k in enumerate(ks):
                    lo, hi = point_offsets[j], point_offsets[j] + step_nodes[j]
                    points[lo:hi] = tr.mesh(k)[0]
                    for name, values in _point_data(tr, k).items():
                        if name not in pdata:
                            pdata.create_dataset(name, (total, *values.shape[1:]), dtype=np.float64)
                            offsets[name] = point_offsets
                        pdata[name][lo:hi] = values
                if in_memory:
                    h5.flush()
                    image = h5.id.get_file_image()
            if in_memory:
                write_synced(tmp, image)
            else:
                fh.flush()
                os.fsync(fh.fileno())
                fh.close()
            os.replace(tmp, out)
        finally:
            if fh is not None:
                try:
                    fh.close()  # after a failed write its buffer cannot be flushed either
                except OSError:
                    pass
            tmp.unlink(missing_ok=True)
    return out


#: Exports up to this size are built in memory and written out at once (see :func:`export_vtkhdf`).
_IN_MEMORY = 1 << 30


def _vtkhdf_bytes(points: int, faces: int) -> int:
    """The size of a VTKHDF export: the points and 8 numbers of point data per exported node, the
    triangles once, and some HDF5 overhead."""
    return 8 * 11 * points + 34 * faces + (1 << 16)


def export_vtu_series(path, output=None, every: int = 1) -> Path:
    """Write ``<stem>.pvd`` and its frames ``<stem>_00000.vtu ...`` beside it; return the .pvd.

    The frames carry the run's name, so two runs exported into one folder do not overwrite each
    other's frames (see :func:`export_path` for the folder). Everything is written into a temporary
    folder beside them first and moved into place when complete (the ``.pvd`` last), replacing the
    frames of an earlier export of the same run, stale ones included; a failure leaves nothing.
    """
    import shutil

    import meshio

    pvd = export_path(path, output, "pvd")
    tr, ks, times = _frames(path, every)
    out_dir = pvd.parent
    with tr:
        check_destination(pvd, _vtkhdf_bytes(sum(tr.mesh(k)[0].shape[0] for k in ks), 0) // 2)
        work = out_dir / f".{pvd.name}{PARTIAL_SUFFIX}"
        shutil.rmtree(work, ignore_errors=True)  # a leftover of a killed export
        try:
            work.mkdir()
            entries = []
            for k in ks:
                pts, tri = tr.mesh(k)
                name = f"{pvd.stem}_{k:05d}.vtu"
                cells = _cells(tr, tri)
                kind = "triangle" if cells.shape[1] == 3 else "triangle6"
                mesh = meshio.Mesh(pts, [(kind, cells)], point_data=_point_data(tr, k))
                meshio.write(work / name, mesh, file_format="vtu")
                entries.append((float(times[k]), name))
            lines = ['<?xml version="1.0"?>', '<VTKFile type="Collection" version="0.1">', "  <Collection>"]
            lines += [f'    <DataSet timestep="{t!r}" part="0" file={quoteattr(n)}/>' for t, n in entries]
            lines += ["  </Collection>", "</VTKFile>", ""]
            write_synced(work / pvd.name, "\n".join(lines).encode())
            # in place: the old .pvd first (no reader follows it to half-replaced frames), the frames
            # of an earlier export of this run, then the new frames and the new .pvd
            pvd.unlink(missing_ok=True)
            for old in _frame_files(out_dir, pvd.stem):
                old.unlink()
            for _, name in entries:
                os.replace(work / name, out_dir / name)
            os.replace(work / pvd.name, pvd)
        finally:
            shutil.rmtree(work, ignore_errors=True)
    return pvd


def _frame_files(folder: Path, stem: str) -> list[Path]:
    """The ``<stem>_<k>.vtu`` frames of a PVD export in ``folder``."""
    import glob
    import re

    pattern = re.compile(re.escape(stem) + r"_\d{5,}\.vtu")
    return [p for p in folder.glob(f"{glob.escape(stem)}_*.vtu") if pattern.fullmatch(p.name)]


def export_trajectory(path, output=None, fmt: str = "vtkhdf", every: int = 1, force: bool = False) -> Path:
    """Export a trajectory for ParaView in the format ``fmt`` (:data:`EXPORT_FORMATS`). An existing
    export of the same run is replaced only with ``force``; a folder that cannot be written, or a
    full disk, is one :class:`~cortex_ti.io.files.OutputError` and leaves nothing behind."""
    if fmt not in EXPORT_FORMATS:
        raise CortexError(f"unknown export format '{fmt}'; choose one of: {', '.join(EXPORT_FORMATS)}")
    target = export_path(path, output, fmt)
    refuse_file_parent(target, "the export")
    if target.exists() and not force:
        raise CortexError(f"'{target}' exists; pass --force to replace it, or choose another -o")
    writer = export_vtkhdf if fmt == "vtkhdf" else export_vtu_series
    try:
        return writer(path, output, every)
    except OutputError:
        raise
    except RuntimeError as exc:  # HDF5 failing a write (an export too large to build in memory)
        failed = hdf5_os_error(exc)
        if failed is None:
            raise
        raise OutputError(f"exporting '{path}' to '{target}' failed ({failed}); nothing was written") from None
    except OSError as exc:
        raise OutputError(
            f"exporting '{path}' to '{target}' failed ({describe_os_error(exc)}); nothing was written"
        ) from None
