"""ParaView export (``cortex-ti export``): one VTKHDF file per run with its frames as time steps,
read back by VTK's own reader (an independent implementation of the format), or a PVD whose
frames carry the run's name; two runs exported into one folder do not mix."""

import os
import shutil
import xml.etree.ElementTree as ET

import h5py
import meshio
import numpy as np
import pytest

from cortex_ti.cli import main
from cortex_ti.io import Trajectory


@pytest.fixture(scope="module")
def run(tmp_path_factory, taichi_runtime):
    out = tmp_path_factory.mktemp("export") / "f.h5"
    assert (
        main(
            [
                "run",
                "furrow_p8_a1",
                "-o",
                str(out),
                "--set",
                "mesh.nodes=162",
                "--set",
                "time.t_end=0.002",
                "--set",
                "time.save_every=0.001",
                "--set",
                "time.scheme=euler",
            ]
        )
        == 0
    )
    return out


def expected_point_data(tr, k):
    v = tr.ds["velocity"].values[k]
    return {
        "velocity": v,
        "speed": np.linalg.norm(v, axis=1),
        "normal_speed": np.einsum("nc,nc->n", v, tr.normals(k)),  # the solver's normals, stored
        "active_stress": tr.ds["active_stress"].values[k],
    }


def check_frame(points, triangles, data, tr, k):
    np.testing.assert_array_equal(points, tr.ds["points"].values[k])
    np.testing.assert_array_equal(triangles, tr.triangles)
    for name, value in expected_point_data(tr, k).items():
        np.testing.assert_allclose(data[name], value, rtol=1e-14, atol=1e-15, err_msg=name)


def test_vtkhdf_is_one_file_read_by_vtk_with_every_time_step(run, tmp_path, capsys):
    vtk = pytest.importorskip("vtk", reason="VTK's reader comes with the [viz] extra: pip install 'cortex-ti[viz]'")
    from vtkmodules.util.numpy_support import vtk_to_numpy

    assert main(["export", str(run), "-o", str(tmp_path)]) == 0
    path = capsys.readouterr().out.strip().splitlines()[-1]
    assert path == str(tmp_path / "f.vtkhdf")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.vtkhdf"]
    tr = Trajectory(run)
    reader = vtk.vtkHDFReader()
    reader.SetFileName(path)
    reader.UpdateInformation()
    assert reader.GetNumberOfSteps() == len(tr.times)
    key = vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS()
    np.testing.assert_array_equal(reader.GetOutputInformation(0).Get(key), tr.times)
    for k, t in enumerate(tr.times):
        reader.UpdateTimeStep(t)
        grid = reader.GetOutput()
        assert grid.GetNumberOfPoints() == tr.ds.sizes["node"] and grid.GetNumberOfCells() == len(tr.triangles)
        assert {grid.GetCellType(c) for c in range(grid.GetNumberOfCells())} == {vtk.VTK_TRIANGLE}
        cells = vtk_to_numpy(grid.GetCells().GetConnectivityArray()).reshape(-1, 3)
        pd = grid.GetPointData()
        data = {pd.GetArrayName(i): vtk_to_numpy(pd.GetArray(i)) for i in range(pd.GetNumberOfArrays())}
        check_frame(vtk_to_numpy(grid.GetPoints().GetData()), cells, data, tr, k)


def test_vtkhdf_layout_follows_the_specification(run, tmp_path):
    """Without VTK: the rows the specification's offsets point at are the frame's (every other frame)."""
    assert main(["export", str(run), "-o", str(tmp_path / "g.vtkhdf"), "--every", "2"]) == 0
    tr = Trajectory(run)
    with h5py.File(tmp_path / "g.vtkhdf", "r") as h5:
        root = h5["VTKHDF"]
        assert root.attrs["Type"] == b"UnstructuredGrid" and int(root.attrs["Version"][0]) == 2
        steps = root["Steps"]
        kept = list(range(0, len(tr.times), 2))
        assert steps.attrs["NSteps"] == len(kept)
        np.testing.assert_array_equal(steps["Values"][()], tr.times[kept])
        n, f = int(root["NumberOfPoints"][0]), int(root["NumberOfCells"][0])
        for j, k in enumerate(kept):
            p0 = int(steps["PointOffsets"][j])
            c0, i0 = int(steps["CellOffsets"][j, 0]), int(steps["ConnectivityIdOffsets"][j, 0])
            offsets = root["Offsets"][c0 + int(steps["PartOffsets"][j]) :][: f + 1]
            conn = root["Connectivity"][i0 + offsets[0] : i0 + offsets[-1]].reshape(-1, 3)
            data = {
                name: root["PointData"][name][int(steps["PointDataOffsets"][name][j]) :][:n]
                for name in root["PointData"]
            }
            check_frame(root["Points"][p0 : p0 + n], conn, data, tr, k)


