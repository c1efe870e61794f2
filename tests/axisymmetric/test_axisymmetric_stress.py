"""The axisymmetric model's in-plane stress (``SimulationResult.principal_stress``, ``min_stress``).

Truth: the 3D code's ``surface_stress`` (the P1 strain rate on each flat triangle, an independent
computation) on the revolved meridian converges to it at first order in the triangle size (the
smallest value over triangles samples a smooth field at their centroids); and the compression
warning follows the model's well-posedness (no bending resistance), not the numbers alone.
"""

import logging
from types import SimpleNamespace

import numpy as np
import pytest

from cortex_ti.analysis.diagnostics import surface_stress
from cortex_ti.axisymmetric.evolve import revolve, simulate
from cortex_ti.axisymmetric.run import AxisymmetricRun
from cortex_ti.scene import load_scene


def ring(theta):
    return 1.0 + 6.0 * np.exp(-10.0 * np.abs(np.asarray(theta) - np.pi / 2) ** 4)


def revolved_min(res, i, n_u, eta_s, eta_b):
    e = res.evaluate(i, np.linspace(0.0, np.pi, n_u), coordinate="sigma")
    pts, tri, where = revolve(e["r"], e["z"], 2 * n_u)
    j, phi = where[:, 0].astype(int), where[:, 1]
    vel = np.stack([e["v_r"][j] * np.cos(phi), e["v_r"][j] * np.sin(phi), e["v_z"][j]], axis=1)
    return float(surface_stress(pts, tri, vel, e["zeta"][j], eta_s, eta_b)[:, 0].min())


@pytest.mark.slow
def test_the_smallest_stress_is_the_revolved_surfaces():
    """A ring of amplitude 6 on the sphere and after 0.5 t_a: the first-order extrapolation of the
    revolved P1 minimum (201 and 401 meridian samples) lands on ``min_stress`` far closer than
    either sample (measured at t = 0: 3.7087, 3.8031 -> 3.8975 against 3.89796; t = 0.5: 0.5593,
    0.5900 -> 0.6206 against 0.62169), and two parametrisations agree (5e-6 at t = 0.5)."""
    runs = [
        simulate(ring, eta_s=1.0, eta_b=0.5, eta_bar=0.0, eta_bar_b=0.0, t_end=0.5, n=48, rtol=1e-10, parametrization=p)
        for p in ("lagrangian", "adaptive")
    ]
    for i in (0, 1):
        coarse, fine = (revolved_min(runs[1], i, n, 1.0, 0.5) for n in (201, 401))
        extrapolated = 2.0 * fine - coarse
        got = runs[1].min_stress[i]
        assert abs(extrapolated - got) < abs(fine - got) / 5
        assert abs(runs[0].min_stress[i] - got) < 1e-4
    # the pattern's tension is the stress of the sphere at rest plus the flow it drives: not zeta alone
    assert abs(runs[1].min_stress[0] - 1.0) > 0.1


def test_compression_is_reported_without_bending_resistance(caplog):
    """One warning line from the first compressed frame when nothing resists bending; none with
    bending viscosity (which damps the short waves while its margin is positive)."""
    res = SimpleNamespace(
        t=np.array([0.0, 1.0, 2.0]),
        min_stress=np.array([0.5, -0.2, -0.4]),
        neck_radius=np.array([np.inf, 0.45, 0.4]),
        furrow_radius=np.array([1.0, 0.45, 0.4]),
    )
    over = ["model=axisymmetric", "mesh.remesh.min_angle=null"]
    with caplog.at_level(logging.WARNING, logger="cortex_ti.axisymmetric.run"):
        AxisymmetricRun(load_scene("myosin_constriction", over))._warn_compressed(res)
        AxisymmetricRun(load_scene("myosin_ring", ["model=axisymmetric"]))._warn_compressed(res)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "from t = 1 (neck 0.45 R0) the cortex is compressed" in lines[0], lines


def test_a_negative_myosin_density_is_reported(caplog):
    """The continuum keeps the myosin density >= 0 (carried, diluted, diffused and turned over toward
    c0 > 0): one warning from the first frame where it is negative past round-off (a ring that gathers
    it faster than n points resolve: measured on cytokinesis_rigid's meridian at n = 48 with normal
    points, -2.1 at the pole by t = 0.3, while the 3D run stays >= 0), none for round-off or without a field."""
    over = ["model=axisymmetric", "mesh.remesh.min_angle=null"]
    run = AxisymmetricRun(load_scene("myosin_constriction", over))
    t = np.array([0.0, 0.1, 0.2])
    fine = np.array([[1.0, 1.0, 1.0], [0.5, 2.0, -1e-9], [0.2, 5.0, 1e-3]])
    bad = np.array([[1.0, 1.0, 1.0], [0.5, 2.0, 0.1], [-0.3, 5.0, 0.2]])
    with caplog.at_level(logging.WARNING, logger="cortex_ti.axisymmetric.run"):
        run._warn_negative_myosin(SimpleNamespace(t=t, c=fine))
        run._warn_negative_myosin(SimpleNamespace(t=t, c=None))
        assert not caplog.records
        run._warn_negative_myosin(SimpleNamespace(t=t, c=bad))
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "from t = 0.2 the myosin density is negative (smallest -0.3, largest 5)" in lines[0], (
        lines
    )
    assert "the frames after it" in lines[0], lines
    # a myosin that makes no tension (zeta0 = 0, as cytokinesis_rigid's): the shape does not depend on it
    caplog.clear()
    tracer = AxisymmetricRun(load_scene("myosin_constriction", [*over, "fields.myosin.tension.zeta0=0"]))
    with caplog.at_level(logging.WARNING, logger="cortex_ti.axisymmetric.run"):
        tracer._warn_negative_myosin(SimpleNamespace(t=t, c=bad))
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 1 and "its values (not the shape: its tension law's zeta0 is 0) after it" in lines[0], lines
