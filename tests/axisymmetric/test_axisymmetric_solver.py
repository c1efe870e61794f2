"""The axisymmetric solver's numerical core (cortex_ti.axisymmetric), each test against an
independent truth: the closed-form sphere flows (docs/method/conventions.md), a per-degree Legendre solution
with the bending viscosity, the general covariant 2D formulas on deformed shapes, closed-form
spheroid geometry, conservation of volume, self-convergence, and the external reference run
(cortex_ti/data/axisym)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numpy.polynomial import legendre as L

from cortex_ti.analysis.reference import DEFAULT_DIR
from cortex_ti.axisymmetric import balance, evolve, spectral
from cortex_ti.axisymmetric.run import axisymmetric_tension, viscosities
from cortex_ti.scene import load_scene


class ax:  # the solver's names, as the tests use them
    Spectral = spectral.Spectral
    _geometry = staticmethod(spectral.geometry)
    _Physics = balance._Physics
    _System = balance.ForceBalance
    static_flow = staticmethod(balance.static_flow)
    simulate = staticmethod(evolve.simulate)

    @staticmethod
    def ring_tension(p, zeta_hat, sigma=10.0, zeta_0=1.0):
        """Eq. 59 written out here, independently of the scene's pattern."""
        return lambda theta: zeta_0 + zeta_hat * np.exp(-sigma * np.abs(np.asarray(theta, float) - 0.5 * np.pi) ** p)

    @staticmethod
    def scene_tension(name):
        """The built-in scene's tension zeta(theta0) and viscosities, as the model runs it."""
        settings = load_scene(name, ["model=axisymmetric"]).settings
        return axisymmetric_tension(settings), viscosities(settings)


#: the external reference ships with the package (cortex_ti/data/axisym): missing, the tests below fail
REF = str(DEFAULT_DIR) + "/"
P8 = ax.ring_tension(8, 1.0)
P4 = ax.ring_tension(4, 1.0)
P4A3 = ax.ring_tension(4, 3.0)
V1 = dict(eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0)  # the furrow viscosities, no bending


def sphere_mean(zeta, nq: int = 800) -> float:
    """Mean of zeta(theta) over the unit sphere (Gauss-Legendre in cos theta)."""
    x, w = L.leggauss(nq)
    return 0.5 * float(np.sum(w * zeta(np.arccos(x))))


def legendre_coeffs(zeta, lmax: int, nq: int = 1200) -> np.ndarray:
    x, w = L.leggauss(nq)
    f = zeta(np.arccos(x))
    V = L.legvander(x, lmax)  # P_l(x)
    return (2 * np.arange(lmax + 1) + 1) / 2 * (V.T @ (w * f))


def bending_closed_form(zeta, theta, R, es, eb, ebar, ebarb, lmax=220):
    """Per-degree solution on a static sphere (DERIVATION.md, Sec. 8):
    v = sum_l zeta_l (alpha_l grad_s P_l + beta_l P_l n), P = 2 zeta_0 / R, with
    kappa_l = (2 ebarb L + 8 ebar - 4 ebarb)/R^3, D = es (L-2)(4 eb/R^2 + kappa) + eb L kappa,
    alpha = R^2 kappa / D, beta = -2 es (L-2)/(R D)."""
    c = legendre_coeffs(zeta, lmax)
    x = np.cos(theta)
    vs = np.zeros_like(theta)
    vn = np.zeros_like(theta)
    for l in range(2, lmax + 1):
        Ll = l * (l + 1)
        kap = (2 * ebarb * Ll + 8 * ebar - 4 * ebarb) / R**3
        D = es * (Ll - 2) * (4 * eb / R**2 + kap) + eb * Ll * kap
        al, be = R**2 * kap / D, -2 * es * (Ll - 2) / (R * D)
        e = np.zeros(l + 1)
        e[l] = 1.0
        P = L.legval(x, e)
        dP = -np.sin(theta) * L.legval(x, L.legder(e))  # dP_l/dtheta
        vs += c[l] * al * dP / R
        vn += c[l] * be * P
    return vs, vn, 2 * c[0] / R


