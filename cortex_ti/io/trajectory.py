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
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import errno
import math
import os
import signal
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import h5netcdf
import h5py
import numpy as np

from ..about import package_version
from ..errors import CortexError
from .claim import check_output
from .files import PARTIAL_SUFFIX, OutputError, describe_os_error, hdf5_os_error
from .frames import COMMIT_ATTR, SEGMENT_GROUP, SEGMENTS_ATTR, _committed, _open_h5, _segments, committed_frames
from .lock import OutputClaim

__all__ = [
    "FRAME_VARIABLES",
    "TrajectoryWriter",
    "Trajectory",
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

#: The per-frame variables every trajectory has: name -> (dims, attrs).
FRAME_VARIABLES: dict[str, tuple[tuple[str, ...], dict[str, str]]] = {
    "points": (("time", "node", "xyz"), {"units": "R0", "long_name": "node positions"}),
    "velocity": (("time", "node", "xyz"), {"units": "R0/t_a", "long_name": "cortex velocity at the nodes"}),
    "active_stress": (("time", "node"), {"units": "zeta_0", "long_name": "isotropic active tension zeta at the nodes"}),
    "pressure": (
        ("time",),
        {
            "units": "zeta_0/R0",
            "long_name": "pressure difference P = p_inside - p_outside (NaN without incompressibility)",
        },
    ),
}
_TIME_ATTRS = {"units": "t_a", "long_name": "time"}
_TRIANGLE_ATTRS = {"units": "1", "long_name": "node indices (0-based) of each triangle"}
_EXTRA_DIMS = ("time", "node", "xyz")
_RESERVED = {"time", "triangles", *FRAME_VARIABLES}
_TIME_CHUNK = 1024
#: Prefix of the stored values of the scene's ``field`` patterns: ``field_values_<i>`` (node), pattern i.
FIELD_PREFIX = "field_values_"
_REFERENCE_ATTRS = {"units": "R0", "long_name": "node positions right after the remeshing (the ALE reference)"}
#: Room reserved for HDF5's metadata on top of a frame's chunks (object headers, chunk index nodes).
_METADATA_RESERVE = 1 << 16
_HELD_SIGNALS = {signal.SIGINT, signal.SIGTERM}


@contextlib.contextmanager
def _signals_held():
    """Hold SIGINT/SIGTERM back (blocked, kept pending) while a frame is written and committed;
    Python's handlers run right after."""
    import threading

    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


#: Variables renamed since older files were written: old name -> the name a reader sees
RENAMED_VARIABLES = {"lsq_residual": "force_residual"}


def _same_scene_but_time(a, b) -> bool:
    """Scenes equal up to their ``time`` section (a run may be resumed with a new t_end or dt)."""
    return scene_difference(a, b) is None


def scene_difference(stored, new) -> str | None:
    """The first key (dotted) in which two scene YAML texts differ outside their ``time`` section,
    as ``"mesh.nodes is 642 in the file, 162 now"``; None if they agree there."""
    import yaml

    try:
        da, db = yaml.safe_load(stored), yaml.safe_load(new)
    except Exception:
        return None if stored == new else "the stored scene cannot be read"
    if not isinstance(da, dict) or not isinstance(db, dict):
        return None if stored == new else "the stored scene is not a mapping"
    da.pop("time", None)
    db.pop("time", None)

    def first(a, b, key):
        if isinstance(a, dict) and isinstance(b, dict):
            for k in [*a, *(k for k in b if k not in a)]:
                found = first(a.get(k, "(not set)"), b.get(k, "(not set)"), f"{key}.{k}" if key else str(k))
                if found:
                    return found
            return None
        if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                found = first(x, y, f"{key}.{i}")
                if found:
                    return found
            return None
        if a == b:
            return None
        return f"{key} is {_short(a)} in the file, {_short(b)} now"

    return first(da, db, "")


def _short(value) -> str:
    text = value if isinstance(value, str) and value == "(not set)" else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def partial_path(path: str | os.PathLike) -> Path:
    """The in-progress file of a trajectory: ``<path>.partial``."""
    return Path(os.fspath(path) + PARTIAL_SUFFIX)


def _close_fd(fd: int) -> int:
    if fd >= 0:
        try:
            os.close(fd)
        except OSError:
            pass
    return -1


def _trim(path: Path) -> None:
    """Give back the space reserved past HDF5's end of file: opening and closing the file lets HDF5
    truncate it to its end of allocation."""
    with h5py.File(path, "r+"):
        pass


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def _attr_value(name: str, value: Any) -> Any:
    """Convert a global attribute to a type netCDF4 can store."""
    if isinstance(value, (bool, np.bool_)):
        return np.int8(value)
    if isinstance(value, (str, int, float, np.integer, np.floating)):
        return value
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = np.asarray(value)
        if arr.dtype.kind in "iuf" and arr.ndim == 1:
            return arr
    raise TypeError(
        f"global attribute {name!r}: cannot store {type(value).__name__} in netCDF "
        "(use a string, a number or a 1-d list of numbers)"
    )


def _global_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """The caller's attributes plus effects/scene derived from a Scene, version and time."""
    from ..scene import Scene

    out: dict[str, Any] = {}
    attrs = dict(attrs)
    scene = attrs.get("scene")
    if isinstance(scene, Scene):
        attrs["scene"] = scene.to_yaml()
        attrs.setdefault("effects", list(scene.data["effects"]))
    effects = attrs.get("effects")
    if effects is not None and not isinstance(effects, str):
        attrs["effects"] = ",".join(effects)
    missing = [k for k in ("effects", "scene") if k not in attrs]
    if missing:
        raise ValueError(
            f"TrajectoryWriter attrs must contain {' and '.join(missing)} "
            "(or 'scene' as a Scene, from which effects are derived)"
        )
    attrs.pop("cortex_ti_version", None)  # always this package's version
    out["effects"] = _attr_value("effects", attrs.pop("effects"))
    out["scene"] = _attr_value("scene", attrs.pop("scene"))
    out["cortex_ti_version"] = package_version()
    out["created"] = _attr_value("created", attrs.pop("created", _now()))
    for key, value in attrs.items():
        out[key] = _attr_value(key, value)
    return out


def _declared(extra_vars: Mapping, allowed=_EXTRA_DIMS) -> dict[str, tuple[tuple[str, ...], dict[str, str]]]:
    """The caller's extra per-frame variables, checked: ``name -> (dims, attrs)``."""
    out = {}
    for name, spec in extra_vars.items():
        try:
            dims, attrs = spec
        except (TypeError, ValueError):
            raise ValueError(f"extra_vars[{name!r}] must be (dims, attrs)") from None
        dims = tuple(dims)
        if name in _RESERVED:
            raise ValueError(f"extra variable {name!r} clashes with a standard variable")
        if not dims or dims[0] != "time" or any(d not in allowed for d in dims) or len(set(dims)) != len(dims):
            raise ValueError(
                f"extra variable {name!r}: dims must start with 'time' and use "
                f"{tuple(allowed)} without repeats, got {dims}"
            )
        attrs = dict(attrs)
        missing = [k for k in ("units", "long_name") if not isinstance(attrs.get(k), str)]
        if missing:
            raise ValueError(f"extra variable {name!r}: attrs must give {' and '.join(missing)}")
        out[name] = (dims, attrs)
    return out


def _node_variables(node_vars: Mapping, n_nodes: int) -> dict:
    """Per-node constants written once (e.g. a ``field`` pattern's values): ``name -> (values, attrs)``."""
    out = {}
    for name, (values, attrs) in node_vars.items():
        if name in _RESERVED:
            raise ValueError(f"node variable {name!r} clashes with a standard variable")
        out[name] = (_array(name, values, (n_nodes,)), dict(attrs))
    return out


def _triangles(triangles, n_nodes: int) -> np.ndarray:
    """The triangles as int32, checked against the node count."""
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] == 0:
        raise ValueError(f"triangles must have shape (n_faces, 3), got {tri.shape}")
    if tri.dtype.kind not in "iu":
        raise ValueError(f"triangles must be integer node indices, got dtype {tri.dtype}")
    if tri.min() < 0 or tri.max() >= n_nodes:
        raise ValueError(f"triangles index nodes outside 0..{n_nodes - 1}")
    return tri.astype(np.int32)


