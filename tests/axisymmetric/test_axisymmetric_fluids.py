"""The axisymmetric cortex between a cytoplasm and a medium (cortex_ti.axisymmetric.stokes) against
the fluid-sphere truth (Lamb's solution, cortex_ti.truth.fluid_sphere, derived independently: no
boundary integral there) and against invariants of the single layer on shapes without a closed form."""

import numpy as np
import pytest
from numpy.polynomial import legendre as leg

from cortex_ti.axisymmetric.balance import ForceBalance, check_visc
from cortex_ti.axisymmetric.spectral import Spectral, geometry
from cortex_ti.axisymmetric.stokes import layers, single_layer, with_fluids
from cortex_ti.truth import fluid_sphere as fs


def _legendre(l, u):
    c = np.zeros(l + 1)
    c[l] = 1.0
    x = np.cos(u)
    return leg.legval(x, c), -np.sin(u) * leg.legval(x, leg.legder(c))


def _solve(sp, r, z, zeta, mu, body_force=0.0, visc=(1.0, 1.0, 5e-4, 2.5e-3), far_field=None):
    """``mu``: a viscosity for both fluids or ``(mu_in, mu_out)``."""
    mu_in, mu_out = (mu, mu) if np.isscalar(mu) else mu
    g = geometry(sp, r, z)
    g["zeta"] = zeta
    A, b = ForceBalance(sp, check_visc(*visc, 1.0)).assemble(g)
    A2, b2 = with_fluids(A, b, sp, g, mu_in=mu_in, mu_out=mu_out, body_force=body_force, far_field=far_field)
    x = np.linalg.solve(A2, b2)
    return x[: sp.n], x[sp.n : 2 * sp.n], g


MUS = [0.1, 1.0, 10.0, (0.3, 2.0), (5.0, 0.5)]


@pytest.mark.parametrize("mu", MUS)
@pytest.mark.parametrize("l,symmetric", [(1, False), (2, True), (3, False)])
def test_flow_of_a_tension_harmonic_is_lambs(l, symmetric, mu):
    """zeta = 1.3 + P_l on the unit sphere with bending viscosity: v = alpha grad_s P_l + beta P_l n.
    Both sides are exact for a degree-l field (the quadrature integrates it to round-off, measured
    ~1e-14 at n = 16): the bound is round-off times the system's size."""
    sp = Spectral(16, symmetric)
    P, dP = _legendre(l, sp.u)
    vs, vn, _ = _solve(sp, np.sin(sp.u), np.cos(sp.u), 1.3 + P, mu)
    mu_in, mu_out = (mu, mu) if np.isscalar(mu) else mu
    alpha, beta = fs.flow_coefficients(
        l, mu_in=mu_in, mu_out=mu_out, eta_s=1.0, eta_b=1.0, eta_bar=5e-4, eta_bar_b=2.5e-3
    )
    assert np.abs(vn - beta * P).max() <= 1e-11
    assert np.abs(vs - alpha * dP).max() <= 1e-11


@pytest.mark.parametrize("mu", MUS)
def test_sedimentation_is_boussinesq_scriven(mu):
    """A body force on the cytoplasm: the sphere translates (v_n = U cos u) at the terminal velocity."""
    sp = Spectral(16, False)
    _, vn, _ = _solve(sp, np.sin(sp.u), np.cos(sp.u), np.ones(16), mu, body_force=1.0, visc=(1.0, 1.0, 0.0, 0.0))
    mu_in, mu_out = (mu, mu) if np.isscalar(mu) else mu
    want = fs.boussinesq_scriven_velocity(1.0, mu_in=mu_in, mu_out=mu_out, eta_b=1.0)
    assert np.abs(vn - want * np.cos(sp.u)).max() <= 1e-11 * max(1.0, want)


def test_reciprocal_identities_hold_for_lambs_fields():
    """On the sphere, Lamb's inner and outer fields of degree 1-4 (velocity a P_l n + b dP_l e_u,
    traction (mu/R) K (a, b)) satisfy u = (S f_in / mu + D u) / 4 pi and u = -(S f_out / mu + D u) / 4 pi:
    the layers' signs and the double layer's principal value, to round-off."""
    sp = Spectral(16, False)
    S, D = layers(sp, np.sin(sp.u), np.cos(sp.u))

    def stacked(l, a, b):
        P, dP = _legendre(l, sp.u)
        u = sp.u
        return np.concatenate([a * P * np.sin(u) + b * dP * np.cos(u), a * P * np.cos(u) - b * dP * np.sin(u)])

    for l in (1, 2, 3, 4):
        k_in, k_out = fs.traction_matrices(l)
        for a, b in ((1.0, 0.3), (-0.2, 0.9)):
            v = stacked(l, a, b)
            assert np.abs((S @ stacked(l, *(k_in @ [a, b])) + D @ v) / (4 * np.pi) - v).max() <= 1e-11
            assert np.abs(-(S @ stacked(l, *(k_out @ [a, b])) + D @ v) / (4 * np.pi) - v).max() <= 1e-11