def roundoff_bound(zeta, R, eta_s, eta_b, n, symmetric, fixed_normal=False):
    """The round-off error to expect of a static solve whose discretisation error is zero (the exact
    solution is in the spectral basis): the standard estimate for a linear system solved by LU with
    partial pivoting, whose matrix and right-hand side are themselves computed to relative
    precision eps, ``|dx| <= m eps cond(A) |x|`` (m the system's size; Higham, Accuracy and Stability
    of Numerical Algorithms, 2nd ed., Thms. 7.2 and 9.4). For the systems here cond(A) ~ 3e3-5e3,
    so the bound is ~6e-11, 60 times the largest error measured (1.01e-12)."""
    sp = ax.Spectral(n, symmetric)
    system = ax._System(sp, ax._Physics(eta_s, eta_b, 0.0, 0.0, fixed_normal=fixed_normal))
    g = ax._geometry(sp, R * np.sin(sp.u), R * np.cos(sp.u))
    g["zeta"] = np.asarray(zeta(sp.u), dtype=float)
    A, b = system.assemble(g)
    x = np.linalg.solve(A, b)
    return A.shape[0] * np.finfo(float).eps * np.linalg.cond(A) * np.max(np.abs(x))


# ------------------------------------------------------------------------------------------
# static sphere: full system without bending, v = -(R/(2 eta_b)) (zeta - zeta_bar) n
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("symmetric", [True, False])
@pytest.mark.parametrize("R,eta_s,eta_b", [(1.0, 1.0, 1.0), (1.7, 0.3, 2.5)])
def test_static_y20(symmetric, R, eta_s, eta_b):
    zeta = lambda t: 0.7 + 1.3 * 0.5 * (3 * np.cos(t) ** 2 - 1)  # noqa: E731
    n = 16 if symmetric else 32
    s = ax.static_flow(zeta, eta_s=eta_s, eta_b=eta_b, eta_bar=0.0, eta_bar_b=0.0, radius=R, n=n, symmetric=symmetric)
    vn_ex = -(R / (2 * eta_b)) * (s.zeta - 0.7)
    bound = roundoff_bound(zeta, R, eta_s, eta_b, n, symmetric)  # Y20 lies in the basis: round-off only
    assert bound < 1e-9  # the estimate itself stays small: a well-conditioned system
    assert np.max(np.abs(s.v_n - vn_ex)) < bound
    assert np.max(np.abs(s.v_s)) < bound
    assert abs(s.P - 2 * 0.7 / R) < bound
    # inward at the poles, outward at the equator (paper Sec. 4.1)
    e = s.at(np.array([0.0, np.pi / 2, np.pi]))
    assert e["v_n"][0] < 0 and e["v_n"][1] > 0 and e["v_n"][2] < 0


@pytest.mark.parametrize("symmetric", [True, False])
@pytest.mark.parametrize("zeta,zbar_quoted", [(P8, 1.64548), (P4, 1.48299), (P4A3, None)])
def test_static_rings(symmetric, zeta, zbar_quoted):
    zbar = sphere_mean(zeta)
    if zbar_quoted is not None:
        assert abs(zbar - zbar_quoted) < 6e-6
    s = ax.static_flow(zeta, **V1, n=64 if symmetric else 128, symmetric=symmetric)
    vn_ex = -0.5 * (s.zeta - zbar)
    assert np.max(np.abs(s.v_n - vn_ex)) < 1e-8
    assert np.max(np.abs(s.v_s)) < 1e-8
    assert abs(s.P - 2 * zbar) < 1e-8
    th = np.linspace(0, np.pi, 101)
    e = s.at(th)  # spectral interpolation between the nodes
    assert np.max(np.abs(e["v_n"] + 0.5 * (zeta(th) - zbar))) < 1e-8
    if zeta is P8:
        assert abs(e["v_n"][0] - 0.3227) < 5e-5  # docs/method/conventions.md


