"""The fluid-sphere truth (cortex_ti.truth.fluid_sphere) against what it does not use: the
viscous dissipation of Lamb's fields integrated over the fluid volume, the literature's closed forms
(Stokes, Hadamard-Rybczynski, Boussinesq-Scriven, Taylor's drop), and the vacuum truth
(sphere_exact) in the limit of vanishing fluid viscosities."""

import math

import numpy as np
import pytest
from numpy.polynomial import legendre as leg

from cortex_ti.truth import fluid_sphere as fs
from cortex_ti.truth import sphere_exact


def _dissipation(l, a, b, inside, R=1.0, mu=1.0, n=40):
    """2 mu int e:e dV of the Stokes field of degree l (m = 0) taking the surface velocity
    a P_l e_r + b dP_l/dtheta e_theta, by Gauss quadrature (exact for these polynomial integrands).
    Stream function f(r) = c1 r^p1 + c2 r^p2; u_r = L f / r^2 P, u_theta = f' / r dP/dtheta."""
    L = l * (l + 1)
    p1, p2 = (l + 1, l + 3) if inside else (-l, 2 - l)
    # surface values: L f(R) / R^2 = a, f'(R) / R = b
    M = np.array([[L * R ** (p1 - 2), L * R ** (p2 - 2)], [p1 * R ** (p1 - 2), p2 * R ** (p2 - 2)]])
    c1, c2 = np.linalg.solve(M, [a, b])

    def f(r, k=0):
        out = 0.0
        for c, p in ((c1, p1), (c2, p2)):
            coef = c
            for j in range(k):
                coef = coef * (p - j)
            out = out + coef * r ** (p - k)
        return out

    x, w = np.polynomial.legendre.leggauss(n)
    if inside:
        r = 0.5 * R * (x + 1.0)
        wr = 0.5 * R * w * r**2
    else:  # r = R / s, s in (0, 1]
        s = 0.5 * (x + 1.0)
        r = R / s
        wr = 0.5 * w * R**3 / s**4
    mu_, wt = np.polynomial.legendre.leggauss(n)  # cos(theta)
    th = np.arccos(mu_)
    cl = np.zeros(l + 1)
    cl[l] = 1.0
    P = leg.legval(mu_, cl)
    dP = leg.legval(mu_, leg.legder(cl))  # dP/dmu
    d2P = leg.legval(mu_, leg.legder(cl, 2))
    sin = np.sin(th)
    Pt = -sin * dP  # dP/dtheta
    Ptt = sin**2 * d2P - mu_ * dP  # d2P/dtheta2
    R_, S = np.meshgrid(r, np.arange(n), indexing="ij")
    rr = r[:, None]
    F, F1, F2 = f(rr), f(rr, 1), f(rr, 2)
    ur = L * F / rr**2 * P
    ut = F1 / rr * Pt
    dur_dr = L * (F1 / rr**2 - 2 * F / rr**3) * P
    dur_dt = L * F / rr**2 * Pt
    dut_dt = F1 / rr * Ptt
    d_ut_over_r_dr = (F2 / rr**2 - 2 * F1 / rr**3) * Pt
    e_rr = dur_dr
    e_tt = dut_dt / rr + ur / rr
    e_pp = ur / rr + ut * (mu_ / sin) / rr
    e_rt = 0.5 * (rr * d_ut_over_r_dr + dur_dt / rr)
    ee = e_rr**2 + e_tt**2 + e_pp**2 + 2 * e_rt**2
    return 2.0 * mu * 2.0 * math.pi * float(np.einsum("i,ij,j->", wr, ee, wt))


