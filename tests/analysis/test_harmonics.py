"""The spherical-harmonic content of a nodal field, against exact harmonics and an exact integral."""

import math

import numpy as np
import pytest

from cortex_ti.analysis.harmonics import degree_amplitudes, growth_rate, harmonic_coefficients
from cortex_ti.surface.mesh import icosphere
from cortex_ti.truth.sphere_exact import real_sph_harm


def test_a_combination_of_harmonics_is_reproduced_exactly_wherever_the_cell_sits():
    """The weighted least squares reproduces any field in the span of the harmonics up to lmax (an
    algebraic identity, round-off only), and the directions are taken from the area centroid, so a
    translated cell has the same coefficients."""
    m = icosphere(642)
    shift = np.array([0.3, -0.1, 0.2])
    f = 1.0 + 0.01 * real_sph_harm(2, 0, m.points) - 0.02 * real_sph_harm(3, 1, m.points)
    for pts in (m.points, m.points + shift):
        a = harmonic_coefficients(pts, m.faces, f, lmax=4)
        assert a[0][0] == pytest.approx(math.sqrt(4 * math.pi), abs=1e-12)
        assert a[2][2] == pytest.approx(0.01, abs=1e-13) and a[3][4] == pytest.approx(-0.02, abs=1e-13)
        assert np.abs(np.delete(np.concatenate(list(a.values())), [0, 6, 13])).max() < 1e-13
        assert degree_amplitudes(pts, m.faces, f, 4)[[1, 4]].max() < 1e-13


def test_a_smooth_field_converges_at_second_order_to_its_integral():
    """``exp(z)`` on the unit sphere: ``a_10 = oint exp(z) Y_10 = sqrt(3/4pi) 2pi (2/e)``; the lumped
    dual areas are a second-order quadrature, so the error falls ~4x per refinement (h halves)."""
    exact = math.sqrt(3.0 / (4.0 * math.pi)) * 2.0 * math.pi * 2.0 / math.e
    err = []
    for n in (642, 2562):
        m = icosphere(n)
        err.append(abs(harmonic_coefficients(m.points, m.faces, np.exp(m.points[:, 2]), 6)[1][1] - exact))
    assert err[0] < 1e-2 * exact
    assert 3.0 < err[0] / err[1] < 5.0


def test_growth_rate_of_an_exponential():
    t = np.linspace(2.0, 6.0, 9)
    assert growth_rate(t, 1e-3 * np.exp(-0.3672 * t)) == pytest.approx(-0.3672, rel=1e-12)
    with pytest.raises(ValueError, match="two frames"):
        growth_rate([1.0], [1.0])
