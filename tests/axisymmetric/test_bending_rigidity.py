"""Helfrich bending rigidity in the axisymmetric model (docs/derivations/bending_rigidity.md).

Independent truths: (i) the force is the energy's first variation: the directional derivative of
the quadrature energy (complex step on the node positions, ``X + i eps w n``) equals
``-oint f w dA``; (ii) the power identity ``oint f v_n dA = D`` at every instant and the power
balance ``E(0) - E(T) = int D dt`` over a relaxation without activity, bounded by the estimated
error of the time quadrature; (iii) the shape-mode rates of the sphere against the closed form
``lambda_l = -M_l K_l`` (:mod:`cortex_ti.truth.helfrich_sphere`).
"""

import numpy as np
import pytest
from numpy.polynomial import legendre as npl
from scipy.integrate import simpson

from cortex_ti.axisymmetric.balance import ForceBalance, check_visc
from cortex_ti.axisymmetric.evolve import simulate
from cortex_ti.axisymmetric.rigidity import area_weights, dissipation, helfrich_energy, helfrich_force
from cortex_ti.axisymmetric.spectral import Spectral, geometry
from cortex_ti.truth.helfrich_sphere import base_pressure, rate


def _P(l, x):
    c = np.zeros(l + 1)
    c[l] = 1.0
    return npl.legval(x, c)


def _shape(sp, amps):
    """Nodes of ``|X| = 1 + sum a_l P_l(cos u)`` along the rays of the sphere's labels."""
    f = 1.0 + sum(a * _P(l, np.cos(sp.u)) for l, a in amps.items())
    return np.concatenate([np.sin(sp.u) * f, np.cos(sp.u) * f])


DEFORMED = {True: {2: 0.15, 4: 0.08}, False: {2: 0.15, 3: 0.1, 4: 0.08}}


@pytest.mark.parametrize("symmetric", [True, False])
@pytest.mark.parametrize("c0", [0.0, 1.3])
def test_force_is_the_first_variation_of_the_energy(symmetric, c0):
    """``dE[X + eps w n]/d eps = -oint f w dA`` for smooth normal fields ``w`` on a deformed shape.
    Converges spectrally (relative to ``oint |f w| dA``, c0 = 0, w = cos^2 u): 3.6e-6, 7.1e-12, 1.1e-14 at
    n = 12, 24, 32 on the half meridian; 3.9e-6, 2.3e-10, 3.9e-13 at n = 24, 48, 64 on the full one."""
    n = 32 if symmetric else 64
    sp = Spectral(n, symmetric)
    y = _shape(sp, DEFORMED[symmetric])
    r, z = y[:n], y[n:]
    g = geometry(sp, r, z)
    f = helfrich_force(sp, g, 0.7, c0)
    nr, nz = -g["zs"], g["rs"]  # outward normal (sin psi, cos psi)
    for w in (np.cos(sp.u) ** 2, 1.0 + 0.5 * np.cos(2 * sp.u), np.exp(np.cos(sp.u) ** 2)):
        eps = 1e-30
        gc = geometry(sp, r + 1j * eps * w * nr, z + 1j * eps * w * nz)
        dE = helfrich_energy(sp, gc, 0.7, c0).imag / eps
        work = -(f * w * area_weights(sp, g)).sum()
        assert abs(dE - work) <= 1e-10 * (abs(f) * abs(w) * area_weights(sp, g)).sum()


@pytest.mark.parametrize("symmetric", [True, False])
def test_rigidity_power_equals_dissipation_at_an_instant(symmetric):
    """``oint f v_n dA = D`` (no activity, volume conserved): the force balance dotted with the
    velocity. Measured on the deformed shape: 1e-12 (symmetric, n = 24), 1e-9 (full, n = 48)."""
    n = 24 if symmetric else 48
    sp = Spectral(n, symmetric)
    y = _shape(sp, DEFORMED[symmetric])
    g = geometry(sp, y[:n], y[n:])
    g["zeta"] = np.zeros(n)
    fb = ForceBalance(sp, check_visc(1.0, 0.5, 0.0, 0.0, 1.0, kappa=0.7, c0=0.4))
    A, b = fb.assemble(g)
    x = np.linalg.solve(A, b)
    D = dissipation(sp, g, x[:n], x[n : 2 * n], 1.0, 0.5)
    W = (helfrich_force(sp, g, 0.7, 0.4) * x[n : 2 * n] * area_weights(sp, g)).sum()
    assert D > 0
    assert abs(W - D) <= 1e-8 * D


def _mode_rate(l, n, eps, T, **kw):
    sym = l % 2 == 0
    sp = Spectral(n, sym)
    y0 = _shape(sp, {l: eps})
    res = simulate(
        lambda t: 0.0 * t + kw.get("zeta0", 0.0),
        eta_s=kw.get("eta_s", 1.0),
        eta_b=kw.get("eta_b", 1.0),
        eta_bar=0.0,
        eta_bar_b=0.0,
        t_end=T,
        save_times=[0.0, T],
        n=n,
        symmetric=sym,
        kappa=kw.get("kappa", 1.0),
        spontaneous_curvature=kw.get("c0", 0.0),
        start=(0.0, y0),
        rtol=1e-12,
        atol=1e-15,
        parametrization="lagrangian",
    )
    rho, th = np.hypot(res.r[-1], res.z[-1]), np.arctan2(res.r[-1], res.z[-1])
    A = np.stack([np.ones_like(th), _P(l, np.cos(th))], 1)
    amp = np.linalg.lstsq(A, rho - 1.0, rcond=None)[0][1]
    return np.log(amp / eps) / T