def test_static_l1_pattern_translation_gauge():
    """A pattern with an l = 1 part: v_n = -(zeta - zeta_bar)/2 + U cos(theta), v_s = -U sin(theta)
    with the rigid translation U fixed by oint v_z dA = 0 (full meridian)."""
    zeta = lambda t: 1.0 + 2.0 * np.exp(-10 * np.abs(t - 1.2) ** 4)  # noqa: E731
    x, w = L.leggauss(600)
    zbar = 0.5 * np.sum(w * zeta(np.arccos(x)))
    U = -0.5 * np.sum(w * (-0.5 * (zeta(np.arccos(x)) - zbar)) * x)
    s = ax.static_flow(zeta, **V1, n=96)
    assert not np.isclose(U, 0.0)
    assert np.max(np.abs(s.v_n - (-0.5 * (s.zeta - zbar) + U * np.cos(s.theta)))) < 1e-9
    assert np.max(np.abs(s.v_s + U * np.sin(s.theta))) < 1e-9
    assert abs(s.lam) < 1e-10


# ------------------------------------------------------------------------------------------
# static sphere with bending viscosity: per-degree closed form
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("zeta,ebar,ebarb", [(P8, 5e-4, 2.5e-3), (P4A3, 1e-4, 3.5e-3), (P4, 0.02, 0.01)])
@pytest.mark.parametrize("R,eta_s,eta_b", [(1.0, 1.0, 1.0), (1.6, 0.7, 0.4)])
def test_static_bending(zeta, ebar, ebarb, R, eta_s, eta_b):
    th = np.linspace(0, np.pi, 181)
    vs_ex, vn_ex, P_ex = bending_closed_form(zeta, th, R, eta_s, eta_b, ebar, ebarb)
    s = ax.static_flow(zeta, eta_s=eta_s, eta_b=eta_b, eta_bar=ebar, eta_bar_b=ebarb, radius=R, n=64)
    e = s.at(th)
    scale = max(np.abs(vn_ex).max(), 1e-3)
    assert np.max(np.abs(e["v_s"] - vs_ex)) < 1e-8 * scale / 1e-2 + 1e-9
    assert np.max(np.abs(e["v_n"] - vn_ex)) < 1e-8 * scale / 1e-2 + 1e-9
    assert abs(s.P - P_ex) < 1e-9
    assert np.max(np.abs(vs_ex)) > 1e-3  # bending makes the tangential flow nonzero


def test_bending_only_eta_b_zero():
    """eta_b = 0 with bending: the per-degree formula still holds (kappa_l > 0 regularises)."""
    th = np.linspace(0, np.pi, 91)
    vs_ex, vn_ex, _ = bending_closed_form(P4, th, 1.0, 1.0, 0.0, 5e-4, 2.5e-3)
    s = ax.static_flow(P4, eta_s=1.0, eta_b=0.0, eta_bar=5e-4, eta_bar_b=2.5e-3, n=64)
    e = s.at(th)
    assert np.max(np.abs(e["v_n"] - vn_ex)) < 1e-7 * np.abs(vn_ex).max()
    assert np.max(np.abs(e["v_s"] - vs_ex)) < 1e-7 * np.abs(vn_ex).max()


