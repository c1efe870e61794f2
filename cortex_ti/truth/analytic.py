r"""Analytic flows of the viscous active cortex on a static sphere, and error measures.

Conventions (``conventions.md``): outward normal ``n``; ``C_ab = g_ab / R`` on a sphere of
radius ``R``; surface stress ``t^ab = 2 eta_s (v^ab - v g^ab / 2) + eta_b v g^ab + zeta g^ab``
with ``v = v^c_c``; tangential balance ``nabla_a t^ab = 0``; normal balance
``C_ab t^ab = P`` (``P = p_in - p_out``); ``zeta > 0`` contractile.

Derivation for one real harmonic ``zeta = zeta_l Y`` of degree ``l`` (``L = l (l + 1)``,
``Lap Y = -L Y / R^2``, ``nabla_a nabla^a nabla^b Y = grad^b Lap Y + grad^b Y / R^2`` on the
sphere) with the ansatz ``v = alpha grad_s Y + beta Y n``:

* ``v_ab = alpha nabla_a nabla_b Y + (beta Y / R) g_ab``, so
  ``v = (-L alpha / R^2 + 2 beta / R) Y`` and
  ``nabla_a (v^ab - v g^ab / 2) = -(L - 2) alpha / (2 R^2) grad^b Y`` (beta drops out).
* Tangential: ``[-eta_s (L - 2) alpha / R^2 - eta_b L alpha / R^2 + 2 eta_b beta / R + zeta_l] grad^b Y = 0``.
* Normal: ``C_ab t^ab = (2 / R) (eta_b v + zeta)`` (the shear part is traceless), so the
  ``Y`` part reads ``(2 / R) [eta_b (-L alpha / R^2 + 2 beta / R) + zeta_l] + kappa_l beta = 0``,
  where ``kappa_l beta Y`` is the normal force of the paper's bending-viscosity stress
  (Sec. 3.4, Eq. 45; it is left out of the tangential balance, as in the paper):
  ``kappa_l = (2 eta_bar_b L + 8 eta_bar - 4 eta_bar_b) / R^3``
  (``2 eta_bar_b (L - 2) / R^3`` from ``eta_bar_b g^ab d_t C``, the traceless ``eta_bar`` part
  contributes nothing on a sphere, ``+8 eta_bar / R^3`` from the extra ``C v_n C^ab`` term).

Without bending viscosity the two equations give ``alpha = 0``, ``beta = -R zeta_l / (2 eta_b)``
for every ``l >= 2`` (so for any pattern without an ``l = 1`` part,
``v = -(R / (2 eta_b)) (zeta - zeta_bar) n``); with ``eta_b = 0`` and ``v_n = 0`` imposed,
``alpha = R^2 zeta_l / (eta_s (L - 2))``.  The uniform part ``zeta_bar`` only sets
``P = 2 zeta_bar / R``.  ``l = 1`` has no solution: ``L - 2 = 0`` and a degree-1 tension
gradient would need an external force.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import SceneError
from ..physics.patterns import (
    evaluate_active_stress,
    harmonic_terms,
    integrate_patterns,
)
from ..physics.spherical import (
    direction_angles,
    real_sph_harm,
    real_sph_harm_surface_gradient,
)

__all__ = [
    "bending_coefficients",
    "error_measures",
    "l1_moments",
    "sphere_bending_solution",
    "sphere_full_solution",
    "sphere_tangential_solution",
]

_SQRT_3_4PI = math.sqrt(3.0 / (4.0 * math.pi))


def _unit_directions(points) -> np.ndarray:
    p = np.atleast_2d(np.asarray(points, dtype=float))
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {np.shape(points)}")
    r = np.linalg.norm(p, axis=1)
    if np.any(r == 0.0):
        raise ValueError("a point lies at the center of the sphere: no radial direction")
    return p / r[:, None]


def _positive(value, name: str, allow_zero: bool = False) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0.0 or (v == 0.0 and not allow_zero):
        raise ValueError(f"{name} must be {'>= 0' if allow_zero else '> 0'}, got {value!r}")
    return v


def l1_moments(patterns: list[dict], order: int | None = None) -> np.ndarray:
    """Degree-1 moments ``int zeta Y_1m dOmega`` over the unit sphere, for ``m = -1, 0, 1``.

    ``Y_1,-1 = sqrt(3/4pi) y``, ``Y_10 = sqrt(3/4pi) z``, ``Y_11 = sqrt(3/4pi) x``
    (:func:`cortex_ti.physics.spherical.real_sph_harm`).  Computed by converged quadrature.

    Returns
    -------
    ndarray, shape (3,)
        ``[<zeta, Y_1-1>, <zeta, Y_10>, <zeta, Y_11>]``.
    """

    def w(pts):
        return _SQRT_3_4PI * pts[:, [1, 2, 0]]

    return np.asarray(integrate_patterns(patterns, weight=w, order=order), dtype=float)


def _check_no_l1(patterns, order=None, rtol=1e-9) -> None:
    mom = l1_moments(patterns, order=order)
    # scale: L2 norm of zeta over the unit sphere
    l2 = math.sqrt(max(float(_l2_squared(patterns, order)), 0.0))
    tol = rtol * max(l2, 1e-300)
    for k, m in enumerate((-1, 0, 1)):
        if abs(mom[k]) > tol:
            direction = {-1: "y", 0: "z", 1: "x"}[m]
            raise ValueError(
                f"the active-stress pattern has an l = 1 part: moment <zeta, Y_1,{m}> = {mom[k]:.6e} "
                f"(along {direction}; L2 norm of zeta {l2:.6e}); the static-sphere solution needs none "
                "(a degree-1 tension gradient would need an external force)"
            )


def _l2_squared(patterns, order=None) -> float:
    """``int zeta^2 dOmega`` (cross terms between patterns included)."""
    # zeta^2 = sum_i zeta_i * zeta: integrate each pattern times the total on its own grid
    return float(integrate_patterns(patterns, weight=lambda p: evaluate_active_stress(p, patterns), order=order))


def sphere_full_solution(
    points, patterns, radius: float = 1.0, eta_b: float = 1.0, order: int | None = None
) -> tuple[np.ndarray, float]:
    """Exact flow of the full system (tangential + normal balance) on a static sphere.

    ``v = -(R / (2 eta_b)) (zeta - zeta_bar) n``, ``P = 2 zeta_bar / R``, for any isotropic
    pattern without an ``l = 1`` part and without bending viscosity, whatever ``eta_s``.
    ``n`` is the outward radial unit vector of each point (about the origin), ``zeta`` is
    evaluated at the points (direction from the origin: only directions matter for the
    registered patterns), ``zeta_bar`` is the mean over the sphere
    (:func:`cortex_ti.physics.patterns.mean_over_sphere`).

    Parameters
    ----------
    points : array_like, shape (N, 3)
    patterns : list of dict
        Scene ``active_stress`` list.
    radius, eta_b : float
        ``R > 0`` and the bulk viscosity ``eta_b > 0``.

    Returns
    -------
    v : ndarray, shape (N, 3)
    P : float

    Raises
    ------
    ValueError
        If a degree-1 moment of the pattern is nonzero (relative to its L2 norm, 1e-9); the
        message names the moment.
    """
    R = _positive(radius, "radius")
    eb = _positive(eta_b, "eta_b")
    n = _unit_directions(points)
    _check_no_l1(patterns, order=order)
    zbar = float(integrate_patterns(patterns, order=order)) / (4.0 * math.pi)
    zeta = evaluate_active_stress(points, patterns)
    v = (-(R / (2.0 * eb)) * (zeta - zbar))[:, None] * n
    return v, 2.0 * zbar / R


def _terms(terms) -> list[tuple[int, int, float]]:
    """Accept a ``terms`` list, or a list of patterns that are all of type ``harmonics``."""
    if isinstance(terms, (list, tuple)) and terms and all(isinstance(t, dict) and "type" in t for t in terms):
        out = []
        for i, t in enumerate(terms):
            if t["type"] != "harmonics":
                raise ValueError(
                    f"pattern {i} has type {t['type']!r}; only 'harmonics' patterns have this analytic solution"
                )
            out.extend(harmonic_terms(t.get("terms", [])))
        return out
    try:
        return harmonic_terms(terms)
    except SceneError as err:
        raise ValueError(str(err)) from None


def sphere_tangential_solution(points, terms, radius: float = 1.0, eta_s: float = 1.0) -> np.ndarray:
    """Exact flow of the tangential system (``eta_b = 0``, ``v_n = 0`` imposed) on a sphere.

    ``v = sum_{l >= 2} coeff R^2 / (eta_s (l (l + 1) - 2)) grad_s Y_lm`` (paper Eq. 56 with
    signs from ``conventions.md``): the flow runs up the tension gradient (to the poles for
    ``Y_20``).  ``l = 0`` terms contribute nothing.  ``grad_s`` is taken on the sphere of
    radius ``radius`` at the direction of each point from the origin (points need not lie
    exactly on that sphere).

    Parameters
    ----------
    points : array_like, shape (N, 3)
    terms : list
        ``[{"l", "m", "coeff"}, ...]`` -- or a list of ``harmonics`` patterns.
    radius, eta_s : float

    Returns
    -------
    ndarray, shape (N, 3)

    Raises
    ------
    ValueError
        For an ``l = 1`` term (no solution) or invalid terms.
    """
    R = _positive(radius, "radius")
    es = _positive(eta_s, "eta_s")
    u = _unit_directions(points)
    v = np.zeros_like(u)
    for l, m, c in _terms(terms):
        if l == 0:
            continue
        if l == 1:
            raise ValueError(
                f"term l = 1, m = {m}: no static-sphere solution "
                "(a degree-1 tension gradient would need an external force)"
            )
        L = l * (l + 1)
        # grad_s on radius R = grad on the unit sphere / R
        v += (c * R * R / (es * (L - 2)) / R) * real_sph_harm_surface_gradient(l, m, u)
    return v


def bending_coefficients(
    l: int, radius: float, eta_s: float, eta_b: float, eta_bar: float, eta_bar_b: float
) -> tuple[float, float]:
    """``(alpha, beta)`` per unit ``zeta_l`` for one degree ``l >= 2`` (module docstring).

    Solves
    ``-[eta_s (L-2) + eta_b L] alpha / R^2 + 2 eta_b beta / R = -zeta_l`` and
    ``-2 eta_b L alpha / R^3 + (4 eta_b / R^2 + kappa_l) beta = -2 zeta_l / R``,
    ``kappa_l = (2 eta_bar_b L + 8 eta_bar - 4 eta_bar_b) / R^3``, with ``zeta_l = 1``.
    Closed form: ``D = eta_s (L-2) (4 eta_b / R^2 + kappa_l) + eta_b L kappa_l``,
    ``alpha = R^2 kappa_l / D``, ``beta = -2 eta_s (L-2) / (R D)``.  So ``alpha >= 0``: the residual
    tangential flow runs up the tension gradient (toward high tension), and ``|beta| <= R / (2 eta_b)``:
    bending viscosity slows the normal motion.
    """
    if l < 2:
        raise ValueError(f"need l >= 2, got l = {l}")
    R = _positive(radius, "radius")
    es = _positive(eta_s, "eta_s", allow_zero=True)
    eb = _positive(eta_b, "eta_b", allow_zero=True)
    ebar = _positive(eta_bar, "eta_bar", allow_zero=True)
    ebarb = _positive(eta_bar_b, "eta_bar_b", allow_zero=True)
    L = l * (l + 1)
    kappa = (2.0 * ebarb * L + 8.0 * ebar - 4.0 * ebarb) / R**3  # >= 0 for l >= 2
    D = es * (L - 2) * (4.0 * eb / R**2 + kappa) + eb * L * kappa
    if not D > 0.0:
        raise ValueError(
            f"degree l = {l}: the balance equations are singular for eta_s={eta_s}, eta_b={eta_b}, "
            f"eta_bar={eta_bar}, eta_bar_b={eta_bar_b} (no unique flow)"
        )
    # closed-form solution of the 2x2 system (Cramer's rule, simplified)
    alpha = R**2 * kappa / D
    beta = -2.0 * es * (L - 2) / (R * D)
    return float(alpha), float(beta)


def sphere_bending_solution(
    points, terms, radius: float, eta_s: float, eta_b: float, eta_bar: float, eta_bar_b: float
) -> tuple[np.ndarray, float]:
    """Exact flow on a static sphere with the bending-viscosity normal force on.

    ``v = sum_{l >= 2} coeff (alpha_l grad_s Y_lm + beta_l Y_lm n)`` with
    ``(alpha_l, beta_l)`` from :func:`bending_coefficients`; ``P = 2 zeta_bar / R`` with
    ``zeta_bar = sum_{l = 0} coeff / sqrt(4 pi)``.  Reduces to :func:`sphere_full_solution`
    for ``eta_bar = eta_bar_b = 0``, and its tangential part equals
    :func:`sphere_tangential_solution` for ``eta_b = 0`` (then the normal part is
    ``beta_l = -2 / (R kappa_l)``).

    Parameters
    ----------
    points : array_like, shape (N, 3)
    terms : list
        ``[{"l", "m", "coeff"}, ...]`` or a list of ``harmonics`` patterns.
    radius, eta_s, eta_b, eta_bar, eta_bar_b : float

    Returns
    -------
    v : ndarray, shape (N, 3)
    P : float

    Raises
    ------
    ValueError
        For an ``l = 1`` term or a singular system.
    """
    R = _positive(radius, "radius")
    u = _unit_directions(points)
    theta, phi = direction_angles(u)
    v = np.zeros_like(u)
    zbar = 0.0
    for l, m, c in _terms(terms):
        if l == 0:
            zbar += c / math.sqrt(4.0 * math.pi)
            continue
        if l == 1:
            raise ValueError(
                f"term l = 1, m = {m}: no static-sphere solution "
                "(a degree-1 tension gradient would need an external force)"
            )
        alpha, beta = bending_coefficients(l, R, eta_s, eta_b, eta_bar, eta_bar_b)
        if alpha != 0.0:
            v += (c * alpha / R) * real_sph_harm_surface_gradient(l, m, u)
        v += (c * beta * real_sph_harm(l, m, theta, phi))[:, None] * u
    return v, 2.0 * zbar / R


def error_measures(v, v_an) -> tuple[float, float]:
    """Paper Eqs. 57, 58: ``eps = mean_nodes |v - v_an|`` and
    ``eps_rel = sqrt(mean_nodes |v - v_an|^2) / max_nodes |v_an|``.

    Parameters
    ----------
    v, v_an : array_like, shape (N, 3) (or (N,) for scalar fields)

    Returns
    -------
    eps, eps_rel : float
        ``eps_rel`` is ``inf`` (or ``nan`` when also ``v = v_an``) if ``v_an`` vanishes.
    """
    a = np.asarray(v, dtype=float)
    b = np.asarray(v_an, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"shapes differ: {a.shape} vs {b.shape}")
    if a.ndim == 1:
        a = a[:, None]
        b = b[:, None]
    d = np.linalg.norm(a - b, axis=1)
    eps = float(np.mean(d))
    vmax = float(np.max(np.linalg.norm(b, axis=1)))
    with np.errstate(divide="ignore", invalid="ignore"):
        eps_rel = float(np.sqrt(np.mean(d * d)) / vmax)
    return eps, eps_rel


def scene_solution(settings, points) -> np.ndarray:
    """The analytic velocity for a static sphere scene (its :class:`~cortex_ti.scene.RunSettings`),
    chosen by its effects.

    Full system (normal balance, no bending viscosity) -> :func:`sphere_full_solution`;
    tangential system (fixed normal velocity, harmonics only) -> :func:`sphere_tangential_solution`;
    with bending viscosity (harmonics only) -> :func:`sphere_bending_solution`.
    Raises ValueError for scenes without a closed-form solution.
    """
    if settings.mesh.file:
        raise ValueError("analytic solutions exist only for the icosphere scenes")
    radius = settings.mesh.radius
    patterns = list(settings.patterns)
    visc = settings.viscosity
    if settings.has("fixed_normal_velocity"):
        return sphere_tangential_solution(points, patterns, radius=radius, eta_s=visc.shear)
    if settings.has("bending_viscosity"):
        terms = [t for p in patterns if p["type"] == "harmonics" for t in p["terms"]]
        if len(terms) != sum(len(p.get("terms", [])) for p in patterns) or len(patterns) != 1:
            raise ValueError("with bending viscosity the analytic solution needs a single harmonics pattern")
        v, _ = sphere_bending_solution(points, terms, radius, visc.shear, visc.bulk, visc.bending, visc.bending_bulk)
        return v
    v, _ = sphere_full_solution(points, patterns, radius=radius, eta_b=visc.bulk)
    return v
