"""Tests of cortex_ti.truth.analytic: static-sphere solutions (docs/method/conventions.md) and error measures.

Besides limits and reference values, the solutions are checked against an independent
finite-difference evaluation of the force balance on the sphere: with
``t^a = t^ab e_b`` the surface force is ``(1/sqrt g) d_a (sqrt g t^a) = (nabla_a t^ab) e_b - C_ab t^ab n``,
so the balance (tangential ``nabla_a t^ab = 0``, normal ``C_ab t^ab = P``) reads
``(1/sqrt g) d_a (sqrt g t^a) + P n = 0``.
"""

import math

import numpy as np
import pytest

from cortex_ti.analysis.reference import DEFAULT_DIR
from cortex_ti.physics.patterns import evaluate_active_stress, mean_over_sphere
from cortex_ti.physics.spherical import (
    real_sph_harm,
    real_sph_harm_surface_gradient,
    sphere_quadrature,
)
from cortex_ti.truth.analytic import (
    bending_coefficients,
    error_measures,
    l1_moments,
    sphere_bending_solution,
    sphere_full_solution,
    sphere_tangential_solution,
)

AXISYM = DEFAULT_DIR / "caseA_p8_zh1_velocity_t0.0.csv"  # shipped with the package
RING8 = {"type": "ring", "zeta0": 1.0, "amplitude": 1.0, "sigma": 10.0, "p": 8}
RING4 = {"type": "ring", "zeta0": 1.0, "amplitude": 1.0, "sigma": 10.0, "p": 4}


def sph_point(R, th, ph):
    th, ph = np.broadcast_arrays(np.asarray(th, float), np.asarray(ph, float))
    return R * np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)


def fd_surface_force(vfunc, zfunc, R, eta_s, eta_b, th, ph, h=1e-3):
    """(1/sqrt g) d_a(sqrt g t^ab e_b) on the sphere of radius R, by centred finite differences.

    vfunc(points (N,3)) -> (N,3) velocity, zfunc(points) -> (N,) active tension.
    """

    def traction_vectors(t, p):
        X = sph_point(R, t, p)
        e_t = R * np.stack([np.cos(t) * np.cos(p), np.cos(t) * np.sin(p), -np.sin(t)], axis=-1)
        e_p = R * np.stack([-np.sin(t) * np.sin(p), np.sin(t) * np.cos(p), np.zeros_like(t)], axis=-1)
        dv_t = (vfunc(sph_point(R, t + h, p)) - vfunc(sph_point(R, t - h, p))) / (2 * h)
        dv_p = (vfunc(sph_point(R, t, p + h)) - vfunc(sph_point(R, t, p - h))) / (2 * h)
        e = [e_t, e_p]
        dv = [dv_t, dv_p]
        # covariant strain rate v_ab = (d_a v . e_b + d_b v . e_a) / 2
        v_cov = np.empty(t.shape + (2, 2))
        for a in range(2):
            for b in range(2):
                v_cov[..., a, b] = 0.5 * (np.sum(dv[a] * e[b], -1) + np.sum(dv[b] * e[a], -1))
        ginv = np.zeros(t.shape + (2, 2))
        ginv[..., 0, 0] = 1 / R**2
        ginv[..., 1, 1] = 1 / (R * np.sin(t)) ** 2
        v_con = np.einsum("...ac,...cd,...db->...ab", ginv, v_cov, ginv)
        tr = np.einsum("...ab,...ab->...", ginv, v_cov)
        zeta = zfunc(X)
        tcon = 2 * eta_s * (v_con - 0.5 * tr[..., None, None] * ginv) + (eta_b * tr + zeta)[..., None, None] * ginv
        sqrtg = R**2 * np.sin(t)
        T = [sqrtg[..., None] * (tcon[..., a, 0, None] * e_t + tcon[..., a, 1, None] * e_p) for a in range(2)]
        return T

    Tt_plus = traction_vectors(th + h, ph)[0]
    Tt_minus = traction_vectors(th - h, ph)[0]
    Tp_plus = traction_vectors(th, ph + h)[1]
    Tp_minus = traction_vectors(th, ph - h)[1]
    sqrtg = R**2 * np.sin(th)
    return ((Tt_plus - Tt_minus) / (2 * h) + (Tp_plus - Tp_minus) / (2 * h)) / sqrtg[..., None]