# ------------------------------------------------------------------------------------------
# tangential-only system: v = R^2 / (eta_s (L - 2)) grad_s zeta_l
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("l,symmetric", [(2, True), (2, False), (3, False), (4, True)])
def test_tangential_only(l, symmetric):
    R, es = 1.3, 0.8
    e = np.zeros(l + 1)
    e[l] = 1.0
    zeta = lambda t: 0.4 + L.legval(np.cos(t), e)  # noqa: E731
    s = ax.static_flow(
        zeta, eta_s=es, eta_b=0.0, eta_bar=0.0, eta_bar_b=0.0, radius=R, n=32, symmetric=symmetric, fixed_normal=True
    )
    th = np.linspace(0, np.pi, 77)
    f = s.at(th)
    dP = -np.sin(th) * L.legval(np.cos(th), L.legder(e))
    v_ex = R**2 / (es * (l * (l + 1) - 2)) * dP / R
    # P_l lies in the basis: round-off only (plus the evaluation's sum of n terms, n eps |v|)
    bound = roundoff_bound(zeta, R, es, 0.0, 32, symmetric, fixed_normal=True) + 32 * np.finfo(float).eps * np.max(
        np.abs(v_ex)
    )
    assert bound < 1e-9
    assert np.max(np.abs(f["v_s"] - v_ex)) < bound
    assert np.max(np.abs(f["v_n"])) == 0.0
    if l == 2:  # flow from the equator to the poles (up the tension gradient)
        assert f["v_s"][10] < 0 < f["v_s"][-10]


# ------------------------------------------------------------------------------------------
# the 1D reduction against the covariant 2D formulas on a non-spherical shape
# ------------------------------------------------------------------------------------------
def _fd(f, x, h, i):
    """8th-order central difference of f along coordinate i (x a 2-array)."""
    c = [4 / 5, -1 / 5, 4 / 105, -1 / 280]
    out = 0.0
    for k, ck in enumerate(c, start=1):
        e = np.zeros(2)
        e[i] = k * h
        out = out + ck * (f(x + e) - f(x - e))
    return out / h


class _Covariant:
    """Direct evaluation of nabla_a t^ab, C_ab t^ab and the bending normal force C_ab t_b^ab for a
    surface of revolution X(u, phi), from the general 2D formulas (metric, Christoffels, curvature
    tensor by numerical differentiation of the embedding).  Independent of the 1D reduction."""

    def __init__(self, rfun, zfun, vsfun, vnfun, zetafun, es, eb, ebar, ebarb):
        self.rf, self.zf, self.vsf, self.vnf, self.zetaf = rfun, zfun, vsfun, vnfun, zetafun
        self.es, self.eb, self.ebar, self.ebarb = es, eb, ebar, ebarb
        self.h = 1e-2

    def X(self, p):
        u, ph = p
        return np.array([self.rf(u) * np.cos(ph), self.rf(u) * np.sin(ph), self.zf(u)])

    def frame(self, p):
        eu = _fd(self.X, p, self.h / 10, 0)
        ep = _fd(self.X, p, self.h / 10, 1)
        nn = np.cross(eu, ep)
        return eu, ep, nn / np.linalg.norm(nn)

    def v(self, p):
        eu, ep, n = self.frame(p)
        return self.vsf(p[0]) * eu / np.linalg.norm(eu) + self.vnf(p[0]) * n

    def tensors(self, p):
        eu, ep, n = self.frame(p)
        E = np.array([eu, ep])
        g = E @ E.T
        gi = np.linalg.inv(g)
        dv = np.array([_fd(self.v, p, self.h, a) for a in range(2)])
        vab = 0.5 * (dv @ E.T + (dv @ E.T).T)
        tr = np.sum(gi * vab)
        vup = gi @ vab @ gi
        t = 2 * self.es * (vup - 0.5 * tr * gi) + self.eb * tr * gi + self.zetaf(p[0]) * gi
        return E, n, g, gi, t

    def sqrtg_t(self, p):
        E, n, g, gi, t = self.tensors(p)
        return math.sqrt(np.linalg.det(g)) * t

    def second(self, p):
        """d_a d_b X (2, 2, 3)."""
        return np.array(
            [[_fd(lambda q, a=a: _fd(self.X, q, self.h / 10, a), p, self.h, b) for b in range(2)] for a in range(2)]
        )

    def forces(self, p):
        # stencils must not cross a pole (the normal flips sign with r there)
        self.h = min(1e-2, p[0] / 10, (np.pi - p[0]) / 10)
        E, n, g, gi, t = self.tensors(p)
        ddX = self.second(p)
        Gam = np.einsum("cd,abk,dk->cab", gi, ddX, E)  # Gamma^c_ab
        Cab = -np.einsum("abk,k->ab", ddX, n)
        sg = math.sqrt(np.linalg.det(g))
        div = sum(_fd(self.sqrtg_t, p, self.h, a)[a] for a in range(2)) / sg  # (1/sqrt g) d_a (sqrt g t^ab)
        div = div + np.einsum("bac,ac->b", Gam, t)
        f_vec = div @ E
        tan = f_vec @ (E[0] / np.linalg.norm(E[0]))
        nor = np.sum(Cab * t)
        # bending: t_b^ab = 2 ebar (D^ab + C v_n C^ab) + (ebarb - ebar) D^c_c g^ab,
        # D^a_b = -nabla^a nabla_b v_n - v_n C^a_c C^c_b
        vn_f = lambda q: self.v(q) @ self.frame(q)[2]  # noqa: E731
        dvn = np.array([_fd(vn_f, p, self.h, a) for a in range(2)])
        ddvn = np.array(
            [[_fd(lambda q, a=a: _fd(vn_f, q, self.h / 10, a), p, self.h, b) for b in range(2)] for a in range(2)]
        )
        hess = ddvn - np.einsum("cab,c->ab", Gam, dvn)
        vn = vn_f(p)
        Cmix = gi @ Cab  # C^a_b
        Cup = Cmix @ gi
        Ctr = np.trace(Cmix)
        Dup = -gi @ hess @ gi - vn * Cmix @ Cmix @ gi  # D^ab
        Dtr = np.sum(Dup * g)
        tb = 2 * self.ebar * (Dup + Ctr * vn * Cup) + (self.ebarb - self.ebar) * Dtr * gi
        return tan, nor, np.sum(Cab * tb)


