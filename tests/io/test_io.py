"""Trajectory files: layout, values, crash safety, resume, atomic finish."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import cortex_ti
from cortex_ti.errors import CortexError
from cortex_ti.io import TrajectoryWriter, last_frame, open_trajectory, partial_path
from cortex_ti.scene import load_scene

REPO = Path(__file__).resolve().parents[2]

# A tetrahedron: 4 nodes, 4 faces.
TRI = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
N = 4
EXTRA = {
    "force_residual": (("time",), {"units": "1", "long_name": "least-squares fit residual"}),
    "constraint_violation": (("time",), {"units": "R0^3", "long_name": "volume constraint violation"}),
    "normal_speed": (("time", "node"), {"units": "R0/t_a", "long_name": "normal velocity"}),
}


def frame(k: int) -> dict:
    """Deterministic, distinct values of frame k (also used by the subprocess)."""
    base = np.arange(N * 3, dtype=float).reshape(N, 3)
    return dict(
        t=0.25 * k,
        points=base + 100.0 * k,
        velocity=-base / (k + 1.0),
        active_stress=np.arange(N, dtype=float) * k + 0.5,
        pressure=1.5 * k - 0.125,
        force_residual=10.0 ** (-k),
        constraint_violation=-1e-3 * k,
        normal_speed=np.full(N, 7.0 * k),
    )


def attrs() -> dict:
    return {"scene": load_scene("sphere_y20_full"), "run_id": "abc", "seed": 7}


def write(writer: TrajectoryWriter, k: int) -> None:
    f = frame(k)
    writer.append(f.pop("t"), f.pop("points"), f.pop("velocity"), f.pop("active_stress"), f.pop("pressure"), **f)


def check_frames(ds: xr.Dataset, n: int) -> None:
    assert ds.sizes == {"time": n, "node": N, "xyz": 3, "face": 4, "corner": 3}
    for k in range(n):
        f = frame(k)
        assert ds["time"].values[k] == f["t"]
        np.testing.assert_array_equal(ds["points"].values[k], f["points"])
        np.testing.assert_array_equal(ds["velocity"].values[k], f["velocity"])
        np.testing.assert_array_equal(ds["active_stress"].values[k], f["active_stress"])
        assert ds["pressure"].values[k] == f["pressure"]
        assert ds["force_residual"].values[k] == f["force_residual"]
        assert ds["constraint_violation"].values[k] == f["constraint_violation"]
        np.testing.assert_array_equal(ds["normal_speed"].values[k], f["normal_speed"])
    np.testing.assert_array_equal(ds["triangles"].values, TRI)


def test_three_frames_layout_values_attrs(tmp_path):
    path = tmp_path / "run.h5"
    scene = load_scene("sphere_y20_full")
    w = TrajectoryWriter(path, TRI, N, attrs(), EXTRA)
    assert w.partial == tmp_path / "run.h5.partial"
    for k in range(3):
        write(w, k)
        assert w.n_frames == k + 1
    assert not path.exists() and w.partial.exists()
    assert w.finish() == path
    assert path.exists() and not partial_path(path).exists()

    with xr.open_dataset(path, engine="h5netcdf") as ds:
        check_frames(ds, 3)
        assert list(ds.coords) == ["time"]
        dims = {name: ds[name].dims for name in ds.variables}
        assert dims == {
            "time": ("time",),
            "points": ("time", "node", "xyz"),
            "velocity": ("time", "node", "xyz"),
            "active_stress": ("time", "node"),
            "pressure": ("time",),
            "force_residual": ("time",),
            "constraint_violation": ("time",),
            "normal_speed": ("time", "node"),
            "triangles": ("face", "corner"),
        }
        assert ds["triangles"].dtype == np.int32
        assert ds["points"].dtype == np.float64
        for name in ds.variables:
            assert isinstance(ds[name].attrs["units"], str), name
            assert isinstance(ds[name].attrs["long_name"], str), name
        assert ds["time"].attrs["units"] == "t_a"
        assert ds["points"].attrs["units"] == "R0"
        assert ds["velocity"].attrs["units"] == "R0/t_a"
        assert ds["constraint_violation"].attrs == {"units": "R0^3", "long_name": "volume constraint violation"}
        assert ds.attrs["effects"] == ("active_stress,shear_viscosity,bulk_viscosity,normal_balance,incompressibility")
        assert ds.attrs["scene"] == scene.to_yaml()
        assert ds.attrs["cortex_ti_version"] == cortex_ti.__version__
        assert ds.attrs["created"][:2] == "20" and "T" in ds.attrs["created"]
        assert ds.attrs["run_id"] == "abc" and ds.attrs["seed"] == 7
        assert ds.sizes["time"] == 3
    # the file is unlimited along time (netCDF4 layout)
    import h5py

    with h5py.File(path, "r") as h5:
        assert h5["time"].maxshape == (None,)
        assert h5["points"].maxshape == (None, N, 3)
        assert "_NCProperties" in h5.attrs

    # the stored scene loads back to an equal scene
    import yaml

    from cortex_ti.scene import scene_from_dict

    with open_trajectory(path) as ds:
        assert scene_from_dict(yaml.safe_load(ds.attrs["scene"])) == scene

    last = last_frame(path)
    f = frame(2)
    assert last["n_frames"] == 3 and last["time"] == 0.5 and last["pressure"] == f["pressure"]
    np.testing.assert_array_equal(last["points"], f["points"])
    np.testing.assert_array_equal(last["velocity"], f["velocity"])
    np.testing.assert_array_equal(last["active_stress"], f["active_stress"])
    assert last["extra"]["force_residual"] == f["force_residual"]
    np.testing.assert_array_equal(last["extra"]["normal_speed"], f["normal_speed"])


CHILD = textwrap.dedent("""
    import os, sys
    sys.path.insert(0, {tests!r})
    from test_io import TRI, N, EXTRA, attrs, write
    from cortex_ti.io import TrajectoryWriter
    w = TrajectoryWriter({path!r}, TRI, N, attrs(), EXTRA)
    write(w, 0)
    write(w, 1)
    os._exit(1)   # killed mid-run: no finish(), no close, no cleanup