def interior_angles(n=25, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.3, np.pi - 0.3, n), rng.uniform(0, 2 * np.pi, n)


def split(f, n):
    fn = np.sum(f * n, axis=1)
    return f - fn[:, None] * n, fn


# ---------------------------------------------------------------------------------------------
# full system
# ---------------------------------------------------------------------------------------------
def test_full_solution_ring_p8_against_axisymmetric_reference():
    data = np.loadtxt(AXISYM, delimiter=",", skiprows=1)
    z, r, vn_ref = data[:, 0], data[:, 1], data[:, 5]
    pts = np.c_[r, np.zeros_like(r), z]
    v, P = sphere_full_solution(pts, [RING8])
    n = pts / np.linalg.norm(pts, axis=1)[:, None]
    vt, vn = split(v, n)
    assert np.max(np.abs(vt)) < 1e-15  # purely normal
    zbar = mean_over_sphere([RING8])
    assert P == pytest.approx(2 * zbar, rel=1e-14)
    # poles: v_n = (zbar - zeta(pole)) / 2 = +0.32274 (outward)
    assert vn[0] == pytest.approx(0.32274, abs=5e-6)
    assert vn[-1] == pytest.approx(0.32274, abs=5e-6)
    assert abs(vn[0] - vn_ref[0]) < 1e-6 and abs(vn[-1] - vn_ref[-1]) < 1e-6
    # whole profile: the reference README quotes agreement to 2e-3 (steep flanks)
    assert np.max(np.abs(vn - vn_ref)) < 3e-3
    # equator moves inward
    i_eq = np.argmin(np.abs(z))
    assert vn[i_eq] == pytest.approx(-(2.0 - zbar) / 2, abs=1e-6)
    assert vn[i_eq] < 0


def test_full_solution_ring_p4_pole_value_and_scaling():
    poles = np.array([[0, 0, 2.0], [0, 0, -2.0]])
    v, P = sphere_full_solution(poles, [RING4], radius=2.0, eta_b=0.5)
    zbar = mean_over_sphere([RING4])
    assert round(zbar, 5) == 1.48299
    # v_n = -(R / (2 eta_b)) (zeta - zbar): R / (2 eta_b) = 2
    zp = 1.0 + math.exp(-10 * (math.pi / 2) ** 4)
    np.testing.assert_allclose(v[:, 2] * [1, -1], -2.0 * (zp - zbar), rtol=1e-12)
    assert v[0, 2] / 4 == pytest.approx(0.2415, abs=5e-5)  # the R = 1, eta_b = 1 value of docs/method/conventions.md
    assert P == pytest.approx(2 * zbar / 2.0, rel=1e-14)


def test_full_solution_harmonics_and_force_balance():
    R, eta_s, eta_b = 1.5, 0.7, 1.3
    pats = [
        {
            "type": "harmonics",
            "terms": [{"l": 0, "m": 0, "coeff": 2.0}, {"l": 2, "m": 0, "coeff": 1.0}, {"l": 3, "m": -2, "coeff": 0.4}],
        }
    ]
    th, ph = interior_angles()
    pts = sph_point(R, th, ph)
    v, P = sphere_full_solution(pts, pats, radius=R, eta_b=eta_b)
    n = pts / R
    y20 = real_sph_harm(2, 0, th, ph)
    y32 = real_sph_harm(3, -2, th, ph)
    np.testing.assert_allclose(v, (-(R / (2 * eta_b)) * (y20 + 0.4 * y32))[:, None] * n, atol=1e-13)
    assert P == pytest.approx(2 * (2.0 / math.sqrt(4 * math.pi)) / R, rel=1e-13)
    # Y_20 is largest at the poles: inward there, outward at the equator
    vp, _ = sphere_full_solution(
        np.array([[0, 0, 1.0], [1.0, 0, 0]]), [{"type": "harmonics", "terms": [{"l": 2, "m": 0, "coeff": 1}]}]
    )
    assert vp[0, 2] < 0 and vp[1, 0] > 0
    # independent check: the finite-difference surface force balances the pressure
    vfun = lambda q: sphere_full_solution(q, pats, radius=R, eta_b=eta_b, order=16)[0]  # noqa: E731
    zfun = lambda q: evaluate_active_stress(q, pats)  # noqa: E731
    f = fd_surface_force(vfun, zfun, R, eta_s, eta_b, th, ph)
    assert np.max(np.abs(f + P * n)) < 1e-5