@pytest.mark.parametrize("symmetric", [True, False])
def test_reduction_matches_covariant_formulas(symmetric):
    if symmetric:
        rfun = lambda u: np.sin(u) * (1 + 0.15 * np.cos(2 * u))  # noqa: E731
        zfun = lambda u: 1.1 * np.cos(u) * (1 - 0.2 * np.sin(u) ** 2)  # noqa: E731
        vsf = lambda u: 0.3 * np.sin(2 * u) + 0.1 * np.sin(4 * u)  # noqa: E731
        vnf = lambda u: 0.2 * np.cos(2 * u) + 0.1  # noqa: E731
        zetaf = lambda u: 1 + 0.5 * np.cos(u) ** 2  # noqa: E731
    else:
        rfun = lambda u: np.sin(u) * (1 + 0.1 * np.cos(u))  # noqa: E731
        zfun = lambda u: 0.9 * np.cos(u) + 0.1 * np.cos(2 * u)  # noqa: E731
        vsf = lambda u: 0.3 * np.sin(u) + 0.1 * np.sin(3 * u)  # noqa: E731
        vnf = lambda u: 0.2 * np.cos(u) + 0.1 * np.cos(2 * u)  # noqa: E731
        zetaf = lambda u: 1 + 0.5 * np.cos(u) + 0.2 * np.cos(u) ** 2  # noqa: E731
    es, eb, ebar, ebarb = 0.7, 1.3, 0.2, 0.45  # large bending viscosities: a sharp test
    sp = ax.Spectral(24, symmetric)
    system = ax._System(sp, ax._Physics(es, eb, ebar, ebarb))
    g = ax._geometry(sp, rfun(sp.u), zfun(sp.u))
    g["zeta"] = zetaf(sp.u)
    tan, nor = system.balance(vsf(sp.u), vnf(sp.u), g)
    cov = _Covariant(rfun, zfun, vsf, vnf, zetaf, es, eb, ebar, ebarb)
    system0 = ax._System(sp, ax._Physics(es, eb, 0.0, 0.0))
    _, nor0 = system0.balance(vsf(sp.u), vnf(sp.u), g)
    for j in (0, 3, 7, 11, sp.n - 1):
        t2, n2, b2 = cov.forces(np.array([sp.u[j], 0.4]))
        assert abs(tan[j] - t2) < 1e-6, (j, tan[j], t2)
        assert abs(nor0[j] - n2) < 1e-6, (j, nor0[j], n2)
        assert abs((nor[j] - nor0[j]) - b2) < 1e-6, (j, nor[j] - nor0[j], b2)
    assert abs(b2) > 1e-2  # the bending force is not trivially small here


