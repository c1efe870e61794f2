"""The set-up of a run (cortex_ti.simulation.setup): the relaxed start of a sheared scene
(``mesh.relax_start``).

Truths: geometry (the moved nodes stay on the sphere, their image on the sheared ellipsoid, no
triangle folds), the definition of the material point (the tension at a node is the pattern at
the node's undeformed position, i.e. at ``S^-1 x``), the conformal distortion falling under its
own gradient flow, and the rule refusing a mesh file.
"""

import subprocess
import sys

import numpy as np

from cortex_ti.dynamics.motion import MotionContext, conformal_distortion
from cortex_ti.physics.patterns import evaluate_active_stress
from cortex_ti.scene import load_scene
from cortex_ti.simulation import Simulation
from cortex_ti.surface.mesh import icosphere


def smallest_angle(points, faces):
    p = points[faces]
    cos = [
        np.sum((p[:, (k + 1) % 3] - p[:, k]) * (p[:, (k + 2) % 3] - p[:, k]), axis=1)
        / np.linalg.norm(p[:, (k + 1) % 3] - p[:, k], axis=1)
        / np.linalg.norm(p[:, (k + 2) % 3] - p[:, k], axis=1)
        for k in range(3)
    ]
    return float(np.degrees(np.arccos(np.max(cos))))


def test_relaxed_start_mends_the_sheared_triangles_and_keeps_the_material_points():
    """shear_075 at 642 nodes: the sheared icosphere's smallest angle 32.3 deg, relaxed 39.0
    (measured; bound 36). The start lies on the sheared ellipsoid (|S^-1 x| = 1 to round-off), the
    tension at each node is the ring pattern at S^-1 x, the distortion against the icosphere's own
    triangles falls by more than half, and no triangle turns over."""
    plain = Simulation(load_scene("shear_075", ["mesh.nodes=642"]))
    relaxed = Simulation(load_scene("shear_075", ["mesh.nodes=642", "mesh.relax_start=true"]))
    faces = relaxed.mesh.faces
    matrix = relaxed.settings.mesh.initial_map()
    inverse = np.linalg.inv(matrix)
    x = relaxed.mesh.points
    assert smallest_angle(plain.mesh.points, faces) < 33.0
    assert smallest_angle(x, faces) > 36.0
    u = x @ inverse.T
    np.testing.assert_allclose(np.linalg.norm(u, axis=1), 1.0, rtol=0, atol=1e-13)
    expected = evaluate_active_stress(u, list(relaxed.settings.patterns))
    np.testing.assert_allclose(relaxed.state0.fields["prescribed_tension"], expected, rtol=0, atol=1e-12)
    sphere = icosphere(642)
    ctx = MotionContext(faces, sphere.points)
    assert conformal_distortion(x, ctx).sum() < 0.5 * conformal_distortion(plain.mesh.points, ctx).sum()
    p = x[faces]
    assert np.all(np.einsum("tc,tc->t", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p.sum(1)) > 0)
    # the default: on with ALE motion (which would keep the sheared triangles), off with the paper's
    ale = Simulation(load_scene("shear_075", ["mesh.nodes=642", "mesh.motion=ale", "tension_transport=material"]))
    np.testing.assert_array_equal(ale.mesh.points, x)
    assert not plain.settings.mesh.relax_start
    # without a shear or transform there is nothing to mend: the icosphere as it is
    same = Simulation(load_scene("furrow_p4_a1", ["mesh.nodes=162", "mesh.relax_start=true"]))
    np.testing.assert_array_equal(same.mesh.points, icosphere(162).points)


def test_relax_start_with_a_mesh_file_is_one_line(tmp_path):
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "cortex_ti",
            "run",
            "shear_075",
            "--set",
            "mesh.nodes=null",
            "--set",
            "mesh.file=sphere.obj",
            "--set",
            "mesh.relax_start=true",
            "-o",
            str(tmp_path / "x.h5"),
        ],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 2 and "mesh.relax_start" in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1
