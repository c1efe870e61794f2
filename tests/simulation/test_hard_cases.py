"""Hard cases stay numerically stable (short runs so CI can afford them).

The resolution is the paper's 2562 nodes: at 642 nodes the furrow rings are not
resolved (measured: the t = 0 velocity is 2-8x the analytic one and one step of
2e-3 sends it to 1e2-1e3, with either fit), because the paper's bending viscosity
is too weak at that mesh size to hold down the spurious normal modes of the
discrete force balance; :func:`test_unresolved_mesh_is_reported` checks that this
is reported as a resolution problem, not as garbage.

Each case runs a short piece of a demanding scene and asserts, frame by frame:
finite values, the enclosed volume kept (the incompressibility constraint makes
the triangulated volume stationary, so the drift is O(dt^2) per step), mesh
quality above a floor, constraint residuals near machine precision, and the
physically expected trend. A step that would go unstable must be stopped by a
StabilityError naming the step size to try, leaving no output file.
"""

import numpy as np
import pytest

from cortex_ti.errors import StabilityError
from cortex_ti.io import open_trajectory, partial_path
from cortex_ti.scene import load_scene
from cortex_ti.simulation import Simulation
from cortex_ti.surface.mesh import icosphere

pytestmark = pytest.mark.hard

#: Sec. 4.4 of the paper: p = 4, zeta_hat = 3.5, eta_bar = 1e-4, eta_bar_b = 5e-3
SHEAR = [
    "active_stress.0.p=4",
    "active_stress.0.amplitude=3.5",
    "viscosity.bending=1e-4",
    "viscosity.bending_bulk=5e-3",
]
#: relative, over a whole short run. The constraint makes dV/dt = 0 at every solve; what is left
#: is explicit Euler's second-order term d2V/dt2 = integral of v_n^2 C dA > 0, i.e. a drift of
#: about (dt/2) * integral(v_n^2 C dA) * t / V, linear in the step: at the scenes' step 5e-3,
#: 2.1e-3 for the 0.75-sheared zeta_hat = 3.5 start over 0.15 t_a (measured; 3e-4 for zeta_hat = 3
#: at 5e-4).
VOLUME_DRIFT = 2.5e-3
MIN_ANGLE_FLOOR = 25.0  # degrees (the icosphere starts at 54; pyvista calls 30-60 good)
#: direct solves meet the constraints to ~1e-16; solves by GMRES reusing an earlier factorisation
#: (solver.reuse, solver.rtol = 1e-10) to ~1e-11 (measured up to 6e-11)
CONSTRAINTS = 1e-9
#: eps_rel of the irregular mesh's t = 0 flow against the exact one (measured 2.36e-2)
IRREGULAR_T0_ERROR = 0.026


def run(tmp_path, scene, overrides, name="run"):
    sim = Simulation(load_scene(scene, overrides))
    out = sim.run(tmp_path / f"{name}.h5", progress=False)
    ds = open_trajectory(out)
    return sim, ds


def assert_healthy(ds, angle_floor=MIN_ANGLE_FLOOR, residual=1e-3):
    for var in ("points", "velocity", "pressure", "volume", "pole_radius", "furrow_radius"):
        assert np.all(np.isfinite(ds[var].values)), var
    vol = ds["volume"].values
    assert np.abs(vol / vol[0] - 1).max() < VOLUME_DRIFT
    assert ds["min_angle_deg"].values.min() > angle_floor
    assert ds["constraint_violation"].values.max() < CONSTRAINTS
    # The least-squares residual measures how far the discrete force balance is from being
    # consistent: ~1e-10 on a sphere, 3e-5 (zeta_hat = 6) to 1.9e-4 (sheared start) measured here.
    assert ds["relative_residual"].values.max() < residual