def test_geometry_of_spheroid():
    """Curvatures, area and volume of a spheroid against closed forms."""
    a, c = 1.3, 0.7
    sp = ax.Spectral(32, True)
    g = ax._geometry(sp, a * np.sin(sp.u), c * np.cos(sp.u))
    u = sp.u
    k1 = a * c / (a**2 * np.cos(u) ** 2 + c**2 * np.sin(u) ** 2) ** 1.5
    k2 = c / (a * np.sqrt(a**2 * np.cos(u) ** 2 + c**2 * np.sin(u) ** 2))
    assert np.max(np.abs(g["k1"] - k1)) < 1e-10 and np.max(np.abs(g["k2"] - k2)) < 1e-10
    e = math.sqrt(1 - c**2 / a**2)
    area = 2 * np.pi * a**2 * (1 + (1 - e**2) / e * np.arctanh(e))
    assert abs(2 * np.pi * np.sum(sp.wR * g["r"] * g["h"]) - area) < 1e-12
    zu = (c * np.cos(u)) @ sp.D["Z"].T
    vol = np.pi * np.sum(sp.wR * g["r"] ** 2 * (-zu))
    assert abs(vol - 4 / 3 * np.pi * a**2 * c) < 1e-12


# ------------------------------------------------------------------------------------------
# dynamics
# ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def p4a3_runs():
    z, v = ax.scene_tension("furrow_p4_a3")
    ts = [0.0, 0.5, 1.5, 3.0]
    base = ax.simulate(z, **v, t_end=3.0, n=32, rtol=1e-9, save_times=ts)
    fine = ax.simulate(z, **v, t_end=3.0, n=64, rtol=5e-10, save_times=ts)
    return base, fine


@pytest.mark.slow
def test_volume_conservation(p4a3_runs):
    base, fine = p4a3_runs
    assert abs(base.volume[0] - 4 / 3 * np.pi) < 1e-13
    assert np.max(np.abs(base.volume - base.volume[0])) < 1e-9
    assert np.max(np.abs(fine.volume - fine.volume[0])) < 1e-10
    assert base.area[-1] > base.area[0]  # an elongating, furrowing cell gains area


@pytest.mark.slow
def test_self_convergence(p4a3_runs):
    base, fine = p4a3_runs
    assert np.max(np.abs(base.pole_radius - fine.pole_radius)) < 1e-7
    assert np.max(np.abs(base.furrow_radius - fine.furrow_radius)) < 1e-7
    # whole fields on the meridian (same labels in the lagrangian parametrisation)
    u = np.linspace(0, np.pi, 41)
    for i in range(len(base.t)):
        a, b = base.evaluate(i, u), fine.evaluate(i, u)
        for k in ("r", "z", "v_s", "v_n"):
            assert np.max(np.abs(a[k] - b[k])) < 1e-7, (i, k)
    assert fine.pole_radius[-1] > 1.28 and fine.furrow_radius[-1] < 0.78


@pytest.mark.slow
def test_full_meridian_and_arclength_agree(p4a3_runs):
    _, fine = p4a3_runs
    z, v = ax.scene_tension("furrow_p4_a3")
    full = ax.simulate(z, **v, t_end=3.0, n=64, rtol=1e-9, symmetric=False, save_times=[0.0, 1.5, 3.0])
    assert full.params["parametrization"] == "arclength"
    assert np.max(np.abs(full.pole_radius - fine.pole_radius[[0, 2, 3]])) < 1e-7
    assert np.max(np.abs(full.furrow_radius - fine.furrow_radius[[0, 2, 3]])) < 1e-7
    assert np.max(np.abs(full.lam)) < 1e-10 and np.max(np.abs(full.z_centroid)) < 1e-10
    assert np.max(full.grid_stretch) < 1 + 1e-6  # equidistant in arc length
    u = np.linspace(0, np.pi, 33)
    a, b = full.evaluate(2, u), fine.evaluate(3, u)  # evaluation at material labels
    for k in ("r", "z", "v_s", "v_n", "zeta"):
        assert np.max(np.abs(a[k] - b[k])) < 1e-6, k


