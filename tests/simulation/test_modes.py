"""``cortex-ti modes``: the growing and stiffest modes of a stored frame (cortex_ti.simulation.modes).

Bad input is one line and exit status 2, before anything is solved. On a small real case (a
162-node furrow_p4_a1 run to t = 0.02) the table is checked against its definitions (the rows
asked for, eigenvalues in order, the run's scheme's step limit (euler: ``2 / |lambda|``, its column
named after the scheme), the effective node count between 1 and N) and, as a regression check,
against :func:`cortex_ti.dynamics.spectrum.normal_spectrum` called directly on the same frame; with
``--sparse`` (ARPACK) the same eigenvalues to ARPACK's tolerance (tests/dynamics/test_spectrum_bodies.py
derives it; 1e-6 relative is far above it on this well-conditioned frame).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from cortex_ti.cli import main


def _modes(argv, capsys):
    status = main(["modes", *argv])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.parametrize(
    "args, says",
    [
        (["--growing", "-1"], "--growing and --stiffest must be >= 0"),
        (["--growing", "0"], "not both 0"),
        (["--dt=-1e-3"], "--dt must be finite and >= 0"),
        (["--time", "nan"], "--time must be finite"),
    ],
)
def test_bad_arguments_are_one_line(tmp_path, capsys, args, says):
    status, out, err = _modes([str(tmp_path / "none.h5"), *args], capsys)
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and says in err


def test_a_missing_trajectory_is_one_line(tmp_path, capsys):
    status, _, err = _modes([str(tmp_path / "none.h5")], capsys)
    assert status == 2 and err.count("\n") == 1 and "does not exist" in err


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    out = tmp_path_factory.mktemp("modes") / "p4.h5"
    argv = ["run", "furrow_p4_a1", "-o", str(out), "--threads", "1"]
    argv += ["--set", "mesh.nodes=162", "--set", "time.t_end=0.02", "--set", "time.scheme=euler"]
    argv += ["--set", "time.dt=0.01"]
    assert main(argv) == 0
    return out


@pytest.mark.slow
def test_a_time_outside_the_run_is_one_line(tiny, capsys):
    status, _, err = _modes([str(tiny), "--time", "5"], capsys)
    assert status == 2 and err.count("\n") == 1 and "outside" in err and "t = 0 to 0.02" in err


@pytest.mark.slow
def test_the_table_of_a_small_run(tiny, capsys):
    from cortex_ti.dynamics.spectrum import normal_spectrum
    from cortex_ti.dynamics.state import State
    from cortex_ti.io.trajectory import Trajectory
    from cortex_ti.simulation import Simulation
    from cortex_ti.simulation.run import frame_fields

    status, out, _ = _modes([str(tiny), "--time", "0.02", "--dt", "0.01", "--growing", "3", "--stiffest", "1"], capsys)
    assert status == 0
    rows = [line for line in out.splitlines() if re.match(r"\| -?\d", line)]
    assert len(rows) == 4
    lam = [complex(r.split("|")[1].strip().replace("i", "j")) for r in rows]
    assert lam[0].real >= lam[1].real >= lam[2].real > lam[3].real and lam[3].real < 0
    assert "| euler step limit |" in out
    limit, effective = float(rows[3].split("|")[2]), [float(r.split("|")[3]) for r in rows]
    assert limit == pytest.approx(2.0 / abs(lam[3]), rel=2e-3)  # both printed to 3-4 digits
    assert all(1 <= e <= 162 for e in effective)

    # regression check: the same frame's spectrum straight from normal_spectrum
    tr = Trajectory(tiny)
    k = tr.frame_at(0.02)
    pts, tri = tr.mesh(k)
    sim = Simulation(tr.scene)
    sim.use_mesh(pts, tri)
    stored = {spec.var: tr.nodal(spec.var, k) for spec in sim.fields if spec.var in tr.ds}
    sim.state0 = State(pts, frame_fields(sim, stored, tr.nodal("active_stress", k), "test"), tri)
    w = np.asarray(normal_spectrum(sim, pts, dt=0.01, dense=True).eigenvalues)
    assert [x.real for x in lam[:3]] == pytest.approx(w.real[:3], rel=1e-3, abs=1e-6)
    assert lam[3].real == pytest.approx(w.real[-1], rel=1e-3)

    status, out, _ = _modes(
        [str(tiny), "--time", "0.02", "--dt", "0.01", "--growing", "3", "--stiffest", "1", "--sparse"], capsys
    )
    assert status == 0 and "ARPACK" in out
    rows = [line for line in out.splitlines() if re.match(r"\| -?\d", line)]
    arpack = [complex(r.split("|")[1].strip().replace("i", "j")) for r in rows]
    assert [x.real for x in arpack] == pytest.approx([x.real for x in lam], rel=1e-6, abs=1e-9)


# ``cortex-ti twin`` (cortex_ti.axisymmetric.compare.twin_report): a 3D run against its axisymmetric twin


def test_twin_refuses_a_missing_file_in_one_line(tmp_path, capsys):
    status = main(["twin", str(tmp_path / "none.h5")])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and "does not exist" in err


@pytest.mark.slow
def test_twin_of_a_small_run(tiny, tmp_path, capsys):
    """The 162-node furrow_p4_a1 run to t = 0.02 against its twin: the radii agree to the polyhedron's
    error (a section through edges of length h lies up to h^2 / 8 inside the sphere: edges up to
    0.33 R0 at 162 nodes, 1.4e-2; bound 2e-2); an axisymmetric run is refused in one line (it is
    the twin)."""
    capsys.readouterr()
    assert main(["twin", str(tiny)]) == 0
    row = next(line for line in capsys.readouterr().out.splitlines() if line.startswith("| furrow_p4_a1 | 162 |"))
    pole, furrow = (float(x) for x in row.split("|")[6].split(","))
    assert 0 < pole < 2e-2 and 0 < furrow < 2e-2
    ax = tmp_path / "ax.h5"
    argv = ["run", "furrow_p4_a1", "-o", str(ax), "--set", "model=axisymmetric", "--set", "time.t_end=0.02"]
    assert main(argv) == 0
    capsys.readouterr()
    assert main(["twin", str(ax)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not a 3D run" in err


# ``cortex-ti angles`` (cortex_ti.io.angles.angle_report): where a run's smallest triangle angle falls


@pytest.mark.parametrize(
    "args, says", [(["--below", "75"], "--below must be an angle"), (["--worst=-1"], "--worst must be >= 0")]
)
def test_angles_bad_arguments_are_one_line(tmp_path, capsys, args, says):
    status = main(["angles", str(tmp_path / "none.h5"), *args])
    err = capsys.readouterr().err
    assert status == 2 and err.count("\n") == 1 and says in err


@pytest.mark.slow
def test_angles_of_a_small_run(tiny, capsys):
    """The first frame is the 162-node icosphere, built here independently: its smallest angle is
    the report's at t = 0 (to the 0.1 deg printed); the worst triangles are listed in order."""
    from cortex_ti.surface.mesh import icosphere
    from cortex_ti.surface.remesh import min_angles

    capsys.readouterr()
    assert main(["angles", str(tiny), "--below", "59", "--worst", "3"]) == 0
    lines = capsys.readouterr().out.splitlines()
    first = float(lines[2].split("|")[2])
    m = icosphere(162)
    assert first == pytest.approx(min_angles(m.points, m.faces).min(), abs=0.051)
    rows = [line for line in lines if re.match(r"\| \d+ \| ", line)]
    worst = [float(r.split("|")[2]) for r in rows]
    assert len(rows) == 3 and worst == sorted(worst)
