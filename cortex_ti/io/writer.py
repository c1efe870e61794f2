"""Writing a trajectory (:mod:`cortex_ti.io.trajectory` describes the file and its crash safety):
:class:`TrajectoryWriter` claims the output, writes frame by frame to ``<path>.partial`` (each
frame's space reserved, signals held back while it is written and committed), resumes a partial
file of the same run, and renames it to ``<path>`` at the end.
"""

from __future__ import annotations

import contextlib
import errno
import math
import os
import signal
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import h5netcdf
import h5py
import numpy as np

from ..errors import CortexError
from .claim import check_output
from .files import OutputError, describe_os_error, hdf5_os_error
from .frames import COMMIT_ATTR, SEGMENT_GROUP, SEGMENTS_ATTR, _segments
from .layout import (
    _REFERENCE_ATTRS,
    FRAME_VARIABLES,
    _array,
    _declared,
    _frame_values,
    _global_attrs,
    _layout,
    _node_variables,
    _now,
    _triangles,
    partial_path,
    scene_difference,
)
from .lock import OutputClaim

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

    def start_segment(
        self, triangles: np.ndarray, n_nodes: int, reference: np.ndarray | None = None, attrs: Mapping | None = None
    ) -> None:
        """The mesh changed (a remeshing): the next frame starts segment ``mesh_<k>`` with these
        triangles and node count (``reference``: the ALE reference nodes, default the next frame's
        points; ``attrs``: attributes of the segment's group, e.g. a division's record, kept when the
        mesh changes again before the next frame). The segment becomes visible to readers with its
        first committed frame. Frames held for the old mesh are
        committed first."""
        self.commit()
        n_nodes = int(n_nodes)
        ref = None if reference is None else _array("reference_points", reference, (n_nodes, 3))
        earlier = {} if self._pending is None else self._pending[3]  # a segment replaced before its first frame
        self._pending = (_triangles(triangles, n_nodes), n_nodes, ref, {**earlier, **dict(attrs or {})})

    def _open_segment(self, points) -> None:
        """Create the pending segment's group (layout of :func:`_layout`) and write to it from now on."""
        triangles, n_nodes, ref, attrs = self._pending
        k = self._segment + 1
        name = SEGMENT_GROUP.format(k)
        if name in self._h5:  # left over from a segment whose first frame was never committed
            del self._h5[name]
        group = self._nc.create_group(name)
        sizes = {**self._sizes, "node": n_nodes}
        _layout(group, sizes, triangles, self._variables(), attrs)
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
