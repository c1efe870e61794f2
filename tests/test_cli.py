"""The command line: ``cortex-ti run | check | scenes``.

Mostly in-process through :func:`cortex_ti.cli.main` (capsys), plus one run of the installed
``cortex-ti`` console script in a subprocess. Every bad input must give exit status 2, one
stderr line ``cortex-ti: error: ...`` naming the problem, no traceback, and no output file.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess

import meshio
import numpy as np
import pytest
import xarray as xr
import yaml

from cortex_ti.cli import main
from cortex_ti.io import partial_path
from cortex_ti.surface.mesh import icosphere
from cortex_ti.truth.analytic import (
    error_measures,
    sphere_full_solution,
    sphere_tangential_solution,
)

pytestmark = pytest.mark.usefixtures("taichi_runtime")

FULL_EFFECTS = "active_stress,bulk_viscosity,incompressibility,normal_balance,shear_viscosity"
Y20 = [{"type": "harmonics", "terms": [{"l": 2, "m": 0, "coeff": 1.0}]}]
Y21 = [
    {
        "type": "harmonics",
        "terms": [{"l": 0, "m": 0, "coeff": math.sqrt(4.0 * math.pi)}, {"l": 2, "m": 1, "coeff": 1.0}],
    }
]


def run(argv, capsys):
    rc = main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


def open_output(path):
    return xr.open_dataset(path, engine="h5netcdf")


# ---------------------------------------------------------------------------------------------
# run
# ---------------------------------------------------------------------------------------------
def test_run_full_scene(tmp_path, capsys):
    """sphere_y20_full on 162 nodes (default fit: quartic). Measured eps_rel 0.0203, P ~ 1e-15."""
    out = tmp_path / "out.h5"
    rc, stdout, stderr = run(
        ["run", "sphere_y20_full", "--set", "mesh.nodes=162", "--threads", "2", "-o", str(out)], capsys
    )
    assert rc == 0, stderr
    assert stdout.strip().splitlines()[-1] == str(out)
    assert "Traceback" not in stderr
    assert out.is_file() and not partial_path(out).exists()
    with open_output(out) as ds:
        assert dict(ds.sizes) == {"time": 1, "node": 162, "xyz": 3, "face": 320, "corner": 3}
        assert ds.attrs["effects"] == FULL_EFFECTS
        scene = yaml.safe_load(ds.attrs["scene"])
        assert scene["name"] == "sphere_y20_full"
        assert scene["mesh"]["nodes"] == 162  # the override is recorded
        assert ds.attrs["fit_scheme"] == "quartic"
        points = ds["points"].values[0]
        velocity = ds["velocity"].values[0]
        pressure = float(ds["pressure"].values[0])
        triangles = ds["triangles"].values
        zeta = ds["active_stress"].values[0]
    assert np.allclose(np.linalg.norm(points, axis=1), 1.0)
    assert triangles.min() == 0 and triangles.max() == 161
    v_an, p_an = sphere_full_solution(points, Y20)
    assert error_measures(velocity, v_an)[1] < 0.03
    assert np.isfinite(pressure) and abs(pressure - p_an) < 1e-8
    # the stored tension is zeta = Y20 at the nodes: sqrt(5 / 16 pi) (3 cos^2 theta - 1)
    cos = points[:, 2]
    assert np.allclose(zeta, math.sqrt(5 / (16 * math.pi)) * (3 * cos**2 - 1))


def test_run_tangential_scene(tmp_path, capsys):
    """sphere_y21_tangential on 162 nodes: no pressure (NaN), flow vs the analytic one
    (measured eps_rel 1.27e-3), tangent to the sphere."""
    out = tmp_path / "tan.h5"
    rc, _, stderr = run(
        ["run", "sphere_y21_tangential", "--set", "mesh.nodes=162", "--threads", "2", "-o", str(out)], capsys
    )
    assert rc == 0, stderr
    with open_output(out) as ds:
        assert ds.attrs["effects"] == "active_stress,fixed_normal_velocity,shear_viscosity"
        assert yaml.safe_load(ds.attrs["scene"])["name"] == "sphere_y21_tangential"
        assert np.isnan(ds["pressure"].values).all()
        points = ds["points"].values[0]
        velocity = ds["velocity"].values[0]
    v_an = sphere_tangential_solution(points, Y21)
    assert error_measures(velocity, v_an)[1] < 1.9e-3
    assert np.abs(np.einsum("nc,nc->n", velocity, points)).max() < 0.02 * np.abs(velocity).max()


# ---------------------------------------------------------------------------------------------
# bad inputs
# ---------------------------------------------------------------------------------------------
def write_obj(path, points, faces):
    meshio.write(str(path), meshio.Mesh(points, [("triangle", np.asarray(faces))]))
    return path


def open_mesh_file(tmp_path):
    m = icosphere(162)
    return write_obj(tmp_path / "open.obj", m.points, m.faces[1:])


def nonmanifold_mesh_file(tmp_path):
    """Two spheres touching at one node: every edge has two faces, but the node has two fans."""
    m = icosphere(162)
    v = 0
    other = 2.0 * m.points[v] - m.points  # point reflection through node v
    index = np.arange(m.n_nodes) + m.n_nodes
    index[v] = v
    keep = np.arange(m.n_nodes) != v
    points = np.vstack([m.points, other[keep]])
    index[keep] = m.n_nodes + np.arange(keep.sum())
    faces = np.vstack([m.faces, index[m.faces][:, ::-1]])  # reflected: reverse to stay outward
    return write_obj(tmp_path / "pinched.obj", points, faces)


def flipped_mesh_file(tmp_path):
    m = icosphere(162)
    faces = m.faces.copy()
    faces[7] = faces[7, ::-1]
    return write_obj(tmp_path / "flipped.obj", m.points, faces)


BAD_SETS = {
    "unknown key": (["--set", "viscosity.shaer=1"], ["viscosity.shaer", "unknown"]),
    "wrong type": (["--set", "viscosity.bulk=abc"], ["viscosity.bulk", "number"]),
    "negative viscosity": (["--set", "viscosity.bulk=-1"], ["viscosity.bulk", "-1"]),
    "nan viscosity": (["--set", "viscosity.bulk=.nan"], ["viscosity.bulk", "nan"]),
    "node count": (["--set", "mesh.nodes=100"], ["mesh.nodes", "100"]),
    "missing mesh": (["--set", "mesh.file=nope.obj"], ["nope.obj", "does not exist"]),
    "unknown effect": (
        ["--set", "effects=[active_stress,shear_viscosity,bulk_viscosity,normal_balance,incompressibility,bogus]"],
        ["bogus", "unknown effect"],
    ),
}
BAD_MESHES = {
    "open mesh": (open_mesh_file, ["open.obj", "not closed"]),
    "non-manifold mesh": (nonmanifold_mesh_file, ["pinched.obj", "not manifold"]),
    "flipped face": (flipped_mesh_file, ["flipped.obj", "inconsistently oriented"]),
}


def assert_clean_failure(rc, stdout, stderr, words, out=None):
    assert rc == 2
    assert "Traceback" not in stderr and "Traceback" not in stdout
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith("cortex-ti: error:")
    for word in words:
        assert word in lines[0], (word, lines[0])
    if out is not None:
        assert not out.exists() and not partial_path(out).exists()
        assert list(out.parent.iterdir()) == [] or all(p.suffix == ".obj" for p in out.parent.iterdir())


@pytest.mark.parametrize("case", list(BAD_SETS))
def test_run_rejects_bad_value(tmp_path, capsys, monkeypatch, case):
    monkeypatch.chdir(tmp_path)
    args, words = BAD_SETS[case]
    out = tmp_path / "out.h5"
    rc, stdout, stderr = run(
        ["run", "sphere_y20_full", "--set", "mesh.nodes=162", *args, "--threads", "2", "-o", str(out)], capsys
    )
    assert_clean_failure(rc, stdout, stderr, words, out)


@pytest.mark.parametrize("case", list(BAD_MESHES))
def test_run_rejects_bad_mesh_file(tmp_path, capsys, case):
    make, words = BAD_MESHES[case]
    path = make(tmp_path)
    out = tmp_path / "out.h5"
    rc, stdout, stderr = run(
        ["run", "sphere_y20_full", "--set", f"mesh.file={path}", "--threads", "2", "-o", str(out)], capsys
    )
    assert_clean_failure(rc, stdout, stderr, words, out)
    # check reports the same problem
    rc, stdout, stderr = run(["check", "sphere_y20_full", "--set", f"mesh.file={path}"], capsys)
    assert_clean_failure(rc, stdout, stderr, words)


def test_run_rejects_missing_scene(tmp_path, capsys):
    out = tmp_path / "out.h5"
    rc, stdout, stderr = run(["run", str(tmp_path / "nope.yaml"), "-o", str(out)], capsys)
    assert_clean_failure(rc, stdout, stderr, ["nope.yaml", "not found"], out)


def test_good_mesh_file_runs(tmp_path, capsys):
    """The same icosphere written to a file is accepted (the bad-mesh cases differ only by the defect)."""
    m = icosphere(162)
    path = write_obj(tmp_path / "good.obj", m.points, m.faces)
    rc, stdout, stderr = run(["check", "sphere_y20_full", "--set", f"mesh.file={path}"], capsys)
    assert rc == 0, stderr
    assert "162 nodes" in stdout


def test_run_refuses_bulk_viscosity_only(tmp_path, capsys):
    out = tmp_path / "bulk.h5"
    rc, stdout, stderr = run(
        [
            "run",
            "sphere_y20_full",
            "--set",
            "mesh.nodes=162",
            "--set",
            "viscosity.shear=0",
            "--set",
            "effects=[active_stress,bulk_viscosity,normal_balance,incompressibility]",
            "--threads",
            "2",
            "-o",
            str(out),
        ],
        capsys,
    )
    assert rc == 2 and not out.exists(), stderr


# ---------------------------------------------------------------------------------------------
# check, scenes
# ---------------------------------------------------------------------------------------------
def test_check_valid_scene(capsys):
    rc, stdout, stderr = run(["check", "sphere_y20_full", "--set", "mesh.nodes=162"], capsys)
    assert rc == 0, stderr
    lines = stdout.strip().splitlines()
    assert lines[-2] == (
        "sphere_y20_full: valid (162 nodes, effects: active_stress, bulk_viscosity, "
        "incompressibility, normal_balance, shear_viscosity)"
    )
    assert lines[-1] == "  numerics: formulation paper, quartic fit; fit-residual rows off"


def test_check_says_how_a_dynamic_scene_steps(capsys):
    rc, stdout, _ = run(["check", "shear_075", "--set", "mesh.nodes=162"], capsys)
    assert rc == 0
    assert stdout.strip().splitlines()[-2:] == [
        "  numerics: formulation rayleigh_p1, quadratic fit (normals, curvature); pressure petrov, "
        "active force balanced",
        "  time: bdf2 from dt = 0.001 to t = 3.5, semi-implicit tension",
    ]
    rc, stdout, _ = run(
        [
            "check",
            "shear_075",
            "--set",
            "mesh.nodes=162",
            "--set",
            "time.scheme=heun",
            "--set",
            "numerics.formulation=paper",
            "--set",
            "numerics.fit_residual_weight=1e-3",
        ],
        capsys,
    )
    assert stdout.strip().splitlines()[-2:] == [
        "  numerics: formulation paper, quadratic fit; fit-residual rows at 0.001",
        "  time: heun from dt = 0.001 to t = 3.5, explicit tension",
    ]


def test_check_rejects_bad_scene(capsys):
    rc, stdout, stderr = run(["check", "sphere_y20_full", "--set", "viscosity.shaer=1"], capsys)
    assert_clean_failure(rc, stdout, stderr, ["viscosity.shaer"])


def test_check_evaluates_field_and_python_patterns(tmp_path, capsys, monkeypatch):
    """check reads a field file and imports a python pattern, as a run does: a wrong node count, a
    NaN, a module that does not import or a wrong result are reported (exit 2) before any solve."""
    monkeypatch.chdir(tmp_path)
    np.save(tmp_path / "ok.npy", np.ones(162))
    np.save(tmp_path / "short.npy", np.ones(42))
    nan = np.ones(162)
    nan[7] = np.nan
    np.save(tmp_path / "nan.npy", nan)
    (tmp_path / "cli_check_patterns.py").write_text(
        "import numpy as np\n\ndef flat(points, value=1.0):\n    return np.full(len(points), value)\n\n"
        "def pair(points):\n    return np.ones((len(points), 2))\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))

    def check(pattern):
        return run(
            ["check", "sphere_y20_full", "--set", "mesh.nodes=162", "--set", f"active_stress=[{pattern}]"], capsys
        )

    for pattern in (
        "{type: field, file: ok.npy}",
        "{type: python, function: 'cli_check_patterns:flat'}",
        "{type: python, function: 'cli_check_patterns:flat', params: {value: 2}}",
    ):
        rc, stdout, stderr = check(pattern)
        assert rc == 0, stderr
        assert "valid (162 nodes" in stdout
    bad = {
        "{type: field, file: short.npy}": [
            f"field file '{tmp_path / 'short.npy'}' has 42 values but the mesh has 162 nodes"
        ],
        "{type: field, file: nan.npy}": [f"field file '{tmp_path / 'nan.npy'}'", "non-finite", "node 7"],
        "{type: field, file: none.npy}": ["active_stress.0.file", str(tmp_path / "none.npy"), "does not exist"],
        "{type: python, function: 'no_such_module_q:f'}": ["'no_such_module_q:f'", "cannot import module"],
        "{type: python, function: 'cli_check_patterns:nope'}": ["'cli_check_patterns:nope'", "no attribute 'nope'"],
        "{type: python, function: 'cli_check_patterns:pair'}": ["'cli_check_patterns:pair'", "shape (162, 2)"],
        "{type: python, function: 'cli_check_patterns:flat', params: {valu: 2}}": ["cli_check_patterns:flat", "valu"],
        "{type: python, function: 'nocolon'}": ["active_stress.0.function must look like"],
    }
    for pattern, words in bad.items():
        rc, stdout, stderr = check(pattern)
        assert_clean_failure(rc, stdout, stderr, words)


def test_scenes_lists_builtin_scenes(capsys):
    rc, stdout, _ = run(["scenes"], capsys)
    assert rc == 0
    names = [line.split()[0] for line in stdout.strip().splitlines() if line and not line.startswith("[")]
    for name in ("sphere_y20_full", "sphere_y20_tangential", "sphere_y21_full", "sphere_y21_tangential"):
        assert name in names
    assert names == sorted(names)


# ---------------------------------------------------------------------------------------------
# the installed console script
# ---------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_console_script_runs(tmp_path):
    """``cortex-ti run sphere_y21_full`` in a fresh process (measured eps_rel 0.0288, P 1.986)."""
    exe = shutil.which("cortex-ti")
    assert exe, "the cortex-ti console script is not installed"
    out = tmp_path / "y21.h5"
    env = dict(os.environ, CORTEX_TI_THREADS="2")
    proc = subprocess.run(
        [exe, "run", "sphere_y21_full", "--set", "mesh.nodes=162", "--threads", "2", "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
        env=env,
        cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == str(out)
    assert "Traceback" not in proc.stderr
    with open_output(out) as ds:
        assert ds.attrs["effects"] == FULL_EFFECTS
        points = ds["points"].values[0]
        velocity = ds["velocity"].values[0]
        pressure = float(ds["pressure"].values[0])
    v_an, p_an = sphere_full_solution(points, Y21)
    assert p_an == pytest.approx(2.0)
    assert error_measures(velocity, v_an)[1] < 0.043
    assert abs(pressure - p_an) < 0.02


def test_a_solve_failing_mid_run_is_one_line_and_keeps_the_frames(tmp_path, capsys, monkeypatch):
    """A failed factorisation in the middle of a run (PARDISO error -4 for an absurd step or
    viscosity) is one line naming the solve, exit 2, and the frames written so far stay in
    OUT.h5.partial."""
    from cortex_ti.errors import SolverError
    from cortex_ti.simulation import Simulation

    calls = {"n": 0}
    original = Simulation.evaluate

    def failing(self, points, dt=0.0):
        calls["n"] += 1
        if calls["n"] > 6:
            raise SolverError("the sparse factorisation of the force balance failed (PyPardisoError error code -4)")
        return original(self, points, dt)

    monkeypatch.setattr(Simulation, "evaluate", failing)
    out = tmp_path / "x.h5"
    rc, stdout, stderr = run(
        [
            "run",
            "furrow_p4_a1",
            "-o",
            str(out),
            "--set",
            "mesh.nodes=162",
            "--set",
            "time.scheme=euler",
            "--set",
            "time.dt=1e-3",
            "--set",
            "time.save_every=1e-3",
        ],
        capsys,
    )
    assert rc == 2
    lines = [ln for ln in stderr.strip().splitlines() if ln.startswith("cortex-ti: error:")]
    assert len(lines) == 1 and "the solve at t = 0.006 for a step dt = 0.001 failed" in lines[0]
    assert not out.exists()
    with xr.open_dataset(partial_path(out), engine="h5netcdf") as ds:
        assert ds.sizes["time"] == 6


def test_a_myosin_collapse_is_one_line_saying_resolution_and_keeps_the_frames(tmp_path, capsys):
    """The noise scene's linear law has no ceiling: the l = 1 mode gathers the myosin into a cap that
    keeps shrinking, until a solve fails (PARDISO -4 at 642 nodes). The guard stops it first, saying it
    is a resolution problem and not the step (dynamics.guard.unresolved_spot): one line, exit 2, the
    frames kept in OUT.h5.partial, the last of them the cap before the stop (still resolved)."""
    from cortex_ti.dynamics.guard import unresolved_spot

    out = tmp_path / "x.h5"
    rc, _, stderr = run(
        ["run", "myosin_noise", "-o", str(out), "--set", "mesh.nodes=162", "--set", "time.t_end=20"], capsys
    )
    assert rc == 2
    lines = [ln for ln in stderr.strip().splitlines() if ln.startswith("cortex-ti: error:")]
    assert len(lines) == 1 and "spot the mesh cannot resolve" in lines[0] and "not the time step" in lines[0]
    assert not out.exists()
    with xr.open_dataset(partial_path(out), engine="h5netcdf") as ds:
        c = ds["myosin"].values
        assert ds.sizes["time"] > 10 and float(ds["time"].values[-1]) < 20
    assert unresolved_spot(c[0]) is None and c[-1].max() > 3 * np.median(c[-1])  # it gathered into a spot


@pytest.mark.parametrize(
    "overrides, words",
    [
        (["viscosity.shear=1e308"], "viscosities"),
        (["viscosity.shear=1e308", "numerics.formulation=paper"], "viscosities"),
        (["time.dt=1e9", "time.scheme=euler", "numerics.formulation=paper"], "time.dt"),
    ],
)
def test_an_impossible_solve_is_one_line(tmp_path, capsys, overrides, words):
    """Finite but absurd input the schema lets through: the solve fails, and says which and why."""
    args = ["run", "furrow_p4_a1", "-o", str(tmp_path / "y.h5"), "--set", "mesh.nodes=162"]
    for o in overrides:
        args += ["--set", o]
    rc, stdout, stderr = run(args, capsys)
    assert rc == 2
    assert stderr.strip().count("\n") == 0 and stderr.startswith("cortex-ti: error: the solve at t = 0")
    assert words in stderr


@pytest.mark.parametrize(
    "overrides, words",
    [
        (["time.tol=1e-12"], "time.tol = 1e-12 is below what bdf2 can honour"),
        (["time.dt=0.5", "time.dt_max=0.1"], "time.dt = 0.5 (bdf2's first"),
        (
            ["numerics.formulation=paper", "time.implicit_tension=true"],
            "numerics.formulation = paper does not implement",
        ),
    ],
)
def test_what_bdf2_cannot_honour_is_one_line(tmp_path, capsys, overrides, words):
    """bdf2 (the dynamic scenes' default): a tolerance below the solves' own error, a first step
    above the largest step, its semi-implicit tension with a formulation that has no such term:
    one line naming the keys, exit 2, no output file."""
    out = tmp_path / "y.h5"
    args = ["run", "furrow_p4_a1", "-o", str(out), "--set", "mesh.nodes=162"]
    for o in overrides:
        args += ["--set", o]
    rc, _, stderr = run(args, capsys)
    assert rc == 2
    assert stderr.strip().count("\n") == 0 and words in stderr
    assert not out.exists()


@pytest.mark.parametrize("model", ["3d", "axisymmetric"])
def test_frames_land_on_the_extra_save_times(tmp_path, capsys, model):
    """``time.save_times`` adds frames at exactly those times (a figure's snapshot times), the
    regular grid of ``save_every`` staying where it was, and nothing past ``t_end``."""
    out = tmp_path / "x.h5"
    rc, _, err = run(
        [
            "run",
            "furrow_p4_a1",
            "-o",
            str(out),
            "--set",
            f"model={model}",
            "--set",
            "mesh.nodes=162",
            "--set",
            "time.scheme=euler",
            "--set",
            "time.dt=5e-3",
            "--set",
            "time.t_end=0.025",
            "--set",
            "time.save_times=[0.0035, 0.087, 0.02]",
        ],
        capsys,
    )
    assert rc == 0, err
    with open_output(out) as ds:
        np.testing.assert_allclose(ds["time"].values, [0.0, 0.0035, 0.01, 0.02, 0.025], rtol=0, atol=1e-12)


def test_check_names_the_centroid_gauge(capsys):
    rc, out, _ = run(["check", "furrow_p4_a1", "--set", "translation=centroid"], capsys)
    assert rc == 0 and "the centroid held (translation: centroid)" in out