def _resume_problems(nc, n_nodes: int, triangles: np.ndarray, variables, scene: str) -> list[str]:
    """Why a partial file cannot be continued by this run (empty: it can)."""
    problems = []
    dims = {k: d.size for k, d in nc.dimensions.items()}
    if dims.get("node") != n_nodes:
        problems.append(f"it has {dims.get('node')} nodes, the run has {n_nodes}")
    elif "triangles" not in nc.variables or not np.array_equal(nc["triangles"][...], triangles):
        problems.append("its triangles differ from the run's mesh")
    want = set(variables) | {"time", "triangles"}
    have = set(nc.variables)
    if want != have:
        problems.append(f"its variables differ from the run's: {', '.join(sorted(want ^ have))}")
    changed = scene_difference(nc.attrs.get("scene"), scene)
    if changed:
        problems.append(f"it was written for a different scene: {changed} (only the time section may change)")
    return problems


def _layout(nc, sizes: dict, triangles: np.ndarray, variables: Mapping, attrs: Mapping) -> None:
    """Dimensions, variables (chunked one frame per chunk), triangles and attributes of a new file."""
    nc.dimensions = {
        "time": None,
        "node": sizes["node"],
        "xyz": 3,
        "face": len(triangles),
        "corner": 3,
        **{k: v for k, v in sizes.items() if k not in ("time", "node", "xyz")},
    }
    t = nc.create_variable("time", ("time",), "f8", chunks=(_TIME_CHUNK,))
    t.attrs.update(_TIME_ATTRS)
    for name, (dims, var_attrs) in variables.items():
        chunks = tuple(1 if d == "time" else sizes[d] for d in dims)
        var = nc.create_variable(name, dims, "f8", chunks=(_TIME_CHUNK,) if chunks == (1,) else chunks)
        var.attrs.update(var_attrs)
    tri = nc.create_variable("triangles", ("face", "corner"), "i4", data=triangles)
    tri.attrs.update(_TRIANGLE_ATTRS)
    nc.attrs.update(attrs)


