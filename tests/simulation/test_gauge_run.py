"""A whole run does not depend on where the cell is nor on how its free translation is fixed
(issue 33: the two translation gauges' shapes drifted apart as t^2).

With the tension carried by the material and lagrangian nodes, the continuum problem is invariant
under translations, and the two gauges (``translation: mean_velocity`` / ``centroid``) differ by a
rigid translation of the flow, so the nodes of the two runs differ by one vector at every time.
The discrete system keeps that exactly when the rigid motions are the kernel of the dissipation
and the gauges' multipliers push along the same rows (cortex_ti.physics.terms.constraints): the
pressure on the Meyer areas and the balanced active force have an O(h^2) net force, which the
centroid gauge used to take up as a force density of its own (docs/validation/formulations.md,
"The two gauges over a run").

Truths: the invariances themselves. Bounds from the error each run is allowed: an explicit step
is the same solve on a translated shape, so the runs agree to the solver's relative tolerance per
solve and rounding; with the adaptive second-order scheme the two gauges take different steps
(its error estimate sees the translation), and each run is within its tolerance per step of the
exact one, so they agree to twice the sum of the per-step tolerance.
"""

import copy

import numpy as np
import pytest

from cortex_ti.dynamics.state import State
from cortex_ti.io import Trajectory
from cortex_ti.scene import load_scene, scene_from_dict
from cortex_ti.simulation import Simulation

#: the issue's scene: the furrow's ring plus 0.3 Y_10 (no up-down symmetry: the gauges differ by a
#: translation along z), carried by lagrangian nodes, no bending viscosity, the exact energy gradient
#: as the active force or the default balanced one
RING_Y10 = {"type": "harmonics", "terms": [{"l": 1, "m": 0, "coeff": 0.3}]}
EPS = np.finfo(float).eps


def scene(gauge, force, sets):
    base = load_scene(
        "furrow_p4_a1",
        [
            "mesh.nodes=162",
            "mesh.motion=lagrangian",
            "tension_transport=material",
            f"numerics.active_force={force}",
            f"translation={gauge}",
            *sets,
        ],
    ).data
    data = copy.deepcopy(base)
    data["effects"] = [e for e in data["effects"] if e != "bending_viscosity"]
    data["viscosity"].update(bending=0.0, bending_bulk=0.0)
    data["active_stress"] = data["active_stress"] + [RING_Y10]
    return scene_from_dict(data)


def run(tmp_path, name, sc, shift=None):
    """The frames' points of a run, its steps and its largest speed."""
    sim = Simulation(sc)
    if shift is not None:  # the whole start translated, the tension with its nodes
        sim.use_mesh(sim.mesh.points + shift, sim.mesh.faces)
        sim.state0 = State(sim.state0.points + shift, sim.state0.fields, sim.state0.faces)
    path = sim.run(tmp_path / f"{name}.h5", progress=False)
    with Trajectory(path) as tr:
        points = tr.ds["points"].values.copy()
        vmax = float(np.abs(tr.ds["velocity"].values).max())
    return points, sim.stats.steps, vmax


def non_rigid(a, b):
    """Largest difference of the frames ``a`` and ``b`` (T, N, 3) once each is centred."""
    return float(np.abs((a - a.mean(1, keepdims=True)) - (b - b.mean(1, keepdims=True))).max())


EXPLICIT = [
    "time.scheme=euler",
    "time.dt=2e-3",
    "time.implicit_tension=false",
    "time.t_end=0.1",
    "time.save_every=0.05",
]


@pytest.mark.parametrize("force", ["gradient", "balanced"])
def test_explicit_runs_of_the_two_gauges_differ_by_a_translation(tmp_path, force):
    """50 explicit steps: the nodes of the two gauges' runs differ by one vector per frame (the
    gauges' flows differ by 0.05 R0 / t_a), to the solver's tolerance per solve and rounding.
    Measured 5.2e-14 (both forces) against the bound 2.9e-11; before the gauges' multipliers
    pushed along the same rows, 9.7e-6 (gradient) and 1.9e-6 (balanced)."""
    a, steps, vmax = run(tmp_path, "mean", scene("mean_velocity", force, EXPLICIT))
    b, _, _ = run(tmp_path, "centroid", scene("centroid", force, EXPLICIT))
    shift = np.abs((a - b).mean(1)).max()
    assert shift > 1e-3  # the gauges do differ by a translation here
    rtol = scene("mean_velocity", force, EXPLICIT).settings.solver.rtol
    bound = 10 * (0.1 * rtol * vmax + steps * EPS)
    assert non_rigid(a, b) < bound


def test_an_explicit_run_translated_is_the_run_translated(tmp_path):
    """The start moved by a vector of 0.6 R0 (the tension moved with its nodes): the same run, moved,
    to the solver's tolerance per solve and rounding at the translated coordinates."""
    shift = np.array([0.3, -0.2, 0.5])
    a, steps, vmax = run(tmp_path, "here", scene("centroid", "balanced", EXPLICIT))
    b, _, _ = run(tmp_path, "there", scene("centroid", "balanced", EXPLICIT), shift=shift)
    rtol = scene("centroid", "balanced", EXPLICIT).settings.solver.rtol
    bound = 10 * (0.1 * rtol * vmax + steps * EPS * (1 + np.linalg.norm(shift)))
    assert np.abs(b - shift - a).max() < bound


@pytest.mark.slow
def test_adaptive_bdf2_runs_of_the_two_gauges_differ_by_a_translation(tmp_path):
    """bdf2 with time.tol = 1e-9 R0 per step to t = 0.1 (the issue's scheme; its first, uncentred
    semi-implicit step taken short, 1e-5, whose drag on the translation is O(dt) and is not what
    the tolerance controls): each run is within tol per step of the exact one, so the two within
    2 tol times the steps (250 each: measured 5.2e-10 against the bound 5e-7; before: 9.9e-6)."""
    sets = ["time.tol=1e-9", "time.dt=1e-5", "time.t_end=0.1", "time.save_every=0.05"]
    a, steps_a, _ = run(tmp_path, "mean", scene("mean_velocity", "gradient", sets))
    b, steps_b, _ = run(tmp_path, "centroid", scene("centroid", "gradient", sets))
    assert non_rigid(a, b) < 1e-9 * (steps_a + steps_b)
