"""ParaView export (cortex-ti export): one VTU per frame with the frame's fields, and a .pvd time series."""

import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from cortex_ti.cli import main
from cortex_ti.io import Trajectory


@pytest.fixture(scope="module")
def run(tmp_path_factory, taichi_runtime):
    out = tmp_path_factory.mktemp("export") / "f.h5"
    assert main(["run", "furrow_p8_a1", "-o", str(out), "--set", "mesh.nodes=162",
                 "--set", "time.t_end=0.002", "--set", "time.save_every=0.001", "--set", "time.scheme=euler"]) == 0
    return out


def test_every_frame_exported_with_its_fields(run, tmp_path, capsys):
    assert main(["export", str(run), "-o", str(tmp_path / "vtu")]) == 0
    pvd = capsys.readouterr().out.strip().splitlines()[-1]
    entries = ET.parse(pvd).getroot().findall("./Collection/DataSet")
    tr = Trajectory(run)
    assert [float(e.get("timestep")) for e in entries] == pytest.approx(tr.times.tolist(), abs=1e-15)
    for k, entry in enumerate(entries):
        m = meshio.read(tmp_path / "vtu" / entry.get("file"))
        v = tr.ds["velocity"].values[k]
        np.testing.assert_array_equal(m.points, tr.ds["points"].values[k])
        np.testing.assert_array_equal(m.cells_dict["triangle"], tr.triangles)
        np.testing.assert_allclose(m.point_data["speed"], np.linalg.norm(v, axis=1), rtol=1e-14)
        # the normal speed with the solver's normals, stored in the trajectory
        np.testing.assert_allclose(m.point_data["normal_speed"], np.einsum("nc,nc->n", v, tr.normals(k)),
                                   rtol=1e-13, atol=1e-15)
        np.testing.assert_array_equal(m.point_data["active_stress"], tr.ds["active_stress"].values[k])


def test_stored_normals_are_unit_and_outward(run):
    tr = Trajectory(run)
    for k in range(len(tr.times)):
        n = tr.normals(k)
        x = tr.ds["points"].values[k]
        np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-13)
        assert np.all(np.einsum("nc,nc->n", n, x - x.mean(axis=0)) > 0.9 * np.linalg.norm(x - x.mean(axis=0), axis=1))
