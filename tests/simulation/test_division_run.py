"""A run across a division (division.neck_radius): a 642-node dumbbell under a uniform tension, cut at
its first step, then evolved as two bodies; resumed across the cut; the daughters rounding up (with
a ring that dissolves at the cut and the weighted semi-implicit tension); the solve by body against
the solves of each body alone; and the scenes the division refuses, in one line with exit 2."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from cortex_ti.cli import main
from cortex_ti.io.trajectory import Trajectory, read_divisions
from cortex_ti.surface.measures import enclosed_volume
from cortex_ti.surface.remesh import remesh_available
from tests.dumbbell_tools import dumbbell

pytestmark = pytest.mark.skipif(not remesh_available(), reason="needs mmgpy (the remesh extra)")

#: the dumbbell (neck 0.264 at t = 0) under the uniform tension of constriction_p4 without its ring:
#: the neck is below division.neck_radius at the first frame, so the first step's end cuts it
SETS = [
    "mesh.nodes=null",
    "active_stress.0.amplitude=0",
    "division.neck_radius=0.27",
    "time.stop_neck=null",
    "time.save_every=0.0002",
]


def _run(tmp_path, out, t_end, *flags):
    args = ["run", "constriction_p4", "-o", str(out), "--threads", "1", "--set", f"mesh.file={tmp_path / 'db.obj'}"]
    for s in [*SETS, f"time.t_end={t_end}"]:
        args += ["--set", s]
    return main([*args, *flags])


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """One run to t = 0.0012 across the cut, and one to t = 0.0004 (before it) resumed to 0.0012."""
    tmp = tmp_path_factory.mktemp("division")
    p, f = dumbbell(642, neck=0.25)
    meshio.write(tmp / "db.obj", meshio.Mesh(p, [("triangle", f)]))
    whole, part = tmp / "whole.h5", tmp / "part.h5"
    assert _run(tmp, whole, 0.0012) == 0
    assert _run(tmp, part, 0.0004) == 0
    assert _run(tmp, part, 0.0012, "--resume") == 0
    return enclosed_volume(p, f), whole, part, tmp


def _check(path, v0):
    ds = Trajectory(path).ds
    n = ds["n_bodies"].values
    assert n[0] == 1 and n[-1] == 2 and np.all(np.diff(n) >= 0)
    vol = ds["body_volume"].values
    assert np.isnan(vol[0, 1]) and np.all(np.isfinite(vol[n == 2]))
    # the constraint keeps each body's volume: the sum stays the initial volume (the run's drift, O(dt^2))
    assert np.all(np.abs(np.nansum(vol, axis=1) / v0 - 1.0) < 1e-5)
    cut = read_divisions(path)
    assert len(cut) == 1 and abs(sum(cut[0]["division_volumes"]) / cut[0]["division_volume"] - 1.0) < 1e-13
    # the two daughters of the symmetric dumbbell: equal to the mesh's asymmetry (icosphere + remeshing)
    after = vol[n == 2]
    assert np.all(np.abs(after[:, 0] / after[:, 1] - 1.0) < 1e-3)
    assert np.all(np.isnan(ds["neck_radius"].values[n == 2]))  # no neck once divided
    return ds


@pytest.mark.slow  # the two runs of the fixture: ~4 CPU s
def test_a_run_divides_and_goes_on_as_two_bodies(runs):
    v0, whole, _, _ = runs
    ds = _check(whole, v0)
    assert float(ds["time"].values[-1]) == pytest.approx(0.0012)
    # the two bodies lie on either side of the cut plane z = 0
    c = ds["body_centroid"].values[-1]
    assert c[0, 2] < -0.3 and c[1, 2] > 0.3


@pytest.mark.slow
def test_a_run_resumed_across_the_cut(runs):
    v0, _, part, _ = runs
    ds = _check(part, v0)
    assert float(ds["time"].values[-1]) == pytest.approx(0.0012)


@pytest.fixture(scope="module")
def rounded(tmp_path_factory):
    """The dumbbell under the uniform tension with division.implicit_tension_weight = 2: a run to t = 0.006
    (frames every 0.001), whose steps after the cut are checked first, and one to t = 2."""
    tmp = tmp_path_factory.mktemp("rounding")
    p, f = dumbbell(642, neck=0.25)
    meshio.write(tmp / "db.obj", meshio.Mesh(p, [("triangle", f)]))
    weight = ["--set", "division.implicit_tension_weight=2"]
    assert _run(tmp, tmp / "early.h5", 0.006, *weight, "--set", "time.save_every=0.001") == 0
    early = Trajectory(tmp / "early.h5").ds
    n = early["n_bodies"].values
    smallest = float(np.min(early["dt"].values[n == 2]))
    if smallest < 1e-5:  # the step collapsed: the run to t = 2 would crawl for hours
        pytest.fail(f"the step fell to {smallest:.2g} after the cut (docs/derivations/implicit_tension_weight.md)")
    assert _run(tmp, tmp / "round.h5", 2.0, *weight, "--set", "time.save_every=1.0") == 0
    return smallest, Trajectory(tmp / "round.h5").ds


@pytest.mark.slow  # the fixture's runs: ~9 CPU s
def test_the_daughters_round_up(rounded):
    """A closed cortex under a uniform tension relaxes to a sphere: each daughter is round within the
    issue's 1e-2 at t = 2 (0.0092 and 0.0079 at t = 1.6, measured; the meshes' own equilibrium, about
    0.007, is reached by t = 2-4), keeping its volume. Without the weight the step fell to ~1e-7 within
    0.004 t_a of the cut (docs/derivations/implicit_tension_weight.md: stable only below ~3e-7 there);
    with it the frames after the cut have steps of at least 4.8e-5 to t = 0.006 (measured), 1e-4 later."""
    from cortex_ti.io.trajectory import frame_mesh
    from cortex_ti.surface.division import body_roundness

    smallest, ds = rounded
    assert smallest > 1e-5
    n = ds["n_bodies"].values
    assert n[0] == 1 and n[-1] == 2
    last = body_roundness(*frame_mesh(ds, len(n) - 1))
    assert all(r < 1e-2 for r, _ in last), last
    v = ds["body_volume"].values
    assert np.all(np.abs(v[-1] / v[np.flatnonzero(n == 2)[0]] - 1.0) < 1e-4)
    assert float(np.min(ds["dt"].values[n == 2])) > 1e-4


@pytest.mark.slow  # ~3.5 CPU s
def test_a_run_on_curved_cells_divides(tmp_path):
    """rayleigh_p2 (curved cells, quartic fit): a dumbbell of 162 corners (neck 0.30, split into 642
    nodes when the run starts) cut at its first step. The cut's sides are the curved cells' volumes
    (they add to the volume before to round-off), each daughter's curved volume is kept by its own
    constraint (the run's drift: O(dt^2), 7e-8 measured), and the two equal daughters of the symmetric
    dumbbell stay equal to the mesh's asymmetry (3e-8 measured)."""
    from cortex_ti.surface.curved_remesh import curved_volume

    p, f = dumbbell(162, neck=0.3, width=0.6)
    meshio.write(tmp_path / "db.obj", meshio.Mesh(p, [("triangle", f)]))
    out = tmp_path / "p2.h5"
    sets = [*SETS[:2], "division.neck_radius=0.33", *SETS[3:], "time.t_end=0.0012"]
    sets += [f"mesh.file={tmp_path / 'db.obj'}", "numerics.formulation=rayleigh_p2", "numerics.fit=quartic"]
    args = ["run", "constriction_p4", "-o", str(out), "--threads", "1"]
    for s in sets:
        args += ["--set", s]
    assert main(args) == 0
    ds = Trajectory(out).ds
    n = ds["n_bodies"].values
    assert n[0] == 1 and n[-1] == 2
    vol = ds["body_volume"].values
    v0 = float(ds["volume"].values[0])
    assert v0 == pytest.approx(vol[0, 0], rel=1e-14)  # both the curved cells' volume
    from cortex_ti.io.trajectory import frame_mesh

    assert v0 == pytest.approx(curved_volume(*frame_mesh(ds, 0)), rel=1e-14)
    cut = read_divisions(out)
    assert len(cut) == 1 and abs(sum(cut[0]["division_volumes"]) / cut[0]["division_volume"] - 1.0) < 1e-13
    after = vol[n == 2]
    assert np.all(np.abs(after.sum(axis=1) / v0 - 1.0) < 1e-6)
    assert np.all(np.abs(after[:, 0] / after[:, 1] - 1.0) < 1e-6)


def test_the_ring_dissolves_at_the_cut(tmp_path):
    """division.ring: dissolve: the daughters' prescribed tension is the ring's base tension zeta0 = 1 on
    every node (before the cut the dumbbell's neck carries 1 + 5)."""
    import cortex_ti as ct
    from cortex_ti.simulation.bodies import divide_due
    from cortex_ti.simulation.core import Simulation

    p, f = dumbbell(642, neck=0.25)
    meshio.write(tmp_path / "db.obj", meshio.Mesh(p, [("triangle", f)]))
    sets = [f"mesh.file={tmp_path / 'db.obj'}", *SETS, "active_stress.0.amplitude=5", "division.ring=dissolve"]
    sets += ["mesh.remesh.settle_steps=0"]
    sim = Simulation(ct.load_scene("constriction_p4", sets))
    before = sim.state0.fields["prescribed_tension"]
    assert before.max() > 5.0
    sim.neck_seen = 0.0  # the neck as a frame would have seen it (the run searches it once it is near)
    after = divide_due(sim, sim.state0, 0.0)
    assert sim.bodies is not None and len(sim.bodies) == 2
    np.testing.assert_array_equal(after.fields["prescribed_tension"], np.ones(after.n_nodes))


def test_the_solve_by_body_equals_each_body_alone():
    """A consistency check (the code against itself): two bodies (a sphere and an ellipsoid) solved
    together, body by body, give each body's velocity and pressure of its own one-body solve."""
    import cortex_ti as ct
    from cortex_ti.simulation.core import Simulation
    from cortex_ti.surface.mesh import icosphere

    m = icosphere(162)
    sim = Simulation(ct.load_scene("constriction_p4", ["mesh.nodes=162", "mesh.remesh.min_angle=null"]))
    a, b = m.points, m.points * np.array([0.8, 0.8, 1.3]) + 3.0
    zeta = 1.0 + 0.5 * m.points[:, 2] ** 2
    sim.use_mesh(np.vstack([a, b]), np.concatenate([m.faces, m.faces + 162]))
    both = sim.solve(sim.mesh.points, 0.0, np.concatenate([zeta, zeta]))
    assert np.isnan(both.pressure)
    for k, x in enumerate((a, b)):
        sim.use_mesh(x, m.faces)
        alone = sim.solve(x, 0.0, zeta)
        np.testing.assert_allclose(both.velocity[162 * k : 162 * (k + 1)], alone.velocity, rtol=0, atol=1e-10)
        assert abs(both.body_pressure[k] - alone.pressure) <= 1e-10 * abs(alone.pressure)


@pytest.mark.parametrize(
    ("sets", "said"),
    [
        (["division.neck_radius=0.01"], "below what the mesh resolves"),
        (["division.neck_radius=0.2", "mesh.remesh.min_angle=null"], "needs remeshing"),
        (["division.neck_radius=0.001", "model=axisymmetric", "mesh.remesh.min_angle=null"], "points resolve"),
        (["division.neck_radius=0.2", "numerics.formulation=paper"], "cannot be cut"),
        (["division.neck_radius=0.05", "time.stop_neck=0.1"], "before the cut"),
        (["numerics.implicit_tension_weight=0.5"], ">= 1"),
        (["numerics.implicit_tension_weight=2", "numerics.formulation=paper"], "rayleigh_p2 only, not paper"),
        (["division.neck_radius=0.2", "division.ring=melt"], "division.ring"),
        (["division.implicit_tension_weight=2"], "set division.neck_radius"),
        (["mesh.remesh.mirror=true"], "numerics.formulation rayleigh_p2"),
        (
            ["mesh.remesh.mirror=true", "numerics.formulation=rayleigh_p2", "active_stress.0.center=1.3"],
            "puts the ring off it",
        ),
        (["active_stress.0.center=3.3"], "active_stress.0.center must be"),
        (
            ["division.neck_radius=0.2", "division.implicit_tension_weight=2", "numerics.formulation=paper"],
            "rayleigh_p1 or rayleigh_p2 only",
        ),
        (
            ["division.ring=dissolve", "model=axisymmetric", "mesh.remesh.min_angle=null", "division.neck_radius=0.1"],
            "axisymmetric model stops",
        ),
    ],
)
def test_division_refusals(tmp_path, capsys, sets, said):
    out = tmp_path / "r.h5"
    args = ["run", "constriction_p4", "-o", str(out)]
    for s in ["time.stop_neck=null", *sets]:
        args += ["--set", s]
    assert main(args) == 2 and not out.exists() and not (tmp_path / "r.h5.partial").exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cortex-ti: error:") and said in err[0], err