def _array(name: str, value, shape: tuple[int, ...]) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    return arr


def _frame_values(sizes: dict, declared: Mapping, points, velocity, active_stress, pressure, extra) -> dict:
    """One frame's values by variable, each checked against its shape; the extras exactly those declared."""
    n = sizes["node"]
    values = {
        "points": _array("points", points, (n, 3)),
        "velocity": _array("velocity", velocity, (n, 3)),
        "active_stress": _array("active_stress", active_stress, (n,)),
        "pressure": _array("pressure", pressure, ()),
    }
    unknown = sorted(set(extra) - set(declared))
    missing = sorted(set(declared) - set(extra))
    if unknown or missing:
        problems = ([f"undeclared extra variables {unknown}"] if unknown else []) + (
            [f"missing extra variables {missing}"] if missing else []
        )
        raise ValueError("append(): " + "; ".join(problems))
    for name, (dims, _) in declared.items():
        values[name] = _array(name, extra[name], tuple(sizes[d] for d in dims[1:]))
    return values


class TrajectoryWriter:
    """Write a run frame by frame to ``<path>.partial``; rename to ``path`` at the end.

    Parameters
    ----------
    path : str or path-like
        Final file name (``.h5`` by convention).  Its folder is created if needed.
    triangles : (n_faces, 3) int array
        Triangles as 0-based node indices; stored once as ``triangles`` (int32).
    n_nodes : int
        Number of mesh nodes.
    attrs : dict
        Global attributes.  Must contain ``scene`` (the scene YAML text, or a
        :class:`~cortex_ti.scene.Scene`, which is stored as ``to_yaml()``) and
        ``effects`` (a comma-separated string or a list of names; derived from a
        Scene when omitted).  ``cortex_ti_version`` and ``created`` are added.
        Other values must be strings, numbers or 1-d lists of numbers (bools
        are stored as 0/1).
    extra_vars : dict, optional
        Extra per-frame float64 variables: ``name -> (dims, attrs)``, dims a
        tuple starting with ``"time"`` drawn from ``("time", "node", "xyz")`` and
        ``extra_dims`` (e.g. ``{"force_residual": (("time",), {"units": "1", "long_name": ...})}``);
        attrs must give ``units`` and ``long_name``.
    extra_dims : dict, optional
        Further fixed dimensions ``name -> size`` (e.g. the axisymmetric model's ``meridian``).
    node_vars : dict, optional
        Per-node constants written once: ``name -> (values (n_nodes,), attrs)`` (a run stores
        its ``field`` patterns' values as ``field_values_<i>``).
    resume : bool, optional
        If ``<path>.partial`` exists, reopen it and continue after its last
        frame instead of starting over.  Its triangles, node count, variables
        and scene (up to its ``time`` section) must match; its ``created`` attribute is kept and the time of
        resumption is appended to the ``resumed`` attribute.  Without a partial
        file a new one is started.
    force : bool, optional
        Replace what is at ``path`` (and start over instead of resuming ``<path>.partial``).
        Without ``resume`` or ``force``, an existing ``path`` or a partial file with frames is
        refused, as the command line refuses it (:func:`cortex_ti.io.claim.check_output`).

    Notes
    -----
    * The path is claimed first (:class:`~cortex_ti.io.lock.OutputClaim`): a
      writer of the same path in another process is refused before anything is
      truncated.
    * Each :meth:`append` reserves the frame's space, writes the frame, flushes it
      and then commits it (``committed_frames``, flushed again), so a killed
      process leaves a readable partial file of its complete frames, and a full
      disk raises :class:`~cortex_ti.io.files.OutputError` with the file as it was.
      (An I/O error *inside* HDF5's flush can still damage the file: HDF5 is not
      journaled; the reservation keeps a full disk from getting there.)
    * The final path never exists half-written: :meth:`finish` closes the file,
      fsyncs it and renames it with :func:`os.replace`.
    * As a context manager, leaving the block normally calls :meth:`finish`
      and leaving it with an exception calls :meth:`abort` (no file is left).
      A process that dies without either keeps its ``.partial`` file for resume.

    Examples
    --------
    ::

        with TrajectoryWriter("run.h5", triangles, len(x), {"scene": scene}) as w:
            w.append(0.0, x, v, zeta, p)       # one frame, flushed to run.h5.partial
        # leaving the block renamed run.h5.partial -> run.h5
    """

    def __init__(
        self,
        path: str | os.PathLike,
        triangles: np.ndarray,
        n_nodes: int,
        attrs: Mapping[str, Any],
        extra_vars: Mapping[str, tuple[tuple[str, ...], Mapping[str, str]]] | None = None,
        resume: bool = False,
        extra_dims: Mapping[str, int] | None = None,
        node_vars: Mapping[str, tuple[np.ndarray, Mapping[str, str]]] | None = None,
        force: bool = False,
    ) -> None:
        self.path = Path(os.fspath(path))
        self.partial = partial_path(self.path)
        n_nodes = int(n_nodes)
        if n_nodes <= 0:
            raise ValueError(f"n_nodes must be positive, got {n_nodes}")
        self.n_nodes = n_nodes
        self.triangles = _triangles(triangles, n_nodes)
        extra_dims = dict(extra_dims or {})
        if set(extra_dims) & {"time", "node", "xyz", "face", "corner"}:
            raise ValueError(f"extra_dims {sorted(extra_dims)} clash with the standard dimensions")
        self._sizes = {"time": 1, "node": n_nodes, "xyz": 3, **{k: int(v) for k, v in extra_dims.items()}}
        self._extra = _declared(extra_vars or {}, tuple(self._sizes))
        self._node_vars = _node_variables(node_vars or {}, n_nodes)
        self._attrs = _global_attrs(attrs)
        self._h5: h5py.File | None = None
        self._nc: h5netcdf.File | None = None
        self._h5data: dict | None = None
        self._n = 0  # frames over all segments
        self._k = 0  # frames of the current segment
        self._segment = 0  # the current segment (0: the root)
        self._pending = None  # (triangles, n_nodes, reference) of a segment to start at the next append
        self._last_t = -math.inf
        self._state = "open"
        self._fd = -1  # a descriptor of the partial file, to reserve space with
        self._reserve = 0
        self._held: list[tuple[float, dict]] = []  # frames appended with hold=True, not yet written
        self._claim = OutputClaim.acquire(self.path)  # before the partial file is truncated or opened
        try:
            check_output(self.path, resume, force)  # the rule of every door (the command line's)
            if resume and self.partial.exists():
                self._reopen()
            else:
                self._create()
        except BaseException:
            self._release()
            raise

    # ----------------------------------------------------------------------------- setup
    def _variables(self) -> dict[str, tuple[tuple[str, ...], dict[str, str]]]:
        return {**FRAME_VARIABLES, **self._extra}

    def _create(self) -> None:
        try:
            self._h5 = h5py.File(self.partial, "w", track_order=True)
            self._nc = h5netcdf.File(self._h5, "w")
            _layout(self._nc, self._sizes, self.triangles, self._variables(), self._attrs)
            for name, (values, var_attrs) in self._node_vars.items():
                var = self._nc.create_variable(name, ("node",), "f8", data=values)
                var.attrs.update(var_attrs)
            self._h5.attrs[COMMIT_ATTR] = np.int64(0)
            self._flush()
            self._open_fd()
        except BaseException as exc:
            try:
                self._close()
            except Exception:  # HDF5 failing to close a file it failed to write (a full disk): it goes anyway
                pass
            self.partial.unlink(missing_ok=True)
            if isinstance(exc, OSError):
                raise OutputError(
                    f"cannot create '{self.partial}': {describe_os_error(exc) if exc.errno else exc}"
                ) from None
            failed = hdf5_os_error(exc)
            if failed is not None:
                raise OutputError(f"cannot create '{self.partial}': {failed}") from None
            raise

    def _open_fd(self) -> None:
        self._fd = os.open(self.partial, os.O_RDWR | os.O_CLOEXEC)
        self._size_reserve()

    def _size_reserve(self) -> None:
        data = self._datasets()
        self._reserve = sum(  # one frame's chunks
            int(np.prod(d.chunks)) * d.dtype.itemsize for d in data.values() if d.chunks is not None
        )

    @property
    def _where(self) -> str:
        """The HDF5 path prefix of the current segment's variables."""
        return "" if self._segment == 0 else SEGMENT_GROUP.format(self._segment) + "/"

    def _segment_node(self):
        """The HDF5 object (root or group) of the current segment."""
        return self._h5 if self._segment == 0 else self._h5[SEGMENT_GROUP.format(self._segment)]

    def _segment_nc(self):
        return self._nc if self._segment == 0 else self._nc.groups[SEGMENT_GROUP.format(self._segment)]

    def start_segment(self, triangles: np.ndarray, n_nodes: int, reference: np.ndarray | None = None) -> None:
        """The mesh changed (a remeshing): the next frame starts segment ``mesh_<k>`` with these
        triangles and node count (``reference``: the ALE reference nodes, default the next frame's
        points). The segment becomes visible to readers with its first committed frame. Frames
        held for the old mesh are committed first."""
        self.commit()
        n_nodes = int(n_nodes)
        ref = None if reference is None else _array("reference_points", reference, (n_nodes, 3))
        self._pending = (_triangles(triangles, n_nodes), n_nodes, ref)

    def _open_segment(self, points) -> None:
        """Create the pending segment's group (layout of :func:`_layout`) and write to it from now on."""
        triangles, n_nodes, ref = self._pending
        k = self._segment + 1
        name = SEGMENT_GROUP.format(k)
        if name in self._h5:  # left over from a segment whose first frame was never committed
            del self._h5[name]
        group = self._nc.create_group(name)
        sizes = {**self._sizes, "node": n_nodes}
        _layout(group, sizes, triangles, self._variables(), {})
        var = group.create_variable("reference_points", ("node", "xyz"), "f8", data=points if ref is None else ref)
        var.attrs.update(_REFERENCE_ATTRS)
        self._h5[name].attrs[COMMIT_ATTR] = np.int64(0)
        self._segment, self._k, self._sizes, self._h5data = k, 0, sizes, None
        self.n_nodes, self.triangles, self._pending = n_nodes, triangles, None
        self._size_reserve()

    def _reopen(self) -> None:
        where = f"cannot resume '{self.partial}'"
        try:
            self._h5 = h5py.File(self.partial, "r+")
            self._nc = h5netcdf.File(self._h5, "a")
        except (OSError, ValueError, KeyError, RuntimeError) as exc:
            self._close()
            raise CortexError(
                f"{where}: it is not a readable trajectory ({exc}); pass --force (or delete it) to start over"
            ) from None
        nc = self._nc
        try:
            problems = _resume_problems(
                nc, self.n_nodes, self.triangles, {**self._variables(), **self._node_vars}, self._attrs["scene"]
            )
            if problems:
                raise CortexError(
                    f"{where}: {'; '.join(problems)}; pass --force (or delete it) to start over, or "
                    "choose another output"
                )
            segments = _segments(self._h5)
            for name in [g for g in self._h5 if g.startswith("mesh_") and g[5:].isdigit()]:
                if int(name[5:]) >= len(segments):  # a segment whose first frame was never committed
                    del self._h5[name]
            self._segment = len(segments) - 1
            self._n = sum(n for _, n in segments)
            self._k = segments[-1][1]
            seg_nc = self._segment_nc()
            if self._segment:
                self.n_nodes = int(seg_nc.dimensions["node"].size)
                self.triangles = np.asarray(seg_nc["triangles"][...], dtype=np.int32)
                self._sizes = {**self._sizes, "node": self.n_nodes}
            if int(seg_nc.dimensions["time"].size) != self._k:  # drop a frame written but not committed
                seg_nc.resize_dimension("time", self._k)
            self._segment_node().attrs[COMMIT_ATTR] = np.int64(self._k)
            if self._k:
                self._last_t = float(seg_nc["time"][self._k - 1])
            resumed = nc.attrs.get("resumed", "")
            nc.attrs.update({k: v for k, v in self._attrs.items() if k != "created"})
            nc.attrs["resumed"] = f"{resumed},{_now()}" if resumed else _now()
            self._flush()
            self._open_fd()
        except BaseException as exc:
            self._close()
            if isinstance(exc, OSError):
                raise OutputError(
                    f"{where}: {describe_os_error(exc) if exc.errno else exc}; its frames are unchanged"
                ) from None
            raise

    # ----------------------------------------------------------------------------- writing
    @property
    def n_frames(self) -> int:
        """Number of frames in the file (including those of a resumed partial file)."""
        return self._n

    @property
    def last_time(self) -> float | None:
        """Time of the last complete frame (None before the first)."""
        return self._last_t if self._n else None

    def _datasets(self) -> dict:
        """The HDF5 datasets of the per-frame variables (written directly: h5netcdf's item
        assignment looks up the variable's metadata on every call, 25 ms a frame)."""
        if self._h5data is None:
            self._h5data = {name: self._h5[self._where + name] for name in ["time", *self._variables()]}
        return self._h5data

    def _flush(self) -> None:
        self._nc.flush()  # h5netcdf bookkeeping (_NCProperties); does not flush HDF5
        self._h5.flush()  # push data and metadata to disk

    def append(self, t: float, points, velocity, active_stress, pressure: float, hold: bool = False, **extra) -> None:
        """Write one frame and flush it to disk (or, with ``hold``, keep it for :meth:`commit`).

        Parameters
        ----------
        t : float
            Time of the frame (t_a); finite and larger than the previous frame's.
        points, velocity : (n_nodes, 3) arrays
            Node positions and velocities.
        active_stress : (n_nodes,) array
            Active tension zeta at the nodes.
        pressure : float
            P = p_inside - p_outside (NaN when not computed).
        hold : bool, optional
            Check the frame and keep it in memory; :meth:`commit` writes the frames held so far
            in one write per variable and one commit (a run holds the frames one time step
            interpolates and commits them after the step: 2-3 frames a step at the paper's
            output interval, written for the price of one). :meth:`start_segment`,
            :meth:`finish` and :meth:`close_partial` commit them first.
        **extra
            One value per extra variable declared in ``extra_vars`` (all of
            them, no others), shaped like its non-time dims.
        """
        if self._state != "open":
            raise RuntimeError(f"trajectory writer for '{self.path}' is already {self._state}")
        t = float(t)
        last = self._held[-1][0] if self._held else self._last_t
        if not math.isfinite(t) or t <= last:
            raise ValueError(f"frame time must be finite and increase: got t = {t} after t = {last}")
        sizes = self._sizes if self._pending is None else {**self._sizes, "node": self._pending[1]}
        self._held.append((t, _frame_values(sizes, self._extra, points, velocity, active_stress, pressure, extra)))
        if not hold:
            self.commit()

    def commit(self) -> None:
        """Write the held frames (:meth:`append` with ``hold``), flush them and then commit them
        (``committed_frames``, flushed again): one write per variable for all of them."""
        if not self._held:
            return
        held, self._held = self._held, []
        times = np.array([t for t, _ in held])
        m = len(held)
        with _signals_held():
            try:
                new_segment = self._pending is not None
                if new_segment:
                    self._open_segment(held[0][1]["points"])
                k = self._k
                self._make_room(m)
                data = self._datasets()
                for dataset in data.values():  # the time dimension's scale and every variable along it
                    dataset.resize(k + m, axis=0)  # (h5netcdf's resize_dimension: 7 ms a frame)
                for name in held[0][1]:
                    data[name][k : k + m, ...] = np.stack([values[name] for _, values in held])
                data["time"][k : k + m] = times
                self._flush()
                self._segment_node().attrs.modify(COMMIT_ATTR, np.int64(k + m))  # last: the frames are complete
                if new_segment:
                    self._h5.attrs[SEGMENTS_ATTR] = np.int64(self._segment + 1)
                self._flush()
            except OSError as exc:
                self._state = "failed"
                what = f"writing frame {self._n}" + (f"-{self._n + m - 1}" if m > 1 else "")
                raise self._write_error(f"{what} (t = {times[0]:.6g})", exc) from None
            self._k = k + m
            self._n += m
            self._last_t = float(times[-1])

    def _make_room(self, frames: int = 1) -> None:
        """Reserve the file space the next ``frames`` frames can take (see the module docstring), so
        that a full disk is met here, with the file untouched, and not inside HDF5."""
        if self._fd < 0:
            return
        end = int(self._h5.id.get_filesize()) + _METADATA_RESERVE + frames * self._reserve
        try:
            os.posix_fallocate(self._fd, 0, end)
        except OSError as exc:
            if exc.errno in (errno.EOPNOTSUPP, errno.EINVAL, errno.ENOSYS):
                self._fd = _close_fd(self._fd)  # cannot reserve here: rely on the commit marker
                return
            raise

    def _write_error(self, what: str, exc: OSError) -> OutputError:
        if self._n:
            kept = (
                f"the {self._n} frame{'s' if self._n > 1 else ''} to t = {self._last_t:.6g} before it "
                f"{'are' if self._n > 1 else 'is'} kept there"
            )
            hint = "; make room and continue with --resume"
        else:
            kept, hint = "no frame was complete", ""
        why = describe_os_error(exc) if exc.errno else str(exc)
        return OutputError(f"{what} to '{self.partial}' failed ({why}); {kept}{hint}")

    # ----------------------------------------------------------------------------- closing
    def _close(self) -> None:
        nc, h5 = self._nc, self._h5
        self._nc = self._h5 = self._h5data = None
        self._fd = _close_fd(self._fd)
        try:
            if nc is not None:
                nc.close()
        finally:
            if h5 is not None:
                h5.close()

    def _release(self) -> None:
        claim, self._claim = getattr(self, "_claim", None), None
        if claim is not None:
            claim.release()

    def finish(self) -> Path:
        """Close the file and atomically rename ``<path>.partial`` to ``path``.

        Returns
        -------
        Path
            The final path.  Calling it again returns the path without doing anything.
        """
        if self._state == "finished":
            return self.path
        if self._state != "open":
            raise RuntimeError(f"trajectory writer for '{self.path}' is already {self._state}")
        self.commit()
        try:
            with _signals_held():
                reserved = self._fd >= 0
                self._close()
                if reserved:
                    _trim(self.partial)
                with open(self.partial, "rb") as fh:
                    os.fsync(fh.fileno())
                os.replace(self.partial, self.path)
        except OSError as exc:
            self._state = "failed"
            self._release()
            raise self._write_error("closing the file", exc) from None
        self._state = "finished"
        self._release()
        return self.path

    def abort(self) -> None:
        """Close and delete the ``.partial`` file, so a failed run leaves no file.

        Does nothing after :meth:`finish` (the finished file is kept) or a
        previous :meth:`abort`.
        """
        if self._state not in ("open", "failed"):
            return
        self._state = "aborted"
        try:
            self._close()
        finally:
            try:
                self.partial.unlink(missing_ok=True)
            finally:
                self._release()

    def close_partial(self) -> Path | None:
        """Close but keep ``<path>.partial`` for :option:`--resume` (interrupted or failed
        dynamic runs); a partial file without any frame is deleted instead."""
        if self._state not in ("open", "failed"):
            return None
        if self._state == "open":
            with contextlib.suppress(OutputError):  # held frames that cannot be written are lost, not the rest
                self.commit()
        if self._n == 0:
            self.abort()
            return None
        self._state = "kept"
        try:
            self._close()
        except OSError:
            pass  # the committed frames are on disk already; a failed close cannot take them back
        finally:
            self._release()
        return self.partial

    def __enter__(self) -> TrajectoryWriter:
        return self

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is None:
            self.finish()
        else:
            self.abort()
        return False

    def __repr__(self) -> str:
        return f"<TrajectoryWriter '{self.partial}' {self._n} frames, {self._state}>"


# --------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------


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