def test_full_solution_rejects_l1_part():
    pts = np.eye(3)
    bad = [{"type": "harmonics", "terms": [{"l": 2, "m": 0, "coeff": 1.0}, {"l": 1, "m": 0, "coeff": 1e-3}]}]
    with pytest.raises(ValueError, match=r"Y_1,0"):
        sphere_full_solution(pts, bad)
    # a shifted ring (zeta0 + ring on the upper half only) has an l = 1 part along z
    with pytest.raises(ValueError, match=r"l = 1"):
        sphere_full_solution(pts, [RING4, {"type": "harmonics", "terms": [{"l": 1, "m": -1, "coeff": 0.2}]}])
    # a tilted ring is up-down symmetric about its own axis: no l = 1 part, no error
    mom = l1_moments([dict(RING8, axis=[1.0, 2.0, -0.5])])
    assert np.max(np.abs(mom)) < 1e-12
    sphere_full_solution(pts, [dict(RING8, axis=[1.0, 2.0, -0.5])])
    # moments of a pure Y_11 term: <Y_11, Y_1m> = delta_m1
    np.testing.assert_allclose(
        l1_moments([{"type": "harmonics", "terms": [{"l": 1, "m": 1, "coeff": 1.0}]}]), [0, 0, 1], atol=1e-14
    )


# ---------------------------------------------------------------------------------------------
# tangential system
# ---------------------------------------------------------------------------------------------
def test_tangential_solution_y20_flows_to_poles():
    R, eta_s = 2.0, 0.5
    th, ph = interior_angles(40, seed=1)
    pts = sph_point(R, th, ph)
    v = sphere_tangential_solution(pts, [{"l": 2, "m": 0, "coeff": 1.0}], radius=R, eta_s=eta_s)
    n = pts / R
    assert np.max(np.abs(np.sum(v * n, axis=1))) < 1e-14
    e_theta = np.stack([np.cos(th) * np.cos(ph), np.cos(th) * np.sin(ph), -np.sin(th)], axis=-1)
    vth = np.sum(v * e_theta, axis=1)
    north = th < np.pi / 2
    assert np.all(vth[north] < 0) and np.all(vth[~north] > 0)  # toward the nearer pole
    g = real_sph_harm_surface_gradient(2, 0, pts)
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), R**2 / (4 * eta_s) * np.linalg.norm(g, axis=1), rtol=1e-13)
    # explicit: grad_s Y_20 = -(3 sqrt(5/(16 pi)) / R) sin(2 theta) e_theta
    np.testing.assert_allclose(
        vth, R**2 / (4 * eta_s) * (-3 * math.sqrt(5 / (16 * math.pi)) / R) * np.sin(2 * th), rtol=1e-12
    )


def test_tangential_solution_no_net_momentum_and_force_balance():
    R, eta_s = 1.3, 0.8
    terms = [
        {"l": 0, "m": 0, "coeff": 5.0},
        {"l": 2, "m": 1, "coeff": 1.0},
        {"l": 3, "m": -2, "coeff": -0.6},
        {"l": 4, "m": 3, "coeff": 0.3},
    ]
    q, w = sphere_quadrature(16)
    pts = R * q
    v = sphere_tangential_solution(pts, terms, radius=R, eta_s=eta_s)
    assert np.max(np.abs(w @ v)) < 1e-13
    assert np.max(np.abs(w @ np.cross(pts, v))) < 1e-13
    assert np.max(np.abs(v)) > 0.05  # not trivially zero
    # l = 0 contributes nothing
    np.testing.assert_allclose(sphere_tangential_solution(pts, terms[1:], radius=R, eta_s=eta_s), v, atol=1e-15)
    # independent check of the tangential balance (eta_b = 0)
    th, ph = interior_angles(seed=2)
    pat = [{"type": "harmonics", "terms": terms}]
    f = fd_surface_force(
        lambda x: sphere_tangential_solution(x, terms, radius=R, eta_s=eta_s),
        lambda x: evaluate_active_stress(x, pat),
        R,
        eta_s,
        0.0,
        th,
        ph,
    )
    ft, _ = split(f, sph_point(1.0, th, ph))
    assert np.max(np.abs(ft)) < 1e-5
    # and a wrong prefactor would fail it
    f_bad = fd_surface_force(
        lambda x: 1.1 * sphere_tangential_solution(x, terms, radius=R, eta_s=eta_s),
        lambda x: evaluate_active_stress(x, pat),
        R,
        eta_s,
        0.0,
        th,
        ph,
    )
    assert np.max(np.abs(split(f_bad, sph_point(1.0, th, ph))[0])) > 1e-2