CASES = [
    dict(kappa=1.0),
    dict(kappa=0.5, c0=1.5, zeta0=0.3, eta_b=2.0),
    dict(kappa=0.1, c0=-1.0, zeta0=1.0, eta_b=0.5),
]


@pytest.mark.parametrize("l", [2, 3, 4])
@pytest.mark.parametrize("case", range(len(CASES)))
def test_shape_mode_rates_match_the_closed_form(l, case):
    """Rate of a small mode over one e-folding, averaged over the amplitudes +-eps (which cancels
    the O(eps) nonlinear error; alone it is 2e-5 at eps = 1e-5). The mode is exact in the spectral
    basis at any n > l, so n = 8 and 16 agree to the time stepping's tolerance. Bound: rtol = 1e-12
    on positions of size 1 against the amplitude eps/e at t = T, ~3e-7 relative; measured 1.5e-10 to
    1.2e-9 (docs/validation/bending_rigidity.md)."""
    kw = CASES[case]
    exact = rate(
        l, kappa=kw["kappa"], eta_s=1.0, eta_b=kw.get("eta_b", 1.0), c0=kw.get("c0", 0.0), zeta0=kw.get("zeta0", 0.0)
    )
    for n in (8, 16):
        eps = 1e-5
        lam = 0.5 * (_mode_rate(l, n, eps, 1 / abs(exact), **kw) + _mode_rate(l, n, -eps, 1 / abs(exact), **kw))
        assert lam == pytest.approx(exact, rel=3e-7)


@pytest.mark.slow
def test_power_balance_over_a_relaxation():
    """``E(0) - E(T) = int_0^T D dt`` without activity (kappa = 1, c0 = 0.5) from a deformed shape,
    the dissipation's time integral by Simpson's rule on save times clustered at the fast start;
    the bound is the quadrature's own error estimate (Richardson: |I_h - I_2h| / 15, measured
    fourth order: 1.9e-4, 1.2e-5, 7.4e-7 relative at 41, 81, 161 frames) plus the integrator's
    tolerance."""
    n, T, kappa, c0 = 16, 0.2, 1.0, 0.5
    sp = Spectral(n, True)
    y0 = _shape(sp, DEFORMED[True])
    fb = ForceBalance(sp, check_visc(1.0, 1.0, 0.0, 0.0, 1.0, kappa=kappa, c0=c0))
    ts = T * np.linspace(0.0, 1.0, 161) ** 4
    E, D = [], []

    def measure(y):
        g = geometry(sp, y[:n], y[n : 2 * n])
        g["zeta"] = np.zeros(n)
        A, b = fb.assemble(g)
        x = np.linalg.solve(A, b)
        E.append(helfrich_energy(sp, g, kappa, c0))
        D.append(dissipation(sp, g, x[:n], x[n : 2 * n], 1.0, 1.0))

    measure(y0)
    simulate(
        lambda t: 0.0 * t,
        eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0, t_end=T, save_times=ts, n=n, symmetric=True,
        kappa=kappa, spontaneous_curvature=c0, start=(0.0, y0), rtol=1e-10, parametrization="lagrangian",
        on_save=lambda frame, y: measure(y),
    )  # fmt: skip
    E, D = np.array(E), np.array(D)
    lost = E[0] - E[-1]
    fine, coarse = simpson(D, x=ts), simpson(D[::2], x=ts[::2])
    assert lost > 0.05 * E[0]
    assert abs(lost - fine) <= 2.0 * abs(fine - coarse) / 15.0 + 1e-8 * lost


def _scene(**over):
    data = {
        "name": "rigid",
        "model": "axisymmetric",
        "mesh": {"nodes": 42},
        "viscosity": {"shear": 1.0, "bulk": 1.0},
        "rigidity": {"bending": 0.05, "spontaneous_curvature": 0.5},
        "active_stress": [{"type": "ring"}],
        "effects": [
            "active_stress", "shear_viscosity", "bulk_viscosity", "normal_balance", "incompressibility",
            "shape_evolution", "bending_rigidity",
        ],
        "time": {"dt": 1e-3, "t_end": 0.1},
    }  # fmt: skip
    data.update(over)
    return data


def test_a_scene_passes_the_rigidity_to_the_meridian_model():
    from cortex_ti.axisymmetric.rigidity import rigidity
    from cortex_ti.scene import scene_from_dict

    s = scene_from_dict(_scene()).settings
    assert rigidity(s) == {"kappa": 0.05, "spontaneous_curvature": 0.5}
    off = _scene(rigidity={}, effects=[e for e in _scene()["effects"] if e != "bending_rigidity"])
    assert rigidity(scene_from_dict(off).settings) == {}  # without the effect: the old keywords, the old run


