"""The closed-form stiffness of the sphere's shape modes under Helfrich rigidity
(:mod:`cortex_ti.truth.helfrich_sphere`) against a second, numerical derivation: the Lagrangian
``E + zeta0 A - P0 V`` of the shape ``r(theta) = R + eps P_l(cos theta)`` by Gauss-Legendre
quadrature (curvatures from the polar form of the meridian, no code of the package), its second
derivative in ``eps`` by a fourth-order central difference, compared with ``K_l oint P_l^2 dA``.
Its first derivative at eps = 0 is the first variation: zero for the base pressure ``P0`` (the sphere
is an equilibrium), which checks ``base_pressure``. Measured: relative agreement 2.3e-10 at worst over
the cases below (difference step h = 1e-3, error ~h^4)."""

import numpy as np
import pytest
from numpy.polynomial import legendre as npl

from cortex_ti.truth.helfrich_sphere import base_pressure, mobility, stiffness


def _lagrangian(eps, l, R, kappa, c0, zeta0, P0, nq=200):
    x, w = npl.leggauss(nq)  # x = cos(theta)
    th = np.arccos(x)
    s, c = np.sin(th), x
    coef = np.zeros(l + 1)
    coef[l] = 1.0
    P = npl.legval(x, coef)
    dP = npl.legval(x, npl.legder(coef))
    d2P = npl.legval(x, npl.legder(coef, 2))
    r = R + eps * P
    r1 = eps * (-s * dP)  # d r / d theta
    r2 = eps * (s * s * d2P - c * dP)
    T = np.hypot(r, r1)
    k1 = (r * r + 2 * r1 * r1 - r * r2) / T**3  # curvature of the polar meridian (sphere: 1/R)
    Trho, Tz = r1 * s + r * c, r1 * c - r * s  # d(rho, z)/d theta
    n_rho = -Tz / T  # outward normal's rho component
    rho = r * s
    k2 = n_rho / rho
    dA = 2 * np.pi * rho * T / s  # per d(cos theta) = sin theta d theta
    E = 0.5 * kappa * np.sum(w * (k1 + k2 - c0) ** 2 * dA)
    A = np.sum(w * dA)
    V = 2 * np.pi / 3 * np.sum(w * r**3)
    assert np.allclose(Trho * Trho + Tz * Tz, T * T)
    return E + zeta0 * A - P0 * V


@pytest.mark.parametrize("l", [2, 3, 4, 6])
@pytest.mark.parametrize("kappa,c0,zeta0,R", [(1.0, 0.0, 0.0, 1.0), (0.3, 1.5, 0.7, 1.3), (2.0, -0.8, -0.2, 0.9)])
def test_stiffness_is_the_second_variation_of_the_energy(l, kappa, c0, zeta0, R):
    P0 = base_pressure(kappa=kappa, c0=c0, zeta0=zeta0, radius=R)
    f = lambda e: _lagrangian(e, l, R, kappa, c0, zeta0, P0)  # noqa: E731
    h = 1e-3
    first = (f(-2 * h) - 8 * f(-h) + 8 * f(h) - f(2 * h)) / (12 * h)
    second = (-f(-2 * h) + 16 * f(-h) - 30 * f(0.0) + 16 * f(h) - f(2 * h)) / (12 * h * h)
    norm = 4 * np.pi * R**2 / (2 * l + 1)  # oint P_l^2 dA
    K = stiffness(l, kappa=kappa, c0=c0, zeta0=zeta0, radius=R)
    scale = abs(K) * norm + kappa * l**4 / R**2 + abs(zeta0) * l**2
    # the sphere is an equilibrium: the first variation vanishes (to the difference error ~ h^4 f^(5))
    assert abs(first) <= 1e-8 * scale
    assert abs(second - K * norm) <= 1e-6 * scale


def test_mobility_limits():
    """Independent limits: without bending viscosity and with eta_b -> infinity the shell is a
    2D incompressible fluid, M_l = L R^2 / (4 eta_s (L - 2)); a bending viscosity alone gives 1/kappa_l."""
    for l in (2, 3, 5):
        L = l * (l + 1)
        assert mobility(l, eta_s=1.0, eta_b=1e12) == pytest.approx(L / (4 * (L - 2)), rel=1e-10)
        assert mobility(l, eta_s=1.0, eta_b=0.0, eta_bar=0.5, eta_bar_b=0.0) == pytest.approx(1 / 4.0)