def test_pvd_frames_are_named_per_run_and_two_runs_do_not_mix(run, tmp_path, capsys):
    other = tmp_path / "g.h5"
    shutil.copy(run, other)
    out = tmp_path / "paraview"
    assert main(["export", str(run), "-o", str(out), "--format", "pvd"]) == 0
    assert main(["export", str(other), "-o", str(out), "--format", "pvd", "--every", "2"]) == 0
    pvd_f, pvd_g = capsys.readouterr().out.strip().splitlines()[-2:]
    tr = Trajectory(run)
    for pvd, stem, kept in ((pvd_f, "f", range(len(tr.times))), (pvd_g, "g", range(0, len(tr.times), 2))):
        entries = ET.parse(pvd).getroot().findall("./Collection/DataSet")
        assert [e.get("file") for e in entries] == [f"{stem}_{k:05d}.vtu" for k in kept]
        assert [float(e.get("timestep")) for e in entries] == pytest.approx(tr.times[list(kept)].tolist(), abs=1e-15)
        for k, entry in zip(kept, entries, strict=False):
            m = meshio.read(out / entry.get("file"))
            check_frame(m.points, m.cells_dict["triangle"], m.point_data, tr, k)
    assert len(list(out.glob("*.vtu"))) == len(tr.times) + len(range(0, len(tr.times), 2))


@pytest.mark.parametrize(
    "args, words",
    [
        (["--format", "xdmf"], "unknown --format 'xdmf'"),
        (["--every", "0"], "--every must be >= 1"),
        (["-o", "OUT/x.pvd", "--format", "vtkhdf"], "another format"),
    ],
)
def test_export_bad_input_one_line_exit_2_nothing_written(run, tmp_path, capsys, args, words):
    args = [a.replace("OUT", str(tmp_path)) for a in args]
    assert main(["export", str(run), "-o", str(tmp_path), *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cortex-ti: error:") and words in err[0]
    assert list(tmp_path.iterdir()) == []


def test_export_missing_file(tmp_path, capsys):
    assert main(["export", str(tmp_path / "nope.h5")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_stored_normals_are_unit_and_outward(run):
    tr = Trajectory(run)
    for k in range(len(tr.times)):
        n = tr.normals(k)
        x = tr.ds["points"].values[k]
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-13)
        assert np.all(np.einsum("nc,nc->n", n, x - x.mean(axis=0)) > 0.9 * np.linalg.norm(x - x.mean(axis=0), axis=1))


# ------------------------------------------------------------------ atomic and checked (issue 34)
def _listing(folder):
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def _one_error(capsys, words):
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cortex-ti: error: ") and words in err[0], err
    return err[0]


@pytest.mark.parametrize("fmt", ["vtkhdf", "pvd"])
def test_export_onto_a_full_disk_is_refused_before_writing(run, tmp_path, capsys, monkeypatch, fmt):
    """The free space is checked before anything is written (shutil.disk_usage reporting a nearly
    full disk): one line, nothing in the folder."""
    import collections

    import cortex_ti.io.export as export

    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage(10**6, 10**6 - 100, 100))
    assert main(["export", str(run), "-o", str(tmp_path), "--format", fmt]) == 2
    _one_error(capsys, "MB free; nothing was written")
    assert list(tmp_path.iterdir()) == []
    assert export.check_destination  # the check the command goes through


@pytest.mark.parametrize("fmt", ["vtkhdf", "pvd"])
def test_a_disk_filling_during_an_export_leaves_the_earlier_one(run, tmp_path, capsys, monkeypatch, fmt):
    """ENOSPC half-way (the disk filled by someone else after the check): one line, exit 2, no stray
    frame or temporary file, and the earlier export of the same run byte for byte."""
    import errno

    import cortex_ti.io.export as export

    assert main(["export", str(run), "-o", str(tmp_path), "--format", fmt]) == 0
    capsys.readouterr()
    before = _listing(tmp_path)
    calls = []

    def filling(real):
        def write(path, *args, **kwargs):
            calls.append(path)
            if len(calls) == 2:  # the second frame (pvd) or the one image (vtkhdf, after half of it)
                with open(path, "ab") as fh:
                    fh.write(b"\0" * 100)
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
            return real(path, *args, **kwargs)

        return write

    if fmt == "pvd":
        monkeypatch.setattr(meshio, "write", filling(meshio.write))
    else:
        calls.append("first")
        monkeypatch.setattr(export, "write_synced", filling(export.write_synced))
    assert main(["export", str(run), "-o", str(tmp_path), "--format", fmt, "--force", "--every", "2"]) == 2
    _one_error(capsys, "No space left on device")
    assert _listing(tmp_path) == before


def test_export_force_replaces_the_whole_previous_pvd_export(run, tmp_path, capsys):
    tr = Trajectory(run)
    assert main(["export", str(run), "-o", str(tmp_path), "--format", "pvd"]) == 0
    assert len(list(tmp_path.glob("f_*.vtu"))) == len(tr.times) == 3
    (tmp_path / "f_notes.vtu").write_text("mine")  # not a frame of the export: kept
    assert main(["export", str(run), "-o", str(tmp_path), "--format", "pvd", "--force", "--every", "2"]) == 0
    capsys.readouterr()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f.pvd", "f_00000.vtu", "f_00002.vtu", "f_notes.vtu"]
    entries = ET.parse(tmp_path / "f.pvd").getroot().findall("./Collection/DataSet")
    assert [e.get("file") for e in entries] == ["f_00000.vtu", "f_00002.vtu"]


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
@pytest.mark.parametrize("fmt", ["vtkhdf", "pvd"])
def test_export_into_a_read_only_folder_is_one_line(run, tmp_path, capsys, fmt):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["export", str(run), "-o", str(ro), "--format", fmt]) == 2
        _one_error(capsys, "Permission denied")
        assert list(ro.iterdir()) == []
    finally:
        ro.chmod(0o755)


@pytest.mark.parametrize("in_memory", [True, False])
@pytest.mark.parametrize("fmt", ["vtkhdf", "pvd"])
def test_writes_that_fail_for_real_leave_one_line_and_nothing(run, tmp_path, fmt, in_memory):
    """A file-size limit (RLIMIT_FSIZE: writes past it fail with EFBIG, as on a full disk) below the
    export's size, in a process of its own: one line, exit 2, no traceback, nothing in the folder.
    ``in_memory=False``: the VTKHDF written by HDF5 directly (exports above 1 GB), whose failed write
    h5py reports from every object it then fails to close."""
    import resource
    import signal
    import subprocess
    import sys
    from pathlib import Path

    if fmt == "pvd" and not in_memory:
        pytest.skip("one way of writing a PVD")
    out = tmp_path / "out"
    code = (
        "import sys\nimport cortex_ti.io.export as ex\nfrom cortex_ti.cli import main\n"
        f"ex._IN_MEMORY = {1 << 30 if in_memory else 0}\n"
        f"sys.exit(main(['export', {str(run)!r}, '-o', {str(out)!r}, '--format', {fmt!r}]))\n"
    )

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        size = 20000 if fmt == "vtkhdf" else 4000  # below the export (pvd: below one 162-node frame)
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))

    root = str(Path(__file__).resolve().parents[2])
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")])}
    env["PYTHONDONTWRITEBYTECODE"] = "1"  # under the limit a .pyc would be written cut short, and kept
    out.mkdir()
    res = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, preexec_fn=limit, env=env, timeout=300
    )
    lines = res.stderr.strip().splitlines()
    assert res.returncode == 2 and len(lines) == 1, res.stderr
    assert lines[0].startswith("cortex-ti: error: ") and "File too large" in lines[0]
    assert list(out.iterdir()) == []