@pytest.mark.parametrize(
    "change,message",
    [
        (dict(model="3d"), "not carried by numerics.formulation = rayleigh_p1 .* rayleigh_p2"),
        (dict(model="3d", numerics={"formulation": "paper"}), "not carried by numerics.formulation = paper"),
        (dict(rigidity={"bending": 0.0}), "rigidity.bending = 0"),
        (
            dict(effects=[e for e in _scene()["effects"] if e != "bending_rigidity"]),
            "the effect 'bending_rigidity' is off",
        ),
        (dict(rigidity={"spontaneous_curvature": 1.0}), "rigidity.bending = 0"),
    ],
)
def test_the_scene_refuses_rigidity_in_one_line(change, message):
    from cortex_ti.errors import SceneError
    from cortex_ti.scene import scene_from_dict

    with pytest.raises(SceneError, match=message) as err:
        scene_from_dict(_scene(**change))
    assert "\n" not in str(err.value)


def test_the_flat_triangle_formulations_refuse_the_effect():
    """Second line of defence: a flat-triangle assembly that met the effect would refuse it, not drop
    it; ``rayleigh_p2`` carries it (tests/physics/test_rayleigh_p2_bending.py), and a 3D scene with
    it loads."""
    from cortex_ti.physics.terms import effects_without_terms
    from cortex_ti.scene import scene_from_dict

    for form in ("paper", "rayleigh_p1"):
        assert effects_without_terms({"bending_rigidity"}, form) == ["bending_rigidity"]
    assert effects_without_terms({"bending_rigidity"}, "rayleigh_p2") == []
    physics = scene_from_dict(_scene(model="3d", numerics={"formulation": "rayleigh_p2"})).settings.physics
    assert (physics.kappa, physics.c0) == (0.05, 0.5)


@pytest.mark.parametrize("symmetric,n", [(True, 8), (True, 16), (False, 16), (False, 32)])
def test_the_linearised_dynamics_has_the_closed_form_rates(symmetric, n):
    """The eigenvalues of the time stepping's Jacobian at the sphere (with tension, rigidity and
    spontaneous curvature) are the rates of every shape mode the grid holds. Half meridian: all even
    degrees up to 2n - 2, measured relative error 3.6e-14 (n = 8), 1.6e-12 (16), 7.8e-11 (32; round-off
    of a Jacobian whose largest entry grows like l^4). Full meridian: the degrees up to n - 7 to 5e-12;
    the few next to the grid's limit are off by up to 25 % (n = 16 and 32 alike), the share
    of exact modes grows with n. The largest rate is the stiffness the integrator meets:
    |lambda| = 4.0e5 at kappa = 0.01, n = 48 (docs/validation/bending_rigidity.md)."""
    from cortex_ti.axisymmetric.dynamics import Dynamics

    kw = dict(kappa=0.3, c0=0.8, zeta0=0.5)
    sp = Spectral(n, symmetric)
    ph = check_visc(1.0, 2.0, 0.0, 0.0, 1.0, kappa=kw["kappa"], c0=kw["c0"])
    dyn = Dynamics(sp, ForceBalance(sp, ph), lambda t: kw["zeta0"] + 0.0 * t, "lagrangian")
    sphere = np.concatenate([np.sin(sp.u), np.cos(sp.u)])
    # the sphere is an equilibrium, held by the closed-form pressure
    _, x, _ = dyn.solve(sphere)
    assert np.abs(dyn.rhs(0.0, sphere)).max() <= 1e-10
    assert x[2 * n] == pytest.approx(base_pressure(kappa=kw["kappa"], c0=kw["c0"], zeta0=kw["zeta0"]), rel=1e-10)
    ev = np.linalg.eigvals(dyn.jac(0.0, sphere))
    ev = np.sort(ev.real[np.abs(ev) > 1e-6])[::-1]  # the tangential (zero) modes dropped; all real, < 0
    degrees = range(2, 2 * n - 1, 2) if symmetric else range(2, n - 6)
    exact = np.array([rate(l, eta_s=1.0, eta_b=2.0, **kw) for l in degrees])
    assert len(ev) >= len(exact)
    np.testing.assert_allclose(ev[: len(exact)], exact, rtol=1e-9)


def test_static_flow_on_the_sphere_with_spontaneous_curvature():
    """The static solve (a scene's ``solve``) holds the sphere with the closed-form pressure and no flow."""
    from cortex_ti.axisymmetric.balance import static_flow

    res = static_flow(
        lambda t: 1.0 + 0.0 * t, eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0, n=16,
        kappa=0.3, spontaneous_curvature=0.8,
    )  # fmt: skip
    assert res.P == pytest.approx(base_pressure(kappa=0.3, c0=0.8, zeta0=1.0), rel=1e-12)
    assert np.abs(res.v_n).max() <= 1e-10 and np.abs(res.v_s).max() <= 1e-10
