"""The lobe mode's rate (cortex_ti.axisymmetric.lobe.lobe_rate) on a sphere under a uniform tension,
against the closed form of its shape modes (cortex_ti.truth.helfrich_sphere.rate, lambda_l = -M_l K_l;
docs/derivations/bending_rigidity.md): the odd modes' slowest is l = 3, and l = 2, slower still
(-4.0 against -12.1 with kappa = 0.1), is even and must be left out."""

from __future__ import annotations

import numpy as np
import pytest

from cortex_ti.axisymmetric.evolve import simulate
from cortex_ti.axisymmetric.lobe import lobe_rate
from cortex_ti.truth.helfrich_sphere import rate


def _uniform(th):
    return np.ones_like(np.asarray(th, dtype=float))


@pytest.mark.parametrize("kappa", [0.0, 0.1])
def test_sphere_odd_rate_is_l3(kappa):
    box = {}
    simulate(
        _uniform,
        eta_s=1.0,
        eta_b=1.0,
        eta_bar=0.0,
        eta_bar_b=0.0,
        t_end=1e-6,
        save_times=[0.0],
        n=16,
        rtol=1e-8,
        parametrization="adaptive",
        on_save=lambda frame, y: box.setdefault("y", y.copy()),
        kappa=kappa,
        interpolate=True,
    )
    truth = rate(3, kappa=kappa, eta_s=1.0, eta_b=1.0, zeta0=1.0)
    assert rate(2, kappa=kappa, eta_s=1.0, eta_b=1.0, zeta0=1.0) > truth  # the even l = 2 would win
    # spectral in the degree: 16 points resolve l = 3 to round-off (measured 1e-12; margin 1e-8)
    assert lobe_rate(_uniform, box["y"], kappa=kappa) == pytest.approx(truth, rel=1e-8)
