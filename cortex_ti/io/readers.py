"""Reading a trajectory back (:mod:`cortex_ti.io.trajectory` describes the file): as an
:class:`xarray.Dataset` lazily (:func:`open_trajectory`) or in memory without HDF5's lock
(:func:`load_trajectory`), the segments of a remeshed run merged into one dataset
(:func:`merge_segments`, :func:`frame_mesh`), the last frame (:func:`last_frame`), and
:class:`Trajectory`, a file that answers for itself (its scene, a frame's normals, the frame
nearest a time).
"""

from __future__ import annotations

import os
from functools import cached_property
from pathlib import Path
from typing import Any

import h5netcdf
import numpy as np

from ..errors import CortexError
from .frames import SEGMENT_GROUP, _committed, _open_h5, _segments
from .layout import _RESERVED, _TRIANGLE_ATTRS, FIELD_PREFIX, FRAME_VARIABLES, RENAMED_VARIABLES, partial_path


def _read_only_dimension_sizes() -> None:
    """Make an unlimited dimension's size a value per open of a read-only file.

    h5netcdf (1.8) recomputes an unlimited dimension's size, on every access, from the shapes of all
    the variables that use it (its ``REFERENCE_LIST``); opening one small trajectory asks for it a few
    hundred times, which was 80 % of the 0.33 s a 162-node, 11-frame trajectory took to load. A file
    opened read-only by this process does not resize under that open handle (a running simulation
    appends to its ``.partial`` file, but what a reader has opened it reads as xarray does: with the
    shapes of the moment it opened it), so the size is kept on the dimension object of that handle.
    A writable handle keeps h5netcdf's own property. Written by hand: h5netcdf has no option for it."""
    cls = getattr(h5netcdf, "Dimension", None)
    original = getattr(cls, "__dict__", {}).get("size")
    if not isinstance(original, property) or getattr(original.fget, "_cortex_ti", False):
        return

    def size(self):
        if self._root._writable:
            return original.fget(self)
        try:
            return self.__dict__["_cortex_ti_size"]
        except KeyError:
            value = self.__dict__["_cortex_ti_size"] = original.fget(self)
            return value

    size._cortex_ti = True
    cls.size = property(size, doc=original.__doc__)


_read_only_dimension_sizes()


def _existing(path: str | os.PathLike) -> Path:
    p = Path(os.fspath(path))
    if p.exists():
        return p
    partial = partial_path(p)
    if partial.exists():
        return partial
    raise CortexError(f"trajectory file '{p}' not found")


def _current_names(ds):
    """``ds`` with the variables of :data:`RENAMED_VARIABLES` under their current names."""
    old = {k: v for k, v in RENAMED_VARIABLES.items() if k in ds.variables and v not in ds.variables}
    return ds.rename(old) if old else ds


def open_trajectory(path: str | os.PathLike):
    """Open a trajectory (final or ``.partial``) as an :class:`xarray.Dataset`.

    Parameters
    ----------
    path : str or path-like
        The file.  If it does not exist but ``<path>.partial`` does, that is opened.

    Returns
    -------
    xarray.Dataset
        Lazily loaded; close it (or use it as a context manager) when done.

    Raises
    ------
    CortexError
        If neither the file nor its partial file exists.
    """
    import xarray as xr  # local import: writing does not need xarray

    file = _existing(path)
    try:
        with _open_h5(file) as h5:
            remeshed = "time" in h5 and len(_segments(h5)) > 1
    except (OSError, KeyError) as exc:
        raise CortexError(f"cannot read trajectory '{file}': {exc}") from None
    if remeshed:  # several meshes: one merged dataset, in memory
        return load_trajectory(file)
    return _current_names(xr.open_dataset(file, engine="h5netcdf"))