@pytest.mark.parametrize("l", [1, 2, 3, 4, 6])
def test_traction_power_is_the_fluids_dissipation(l):
    """The power the surface puts into each fluid, (mu/R) (4 pi R^2 / (2l+1)) (a Tn + L b Tt), is the
    dissipation of Lamb's field integrated over the fluid: a check of K_in and K_out that shares
    nothing with their derivation (no pressure, no traction). Quadrature and round-off: ~1e-13."""
    L = l * (l + 1)
    k_in, k_out = fs.traction_matrices(l)
    W = np.diag([1.0, L])
    rng = np.random.default_rng(l)
    R = 1.3
    for _ in range(3):
        a, b = rng.normal(size=2)
        norm = 4.0 * math.pi * R**2 / (2 * l + 1)
        tn, tt = k_in @ [a, b]
        power_in = (1.0 / R) * norm * (a * tn + L * b * tt)
        assert power_in == pytest.approx(_dissipation(l, a, b, True, R=R), rel=1e-10)
        tn, tt = k_out @ [a, b]
        power_out = -(1.0 / R) * norm * (a * tn + L * b * tt)
        assert power_out == pytest.approx(_dissipation(l, a, b, False, R=R), rel=1e-10)
    # reciprocity: the power forms are symmetric (so the quadratic forms above fix them entirely)
    assert np.allclose(W @ k_in, (W @ k_in).T, rtol=0, atol=1e-12 * L)
    assert np.allclose(W @ k_out, (W @ k_out).T, rtol=0, atol=1e-12 * L)


def test_rigid_translation_meets_stokes_drag():
    _, k_out = fs.traction_matrices(1)
    tn, tt = k_out @ [1.0, 1.0]  # a = b = U = 1, mu = R = 1
    # z-force: oint (Tn cos^2 + Tt sin^2) dA = 4 pi (Tn + 2 Tt) / 3
    assert 4 * math.pi * (tn + 2 * tt) / 3 == pytest.approx(-6 * math.pi, rel=1e-14)


@pytest.mark.parametrize("lam", [0.0, 0.3, 1.0, 5.0])
def test_clean_drop_relaxation_and_deformation_rate_are_taylors(lam):
    """No surface viscosity: Taylor's drop. Relaxation of l = 2 at -40 (1 + lam) / ((2 lam + 3)(19 lam + 16))
    (gamma = mu = R = 1) and, from his steady deformation D = Ca (19 lam + 16) / (16 lam + 16), the
    initial normal speed in a strain: a = 5 R / (2 lam + 3) per unit n.E.n."""
    rate = fs.relaxation_rate(2, tension=1.0, mu_in=lam, mu_out=1.0, eta_s=0.0, eta_b=0.0)
    assert rate == pytest.approx(-40 * (1 + lam) / ((2 * lam + 3) * (19 * lam + 16)), rel=1e-13)
    a, _ = fs.strain_response(mu_in=lam, mu_out=1.0, eta_s=0.0, eta_b=0.0)
    assert a == pytest.approx(5.0 / (2 * lam + 3), rel=1e-13)


@pytest.mark.parametrize("mu_in,eta_b,eta_s", [(0.5, 0.0, 3.0), (1.0, 1.0, 1.0), (2.0, 10.0, 0.1), (0.1, 1e6, 1.0)])
def test_sedimentation_is_boussinesq_scriven(mu_in, eta_b, eta_s):
    """Only the dilatational viscosity enters (degree 1 is shear-free); the shear viscosity does not.
    The 2 x 2 solve's condition number grows like eta_b / mu: round-off ~1e-15 times that."""
    u = fs.sedimentation_velocity(1.0, mu_in=mu_in, mu_out=0.7, eta_s=eta_s, eta_b=eta_b)
    want = fs.boussinesq_scriven_velocity(1.0, mu_in=mu_in, mu_out=0.7, eta_b=eta_b)
    assert u == pytest.approx(want, rel=1e-13 * (1.0 + eta_b / 0.7))


@pytest.mark.parametrize("l", [2, 3, 8])
def test_vanishing_fluids_give_the_vacuum_flow(l):
    """mu -> 0: the flow of sphere_exact (with bending viscosity), to first order in mu."""
    mu = 1e-9
    got = fs.flow_coefficients(l, mu_in=mu, mu_out=mu, eta_bar=5e-4, eta_bar_b=2.5e-3)
    want = sphere_exact.flow_coefficients(l, eta_bar=5e-4, eta_bar_b=2.5e-3)
    assert got == pytest.approx(want, rel=1e-6)


def test_faxen_rotation_of_a_simple_shear():
    """u = G y e_x: no mean velocity at the centre, rotation -G/2 about z."""
    G = 0.4
    grad = np.zeros((3, 3))
    grad[0, 1] = G
    u, w = fs.faxen(grad)
    assert np.allclose(u, 0.0) and np.allclose(w, [0.0, 0.0, -G / 2])
