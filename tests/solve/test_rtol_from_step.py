"""``solver.rtol`` unset: for ``rayleigh_p2`` under ``bdf2`` / ``bdf3`` the GMRES tolerance follows the
step's (``time.tol / 100``, never below 1e-10; :func:`cortex_ti.scene.rules.solver_rtol`), everywhere
else it stays 1e-10.

The run check: a ``bdf3`` furrow at 162 nodes with the derived tolerance against the same run with
``solver.rtol = 1e-12`` (the solves exact to round-off's scale). Each step's displacement error budget
is ``time.tol``; a solve's velocity error ``rtol`` relative, times the step's ``dt |v|`` (< 0.01 R0
here), is ``~1e-2 rtol = 1e-4 tol`` a step where it enters, and it is carried on by the later steps.
The bound asserted: ``1e-2 tol`` a step, summed over the steps (measured: 2.7e-6 of it here; the
2562-node furrow to t = 3, 100 steps at tol 1e-6, differs by 7.2e-8 at the nodes, 7e-4 of it, 14x
inside the bound; docs/validation/curved_cost.md, "The solve's tolerance"). The runs must differ at all (the
derived tolerance is in force).
"""

import numpy as np
import pytest

from cortex_ti.scene import load_scene
from cortex_ti.scene.rules import DEFAULT_RTOL, RTOL_PER_TOL

P2 = ["numerics.formulation=rayleigh_p2", "numerics.fit=quartic"]
RUN = ["mesh.nodes=162", "time.scheme=bdf3", "time.t_end=0.3", "time.save_every=0.05", "time.tol=1e-5"]


@pytest.mark.parametrize(
    "sets, expected",
    [
        ([], DEFAULT_RTOL),  # rayleigh_p1 keeps 1e-10 (its runs bitwise as before)
        (["time.scheme=bdf3"], DEFAULT_RTOL),
        (P2 + ["time.scheme=euler"], DEFAULT_RTOL),  # no step tolerance to follow
        (P2 + ["time.scheme=bdf3", "time.tol=1e-6"], 1e-6 / RTOL_PER_TOL),
        (P2 + ["time.scheme=bdf2", "time.tol=4e-6"], 4e-6 / RTOL_PER_TOL),
        (P2 + ["time.scheme=bdf3", "time.tol=1e-9"], DEFAULT_RTOL),  # never below 1e-10
        (P2 + ["time.scheme=bdf3", "solver.rtol=1e-12"], 1e-12),  # set: taken as it is
    ],
)
def test_the_resolved_tolerance(sets, expected):
    assert load_scene("furrow_p4_a1", sets).settings.solver.rtol == pytest.approx(expected, rel=1e-12)


def test_the_default_tolerance_follows_the_scheme_default():
    """bdf3's own default tolerance at 2562 nodes (1e-6): 1e-8."""
    s = load_scene("furrow_p4_a1", [*P2, "time.scheme=bdf3", "mesh.nodes=2562"]).settings
    assert s.solver.rtol == pytest.approx(s.time.tol / RTOL_PER_TOL, rel=1e-12)
    assert s.solver.rtol == pytest.approx(1e-8, rel=1e-12)


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    from cortex_ti.io import Trajectory
    from cortex_ti.simulation import Simulation

    out = {}
    for name, extra in (("derived", []), ("exact", ["solver.rtol=1e-12"])):
        sim = Simulation(load_scene("furrow_p4_a1", [*P2, *RUN, *extra]))
        path = tmp_path_factory.mktemp("rtol") / f"{name}.h5"
        with Trajectory(sim.run(path, progress=False)) as tr:
            out[name] = (tr.ds["points"].values.copy(), tr.ds["dt"].values.copy(), sim.settings)
    return out


def test_the_derived_tolerance_leaves_the_answer_within_the_time_tolerance(runs):
    a, dt_a, settings = runs["derived"]
    b, _, _ = runs["exact"]
    assert settings.solver.rtol == pytest.approx(1e-5 / RTOL_PER_TOL)
    steps = settings.time.t_end / dt_a[dt_a > 0].min()  # at most this many steps
    diff = np.abs(a - b).max()
    print(f"rtol {settings.solver.rtol:g}: {diff:.2e} = {diff / (settings.time.tol * steps):.1e} of tol x steps")
    assert 0.0 < diff < 1e-2 * settings.time.tol * steps, diff