def load_trajectory(path: str | os.PathLike):
    """Read a whole trajectory into memory and close the file; works while a run is writing it.

    A running simulation holds HDF5's file lock on its ``.partial`` file, so
    :func:`open_trajectory` cannot open it; this function opens the file without taking the
    lock (read-only).  The writer flushes after every frame, so the frames read are those
    complete at that moment: only the committed frames are read (``committed_frames``, see the
    module docstring), a frame caught half-appended is left out. (For files written before the
    commit marker: the leading frames with finite, increasing times.) It also opens a file this
    process has open already (e.g. with :func:`xarray.open_dataset`).

    Parameters
    ----------
    path : str or path-like
        A final or ``.partial`` trajectory; if ``path`` does not exist but
        ``<path>.partial`` does, that is read.

    Returns
    -------
    xarray.Dataset
        In memory; no file stays open.

    Raises
    ------
    CortexError
        Neither file exists, or the file is not a readable trajectory.
    """
    import xarray as xr  # local import: writing does not need xarray

    file = _existing(path)
    try:
        with _open_h5(file) as h5, h5netcdf.File(h5, "r") as nc:
            segments = _segments(h5) if "time" in h5 else [(h5, None)]
            parts = []
            for k, (_, n) in enumerate(segments):
                group = None if k == 0 else SEGMENT_GROUP.format(k)
                ds = xr.open_dataset(xr.backends.H5NetCDFStore(nc, group=group))
                if n is not None and ds.sizes.get("time", n) != n:
                    ds = ds.isel(time=slice(0, n))
                parts.append(ds.load())
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:
        raise CortexError(f"cannot read trajectory '{file}': {exc}") from None
    return _current_names(parts[0] if len(parts) == 1 else merge_segments(parts))


def merge_segments(parts: list):
    """One dataset of the segments of a remeshed run (module docstring): frames along ``time``, the
    ``node`` and ``face`` dimensions padded to the largest mesh (NaN; triangles -1), with
    ``mesh_id(time)``, ``n_nodes(mesh)``, ``n_faces(mesh)`` and ``triangles(mesh, face, corner)``."""
    import xarray as xr

    nodes = [p.sizes["node"] for p in parts]
    faces = [p.sizes["face"] for p in parts]
    n_max, f_max = max(nodes), max(faces)
    tri = np.full((len(parts), f_max, 3), -1, dtype=np.int32)
    frames, mesh_id = [], []
    for k, p in enumerate(parts):
        tri[k, : faces[k]] = p["triangles"].values
        per_frame = p.drop_vars(["triangles", "reference_points"], errors="ignore")
        per_frame = per_frame[[v for v in per_frame.data_vars if "time" in per_frame[v].dims]]
        frames.append(per_frame.pad(node=(0, n_max - nodes[k])) if nodes[k] < n_max else per_frame)
        mesh_id.append(np.full(p.sizes["time"], k, dtype=np.int32))
    out = xr.concat(frames, dim="time", data_vars="all", coords="minimal", join="outer", combine_attrs="override")
    constants = parts[0][[v for v in parts[0].data_vars if "time" not in parts[0][v].dims and v != "triangles"]]
    out = out.assign(
        mesh_id=("time", np.concatenate(mesh_id), {"units": "1", "long_name": "the mesh segment of each frame"}),
        n_nodes=("mesh", np.asarray(nodes, dtype=np.int32), {"units": "1", "long_name": "nodes of each mesh"}),
        n_faces=("mesh", np.asarray(faces, dtype=np.int32), {"units": "1", "long_name": "triangles of each mesh"}),
        triangles=(("mesh", "face", "corner"), tri, {**_TRIANGLE_ATTRS, "padding": -1}),
    )
    for name in constants.data_vars:  # per-node constants of the first mesh (field pattern values)
        out[name] = constants[name].rename(node="node0")
    out.attrs = dict(parts[0].attrs)
    return out