def test_initial_velocity_matches_sphere_solution():
    z, v = ax.scene_tension("furrow_p8_a1")
    res = ax.simulate(z, **{**v, "eta_bar": 0.0, "eta_bar_b": 0.0}, n=48, t_end=0.05, save_times=[0.0])
    zbar = sphere_mean(z)
    assert np.max(np.abs(res.v_n[0] + 0.5 * (res.zeta[0] - zbar))) < 1e-9
    assert np.max(np.abs(res.v_s[0])) < 1e-9
    assert abs(res.P[0] - 2 * zbar) < 1e-9


def _ref_radii():
    d = np.loadtxt(REF + "caseA_p8_zh1_radii_vs_time.csv", delimiter=",", skiprows=1, usecols=(0, 1, 2))
    return d[d[:, 0] <= 3.0 + 1e-9]


@pytest.fixture(scope="module")
def p8_nobend():
    d = _ref_radii()
    ts = np.unique(np.concatenate([d[:, 0], [0.1, 1.5, 3.0]]))
    return ax.simulate(P8, **V1, t_end=3.0, save_times=ts, n=48, rtol=1e-10, interpolate=True)


def test_reference_radii(p8_nobend):
    d = _ref_radii()
    idx = np.searchsorted(p8_nobend.t, d[:, 0])
    assert np.allclose(p8_nobend.t[idx], d[:, 0])
    assert np.max(np.abs(p8_nobend.pole_radius[idx] - d[:, 1])) < 1e-4
    assert np.max(np.abs(p8_nobend.furrow_radius[idx] - d[:, 2])) < 1e-4


@pytest.mark.parametrize("t", [0.1, 1.5, 3.0])
def test_reference_profiles(p8_nobend, t):
    """v_n and |v_t| against z, interpolated on our spectral curve, within 1e-3 -- away from the
    polar caps, where the z-parametrisation is singular (dz/ds = 0) and the two pole positions
    differ by ~1e-5 (see REPORT.md; the arc-length comparison there covers the caps)."""
    ref = np.loadtxt(REF + f"caseA_p8_zh1_velocity_t{t}.csv", delimiter=",", skiprows=1)
    i = p8_nobend.index(t)
    uu = np.linspace(0, np.pi, 4001)
    e = p8_nobend.evaluate(i, uu)
    u = np.interp(ref[:, 0], e["z"][::-1], uu[::-1])
    for _ in range(6):  # Newton on z(u) = z_ref
        f = p8_nobend.evaluate(i, u)
        zu = p8_nobend._spectral.evaluate("Z", p8_nobend._states[i]["z"], u, 1)
        ok = np.abs(zu) > 1e-3
        u = np.clip(u - np.where(ok, (f["z"] - ref[:, 0]) / np.where(ok, zu, 1.0), 0.0), 0, np.pi)
    f = p8_nobend.evaluate(i, u)
    m = np.abs(ref[:, 0]) < 0.98 * np.abs(ref[:, 0]).max()
    assert np.max(np.abs(f["v_n"] - ref[:, 5])) < 1e-3  # everywhere
    assert np.max(np.abs(np.abs(f["v_s"]) - ref[:, 3])[m]) < 1e-3
    assert np.max(np.abs(-f["v_s"] - ref[:, 4])[m]) < 1e-3  # signed: reference is south -> north
    # whole meridian, matched by arc length from the south pole (scaled to the total length)
    uu = np.linspace(0, np.pi, 20001)
    sp, st = p8_nobend._spectral, p8_nobend._states[i]
    h = np.hypot(sp.evaluate("R", st["r"], uu, 1), sp.evaluate("Z", st["z"], uu, 1))
    s_north = np.concatenate([[0], np.cumsum(0.5 * (h[1:] + h[:-1]) * np.diff(uu))])
    s_south = s_north[-1] - s_north
    u_s = np.interp(ref[:, 2] / ref[-1, 2] * s_north[-1], s_south[::-1], uu[::-1])
    g = p8_nobend.evaluate(i, u_s)
    assert np.max(np.abs(g["v_n"] - ref[:, 5])) < 1e-3
    assert np.max(np.abs(np.abs(g["v_s"]) - ref[:, 3])) < 1e-3