@pytest.mark.slow
def test_strong_ring_zeta_hat_3(tmp_path):
    """furrow_p4_a3 (the paper's hardest furrow) at 642 nodes: the furrow closes in, the poles extend."""
    _, ds = run(tmp_path, "furrow_p4_a3", ["time.t_end=0.15"])
    assert_healthy(ds)
    pole, furrow = ds["pole_radius"].values, ds["furrow_radius"].values
    assert pole[-1] > pole[0] + 0.02 and furrow[-1] < furrow[0] - 0.02
    assert np.all(np.diff(furrow) < 1e-6)


@pytest.mark.slow
def test_amplitude_beyond_the_paper(tmp_path):
    """zeta_hat = 6, twice the paper's largest, stays stable."""
    _, ds = run(tmp_path, "furrow_p4_a3", ["time.t_end=0.1", "active_stress.0.amplitude=6"])
    assert_healthy(ds)
    assert ds["furrow_radius"].values[-1] < ds["furrow_radius"].values[0] - 0.03


@pytest.mark.slow
def test_strongly_sheared_start_turns_back(tmp_path):
    """x -> x + 0.75 z at t = 0 (paper Fig. 12): stable, and the long axis turns toward the pattern axis."""
    _, ds = run(tmp_path, "furrow_p4_a3", ["time.t_end=0.15", "mesh.shear=0.75"] + SHEAR)
    assert_healthy(ds)
    angle = ds["orientation_angle"].values
    assert angle[0] > 40.0 and angle[-1] < angle[0] - 5.0


@pytest.mark.slow
def test_sheared_start_reorients_while_the_furrow_forms(tmp_path):
    """x -> x + 0.35 z (paper Fig. 10): the long axis turns toward the pattern axis and, at the
    same time, the furrow across the long axis closes (measured to t = 3.5: 50 deg -> 3.5 deg,
    furrow radius along the long axis 0.918 -> 0.742)."""
    _, ds = run(tmp_path, "shear_035", ["time.t_end=0.15"])
    assert_healthy(ds)
    angle = ds["orientation_angle"].values
    furrow = ds["furrow_radius_long_axis"].values
    assert angle[0] == pytest.approx(49.96, abs=0.05) and angle[-1] < angle[0] - 10.0
    assert furrow[-1] < furrow[0] - 0.01  # 0.918 -> 0.900 at t = 0.15


@pytest.mark.slow
def test_tilted_sheared_start_keeps_its_orientation(tmp_path):
    """Pattern axis tilted 45 degrees toward the shear (paper Fig. 11): the sheared shape starts
    nearly aligned with it and stays so (measured to t = 3.5: 5.0 deg -> 11.0 deg, while the
    untilted start turns from 50 deg to 3.5 deg). The ring, carried by the shear, lies in a plane
    whose normal is atan(1 / (1 - gamma)) from z, i.e. 12.0 deg from the pattern axis: the long
    axis drifts toward that normal, never toward the untilted z axis."""
    _, ds = run(tmp_path, "shear_035_tilted", ["time.t_end=0.15"])
    assert_healthy(ds)
    angle = ds["orientation_angle"].values
    ring_normal_tilt = np.degrees(np.arctan(1.0 / (1.0 - 0.35))) - 45.0
    shear = np.array([[1.0, 0, 0.35], [0, 1, 0], [0, 0, 1]])
    long_axis = np.linalg.eigh(shear @ shear.T)[1][:, -1]  # of the sheared unit sphere
    start = np.degrees(np.arccos(abs(long_axis @ np.array([1.0, 0, 1]) / np.sqrt(2))))
    assert angle[0] == pytest.approx(start, abs=0.05)  # 4.96 deg
    assert np.all(angle < ring_normal_tilt + 1.0)
    assert angle[-1] > angle[0]  # toward the ring's normal, away from z


