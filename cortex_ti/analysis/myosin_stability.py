r"""Exact linear stability of a uniform, self-organising cortex on a sphere.

A regulator (myosin) surface density ``c``, carried by the full cortical velocity (dilution by
area change included), with surface diffusion ``D`` and linear turnover toward ``c0`` at rate
``k``, sets an isotropic active tension ``zeta(c)``:

    d_t c + c v^a_a = D Lap c - k (c - c0)        (d_t at fixed material point)

on the paper's viscous shell (shear ``eta_s``, bulk ``eta_b``, the 3D code's bending-viscosity
normal force with ``eta_bar, eta_bar_b``; conventions.md signs: outward normal, ``C = 2/R`` on a
sphere, ``zeta > 0`` contractile, ``C_ab t^ab = P``), incompressible interior, the rigid motion
fixed by zero mean velocity (scene ``translation: mean_velocity``) or the enclosed volume's
centroid held (``translation: centroid``), zero angular momentum; the surface moves with the
normal velocity. The uniform state is ``c = c0`` on a sphere of radius ``R`` under the tension
``zeta0 = zeta(c0)`` balanced by the Laplace pressure ``P = 2 zeta0 / R``.

Perturb it by ``c = c0 + sum c_lm Y_lm``, ``r = R + sum u_lm Y_lm`` (``u`` the normal
displacement of the shape; real orthonormal ``Y_lm``). Only the activity

    A = c0 zeta'(c0)          (linear law ``zeta0 (1 - gamma + gamma c/c0)``: A = zeta0 gamma;
                               saturating ``2 zeta0 c^2/(c0^2 + c^2)``: A = zeta0, i.e. gamma = 1)

enters at linear order. Each ``(l, m)`` evolves alone, ``d/dt (c_lm, u_lm) = J_l (c_lm, u_lm)``,
with (``L = l(l+1)``, ``mu_l = D L / R^2 + k``, ``kappa_l`` the bending normal drag of
:func:`cortex_ti.truth.sphere_exact.bending_kappa`)::

    E_l = eta_s (L-2) + eta_b L,  X_l = L R^2 kappa_l + 4 eta_s (L-2),
    D_l = R^2 kappa_l E_l + 4 eta_b eta_s (L-2)

    J_l = [[ A X_l / D_l - mu_l,             2 c0 zeta0 eta_s (L-2)^2 / (R D_l) ],
           [ -2 eta_s (L-2) R A / (c0 D_l),  -(L-2) E_l zeta0 / D_l            ]]      (l >= 2)

``det J_l = (L-2) zeta0 (E_l mu_l - L A) / D_l``, so the uniform state loses stability at degree
l (stationary onset, the only one for ``gamma <= 1``) at

    A_c(l) = E_l mu_l / L = (eta_s (L-2) + eta_b L) (D / R^2 + k / L),

whatever the bending viscosity and the base tension ``zeta0``; ``A_c(l)`` grows with l, so l = 1
(polarity) goes first, and l = 2 (a ring) first among the modes even under ``z -> -z``.
Degree 1: the myosin part grows at ``A G_1 - mu_1``, ``G_1 = 1/eta_b`` (exact; with bending
viscosity and the mean-velocity gauge see :func:`l1_gain`); the shape part is a rigid translation
(neutral, the mean-velocity gauge lets it drift at ``-(2 a_1 / R) (A / c0)`` per unit ``c_1m``, the
centroid gauge removes it). Degree 0: ``u_00 = 0`` (volume), ``c_00`` decays at ``-k``.

Derivation: ``docs/derivations/myosin_stability.md``; guide with a table of onsets:
``docs/method/myosin_stability.md``. Pure numpy; it imports nothing of the package (a truth for
the tests of the runs and of the spectrum tool).

>>> growth_rates(2, zeta0=1.0, gamma=1.0, D=0.05, k=0.2)
array([ 0.118034, -2.118034])
>>> critical_activity(2, D=0.05, k=0.2), critical_activity(1, D=0.05, k=0.2)
(0.8333333333333334, 0.30000000000000004)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "FORMULATIONS",
    "TRANSLATIONS",
    "Modes",
    "activity",
    "critical_activity",
    "first_unstable_degree",
    "growth_rates",
    "l1_gain",
    "laplace_rate",
    "mode_matrix",
    "modes",
    "oscillatory_gamma",
]

#: Values of the scene key ``translation`` (scene.schema.json, its enum; a test checks they agree):
#: ``mean_velocity`` (``oint v dA = 0``, paper Eq. 36) or ``centroid`` (the enclosed volume's
#: centroid held, ``oint (x - x_c) v_n dA = 0``).
TRANSLATIONS = ("mean_velocity", "centroid")
#: How the 3D formulation closes the one l = 1 equation the bending viscosity makes inconsistent with
#: the mean-velocity gauge (names of ``physics.formulations.FORMULATIONS``): ``rayleigh_p1`` (the
#: gauge's multiplier is a uniform force density, as in the axisymmetric model) or ``paper`` (the
#: constrained least squares, its normal rows weighted 1/h -> infinity).
FORMULATIONS = ("rayleigh_p1", "paper")
#: Tension laws and their activity ``c0 zeta'(c0)`` in units of ``zeta0``.
_LAWS = {"linear": lambda gamma: gamma, "saturating": lambda gamma: 1.0}


def activity(law: str, zeta0: float, gamma: float | None = None) -> float:
    """The activity ``A = c0 zeta'(c0)`` of a tension law with ``zeta(c0) = zeta0``.

    ``linear``: ``zeta0 (1 - gamma + gamma c/c0)`` -> ``zeta0 gamma``;
    ``saturating``: ``2 zeta0 c^2 / (c0^2 + c^2)`` -> ``zeta0`` (``gamma`` ignored).

    >>> activity("linear", 2.0, 0.5), activity("saturating", 2.0)
    (1.0, 2.0)
    """
    if law not in _LAWS:
        raise ValueError(f"tension law must be one of {sorted(_LAWS)}, got {law!r}")
    if law == "linear" and gamma is None:
        raise ValueError("the linear law needs gamma")
    return float(zeta0) * float(_LAWS[law](gamma))


# ---------------------------------------------------------------------------------------------
# checks and the per-degree coefficients
# ---------------------------------------------------------------------------------------------


def _degree(l) -> int:
    if isinstance(l, bool) or int(l) != l or l < 0:
        raise ValueError(f"degree l must be an integer >= 0, got {l!r}")
    return int(l)


def _check(D, k, c0, eta_s, eta_b, eta_bar, eta_bar_b, radius, translation, formulation) -> None:
    vals = {
        "D": D,
        "k": k,
        "c0": c0,
        "eta_s": eta_s,
        "eta_b": eta_b,
        "eta_bar": eta_bar,
        "eta_bar_b": eta_bar_b,
        "radius": radius,
    }
    for name, v in vals.items():
        if not (isinstance(v, (int, float, np.floating, np.integer)) and math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
    for name in ("c0", "eta_s", "radius"):
        if not vals[name] > 0:
            raise ValueError(f"{name} must be > 0, got {vals[name]!r}")
    if translation not in TRANSLATIONS:
        raise ValueError(f"translation must be one of {TRANSLATIONS}, got {translation!r}")
    if formulation not in FORMULATIONS:
        raise ValueError(f"formulation must be one of {FORMULATIONS}, got {formulation!r}")


def _kappa(l: int, R: float, eta_bar: float, eta_bar_b: float) -> float:
    """Bending normal drag per unit normal speed of degree l on the sphere (the 3D code's Eq. 45
    force; the same expression as ``sphere_exact.bending_kappa``, repeated so that this module
    stays independent of the one its tests use as the truth)."""
    return (2.0 * eta_bar_b * l * (l + 1) + 8.0 * eta_bar - 4.0 * eta_bar_b) / R**3


def _coefficients(l, eta_s, eta_b, eta_bar, eta_bar_b, R):
    """``(E_l, X_l, D_l)`` for l >= 2 (module docstring), checking ``D_l > 0``."""
    L = l * (l + 1)
    kap = _kappa(l, R, eta_bar, eta_bar_b)
    E = eta_s * (L - 2) + eta_b * L
    X = L * R * R * kap + 4.0 * eta_s * (L - 2)
    Dl = R * R * kap * E + 4.0 * eta_b * eta_s * (L - 2)
    if not Dl > 0.0:
        raise ValueError(
            f"degree {l}: the normal balance is singular (eta_b = {eta_b} and bending "
            f"drag {kap}): it needs eta_b > 0 or a bending viscosity"
        )
    return E, X, Dl


def l1_gain(
    *,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    radius: float = 1.0,
    translation: str = "mean_velocity",
    formulation: str = "rayleigh_p1",
) -> tuple[float, float]:
    r"""Degree 1: ``(G_1, a_1)``, the area-dilation rate ``-v^c_c`` and the poloidal potential
    ``a`` of the flow ``v = a grad_s Y_1m + b Y_1m n`` per unit tension ``zeta_1m``.

    Degree-1 flows are shear-free, so the tangential balance is ``s := eta_b v^c_c + zeta = 0`` and
    the normal one ``2 s / R + kappa_1 b = 0``, ``kappa_1 = 8 eta_bar / R^3`` (the paper's bending
    term ``2 eta_bar C v_n C^ab`` is not invariant under translations).

    * ``centroid`` (``b = 0``): exact, ``a = R^2 / (2 eta_b)``, ``G_1 = 1 / eta_b``.
    * ``mean_velocity`` (``b = -2 a / R``), no bending: exact, ``a = R^2 / (6 eta_b)``, ``G_1 = 1/eta_b``.
    * ``mean_velocity`` with ``eta_bar > 0``: no force-free flow; the gauge's multiplier is a uniform
      force density (``rayleigh_p1``, the axisymmetric model; the minimum of the Rayleighian on the
      gauge): ``a = R^2 / (6 eta_b + 16 eta_bar / (3 R))``; the paper's least squares with its
      normal rows dominant (``paper``): ``a = R^2 / (6 eta_b + 8 eta_bar / R)``
      (``sphere_exact.l1_coefficients``). ``G_1 = 6 a / R^2``.

    >>> l1_gain(eta_b=2.0)
    (0.5, 0.08333333333333333)
    """
    R = float(radius)
    if translation == "centroid" or eta_bar == 0.0:
        if not eta_b > 0.0:
            raise ValueError(
                "degree 1 needs eta_b > 0 (the tension gradient is balanced by the bulk viscous stress alone)"
            )
        a = R * R / (2.0 * eta_b) if translation == "centroid" else R * R / (6.0 * eta_b)
        return 1.0 / eta_b, a
    kap1 = _kappa(1, R, eta_bar, 0.0)
    extra = (2.0 / 3.0) * kap1 * R * R if formulation == "rayleigh_p1" else kap1 * R * R
    a = R * R / (6.0 * eta_b + extra)
    return 6.0 * a / (R * R), a


# ---------------------------------------------------------------------------------------------
# the linear system per degree
# ---------------------------------------------------------------------------------------------


def mode_matrix(
    l: int,
    zeta0: float,
    gamma: float,
    D: float,
    k: float,
    *,
    c0: float = 1.0,
    eta_s: float = 1.0,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    radius: float = 1.0,
    translation: str = "mean_velocity",
    formulation: str = "rayleigh_p1",
) -> np.ndarray:
    r"""The matrix ``J_l`` of ``d/dt x = J_l x`` for one ``(l, m)`` (the same for every m).

    State ``x = (c_lm, u_lm)``: myosin and normal shape displacement amplitudes. ``l = 0``:
    ``x = (c_00,)`` (the volume fixes ``u_00 = 0``); ``l = 1`` with ``translation='centroid'``:
    ``x = (c_1m,)`` (the centroid fixes ``u_1m = 0``); otherwise 2 x 2. ``A = zeta0 gamma`` (the
    linear law; pass ``gamma=1`` for the saturating one, :func:`activity`).

    >>> mode_matrix(2, 1.0, 1.0, 0.05, 0.2)
    array([[ 0.5,  2. ],
           [-0.5, -2.5]])
    >>> mode_matrix(1, 1.0, 1.0, 0.05, 0.2)        # mean velocity: the shape drifts, neutral
    array([[ 0.7       ,  0.        ],
           [-0.33333333,  0.        ]])
    """
    l = _degree(l)
    _check(D, k, c0, eta_s, eta_b, eta_bar, eta_bar_b, radius, translation, formulation)
    R = float(radius)
    A = float(zeta0) * float(gamma)
    L = l * (l + 1)
    mu = D * L / R**2 + k
    if l == 0:
        return np.array([[-float(k)]])
    if l == 1:
        G1, a1 = l1_gain(eta_b=eta_b, eta_bar=eta_bar, radius=R, translation=translation, formulation=formulation)
        if translation == "centroid":
            return np.array([[A * G1 - mu]])
        return np.array([[A * G1 - mu, 0.0], [-2.0 * a1 / R * A / c0, 0.0]])
    E, X, Dl = _coefficients(l, eta_s, eta_b, eta_bar, eta_bar_b, R)
    return np.array(
        [
            [A * X / Dl - mu, 2.0 * c0 * zeta0 * eta_s * (L - 2) ** 2 / (R * Dl)],
            [-2.0 * eta_s * (L - 2) * R * A / (c0 * Dl), -(L - 2) * E * zeta0 / Dl],
        ]
    )


@dataclass(frozen=True)
class Modes:
    """Eigenvalues ``rates`` (largest real part first) and eigenvectors ``vectors[:, i]`` (unit
    2-norm, the myosin component real and >= 0) of :func:`mode_matrix`; ``state`` names the
    components."""

    rates: np.ndarray
    vectors: np.ndarray
    state: tuple


def _eig2(J: np.ndarray):
    """Closed-form eigenpairs of a real 2 x 2 (or 1 x 1) matrix: ``T/2 +- sqrt(T^2/4 - det)``."""
    if J.shape == (1, 1):
        return np.array([J[0, 0]]), np.ones((1, 1))
    T, det = J[0, 0] + J[1, 1], J[0, 0] * J[1, 1] - J[0, 1] * J[1, 0]
    disc = T * T / 4.0 - det
    root = math.sqrt(disc) if disc >= 0 else 1j * math.sqrt(-disc)
    lam = np.array([T / 2.0 + root, T / 2.0 - root])
    vecs = []
    for w in lam:
        # (J - w) x = 0: take the row of larger norm, x orthogonal to it
        r0, r1 = J[0] - [w, 0.0], J[1] - [0.0, w]
        row = r0 if np.linalg.norm(r0) >= np.linalg.norm(r1) else r1
        x = np.array([-row[1], row[0]]) if np.linalg.norm(row) > 0 else np.array([1.0, 0.0])
        if abs(x[0]) > 0:
            x = x * (abs(x[0]) / x[0])
        elif np.real(x[1]) < 0:
            x = -x
        vecs.append(x / np.linalg.norm(x))
    out = np.stack(vecs, axis=1)
    if disc >= 0:
        lam, out = lam.real, out.real
    return lam, out


def modes(l: int, zeta0: float, gamma: float, D: float, k: float, **kw) -> Modes:
    """Eigenvalues and eigenvectors of :func:`mode_matrix` (same arguments).

    >>> m = modes(2, 1.0, 1.0, 0.05, 0.2)
    >>> m.state, m.rates.round(6)
    (('c', 'u'), array([ 0.118034, -2.118034]))
    >>> m.vectors[:, 0].round(4)      # the growing mode: more myosin where the shape moves in
    array([ 0.9822, -0.1876])
    """
    l = _degree(l)
    J = mode_matrix(l, zeta0, gamma, D, k, **kw)
    lam, vec = _eig2(J)
    order = np.argsort(-np.real(lam), kind="stable")
    return Modes(lam[order], vec[:, order], ("c", "u")[: J.shape[0]])


def growth_rates(
    l: int,
    zeta0: float,
    gamma: float,
    D: float,
    k: float,
    *,
    eta_s: float = 1.0,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    translation: str = "mean_velocity",
    c0: float = 1.0,
    radius: float = 1.0,
    formulation: str = "rayleigh_p1",
    decimals: int | None = 6,
) -> np.ndarray:
    r"""Growth rates of degree l (largest real part first; complex only past a Hopf point).

    ``decimals``: rounding of the result (the doctests' display; ``None`` for full precision).

    >>> growth_rates(1, 1.0, 1.0, 0.05, 0.2)                      # polarity grows; translation 0
    array([0.7, 0. ])
    >>> growth_rates(1, 1.0, 1.0, 0.05, 0.2, translation="centroid")
    array([0.7])
    >>> growth_rates(3, 1.0, 0.0, 0.05, 0.2)                      # no activity: -D L - k, Laplace
    array([-0.8, -5.5])
    """
    m = modes(
        l,
        zeta0,
        gamma,
        D,
        k,
        eta_s=eta_s,
        eta_b=eta_b,
        eta_bar=eta_bar,
        eta_bar_b=eta_bar_b,
        translation=translation,
        c0=c0,
        radius=radius,
        formulation=formulation,
    )
    r = m.rates
    return r if decimals is None else np.round(r, decimals) + 0.0


def laplace_rate(
    l: int,
    zeta0: float,
    *,
    eta_s: float = 1.0,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    radius: float = 1.0,
) -> float:
    r"""Relaxation rate of a shape mode of degree l >= 2 of a uniformly tense sphere (no myosin
    feedback): ``-(L-2) E_l zeta0 / D_l``; without bending ``-zeta0 (eta_s (L-2) + eta_b L) /
    (4 eta_s eta_b)`` (independent of R). ``l = 1`` (translation): 0.

    >>> laplace_rate(2, 1.0), laplace_rate(3, 1.0, eta_b=2.0)
    (-2.5, -4.25)
    """
    l = _degree(l)
    _check(0.0, 0.0, 1.0, eta_s, eta_b, eta_bar, eta_bar_b, radius, "mean_velocity", "rayleigh_p1")
    if l == 0:
        raise ValueError("degree 0 is no shape mode (the volume is held)")
    if l == 1:
        return 0.0
    E, _, Dl = _coefficients(l, eta_s, eta_b, eta_bar, eta_bar_b, float(radius))
    L = l * (l + 1)
    return -(L - 2) * E * float(zeta0) / Dl


# ---------------------------------------------------------------------------------------------
# onsets
# ---------------------------------------------------------------------------------------------


def critical_activity(
    l: int,
    D: float,
    k: float,
    *,
    gamma: float = 1.0,
    eta_s: float = 1.0,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    translation: str = "mean_velocity",
    radius: float = 1.0,
    formulation: str = "rayleigh_p1",
) -> float:
    r"""The activity ``A = zeta0 gamma`` at which degree l starts to grow, raising ``zeta0`` at
    fixed ``gamma`` (``inf`` if it never does).

    Stationary onset (``det J_l = 0``): ``A_c = E_l mu_l / L`` for l >= 2, independent of the
    bending viscosity and of ``zeta0``; l = 1: ``mu_1 / G_1`` (:func:`l1_gain`); l = 0: never.
    If ``gamma`` exceeds :func:`oscillatory_gamma` the trace vanishes first (a Hopf onset at
    ``A_H = mu_l D_l gamma / (X_l gamma - (L-2) E_l)``) and that activity is returned.

    >>> critical_activity(2, D=0.05, k=0.2, eta_b=2.0)           # (4 + 12)(0.05 + 0.2/6)
    1.3333333333333333
    >>> critical_activity(2, D=0.0, k=0.0)                       # no diffusion nor turnover
    0.0
    """
    l = _degree(l)
    _check(D, k, 1.0, eta_s, eta_b, eta_bar, eta_bar_b, radius, translation, formulation)
    R = float(radius)
    L = l * (l + 1)
    mu = D * L / R**2 + k
    if l == 0:
        return math.inf
    if l == 1:
        G1, _ = l1_gain(eta_b=eta_b, eta_bar=eta_bar, radius=R, translation=translation, formulation=formulation)
        return mu / G1
    E, X, Dl = _coefficients(l, eta_s, eta_b, eta_bar, eta_bar_b, R)
    stationary = E * mu / L
    if gamma > oscillatory_gamma(l, eta_s=eta_s, eta_b=eta_b):
        return mu * Dl * gamma / (X * gamma - (L - 2) * E)
    return stationary


def oscillatory_gamma(l: int, *, eta_s: float = 1.0, eta_b: float = 1.0) -> float:
    r"""The slope ``gamma`` above which degree l >= 2 loses stability by oscillation (a Hopf point,
    trace 0 while det > 0) before the stationary onset: ``E_l^2 / (4 eta_s^2 (L-2))``, for any
    bending viscosity. At least ``max((L-2)/4, eta_b L/eta_s) >= 1``: never for the tension laws
    that keep ``zeta >= 0`` (``gamma <= 1``). ``inf`` for l <= 1 (real spectrum).

    >>> oscillatory_gamma(2), oscillatory_gamma(3)
    (6.25, 12.1)
    """
    l = _degree(l)
    if l <= 1:
        return math.inf
    L = l * (l + 1)
    E = eta_s * (L - 2) + eta_b * L
    return E * E / (4.0 * eta_s * eta_s * (L - 2))


def first_unstable_degree(D: float, k: float, *, lmax: int = 50, parity: str = "any", **kw) -> tuple[int, float]:
    r"""``(l, A_c)``: the degree with the lowest onset among ``1..lmax`` (``parity='even'``: among
    the even degrees, the modes a mirror-symmetric seed excites). Keywords as
    :func:`critical_activity`.

    >>> first_unstable_degree(0.05, 0.2), first_unstable_degree(0.05, 0.2, parity="even")
    ((1, 0.30000000000000004), (2, 0.8333333333333334))
    """
    if parity not in ("any", "even"):
        raise ValueError(f"parity must be 'any' or 'even', got {parity!r}")
    ls = range(2 if parity == "even" else 1, lmax + 1, 2 if parity == "even" else 1)
    onsets = [(critical_activity(l, D, k, **kw), l) for l in ls]
    a, l = min(onsets)
    return l, a