def test_surface_mesh_closed_and_outward():
    z, v = ax.scene_tension("furrow_p4_a1")
    res = ax.simulate(z, **v, n=32, rtol=1e-8, save_times=[0.0, 1.0], t_end=1.0)
    pts, tri = res.surface(1, n_u=81, n_phi=96)
    # every edge shared by exactly two triangles, in opposite directions (closed, oriented)
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    fwd = {tuple(e) for e in edges}
    assert len(fwd) == len(edges) and all((b, a) in fwd for a, b in fwd)
    # outward orientation: signed volume by the divergence theorem ~ the solver's volume
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    vol = np.sum(np.einsum("ij,ij->i", a, np.cross(b, c))) / 6
    assert 0 < res.volume[1] - vol < 2e-3 * res.volume[1]  # inscribed polyhedron: slightly smaller
    e = res.evaluate(1, np.array([0.0, np.pi / 2, np.pi]))
    assert abs(e["r"][0]) < 1e-14 and abs(e["r"][2]) < 1e-14
    assert abs(e["z"][0] - res.pole_radius[1]) < 1e-13 and abs(e["r"][1] - res.furrow_radius[1]) < 1e-13


# ------------------------------------------------------------------------------------------
# input validation
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kw",
    [
        dict(eta_s=0.0),
        dict(eta_s=-1.0),
        dict(eta_b=-0.1),
        dict(eta_bar=float("nan")),
        dict(eta_bar_b=-1e-3),
        dict(radius=0.0),
        dict(radius=float("inf")),
        dict(n=3),
        dict(n=10.5),
        dict(eta_b=0.0, eta_bar=0.0, eta_bar_b=0.0),
    ],
)
def test_bad_input_static(kw):
    with pytest.raises(ValueError) as err:
        ax.static_flow(P4, **{**V1, **kw})
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "kw",
    [
        dict(t_end=0.0),
        dict(t_end=float("nan")),
        dict(rtol=-1.0),
        dict(atol=0.0),
        dict(save_times=[0.5, 0.1]),
        dict(save_times=[4.0]),
        dict(method="RK45"),
        dict(parametrization="x"),
        dict(gauge="x"),
        dict(eta_s=0),
    ],
)
def test_bad_input_simulate(kw):
    with pytest.raises(ValueError) as err:
        ax.simulate(P4, **{**V1, "t_end": 1.0, **kw})
    assert "\n" not in str(err.value)


def test_bad_zeta():
    with pytest.raises(ValueError):
        ax.static_flow(lambda t: np.full_like(t, np.nan), **V1)
    with pytest.raises(ValueError):
        ax.static_flow(3.0, **V1)


@pytest.mark.slow
def test_step_failure_is_value_error():
    # a compressive (negative) tension without bending viscosity buckles at the grid scale:
    # the integrator cannot keep the error small -> ValueError, not a hang or another exception
    # (n = 16 fails at t = 0.051 in 2.5 CPU s, as n = 32 does at t = 0.019 in 7 s)
    with pytest.raises(ValueError, match="step failed") as err:
        ax.simulate(lambda t: -1.0 - 2.0 * np.cos(t) ** 2, **V1, n=16, t_end=50.0, max_steps=3000)
    assert "\n" not in str(err.value)