@pytest.mark.slow
def test_irregular_mesh(tmp_path):
    """An irregular triangulation of the sphere read from a file: every node moved by up to 20 %
    of an edge within the surface (min angle 17.7 deg, edge ratio 3.0). Its flow at t = 0 must
    match the exact flow on the sphere at its nodes (with the scene's bending viscosity; measured
    eps_rel 2.4e-2, the regular mesh's 1.0e-2; the paper's formulation: 4.7e-2 and 4.5e-2) and
    the run stay stable.

    (Random jitter *off* the surface is a different matter: node-scale bumps under tension
    relax with speeds ~1e2 on a time scale ~1e-5, a genuinely stiff start, not a solver fault.)
    """
    import meshio

    from cortex_ti.physics.patterns import evaluate_active_stress
    from cortex_ti.truth.analytic import error_measures
    from cortex_ti.truth.sphere_exact import sphere_flow

    mesh = icosphere(2562)
    rng = np.random.default_rng(3)
    pts = mesh.points + 0.2 * 0.076 * rng.uniform(-1, 1, (2562, 3))
    pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    path = tmp_path / "irregular.obj"
    meshio.write(path, meshio.Mesh(pts, [("triangle", mesh.faces)]))
    sim, ds = run(tmp_path, "furrow_p4_a1", [f"mesh.file={path}", "time.t_end=0.1"])
    angle0 = ds["min_angle_deg"].values[0]
    assert 15.0 < angle0 < 20.0
    assert_healthy(ds, angle_floor=0.9 * angle0)
    v = sim.settings.viscosity
    pats = list(sim.settings.patterns)
    exact, _, _ = sphere_flow(
        lambda x: evaluate_active_stress(x, pats),
        pts,
        eta_s=v.shear,
        eta_b=v.bulk,
        eta_bar=v.bending,
        eta_bar_b=v.bending_bulk,
        axis=(0, 0, 1),
        lmax=120,
    )
    assert error_measures(sim.solve(pts).velocity, exact)[1] < IRREGULAR_T0_ERROR
    assert ds["furrow_radius"].values[-1] < ds["furrow_radius"].values[0]


@pytest.mark.slow
def test_step_near_the_limit_runs_and_beyond_it_is_caught(tmp_path):
    """The paper's explicit Euler (time.implicit_tension=false) just below the measured stability
    limit is fine; far beyond it the guard stops the run with a StabilityError that names a step
    to try and leaves no output."""
    explicit = ["time.scheme=euler", "time.implicit_tension=false"]
    _, ds = run(tmp_path, "furrow_p4_a1", explicit + [f"time.dt={DT_STABLE}", "time.t_end=0.1"], name="near")
    assert_healthy(ds)
    sim = Simulation(load_scene("furrow_p4_a1", explicit + [f"time.dt={4 * DT_STABLE}", "time.t_end=0.5"]))
    out = tmp_path / "beyond.h5"
    with pytest.raises(StabilityError, match=r"try time\.dt=") as err:
        sim.run(out, progress=False)
    assert "unstable" in str(err.value)
    assert not out.exists()
    # the frames before the blow-up are kept for inspection or --resume with a smaller step
    if partial_path(out).exists():
        with open_trajectory(partial_path(out)) as ds:
            assert np.all(np.isfinite(ds["points"].values))


@pytest.mark.slow
def test_the_semi_implicit_step_runs_far_beyond_the_explicit_limit(tmp_path):
    """The same fixed Euler step that blows up explicitly (4x the limit, 1e-2) runs with the
    semi-implicit tension (the default), healthy, and the ring contracts as with small steps."""
    sim, ds = run(
        tmp_path,
        "furrow_p4_a1",
        ["time.scheme=euler", f"time.dt={4 * DT_STABLE}", "time.t_end=0.5", "time.save_every=0.05"],
        name="implicit",
    )
    assert sim.stats.steps == 50
    assert_healthy(ds)
    furrow = ds["furrow_radius"].values
    assert np.all(np.diff(furrow) < 0) and furrow[-1] < 0.97


@pytest.mark.slow
def test_unresolved_mesh_is_reported(tmp_path):
    """642 nodes with the paper's method (no fit-residual rows): the zeta_hat = 3 ring's run must
    stop with an error that points at the mesh and the stable formulation (not only at the time
    step), and leave no output file."""
    paper_euler = ["numerics.formulation=paper", "time.scheme=euler", "time.dt=5e-3"]  # the defaults before bdf2
    sim = Simulation(load_scene("furrow_p4_a3", ["mesh.nodes=642", "time.t_end=0.3", *paper_euler]))
    out = tmp_path / "coarse.h5"
    with pytest.raises(StabilityError, match="formulation=rayleigh_p1") as err:
        sim.run(out, progress=False)
    assert "nodes" in str(err.value)
    assert not out.exists()