def test_tangential_solution_rejects_l1():
    with pytest.raises(ValueError, match="l = 1"):
        sphere_tangential_solution(np.eye(3), [{"l": 1, "m": 0, "coeff": 1.0}])
    # harmonics patterns are accepted in place of terms
    t = [{"l": 2, "m": -1, "coeff": 1.0}]
    np.testing.assert_array_equal(
        sphere_tangential_solution(np.eye(3), [{"type": "harmonics", "terms": t}]),
        sphere_tangential_solution(np.eye(3), t),
    )


# ---------------------------------------------------------------------------------------------
# bending viscosity
# ---------------------------------------------------------------------------------------------
TERMS = [
    {"l": 0, "m": 0, "coeff": 1.2},
    {"l": 2, "m": 0, "coeff": 1.0},
    {"l": 3, "m": 1, "coeff": -0.5},
    {"l": 5, "m": -4, "coeff": 0.2},
]


def kappa(l, R, eta_bar, eta_bar_b):
    L = l * (l + 1)
    return (2 * eta_bar_b * L + 8 * eta_bar - 4 * eta_bar_b) / R**3


def test_bending_reduces_to_full_solution_without_bending_viscosity():
    R, eta_s, eta_b = 1.5, 0.7, 1.3
    pts = sph_point(R, *interior_angles(30, seed=3))
    v, P = sphere_bending_solution(pts, TERMS, R, eta_s, eta_b, 0.0, 0.0)
    v_full, P_full = sphere_full_solution(pts, [{"type": "harmonics", "terms": TERMS}], radius=R, eta_b=eta_b)
    np.testing.assert_allclose(v, v_full, atol=1e-14)
    assert P == pytest.approx(P_full, rel=1e-13)
    for l in (2, 3, 7):
        a, b = bending_coefficients(l, R, eta_s, eta_b, 0.0, 0.0)
        assert a == 0.0 and b == pytest.approx(-R / (2 * eta_b), rel=1e-14)


def test_bending_tangential_part_equals_tangential_solution_when_eta_b_zero():
    R, eta_s, eb, ebb = 1.5, 0.7, 2e-3, 5e-3
    th, ph = interior_angles(30, seed=4)
    pts = sph_point(R, th, ph)
    n = pts / R
    v, _ = sphere_bending_solution(pts, TERMS, R, eta_s, 0.0, eb, ebb)
    vt, vn = split(v, n)
    np.testing.assert_allclose(vt, sphere_tangential_solution(pts, TERMS, radius=R, eta_s=eta_s), atol=1e-13)
    # the normal part is -2 zeta_l / (R kappa_l) per term
    vn_exp = sum(
        t["coeff"] * (-2 / (R * kappa(t["l"], R, eb, ebb))) * real_sph_harm(t["l"], t["m"], th, ph)
        for t in TERMS
        if t["l"] > 0
    )
    np.testing.assert_allclose(vn, vn_exp, rtol=1e-12)
    # with a huge bending viscosity the normal motion is frozen: the tangential system
    v_big, _ = sphere_bending_solution(pts, TERMS, R, eta_s, 0.0, 0.0, 1e12)
    np.testing.assert_allclose(v_big, sphere_tangential_solution(pts, TERMS, radius=R, eta_s=eta_s), atol=1e-11)