def test_a_run_on_curved_cells_is_exported_as_quadratic_triangles(tmp_path, capsys):
    """formulation rayleigh_p2: every four triangles of the mesh one curved cell, exported as VTK's
    six-node quadratic triangle (type 22: corners, then the midpoints of edges 01, 12, 20) in both
    formats, so that ParaView draws the curved surface; the cells are the mesh's split cells."""
    from cortex_ti.io.export import VTK_QUADRATIC_TRIANGLE
    from cortex_ti.surface.curved import p2_cells

    h5 = tmp_path / "curved.h5"
    args = ["--set", "mesh.nodes=162", "--set", "numerics.formulation=rayleigh_p2", "--set", "time.t_end=0.01"]
    assert main(["run", "furrow_p4_a1", "-o", str(h5), "--threads", "1", *args]) == 0
    with Trajectory(h5) as tr:
        cells = p2_cells(tr.mesh(0)[1])
    assert main(["export", str(h5), "-o", str(tmp_path / "c.vtkhdf")]) == 0
    with h5py.File(tmp_path / "c.vtkhdf") as f:
        root = f["VTKHDF"]
        assert set(root["Types"][()].tolist()) == {VTK_QUADRATIC_TRIANGLE}
        assert np.array_equal(root["Connectivity"][()].reshape(-1, 6), cells)
    assert main(["export", str(h5), "--format", "pvd", "-o", str(tmp_path)]) == 0
    frame = meshio.read(sorted(tmp_path.glob("curved_*.vtu"))[0])
    assert frame.cells[0].type == "triangle6" and np.array_equal(frame.cells[0].data, cells)
    capsys.readouterr()