@pytest.mark.slow
def test_an_unresolved_ring_is_stopped_even_when_the_step_is_damped(tmp_path):
    """p = 8 at 642 nodes is beyond what the rows can rescue (the ring is about two mesh spacings
    wide). Without the guard's residual check this run went on to t = 0.3 with speeds 100x the
    physical ones and a mesh collapsed to 0.1 deg angles; it must stop early, naming the mesh."""
    sim = Simulation(
        load_scene(
            "furrow_p8_a1",
            [
                "mesh.nodes=642",
                "numerics.formulation=paper",
                "numerics.fit_residual_weight=1e-3",
                "time.scheme=euler",
                "time.t_end=0.3",
            ],
        )
    )
    out = tmp_path / "p8.h5"
    with pytest.raises(StabilityError, match="no longer satisfied.*mesh nodes"):
        sim.run(out, progress=False)
    assert not out.exists()


@pytest.mark.slow
@pytest.mark.parametrize("scene, bound", [("furrow_p4_a3", 4.2e-3), ("furrow_p8_a1", 2.9e-3)])
def test_the_coarse_rings_the_papers_method_cannot_run_run_with_the_stable_formulation(tmp_path, scene, bound):
    """The two 642-node runs above, with the default formulation (rayleigh_p1, no rows, no
    tuning): healthy to t = 0.3 and within a few 1e-3 of the axisymmetric solution of the same
    scene (measured largest radius errors 3.79e-3 and 2.60e-3 R0 over the run; 2.54e-3 of it is
    already the furrow radius of the initial 642-node polyhedron)."""
    from cortex_ti.axisymmetric.compare import compare

    sim, ds = run(tmp_path, scene, ["mesh.nodes=642", "time.t_end=0.3"])
    assert ds["time"].values[-1] == pytest.approx(0.3)
    assert_healthy(ds)
    r = compare(str(tmp_path / "run.h5"))
    assert max(r["pole_radius"][0], r["furrow_radius"][0]) < bound


#: furrow_p4_a3 at t = 0.3 on 2562 nodes (quick workflow run, semi-implicit adaptive Euler)
P4A3_2562_AT_03 = {"pole_radius": 1.14344, "furrow_radius": 0.88800}


@pytest.mark.slow
def test_coarse_mesh_with_fit_residual_rows_runs_and_approaches_the_fine_one(tmp_path):
    """The same coarse run with numerics.fit_residual_weight = 1e-3 is healthy and lands within
    1e-2 R0 of the 2562-node run (measured 4.5e-3 and 6.6e-3: the O(h^2) error of 642 nodes, 4x
    the 1.1e-3 of 2562 nodes against 10242)."""
    _, ds = run(
        tmp_path,
        "furrow_p4_a3",
        [
            "mesh.nodes=642",
            "time.t_end=0.3",
            "numerics.formulation=paper",
            "numerics.fit_residual_weight=1e-3",
            "time.scheme=adaptive_euler",
            "time.dt=5e-4",
        ],
    )
    assert ds["time"].values[-1] == pytest.approx(0.3)
    # the rows ask for what the force rows cannot quite give on a coarse mesh: the least squares is
    # inconsistent at the fits' truncation level (measured 1.9e-3 at t = 0, 1.3e-4 later)
    assert_healthy(ds, residual=5e-3)
    for var, fine in P4A3_2562_AT_03.items():
        assert abs(float(ds[var].values[-1]) - fine) < 1e-2, var


#: measured on furrow_p8_a1 at 2562 nodes: Euler with dt = 3e-3 ran to t = 0.4, 5e-3 blew up at t = 0.07
DT_STABLE = 2.5e-3
