"""Trajectories whose mesh changes (cortex_ti.io.trajectory, segments ``mesh_<k>``): written frame by
frame across a change of mesh, read back exactly through Trajectory, open_trajectory (xarray),
last_frame and committed_frames; a partial file resumed inside a later segment; a segment whose
first frame was never committed is invisible and dropped on resume; a file without a change of
mesh keeps the single-mesh layout (no group, no segment attribute)."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from cortex_ti.io.trajectory import (
    SEGMENTS_ATTR,
    ResumeState,
    Trajectory,
    TrajectoryWriter,
    committed_frames,
    last_frame,
    load_trajectory,
    open_trajectory,
    partial_path,
)
from cortex_ti.surface.mesh import icosphere

SCENE = "name: t\nmesh: {nodes: 42}\n"
EXTRA = {
    "normal": (("time", "node", "xyz"), {"units": "1", "long_name": "normal"}),
    "dt": (("time",), {"units": "t_a", "long_name": "step"}),
    "c": (("time", "node"), {"units": "1", "long_name": "c"}),
}
MESHES = [icosphere(42), icosphere(162), icosphere(12)]


def _frame(mesh, k):
    n = mesh.n_nodes
    rng = np.random.default_rng(k)
    return {
        "points": mesh.points * (1 + 0.01 * k),
        "velocity": rng.standard_normal((n, 3)),
        "active_stress": rng.standard_normal(n),
        "pressure": float(k),
        "dt": 0.1 * k,
        "c": rng.standard_normal(n),
        "normal": mesh.points / np.linalg.norm(mesh.points, axis=1, keepdims=True),
    }


def _write(writer, mesh, k):
    f = _frame(mesh, k)
    writer.append(0.5 * k, f.pop("points"), f.pop("velocity"), f.pop("active_stress"), f.pop("pressure"), **f)


def _writer(path, resume=False):
    return TrajectoryWriter(
        path, MESHES[0].faces, 42, {"scene": SCENE, "effects": "x"}, extra_vars=EXTRA, resume=resume
    )


# frames 0-1 on mesh 0, 2-4 on mesh 1, 5 on mesh 2
PLAN = [0, 0, 1, 1, 1, 2]


def _write_plan(path, upto=None, finish=True):
    w = _writer(path)
    seg = 0
    for k in range(len(PLAN) if upto is None else upto):
        if PLAN[k] != seg:
            seg = PLAN[k]
            w.start_segment(MESHES[seg].faces, MESHES[seg].n_nodes, MESHES[seg].points * 0.9)
        _write(w, MESHES[seg], k)
    if finish:
        w.finish()
    return w


def test_segments_read_back_exactly(tmp_path):
    path = tmp_path / "r.h5"
    _write_plan(path)
    assert committed_frames(path) == (6, 2.5)
    for ds in (load_trajectory(path), open_trajectory(path)):
        assert ds.sizes["time"] == 6 and ds.sizes["node"] == 162 and ds.sizes["mesh"] == 3
        assert ds["mesh_id"].values.tolist() == PLAN
        assert ds["n_nodes"].values.tolist() == [42, 162, 12]
    tr = Trajectory(path)
    assert tr.remeshed
    for k, seg in enumerate(PLAN):
        points, tri = tr.mesh(k)
        want = _frame(MESHES[seg], k)
        np.testing.assert_array_equal(points, want["points"])
        np.testing.assert_array_equal(tri, MESHES[seg].faces)
        np.testing.assert_array_equal(tr.nodal("c", k), want["c"])
        assert np.isnan(tr.ds["c"].values[k, MESHES[seg].n_nodes :]).all()  # padding
    last = last_frame(path)
    assert last["segment"] == 2 and last["n_frames"] == 6
    np.testing.assert_array_equal(last["triangles"], MESHES[2].faces)
    np.testing.assert_array_equal(last["reference_points"], MESHES[2].points * 0.9)


def test_resume_inside_a_later_segment(tmp_path):
    path = tmp_path / "r.h5"
    w = _write_plan(path, upto=4, finish=False)  # frames 0-3: killed inside segment 1
    w.close_partial()
    state = ResumeState.read(path)
    assert state.segment == 1 and state.n_frames == 4 and state.points.shape == (162, 3)
    np.testing.assert_array_equal(state.triangles, MESHES[1].faces)
    w = _writer(path, resume=True)
    assert w.n_frames == 4 and w.n_nodes == 162
    _write(w, MESHES[1], 4)
    w.start_segment(MESHES[2].faces, 12, MESHES[2].points * 0.9)
    _write(w, MESHES[2], 5)
    w.finish()
    whole = tmp_path / "whole.h5"
    _write_plan(whole)
    a, b = load_trajectory(path), load_trajectory(whole)
    for name in ("points", "velocity", "c", "time", "mesh_id", "triangles"):
        np.testing.assert_array_equal(a[name].values, b[name].values)


def test_a_segment_never_committed_is_invisible_and_dropped(tmp_path):
    path = tmp_path / "r.h5"
    w = _write_plan(path, upto=3, finish=False)  # segment 1 has its first frame
    w.close_partial()
    with h5py.File(partial_path(path), "r+") as h5:  # as if killed while its first frame was written
        h5.attrs[SEGMENTS_ATTR] = np.int64(1)
    assert committed_frames(partial_path(path)) == (2, 0.5)
    assert load_trajectory(path).sizes["time"] == 2 and "mesh_id" not in load_trajectory(path)
    w = _writer(path, resume=True)
    assert w.n_frames == 2 and w.n_nodes == 42
    w.start_segment(MESHES[1].faces, 162)
    _write(w, MESHES[1], 2)
    w.finish()
    with h5py.File(path, "r") as h5:
        assert int(h5.attrs[SEGMENTS_ATTR]) == 2 and "mesh_2" not in h5
    assert load_trajectory(path)["mesh_id"].values.tolist() == [0, 0, 1]


def test_a_run_without_remeshing_keeps_the_single_mesh_layout(tmp_path):
    path = tmp_path / "r.h5"
    w = _writer(path)
    for k in range(3):
        _write(w, MESHES[0], k)
    w.finish()
    with h5py.File(path, "r") as h5:
        assert SEGMENTS_ATTR not in h5.attrs and not any(name.startswith("mesh_") for name in h5)
    ds = open_trajectory(path)
    assert "mesh_id" not in ds and ds["triangles"].dims == ("face", "corner")
    tr = Trajectory(path)
    assert not tr.remeshed
    np.testing.assert_array_equal(tr.mesh(2)[1], MESHES[0].faces)
    ds.close()


def test_a_segment_checks_its_frames(tmp_path):
    w = _writer(tmp_path / "r.h5")
    _write(w, MESHES[0], 0)
    w.start_segment(MESHES[1].faces, 162)
    with pytest.raises(ValueError, match="points must have shape"):
        _write(w, MESHES[0], 1)  # a frame of the old mesh after the change
    with pytest.raises(ValueError, match="outside"):
        w.start_segment(MESHES[1].faces, 12)
    w.abort()


def test_export_and_plot_give_each_frame_its_mesh(tmp_path):
    """VTKHDF (read back by VTK's own reader when installed) and PVD: every step has its frame's
    points, triangles and point data; the matplotlib picture draws the frame's triangles."""
    from cortex_ti.io.export import export_trajectory
    from cortex_ti.viz.plotting import plot_frame

    path = tmp_path / "r.h5"
    _write_plan(path)
    tr = Trajectory(path)
    pvd = export_trajectory(path, tmp_path / "pvd", fmt="pvd")
    import meshio

    for k, seg in enumerate(PLAN):
        mesh = meshio.read(pvd.parent / f"r_{k:05d}.vtu")
        np.testing.assert_array_equal(mesh.points, tr.mesh(k)[0])
        np.testing.assert_array_equal(mesh.cells_dict["triangle"], MESHES[seg].faces)
        np.testing.assert_array_equal(mesh.point_data["active_stress"], tr.nodal("active_stress", k))
    out = export_trajectory(path, tmp_path / "hdf", fmt="vtkhdf")
    for k, seg in enumerate(PLAN):
        _, surface = plot_frame(tr.ds, k)
        assert len(surface.get_array()) == MESHES[seg].n_faces
    vtk = pytest.importorskip("vtk", reason="VTK not installed (the viz extra): the VTKHDF file is not read back")
    from vtk.util.numpy_support import vtk_to_numpy

    reader = vtk.vtkHDFReader()
    reader.SetFileName(str(out))
    reader.UpdateInformation()
    assert reader.GetNumberOfSteps() == len(PLAN)
    for k, seg in enumerate(PLAN):
        reader.SetStep(k)
        reader.Update()
        grid = reader.GetOutput()
        np.testing.assert_array_equal(vtk_to_numpy(grid.GetPoints().GetData()), tr.mesh(k)[0])
        cells = vtk_to_numpy(grid.GetCells().GetConnectivityArray()).reshape(-1, 3)
        np.testing.assert_array_equal(cells, MESHES[seg].faces)
        np.testing.assert_array_equal(vtk_to_numpy(grid.GetPointData().GetArray("velocity")), tr.nodal("velocity", k))
