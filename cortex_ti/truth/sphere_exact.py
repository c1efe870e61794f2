r"""Exact (spectral) solution of the viscous active cortex force balance on a static sphere.

Independent reference ("truth") for the tests of the 3D and axisymmetric solvers: written from
its own derivation (``docs/derivations/sphere_exact.md``), it imports nothing of the package but its
spherical harmonics (:mod:`cortex_ti.truth.spherical_harmonics`, whose names ``expand``,
``Spectrum``, ``real_sph_harm(s)``, ``sphere_mean`` and ``frame_matrix`` stay importable from here).
The conventions are those of docs/method/conventions.md:
outward normal ``n``, ``C_ab = g_ab / R``, surface stress
``t^ab = 2 eta_s (v^ab - v^c_c g^ab / 2) + eta_b v^c_c g^ab + zeta g^ab`` (``zeta > 0``
contractile), tangential balance ``nabla_a t^ab = 0``, normal balance
``C_ab (t^ab + t_b^ab) = P`` with the bending-viscosity normal force of the 3D code
(``C_ab t_b^ab = kappa_l v_n`` for a degree-l normal speed, see :func:`bending_kappa`; the
tangential part of the bending stress is dropped, as in the 3D code), incompressible interior
(``oint v_n dA = 0``, multiplier ``P``), zero total velocity and zero angular momentum.

For ``zeta = sum_lm zeta_lm Y_lm`` (real orthonormal harmonics on the unit sphere, evaluated at
``n``) the flow is, degree by degree,

    v = sum_{l, m} zeta_lm [ alpha_l grad_s Y_lm + beta_l Y_lm n ],     P = 2 zeta_bar / R,

with ``grad_s`` the surface gradient on the sphere of radius ``R`` and ``(alpha_l, beta_l)``
from :func:`flow_coefficients` (degree 1: :func:`l1_coefficients`).

Public API
----------
``sphere_flow(zeta, points, ...) -> (v, P, info)``   velocity at points on the sphere
``expand(zeta, lmax, ...) -> Spectrum``              spherical-harmonic expansion of a callable
``flow_coefficients(l, ...)``, ``l1_coefficients(...)``, ``bending_kappa(l, ...)``
``real_sph_harm(l, m, points)``                      real orthonormal Y_lm (no Condon-Shortley)
``real_sph_harms(lmax, points)``                     every Y_lm up to lmax at once (one recurrence)
``sphere_mean(zeta, axis=None)``                     mean of a callable over the unit sphere
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np

from .spherical_harmonics import (
    FOUR_PI,
    Spectrum,
    check_axisymmetric,
    expand,
    frame_matrix,
    gauss_legendre,
    real_sph_harm,
    real_sph_harms,
    sphere_mean,
    synthesize_chunked,
)

__all__ = [
    "sphere_flow",
    "expand",
    "Spectrum",
    "flow_coefficients",
    "l1_coefficients",
    "bending_kappa",
    "real_sph_harm",
    "real_sph_harms",
    "sphere_mean",
    "frame_matrix",
    "NotConvergedError",
    "L1Error",
]


class NotConvergedError(RuntimeError):
    """The harmonic expansion did not reach the requested tolerance at this l_max."""


class L1Error(ValueError):
    """The tension has a degree-1 part and the problem has no exact solution for it."""


# ---------------------------------------------------------------------------------------------
# per-degree coefficients
# ---------------------------------------------------------------------------------------------


def bending_kappa(l: int, radius: float, eta_bar: float, eta_bar_b: float) -> float:
    r"""Normal bending-viscosity force per unit normal speed for a degree-l ``v_n`` on a sphere.

    ``C_ab t_b^ab = beta^cd nabla_c nabla_d v_n + beta_0 v_n`` with
    ``beta^cd = -2 eta_bar C^cd - (eta_bar_b - eta_bar) C g^cd = -(2 eta_bar_b / R) g^cd`` and
    ``beta_0 = 2 eta_bar (C C~ - C-) - (eta_bar_b - eta_bar) C C~ = (8 eta_bar - 4 eta_bar_b) / R^3``
    (``C = 2/R, C~ = 2/R^2, C- = 2/R^3``); with ``Lap v_n = -l(l+1) v_n / R^2``:
    ``kappa_l = (2 eta_bar_b l(l+1) + 8 eta_bar - 4 eta_bar_b) / R^3``.
    """
    L = l * (l + 1)
    return (2.0 * eta_bar_b * L + 8.0 * eta_bar - 4.0 * eta_bar_b) / radius**3


def flow_coefficients(
    l: int,
    *,
    radius: float = 1.0,
    eta_s: float = 1.0,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    system: str = "full",
) -> tuple[float, float]:
    r"""``(alpha_l, beta_l)`` of ``v = zeta_lm (alpha_l grad_s Y_lm + beta_l Y_lm n)`` for l >= 2.

    ``l = 0`` returns ``(0, 0)`` (a uniform tension only sets ``P``). For ``l = 1`` use
    :func:`l1_coefficients` (the answer depends on the gauge, see ``docs/derivations/sphere_exact.md``).

    full system, ``L = l(l+1)``, ``kappa = kappa_l`` (:func:`bending_kappa`)::

        D_l     = R^2 kappa (eta_s (L-2) + eta_b L) + 4 eta_b eta_s (L-2)
        alpha_l = R^4 kappa / D_l
        beta_l  = -2 eta_s (L-2) R / D_l

    (no bending: ``alpha_l = 0, beta_l = -R / (2 eta_b)``).
    tangential system (``v_n = 0`` imposed, normal balance not solved)::

        alpha_l = R^2 / (eta_s (L-2) + eta_b L),  beta_l = 0.
    """
    if l < 0:
        raise ValueError(f"degree must be >= 0, got {l}")
    if l == 0:
        return 0.0, 0.0
    if l == 1:
        raise ValueError("degree 1 has no gauge-free coefficients: use l1_coefficients")
    R = float(radius)
    L = l * (l + 1)
    if system == "tangential":
        den = eta_s * (L - 2) + eta_b * L
        if den <= 0.0:
            raise ValueError("tangential system needs eta_s > 0")
        return R * R / den, 0.0
    if system != "full":
        raise ValueError(f"system must be 'full' or 'tangential', got {system!r}")
    kap = bending_kappa(l, R, eta_bar, eta_bar_b)
    den = R * R * kap * (eta_s * (L - 2) + eta_b * L) + 4.0 * eta_b * eta_s * (L - 2)
    if not den > 0.0:
        raise ValueError(
            f"full system, degree {l}: no solution (eta_b = {eta_b}, kappa_l = {kap}); the normal "
            "balance needs eta_b > 0 or a bending viscosity"
        )
    return R**4 * kap / den, -2.0 * eta_s * (L - 2) * R / den


def l1_coefficients(
    *,
    radius: float = 1.0,
    eta_s: float = 1.0,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    system: str = "full",
    weight: float = math.inf,
) -> tuple[float, float, bool, float, float]:
    r"""Degree 1: ``(alpha_1, beta_1, exact, res_t, res_n)``.

    All l = 1 motions are shear-free, so the tangential balance reduces to
    ``s := eta_b v^c_c + zeta = 0`` and the normal balance to ``2 s / R + kappa_1 v_n = 0``
    (per unit ``zeta_1m``, with ``v = a grad_s Y + b Y n``, ``v^c_c = (-2 a / R^2 + 2 b / R) Y``,
    ``kappa_1 = 8 eta_bar / R^3`` -- the paper's stabilising term ``2 eta_bar C v_n C^ab``
    is not invariant under translations). The gauge (zero total velocity) is ``2 a + b R = 0``;
    zero angular momentum removes the toroidal l = 1 field.

    * full, ``eta_bar = 0``, ``eta_b > 0``: exact solution compatible with the gauge,
      ``a = R^2 / (6 eta_b), b = -R / (3 eta_b)``.
    * full otherwise: no exact solution in the gauge. Returned: the gauge-constrained least squares
      ``min |s|^2 |grad Y|^2 + weight^2 |2 s / R + kappa_1 b|^2`` (the 3D code's bordered
      least squares, its normal rows weighted by ``weight`` relative to the tangential rows;
      ``weight = inf`` is the limit h -> 0 of its 1/h equilibration):
      ``a = R^2 / (6 eta_b + 8 eta_bar / R)``, ``b = -2 a / R`` for ``weight = inf``.
    * tangential (``v_n = 0``): the gauge forces ``a = 0`` (a degree-1 tangential gradient field
      has a nonzero mean), so the l = 1 velocity vanishes; exact only without l = 1 tension.

    ``res_t, res_n``: amplitudes of the remaining tangential force ``s`` (multiplies
    ``zeta_1m grad_s Y_1m``) and normal force (multiplies ``zeta_1m Y_1m``).
    """
    R = float(radius)
    if system == "tangential":
        # s = -2 eta_b a / R^2 + 1 with a = 0
        return 0.0, 0.0, False, 1.0, float("nan")
    if system != "full":
        raise ValueError(f"system must be 'full' or 'tangential', got {system!r}")
    kap1 = bending_kappa(1, R, eta_bar, eta_bar_b)  # = 8 eta_bar / R^3
    if kap1 == 0.0 and eta_b > 0.0:
        return R * R / (6.0 * eta_b), -R / (3.0 * eta_b), True, 0.0, 0.0
    # unknown a, b = -2 a / R; s = 1 - 6 eta_b a / R^2; normal = 2 s / R + kap1 b
    if math.isinf(weight):
        c = 6.0 * eta_b / R**2 + kap1
        if c == 0.0:
            raise L1Error("degree 1 undetermined: eta_b = 0 and no bending viscosity")
        a = 1.0 / c
    else:
        w = float(weight)
        r0 = np.array([math.sqrt(2.0) / R, 2.0 * w / R])
        r1 = np.array([-6.0 * math.sqrt(2.0) * eta_b / R**3, w * (-12.0 * eta_b / R**3 - 2.0 * kap1 / R)])
        nn = float(r1 @ r1)
        if nn == 0.0:
            raise L1Error("degree 1 undetermined: eta_b = 0 and no bending viscosity")
        a = -float(r0 @ r1) / nn
    b = -2.0 * a / R
    s = 1.0 - 6.0 * eta_b * a / R**2
    return a, b, False, s, 2.0 * s / R + kap1 * b


# ---------------------------------------------------------------------------------------------
# the flow
# ---------------------------------------------------------------------------------------------


def _degree_weights(lmax, R, eta_s, eta_b, eta_bar, eta_bar_b, system):
    alpha = np.zeros(lmax + 1)
    beta = np.zeros(lmax + 1)
    for l in range(2, lmax + 1):
        alpha[l], beta[l] = flow_coefficients(
            l, radius=R, eta_s=eta_s, eta_b=eta_b, eta_bar=eta_bar, eta_bar_b=eta_bar_b, system=system
        )
    return alpha, beta


def _truncation(B: np.ndarray, noise: np.ndarray) -> tuple[float, float]:
    """(geometric tail estimate beyond lmax, rigorous bound on |v_lmax - v_lmax/2|)."""
    lmax = B.size - 1
    half = sum(B[lmax // 2 + 1 :])
    q = max(lmax // 4, 1)
    S4 = float(np.sum(B[lmax - q + 1 :]))
    S3 = float(np.sum(B[lmax - 2 * q + 1 : lmax - q + 1]))
    floor = 10.0 * float(np.sum(noise[lmax - q + 1 :]))
    if S4 <= floor:
        return S4, float(half)  # at the rounding level
    if S3 <= 0.0:
        return math.inf, float(half)
    r = S4 / S3
    tail = S4 * r / (1.0 - r) if r < 1.0 else math.inf
    return float(tail), float(half)


def sphere_flow(
    zeta,
    points,
    *,
    radius: float = 1.0,
    eta_s: float = 1.0,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    system: str = "full",
    axis=None,
    axisymmetric: bool | None = None,
    lmax=120,
    tol: float = 1e-10,
    on_unconverged: str = "raise",
    l1: str = "auto",
    l1_weight: float = math.inf,
    l1_rtol: float = 1e-11,
    check_radius: float = 1e-8,
    spectrum: Spectrum | None = None,
):
    r"""Exact flow on the static sphere of radius ``radius`` centred at the origin.

    Parameters
    ----------
    zeta : callable ``zeta(points (N, 3) on the unit sphere) -> (N,)``, the isotropic active
        tension (``zeta > 0`` contractile). Ignored if ``spectrum`` is given.
    points : (N, 3) points on the sphere (``| |x| - R | <= check_radius R``).
    system : ``"full"`` (tangential + normal balance, incompressible) or ``"tangential"``
        (``v_n = 0`` imposed, normal balance not solved; ``eta_b = 0`` allowed; ``P = nan``).
    axis : pattern axis (expansion frame). With ``axisymmetric=None`` an axis triggers a check
        of axisymmetry and, if so, the (cheap) Legendre expansion.
    lmax : int, or ``"auto"`` (doubling from 32 until converged; up to 1024 axisymmetric,
        256 general).
    tol : tolerance on the estimated truncation error relative to the velocity scale
        ``max(rms over the sphere, max over points)``; ``on_unconverged`` = "raise" | "warn" |
        "ignore".
    l1 : what to do with a degree-1 part of zeta (see ``docs/derivations/sphere_exact.md``): ``"auto"`` (use the
        exact solution when there is one -- full system without eta_bar -- else raise
        :class:`L1Error` if the l = 1 part exceeds ``l1_rtol`` times the tension scale),
        ``"raise"`` (raise whenever it is present), ``"lsq"`` (return the gauge-constrained
        least-squares answer of :func:`l1_coefficients` with ``weight=l1_weight``), ``"drop"``
        (ignore the l = 1 part).

    Returns
    -------
    v : (N, 3) velocity; P : pressure difference ``2 zeta_bar / R`` (full) or nan (tangential);
    info : dict with ``lmax``, ``truncation_error`` (estimated sup error, absolute),
        ``truncation_error_rel``, ``change_half`` (rigorous bound on ``max |v_lmax - v_lmax/2|``
        over the sphere), ``change_half_points`` (the same at the given points), ``zeta_mean``,
        ``alpha``, ``beta``, ``degree_bound`` (sup bound of each degree's velocity), ``l1``
        (dict), ``spectrum``, timings.
    """
    t0 = time.perf_counter()
    R = float(radius)
    u = _check_flow_input(points, R, eta_s, eta_b, eta_bar, eta_bar_b, system, on_unconverged, l1, check_radius)
    if isinstance(lmax, str):
        return _flow_auto_lmax(
            zeta,
            points,
            lmax,
            spectrum,
            axis,
            axisymmetric,
            on_unconverged,
            dict(
                radius=radius,
                eta_s=eta_s,
                eta_b=eta_b,
                eta_bar=eta_bar,
                eta_bar_b=eta_bar_b,
                system=system,
                tol=tol,
                l1=l1,
                l1_weight=l1_weight,
                l1_rtol=l1_rtol,
                check_radius=check_radius,
            ),
        )
    t1 = time.perf_counter()
    spec = spectrum if spectrum is not None else expand(zeta, int(lmax), axis=axis, axisymmetric=axisymmetric)
    lmax = spec.lmax
    t2 = time.perf_counter()
    alpha, beta = _degree_weights(lmax, R, eta_s, eta_b, eta_bar, eta_bar_b, system)
    norms = spec.degree_norms
    zbar = spec.mean
    zscale = max(abs(zbar), float(np.sqrt(np.sum(norms[1:] ** 2) / FOUR_PI)), 1e-300)
    l1info = _degree_one(spec, alpha, beta, zscale, R, eta_s, eta_b, eta_bar, eta_bar_b, system, l1, l1_weight, l1_rtol)
    trunc, change_half, vrms, B = _truncation_estimate(norms, alpha, beta, R, lmax)

    out = synthesize_chunked(spec, beta, alpha / R, u, half=lmax // 2)
    v = out["vn"][:, None] * u + out["g"]
    vh = out["vn_half"][:, None] * u + out["g_half"]
    t3 = time.perf_counter()
    vmax = float(np.max(np.linalg.norm(v, axis=1))) if v.shape[0] else 0.0
    vscale = max(vrms, vmax)
    rel = trunc / vscale if vscale > 0 else 0.0
    info = {
        "lmax": lmax,
        "system": system,
        "axisymmetric": spec.axisymmetric,
        "truncation_error": trunc,
        "truncation_error_rel": rel,
        "change_half": change_half,
        "change_half_points": float(np.max(np.linalg.norm(v - vh, axis=1))) if v.shape[0] else 0.0,
        "v_rms": vrms,
        "v_max_points": vmax,
        "zeta_mean": zbar,
        "alpha": alpha,
        "beta": beta,
        "degree_bound": B,
        "l1": l1info,
        "spectrum": spec,
        "quadrature": spec.quadrature,
        "time_expand": t2 - t1,
        "time_evaluate": t3 - t2,
        "time_total": t3 - t0,
    }
    P = 2.0 * zbar / R if system == "full" else float("nan")
    if rel > tol:
        msg = (
            f"sphere_flow: estimated truncation error {trunc:.3g} ({rel:.3g} relative) at "
            f"lmax = {lmax} exceeds tol = {tol:.3g}"
        )
        if on_unconverged == "raise":
            err = NotConvergedError(msg)
            err.info = info
            raise err
        if on_unconverged == "warn":
            warnings.warn(msg, RuntimeWarning, stacklevel=2)
    return v, P, info


def _check_flow_input(
    points, R, eta_s, eta_b, eta_bar, eta_bar_b, system, on_unconverged, l1, check_radius
) -> np.ndarray:
    """The points' unit directions, after checking every argument of :func:`sphere_flow`."""
    if not (R > 0 and eta_s > 0 and eta_b >= 0 and eta_bar >= 0 and eta_bar_b >= 0):
        raise ValueError("need radius > 0, eta_s > 0 and eta_b, eta_bar, eta_bar_b >= 0")
    if system not in ("full", "tangential"):
        raise ValueError(f"system must be 'full' or 'tangential', got {system!r}")
    if on_unconverged not in ("raise", "warn", "ignore"):
        raise ValueError("on_unconverged must be 'raise', 'warn' or 'ignore'")
    if l1 not in ("auto", "raise", "lsq", "drop"):
        raise ValueError("l1 must be 'auto', 'raise', 'lsq' or 'drop'")
    p = np.atleast_2d(np.asarray(points, dtype=float))
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {p.shape}")
    rad = np.linalg.norm(p, axis=1)
    if p.shape[0] and np.max(np.abs(rad - R)) > check_radius * R:
        raise ValueError(
            f"points are not on the sphere of radius {R} (max | |x| - R | = {np.max(np.abs(rad - R)):.3g})"
        )
    return p / rad[:, None] if p.shape[0] else p.copy()


def _flow_auto_lmax(zeta, points, lmax, spectrum, axis, axisymmetric, on_unconverged, kw):
    """``lmax = "auto"``: :func:`sphere_flow` with lmax doubled from 32 until converged (up to 1024
    for an axisymmetric pattern, 256 otherwise)."""
    if lmax != "auto":
        raise ValueError("lmax must be an int or 'auto'")
    if spectrum is not None:
        raise ValueError("lmax='auto' needs the callable, not a spectrum")
    if axisymmetric is None and axis is not None:
        zt, _ = gauss_legendre(96)
        axisymmetric = check_axisymmetric(zeta, frame_matrix(axis), zt) <= 1e-12
    top = 1024 if axisymmetric else 256
    L = 32
    while True:
        try:
            return sphere_flow(
                zeta,
                points,
                axis=axis,
                axisymmetric=bool(axisymmetric),
                lmax=L,
                on_unconverged="raise" if L < top else on_unconverged,
                **kw,
            )
        except NotConvergedError:
            if L >= top:
                raise
            L *= 2


def _degree_one(spec, alpha, beta, zscale, R, eta_s, eta_b, eta_bar, eta_bar_b, system, l1, l1_weight, l1_rtol) -> dict:
    """The treatment of a degree-1 part of the tension (``alpha[1]``, ``beta[1]`` set in place), as
    :func:`sphere_flow`'s ``l1`` asks; what was done, as the ``info["l1"]`` dict."""
    lmax, norms = spec.lmax, spec.degree_norms
    l1info = {"zeta_1_vector": spec.l1_vector() if lmax >= 1 else np.zeros(3), "treatment": "none"}
    if lmax < 1:
        return l1info
    sup1 = math.sqrt(3.0 / FOUR_PI) * norms[1]
    l1info["zeta_1_sup"] = sup1
    present = sup1 > l1_rtol * zscale
    a1, b1, exact, rt, rn = l1_coefficients(
        radius=R, eta_s=eta_s, eta_b=eta_b, eta_bar=eta_bar, eta_bar_b=eta_bar_b, system=system, weight=l1_weight
    )
    l1info.update(exact_solution_exists=exact)
    if not present:
        l1info["treatment"] = "negligible (dropped)"
    elif l1 == "drop":
        l1info["treatment"] = "dropped"
    elif l1 == "raise" or (l1 == "auto" and not exact):
        raise L1Error(
            f"the tension has a degree-1 part (sup {sup1:.3g}, gradient vector "
            f"{l1info['zeta_1_vector']}) and the {system} system"
            + (" with bending viscosity" if system == "full" and eta_bar > 0 else "")
            + " has no exact solution satisfying the zero-total-velocity gauge; pass "
            "l1='lsq' for the gauge-constrained least-squares answer or l1='drop'"
        )
    else:
        alpha[1], beta[1] = a1, b1
        l1info["treatment"] = "exact" if exact else f"least squares (normal weight {l1_weight})"
        l1info["residual_tangential"] = abs(rt) * sup1 / R if not exact else 0.0
        l1info["residual_normal"] = abs(rn) * sup1 if not exact else 0.0
        l1info["alpha_1"], l1info["beta_1"] = a1, b1
    return l1info


def _truncation_estimate(norms, alpha, beta, R, lmax):
    """``(estimated sup error, bound on the change from lmax / 2, rms velocity, per-degree sup bounds)``."""
    lv = np.arange(lmax + 1)
    Lv = lv * (lv + 1.0)
    amp = np.sqrt((2 * lv + 1) / FOUR_PI) * (np.abs(beta) + np.abs(alpha) * np.sqrt(Lv) / R)
    B = amp * norms
    noise = amp * 1e-15 * float(np.sqrt(np.sum(norms**2)))
    trunc, change_half = _truncation(B, noise) if lmax >= 4 else (math.inf, math.inf)
    vrms = float(np.sqrt(np.sum((norms * beta) ** 2 + (norms * alpha) ** 2 * Lv / R**2) / FOUR_PI))
    return trunc, change_half, vrms, B