@pytest.mark.parametrize("l", [2, 3])
def test_shape_mode_relaxes_at_lambs_rate(l):
    """r = 1 + eps P_l under a uniform tension: the normal speed's P_l part is lambda_l eps + O(eps^2)
    (the shape is computed, not linearised: curvature, normal and single layer of the deformed
    surface). The O(eps) remainder must fall tenfold with eps."""
    lam = fs.relaxation_rate(l, tension=1.0, mu_in=0.2, mu_out=0.5, eta_s=1.0, eta_b=1.0)
    errs = []
    for eps in (1e-3, 1e-4):
        sp = Spectral(16, l % 2 == 0)
        P, _ = _legendre(l, sp.u)
        rad = 1.0 + eps * P
        _, vn, _ = _solve(
            sp, rad * np.sin(sp.u), rad * np.cos(sp.u), np.ones(16), (0.2, 0.5), visc=(1.0, 1.0, 0.0, 0.0)
        )
        w = sp.wR * np.sin(sp.u)
        errs.append(abs((w @ (vn * P)) / (w @ (P * P)) / eps - lam))
    assert errs[1] <= 3e-4 * abs(lam)
    assert errs[1] <= 0.15 * errs[0] + 1e-10


@pytest.mark.parametrize("shape", ["prolate", "furrow"])
def test_single_layer_invariants_on_deformed_shapes(shape):
    """For any closed surface a uniform normal density moves nothing (S n = 0: it is a pressure) and
    every single-layer velocity conserves the enclosed volume. Spectral convergence on a smooth
    shape (measured: prolate 1.4e-7, 4.3e-10, 1.6e-12 at n = 16, 24, 32; the steep furrow 8e-4,
    5.6e-5, 6.1e-6 at n = 16, 32, 48)."""
    n = 32
    sp = Spectral(n, False)
    u = sp.u
    if shape == "prolate":
        r, z, bound = 0.8 * np.sin(u), 1.4 * np.cos(u), 1e-10
    else:
        rad = 1.0 - 0.35 * np.exp(-10.0 * (u - np.pi / 2) ** 2)
        r, z, bound = rad * np.sin(u), 1.1 * rad * np.cos(u), 2e-4
    g = geometry(sp, r, z)
    nr, nz = -g["zs"], g["rs"]
    S = single_layer(sp, r, z)
    assert np.abs(S @ np.concatenate([nr, nz])).max() / (8 * np.pi) <= bound
    v = -S @ np.concatenate([np.sin(u) * np.cos(u) ** 2, np.cos(u) ** 3 + 0.3]) / (8 * np.pi)
    flux = 2 * np.pi * sp.wR @ ((v[:n] * nr + v[n:] * nz) * g["r"] * g["h"])
    assert abs(flux) <= bound


@pytest.mark.parametrize("mu", [1.0, (0.3, 2.0), (5.0, 0.5)])
def test_far_field_extension_and_uniform_flow(mu):
    """u_inf = E (-r/2 e_r + z e_z): q = n.E.n = E P_2, and the surface moves with (a q n + b R grad q) of
    strain_response; a uniform flow along the axis carries the cell along unchanged (Faxén)."""
    mu_in, mu_out = (mu, mu) if np.isscalar(mu) else mu
    sp = Spectral(16, False)
    r, z = np.sin(sp.u), np.cos(sp.u)
    E = 0.7
    vs, vn, _ = _solve(
        sp, r, z, np.ones(16), mu, visc=(1.0, 1.0, 0.0, 0.0), far_field=np.concatenate([-E * r / 2, E * z])
    )
    a, b = fs.strain_response(mu_in=mu_in, mu_out=mu_out, eta_s=1.0, eta_b=1.0)
    P, dP = _legendre(2, sp.u)
    assert np.abs(vn - a * E * P).max() <= 1e-11
    assert np.abs(vs - b * E * dP).max() <= 1e-11
    U = 0.4
    vs, vn, _ = _solve(
        sp, r, z, np.ones(16), mu, visc=(1.0, 1.0, 0.0, 0.0), far_field=np.concatenate([0 * r, U + 0 * z])
    )
    assert np.abs(vn - U * np.cos(sp.u)).max() <= 1e-11
    assert np.abs(vs + U * np.sin(sp.u)).max() <= 1e-11