def frame_mesh(ds, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``(points (N, 3), triangles (F, 3))`` of frame ``k`` of a trajectory dataset, a remeshed run's
    (:func:`merge_segments`) or one of a fixed mesh."""
    points = np.asarray(ds["points"].isel(time=k).values, dtype=float)
    if "mesh_id" not in ds:
        return points, np.asarray(ds["triangles"].values)
    m = int(ds["mesh_id"].values[k])
    n, f = int(ds["n_nodes"].values[m]), int(ds["n_faces"].values[m])
    return points[:n], np.asarray(ds["triangles"].values[m, :f])


def _open_lazily(file: Path):
    """``(dataset of the committed frames, open files)``, read lazily, without HDF5's lock (or with it
    when this process has the file open already); errors are one :class:`CortexError`."""
    import xarray as xr

    h5 = nc = None
    try:
        h5 = _open_h5(file)
        if "time" in h5 and len(_segments(h5)) > 1:  # a remeshed run: merged in memory
            h5.close()
            h5 = None
            return load_trajectory(file), ()
        n = _committed(h5) if "time" in h5 else None
        nc = h5netcdf.File(h5, "r")
        ds = xr.open_dataset(xr.backends.H5NetCDFStore(nc))
        if n is not None and ds.sizes.get("time", n) != n:
            ds = ds.isel(time=slice(0, n))
        return ds, (nc, h5)
    except (OSError, KeyError, ValueError, TypeError, RuntimeError) as exc:
        for f in (nc, h5):
            if f is not None:
                f.close()
        raise CortexError(f"cannot read trajectory '{file}': {exc}") from None


def last_frame(path: str | os.PathLike) -> dict[str, Any]:
    """The last frame of a trajectory, for resuming a run.

    Parameters
    ----------
    path : str or path-like
        A final or ``.partial`` trajectory file; if ``path`` does not exist but
        ``<path>.partial`` does, that is read.

    Returns
    -------
    dict
        ``n_frames`` (int), ``time`` (float), ``points`` and ``velocity``
        ((n_nodes, 3) arrays), ``active_stress`` ((n_nodes,) array),
        ``pressure`` (float), ``extra`` (dict name -> value of each extra
        per-frame variable), ``path`` (the file read), ``segment`` (the mesh segment of the frame,
        0 without remeshing), ``triangles`` (its mesh) and ``reference_points`` (the segment's ALE
        reference; None in segment 0).  With no frames, ``n_frames`` is 0 and the other values are
        None (``extra`` is empty).
    """
    file = _existing(path)
    try:
        with _open_h5(file) as h5, h5netcdf.File(h5, "r") as nc:
            segments = _segments(h5)
            total = sum(n for _, n in segments)
            out: dict[str, Any] = {"path": file, "n_frames": total, "segment": len(segments) - 1}
            if total == 0:
                out.update(time=None, points=None, velocity=None, active_stress=None, pressure=None, extra={})
                out.update(triangles=None, reference_points=None)
                return out
            n = segments[-1][1]
            if len(segments) > 1:
                nc = nc.groups[SEGMENT_GROUP.format(len(segments) - 1)]
            out["triangles"] = np.asarray(nc["triangles"][...])
            out["reference_points"] = (
                np.asarray(nc["reference_points"][...]) if "reference_points" in nc.variables else None
            )
            out["time"] = float(nc["time"][n - 1])
            for name in FRAME_VARIABLES:
                out[name] = np.asarray(nc[name][n - 1, ...])
            out["pressure"] = float(out["pressure"])
            out["extra"] = {
                RENAMED_VARIABLES.get(name, name): np.asarray(var[n - 1, ...])
                for name, var in nc.variables.items()
                if name not in _RESERVED and name != "reference_points" and var.dimensions[:1] == ("time",)
            }
            return out
    except (OSError, KeyError, ValueError, RuntimeError) as exc:
        raise CortexError(f"cannot read trajectory '{file}': {exc}") from None


class Trajectory:
    """A trajectory file read back, answering for itself: its dataset, its scene and settings, the
    normals of a frame, the frame nearest a time.

    ``Trajectory(path)`` reads the whole file into memory without HDF5's lock (it works on the
    ``.partial`` of a running simulation, see :func:`load_trajectory`); ``lazy=True`` opens it
    lazily instead (:func:`open_trajectory`; use it as a context manager to close it).

    Examples
    --------
    ::

        tr = Trajectory("p8.h5")
        tr.scene.name, tr.settings.numerics.fit      # the stored scene, resolved
        k = tr.frame_at(1.5)                          # nearest frame to t = 1.5
        tr.normals(k)                                 # (N, 3) the solver's normals of that frame
    """

    def __init__(self, path: str | os.PathLike, lazy: bool = False):
        self.path = _existing(path)
        self._files = ()
        if lazy:
            self.ds, self._files = _open_lazily(self.path)
        else:
            self.ds = load_trajectory(self.path)

    def __enter__(self) -> Trajectory:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        self.ds.close()
        for f in self._files:
            f.close()
        self._files = ()

    @cached_property
    def scene(self):
        """The scene the trajectory was written for (:class:`~cortex_ti.scene.Scene`).

        A ``field`` pattern whose values the file stores (``field_values_<i>``, written by a run)
        reads them from the trajectory, not from the file the run read, so the scene answers after
        that file moved or changed."""
        from ..scene import scene_from_yaml
        from ..scene.yamltext import dump_yaml, load_yaml

        text = self.ds.attrs["scene"]
        stored = {
            int(name[len(FIELD_PREFIX) :]): name
            for name in self.ds.variables
            if name.startswith(FIELD_PREFIX) and name[len(FIELD_PREFIX) :].isdigit()
        }
        if not stored:
            return scene_from_yaml(text)
        import tempfile

        data = load_yaml(text)
        self._field_dir = tempfile.TemporaryDirectory(prefix="cortex-ti-fields-")
        for i, name in stored.items():
            file = Path(self._field_dir.name) / f"{name}.npy"
            np.save(file, np.asarray(self.ds[name].values, dtype=float))
            data["active_stress"][i] = {"type": "field", "file": str(file)}
        return scene_from_yaml(dump_yaml(data))

    @property
    def settings(self):
        """The stored scene's :class:`~cortex_ti.scene.RunSettings`."""
        return self.scene.settings

    @property
    def times(self) -> np.ndarray:
        return np.asarray(self.ds["time"].values, dtype=float)

    @property
    def triangles(self) -> np.ndarray:
        """The triangles of the first frame's mesh (of every frame's, without remeshing; see
        :meth:`mesh`)."""
        return self.mesh(0)[1] if self.remeshed else np.asarray(self.ds["triangles"].values)

    @property
    def remeshed(self) -> bool:
        """Whether the frames have more than one mesh (a run that remeshed)."""
        return "mesh_id" in self.ds

    def mesh(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """``(points (N, 3), triangles (F, 3))`` of frame ``k`` (:func:`frame_mesh`)."""
        return frame_mesh(self.ds, k)

    def nodal(self, name: str, k: int) -> np.ndarray:
        """A per-node variable of frame ``k`` on that frame's nodes (padding dropped)."""
        values = np.asarray(self.ds[name].isel(time=k).values)
        return values[: self.mesh(k)[0].shape[0]] if self.remeshed else values

    def frame_at(self, t: float) -> int:
        """Index of the frame nearest to time ``t`` (the earlier one on a tie)."""
        return int(np.argmin(np.abs(self.times - float(t))))

    def normals(self, k: int) -> np.ndarray:
        """The unit normals ``(N, 3)`` of frame ``k``: those the solver used (the ``normal``
        variable runs write); for files written before it existed, the normal of the fitted
        surface is computed again with the file's fit scheme."""
        if "normal" in self.ds:
            return np.asarray(self.nodal("normal", k), dtype=float)
        points, triangles = self.mesh(k)
        return _fitted_normals(points, triangles, self.ds.attrs.get("fit_scheme", "quadratic"))


def _fitted_normals(points: np.ndarray, triangles: np.ndarray, fit: str) -> np.ndarray:
    """Normals of the fitted surface (:mod:`cortex_ti.surface.geometry`) of a stored shape."""
    from ..surface.fits import StencilChooser
    from ..surface.geometry import compute_geometry
    from ..surface.mesh import Mesh
    from ..surface.topology import build_topology

    topo = build_topology(Mesh(points, triangles))
    return compute_geometry(points, topo, StencilChooser(topo, fit)).normal


def read_divisions(path: str | os.PathLike) -> list[dict]:
    """The divisions a trajectory records (``division.neck_radius``): for each, the segment it starts
    and the attributes of that segment's group (``division_time``, ``division_neck``,
    ``division_volume``, ``division_volumes``; :data:`cortex_ti.simulation.bodies.CUT_ATTRS`), in order."""
    import h5py

    out = []
    with h5py.File(_existing(path), "r") as h5:
        for k in range(1, len(h5) + 1):
            name = SEGMENT_GROUP.format(k)
            if name not in h5:
                continue
            attrs = h5[name].attrs
            if "division_time" in attrs:
                rec = {key: _attr(attrs[key]) for key in attrs if key.startswith("division_")}
                out.append({"segment": k, **rec})
    return out


def _attr(value):
    """An attribute as a number (one value; netCDF stores it as an array of one) or a list."""
    arr = np.asarray(value, dtype=float)
    return float(arr.reshape(-1)[0]) if arr.size == 1 else arr.tolist()