def test_bending_alpha_sign_and_balance_equations():
    R, eta_s, eta_b, eb, ebb = 1.0, 1.0, 1.0, 5e-4, 2.5e-3
    for l in (2, 3, 6, 12):
        L = l * (l + 1)
        a, b = bending_coefficients(l, R, eta_s, eta_b, eb, ebb)
        k = kappa(l, R, eb, ebb)
        # the two balance equations (per unit zeta_l) are satisfied
        assert -eta_s * (L - 2) * a / R**2 - eta_b * L * a / R**2 + 2 * eta_b * b / R + 1 == pytest.approx(0, abs=1e-13)
        assert (2 / R) * (eta_b * (-L * a / R**2 + 2 * b / R) + 1) + k * b == pytest.approx(0, abs=1e-13)
        # physics: bending viscosity damps the normal motion (|beta| < R / (2 eta_b), same sign: inward
        # where tension is high), and the tension gradient left unbalanced drives a tangential flow UP the
        # gradient (alpha > 0: toward high tension, as in the tangential system) but slower than there.
        assert -R / (2 * eta_b) < b < 0
        assert 0 < a < R**2 / (eta_s * (L - 2))
    # Y_20: the residual tangential flow goes toward the poles (the high-tension sites)
    th = np.array([0.5, np.pi - 0.5])
    pts = sph_point(R, th, np.zeros(2))
    v, _ = sphere_bending_solution(pts, [{"l": 2, "m": 0, "coeff": 1.0}], R, eta_s, eta_b, eb, ebb)
    e_theta = np.stack([np.cos(th), np.zeros(2), -np.sin(th)], axis=-1)
    vth = np.sum(v * e_theta, axis=1)
    assert vth[0] < 0 < vth[1]
    with pytest.raises(ValueError):
        bending_coefficients(1, R, eta_s, eta_b, eb, ebb)
    with pytest.raises(ValueError):
        bending_coefficients(2, R, 0.0, 0.0, 0.0, 0.0)  # no viscosity at all: singular


def test_bending_solution_satisfies_fd_force_balance():
    # tangential balance without bending terms (as in the paper), normal balance C_ab t^ab + F_b = P
    # with the bending normal force F_b = sum c kappa_l beta_l Y_lm.
    R, eta_s, eta_b, eb, ebb = 1.2, 0.9, 1.1, 0.05, 0.08
    terms = [{"l": 0, "m": 0, "coeff": 0.8}, {"l": 2, "m": 1, "coeff": 1.0}, {"l": 4, "m": -3, "coeff": 0.5}]
    pat = [{"type": "harmonics", "terms": terms}]
    th, ph = interior_angles(seed=5)
    n = sph_point(1.0, th, ph)
    v, P = sphere_bending_solution(R * n, terms, R, eta_s, eta_b, eb, ebb)
    assert np.max(np.abs(split(v, n)[0])) > 1e-3  # a real tangential part
    f = fd_surface_force(
        lambda x: sphere_bending_solution(x, terms, R, eta_s, eta_b, eb, ebb)[0],
        lambda x: evaluate_active_stress(x, pat),
        R,
        eta_s,
        eta_b,
        th,
        ph,
    )
    ft, fn = split(f, n)
    Fb = np.zeros_like(th)
    for t in terms[1:]:
        _, b = bending_coefficients(t["l"], R, eta_s, eta_b, eb, ebb)
        Fb += t["coeff"] * kappa(t["l"], R, eb, ebb) * b * real_sph_harm(t["l"], t["m"], th, ph)
    assert np.max(np.abs(ft)) < 1e-5
    # f . n = -C_ab t^ab = F_b - P
    assert np.max(np.abs(fn - (Fb - P))) < 1e-5
    assert P == pytest.approx(2 * 0.8 / math.sqrt(4 * math.pi) / R, rel=1e-14)


# ---------------------------------------------------------------------------------------------
# error measures
# ---------------------------------------------------------------------------------------------
def test_error_measures_hand_made():
    v_an = np.array([[1.0, 0, 0], [0, 2.0, 0], [0, 0, 0], [0, 0, -4.0]])
    v = np.array([[1.0, 0, 0], [0, 2.0, 0], [3.0, 4.0, 0], [0, 0, -4.0]])  # one node off by |(3,4,0)| = 5
    eps, eps_rel = error_measures(v, v_an)
    assert eps == pytest.approx(5 / 4, rel=1e-15)
    assert eps_rel == pytest.approx(math.sqrt(25 / 4) / 4, rel=1e-15)
    v2 = v_an + np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0], [0, 0, 0]])  # three nodes off by 1
    eps, eps_rel = error_measures(v2, v_an)
    assert eps == pytest.approx(0.75, rel=1e-15)
    assert eps_rel == pytest.approx(math.sqrt(0.75) / 4, rel=1e-15)
    assert error_measures(v_an, v_an) == (0.0, 0.0)
    with pytest.raises(ValueError):
        error_measures(v[:3], v_an)