""")


def test_files_written_before_a_rename_read_under_the_new_name(tmp_path):
    """A trajectory written with the solve diagnostic's old name ``lsq_residual`` reads back
    (whole, lazily, last frame) as ``force_residual``, its values unchanged."""
    from cortex_ti.io import Trajectory

    path = tmp_path / "old.h5"
    old = {"lsq_residual" if k == "force_residual" else k: v for k, v in EXTRA.items()}
    with TrajectoryWriter(path, TRI, N, attrs(), old) as w:
        for k in range(2):
            f = frame(k)
            f["lsq_residual"] = f.pop("force_residual")
            w.append(f.pop("t"), f.pop("points"), f.pop("velocity"), f.pop("active_stress"), f.pop("pressure"), **f)
    want = [frame(k)["force_residual"] for k in range(2)]
    with Trajectory(path) as tr:
        assert "lsq_residual" not in tr.ds and list(tr.ds["force_residual"].values) == want
    with open_trajectory(path) as ds:
        assert list(ds["force_residual"].values) == want
    assert last_frame(path)["extra"]["force_residual"] == want[-1]


def test_killed_writer_leaves_readable_partial_and_resumes(tmp_path):
    path = tmp_path / "run.h5"
    code = CHILD.format(tests=str(Path(__file__).parent), path=str(path))
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert not path.exists()
    partial = partial_path(path)
    assert partial.exists()

    with xr.open_dataset(partial, engine="h5netcdf") as ds:
        check_frames(ds, 2)
    last = last_frame(path)  # falls back to the .partial file
    assert last["path"] == partial and last["n_frames"] == 2 and last["time"] == 0.25
    np.testing.assert_array_equal(last["points"], frame(1)["points"])

    w = TrajectoryWriter(path, TRI, N, attrs(), EXTRA, resume=True)
    assert w.n_frames == 2
    with pytest.raises(ValueError, match="increase"):
        write(w, 1)  # t = 0.25 again
    write(w, 2)
    assert w.n_frames == 3
    w.finish()
    assert not partial.exists()
    with open_trajectory(path) as ds:
        check_frames(ds, 3)
        assert "resumed" in ds.attrs


def test_held_frames_are_written_at_commit_and_kept_when_the_run_stops(tmp_path):
    """Frames appended with ``hold`` are invisible until ``commit`` (one write for all of them),
    and a run that stops (``close_partial``) or finishes with frames still held keeps them."""
    path = tmp_path / "run.h5"
    w = TrajectoryWriter(path, TRI, N, attrs(), EXTRA)
    for k in range(3):
        f = frame(k)
        w.append(
            f.pop("t"), f.pop("points"), f.pop("velocity"), f.pop("active_stress"), f.pop("pressure"), hold=True, **f
        )
    assert w.n_frames == 0 and last_frame(path)["n_frames"] == 0  # nothing committed yet
    with pytest.raises(ValueError, match="increase"):
        write(w, 2)  # the held frames count for the time order
    w.commit()
    assert w.n_frames == 3 and w.last_time == 0.5
    f = frame(3)
    w.append(f.pop("t"), f.pop("points"), f.pop("velocity"), f.pop("active_stress"), f.pop("pressure"), hold=True, **f)
    assert w.close_partial() == partial_path(path)
    with xr.open_dataset(partial_path(path), engine="h5netcdf") as ds:
        check_frames(ds, 4)


def test_resume_rejects_a_different_mesh_or_scene(tmp_path):
    path = tmp_path / "run.h5"
    w = TrajectoryWriter(path, TRI, N, attrs(), EXTRA)
    write(w, 0)
    w._close()  # simulate a dead process: the partial file stays
    with pytest.raises(CortexError, match="triangles differ"):
        TrajectoryWriter(path, TRI[:, ::-1], N, attrs(), EXTRA, resume=True)
    with pytest.raises(CortexError, match="different scene"):
        TrajectoryWriter(path, TRI, N, {"scene": load_scene("sphere_y21_full")}, EXTRA, resume=True)
    with pytest.raises(CortexError, match="variables differ"):
        TrajectoryWriter(path, TRI, N, attrs(), {}, resume=True)
    assert last_frame(partial_path(path))["n_frames"] == 1
    # without resume the partial file's frames are not thrown away (as on the command line);
    # with force a new file replaces it
    with pytest.raises(CortexError, match="holds 1 frames .* of an interrupted run"):
        TrajectoryWriter(path, TRI, N, attrs(), EXTRA)
    assert last_frame(partial_path(path))["n_frames"] == 1
    w = TrajectoryWriter(path, TRI, N, attrs(), EXTRA, force=True)
    assert w.n_frames == 0
    w.abort()


def test_abort_leaves_no_file(tmp_path):
    path = tmp_path / "run.h5"
    w = TrajectoryWriter(path, TRI, N, attrs(), EXTRA)
    write(w, 0)
    w.abort()
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(RuntimeError, match="aborted"):
        write(w, 1)
    w.abort()  # idempotent


def test_exception_in_context_manager_leaves_no_file(tmp_path):
    path = tmp_path / "run.h5"
    with pytest.raises(ZeroDivisionError):
        with TrajectoryWriter(path, TRI, N, attrs(), EXTRA) as w:
            write(w, 0)
            write(w, 1)
            raise ZeroDivisionError("a step that fails")
    assert list(tmp_path.iterdir()) == []


def test_context_manager_finishes(tmp_path):
    path = tmp_path / "out" / "run.h5"
    with TrajectoryWriter(path, TRI, N, attrs(), EXTRA) as w:
        write(w, 0)
    assert sorted(p.name for p in path.parent.iterdir()) == ["run.h5"]
    with open_trajectory(path) as ds:
        check_frames(ds, 1)
    w.abort()  # after finish: keeps the finished file
    assert path.exists()


def test_append_checks_its_input(tmp_path):
    w = TrajectoryWriter(tmp_path / "run.h5", TRI, N, attrs(), EXTRA)
    f = frame(0)
    args = (f["t"], f["points"], f["velocity"], f["active_stress"], f["pressure"])
    extra = {k: f[k] for k in EXTRA}
    with pytest.raises(ValueError, match=r"points must have shape \(4, 3\), got \(3, 3\)"):
        w.append(0.0, f["points"][:3], *args[2:], **extra)
    with pytest.raises(ValueError, match="missing extra variables"):
        w.append(*args, force_residual=1.0)
    with pytest.raises(ValueError, match="undeclared extra variables"):
        w.append(*args, **extra, pole_radius=1.0)
    with pytest.raises(ValueError, match=r"normal_speed must have shape \(4,\)"):
        w.append(*args, **{**extra, "normal_speed": np.zeros(5)})
    assert w.n_frames == 0  # nothing half-written
    w.append(*args, **extra)
    with pytest.raises(ValueError, match="increase"):
        w.append(*args, **extra)
    w.abort()


def test_constructor_checks(tmp_path):
    p = tmp_path / "run.h5"
    with pytest.raises(ValueError, match="outside"):
        TrajectoryWriter(p, TRI + 1, N, attrs())
    with pytest.raises(ValueError, match="long_name"):
        TrajectoryWriter(p, TRI, N, attrs(), {"x": (("time",), {"units": "1"})})
    with pytest.raises(ValueError, match="start with 'time'"):
        TrajectoryWriter(p, TRI, N, attrs(), {"x": (("node",), {"units": "1", "long_name": "x"})})
    with pytest.raises(ValueError, match="scene"):
        TrajectoryWriter(p, TRI, N, {"effects": "a,b"})
    assert list(tmp_path.iterdir()) == []


def test_missing_trajectory(tmp_path):
    with pytest.raises(CortexError, match="not found"):
        open_trajectory(tmp_path / "none.h5")
    with pytest.raises(CortexError, match="not found"):
        last_frame(tmp_path / "none.h5")


def test_a_trajectory_rewritten_by_xarray_reads_back(tmp_path):
    """xarray writes the global attributes, committed_frames among them, as one-element arrays; a
    trajectory cut and written again by xarray (as users and the viewer's test do) still reads, with
    its own number of frames (the stale count is clamped to the frames present)."""
    from cortex_ti.io import load_trajectory
    from cortex_ti.io.files import write_dataset

    tri = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    pts = np.array([[0.0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, -1, -1]])
    with TrajectoryWriter(tmp_path / "a.h5", tri, 4, {"scene": "name: x\n", "effects": "a"}) as w:
        for k in range(5):
            w.append(0.1 * k, pts, np.zeros((4, 3)), np.ones(4), 0.0)
    ds = load_trajectory(tmp_path / "a.h5")
    write_dataset(ds.isel(time=slice(0, 3)), tmp_path / "b.h5")
    again = load_trajectory(tmp_path / "b.h5")
    assert again.sizes["time"] == 3 and list(again.time.values) == [0.0, 0.1, 0.2]


def test_a_partial_file_read_while_it_grows_shows_each_opens_frames(tmp_path):
    """The readers keep an unlimited dimension's size per read-only open (``readers._read_only_dimension_sizes``):
    a reader that opens the growing ``.partial`` file again sees the new frames, the writer's own
    writable handle keeps counting, and every value is the one written."""
    path = tmp_path / "run.h5"
    w = TrajectoryWriter(path, TRI, N, attrs(), EXTRA)
    for k in range(2):
        write(w, k)
    check_frames(cortex_ti.io.load_trajectory(partial_path(path)), 2)
    write(w, 2)
    assert w.n_frames == 3
    check_frames(cortex_ti.io.load_trajectory(partial_path(path)), 3)
    w.finish()
    check_frames(cortex_ti.io.load_trajectory(path), 3)
