"""The ring off the equator (``center``, the ring's polar angle from its axis): its sphere mean and its
t = 0 flow on the sphere against independent truths.

Truths: the mean of the pattern written out and integrated in one dimension by adaptive quadrature
(``scipy.integrate.quad``: ``zeta_bar = 1/2 int zeta(theta) sin(theta) dtheta``); the exact spectral
sphere flow of that written-out tension (:func:`cortex_ti.truth.sphere_exact.sphere_flow`, derived
independently of the axisymmetric model, docs/derivations/sphere_exact.md).
"""

import numpy as np
import pytest
from scipy.integrate import quad

from cortex_ti.axisymmetric.run import AxisymmetricRun
from cortex_ti.physics.patterns import evaluate_active_stress, mean_over_sphere
from cortex_ti.scene import load_scene
from cortex_ti.truth.analytic import error_measures
from cortex_ti.truth.sphere_exact import sphere_flow

NO_BENDING = [
    "viscosity.bending=0",
    "viscosity.bending_bulk=0",
    "effects=[active_stress, shear_viscosity, bulk_viscosity, normal_balance, incompressibility]",
]
CENTER = 1.2  # rad: 0.37 rad (21 deg) toward the north pole


def eq59(theta, center=CENTER, zeta0=1.0, amplitude=3.0, sigma=10.0, p=4.0):
    """Eq. 59 with the ring's centre at ``center``, written out here."""
    return zeta0 + amplitude * np.exp(-sigma * np.abs(theta - center) ** p)


def exact_mean(center=CENTER):
    """``zeta_bar = 1/2 int_0^pi zeta sin(theta) dtheta`` by adaptive quadrature, split at the ring."""
    f = lambda t: eq59(t, center) * np.sin(t)  # noqa: E731
    return 0.5 * quad(f, 0.0, np.pi, epsabs=1e-13, epsrel=1e-13, limit=200, points=[center])[0]


RING = {"type": "ring", "zeta0": 1.0, "amplitude": 3.0, "sigma": 10.0, "p": 4, "center": CENTER}


def test_the_off_centre_ring_is_eq59_about_its_centre_and_its_mean_is_exact():
    theta = np.linspace(0.05, np.pi - 0.05, 40)
    phi = np.linspace(0.0, 2 * np.pi, 40)
    pts = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], -1)
    np.testing.assert_allclose(evaluate_active_stress(pts, [RING]), eq59(theta), rtol=1e-14)
    assert mean_over_sphere([RING]) == pytest.approx(exact_mean(), rel=1e-12)
    # the default centre is the equator: the paper's ring, unchanged
    default = {k: v for k, v in RING.items() if k != "center"}
    assert mean_over_sphere([default]) == pytest.approx(exact_mean(np.pi / 2), rel=1e-12)


def test_the_axisymmetric_t0_flow_of_an_off_centre_ring_is_the_exact_sphere_flow():
    """The full meridian (no up-down symmetry: the model detects it) at t = 0 against the exact spectral
    flow of the written-out tension; the pressure is 2 zeta_bar / R. Without bending viscosity: an
    off-centre ring has a degree-1 part, which with it has no exact solution in the velocity gauge
    (sphere_exact's L1Error)."""
    run = AxisymmetricRun(
        load_scene("furrow_p4_a3", ["model=axisymmetric", f"active_stress.0.center={CENTER}", *NO_BENDING])
    )
    ring, v = run.settings.patterns[0], run.settings.viscosity
    assert ring["center"] == CENTER and ring["amplitude"] == 3.0 and ring["p"] == 4
    res = run.solve()
    theta = np.linspace(0.0, np.pi, 101)
    pts = np.c_[np.sin(theta), 0.0 * theta, np.cos(theta)]

    def zeta(x):
        return eq59(np.arccos(np.clip(x[:, 2] / np.linalg.norm(x, axis=1), -1, 1)))

    v_exact, P, _ = sphere_flow(
        zeta,
        pts,
        eta_s=v.shear,
        eta_b=v.bulk,
        axis=(0, 0, 1),
        lmax=240,
        tol=1e-9,  # no bending viscosity
    )
    at = res.at(theta)
    v_ax = np.stack([at["v_r"], np.zeros_like(theta), at["v_z"]], -1)
    assert error_measures(v_ax, v_exact)[1] <= 1e-8
    assert res.P == pytest.approx(P, rel=1e-10)
    assert P == pytest.approx(2.0 * exact_mean(), rel=1e-10)
    # the flow is not up-down symmetric: the ring's side moves in more (a check that the centre took effect)
    assert abs(at["v_n"][30] - at["v_n"][-31]) > 0.1
