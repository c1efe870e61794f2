"""Functions on the unit sphere: pattern frames and angles, real spherical harmonics and
their surface gradients, and quadrature.

Used by the active-stress patterns (:mod:`cortex_ti.physics.patterns`), the harmonic content of a
field (:mod:`cortex_ti.analysis.harmonics`), the spectrum of the normal dynamics
(:mod:`cortex_ti.dynamics.spectrum`) and by the analytic sphere solutions
(:mod:`cortex_ti.truth.analytic`). The exact sphere flow (:mod:`cortex_ti.truth.sphere_exact`) has
its own harmonics, written independently: production code does not import the truths.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

__all__ = [
    "pattern_frame",
    "direction_angles",
    "real_sph_harm",
    "real_sph_harms_at",
    "real_sph_harm_surface_gradient",
    "sphere_quadrature",
    "integrate_over_sphere",
]


def _special():
    """scipy.special, imported when a harmonic is first evaluated (a tenth of a second at start-up
    that a scene without harmonics does not pay)."""
    from scipy import special

    return special


def pattern_frame(axis=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Right-handed orthonormal frame ``(e1, e2, a)`` attached to a pattern axis.

    ``a = axis / |axis|``.  The reference direction ``e1`` (``phi = 0``) is the image of +x
    under the *minimal rotation* that takes +z to ``a`` (rotation about ``z x a`` by the angle
    between them); ``e2 = a x e1``.  Consequences:

    * ``axis = +z`` gives ``e1 = +x, e2 = +y``: the usual ``phi = atan2(y, x)``;
    * a pattern with axis ``a`` is the +z pattern rigidly rotated by that minimal rotation,
      e.g. ``axis = (sin b, 0, cos b)`` is the +z pattern rotated by ``b`` about +y
      (``e1 = (cos b, 0, -sin b)``); ``axis = +x`` gives ``e1 = -z, e2 = +y``;
    * ``axis = -z`` (no unique minimal rotation) uses the rotation by pi about +x:
      ``e1 = +x, e2 = -y``.

    Closed form: with ``a = (ax, ay, az)``,
    ``e1 = (1 - ax^2 / (1 + az), -ax ay / (1 + az), -ax)``.

    Raises
    ------
    ValueError
        If ``axis`` is not a finite nonzero 3-vector.
    """
    a = np.asarray(axis, dtype=float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"axis must be a finite 3-vector, got {axis!r}")
    norm = float(np.linalg.norm(a))
    if norm == 0.0:
        raise ValueError("axis must be nonzero")
    a = a / norm
    ax, ay, az = a
    if 1.0 + az < 1e-12:  # a = -z: rotation by pi about +x
        e1 = np.array([1.0, 0.0, 0.0])
    else:
        e1 = np.array([1.0 - ax * ax / (1.0 + az), -ax * ay / (1.0 + az), -ax])
    # clean up rounding: Gram-Schmidt against a, renormalise
    e1 = e1 - np.dot(e1, a) * a
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    return e1, e2, a


def direction_angles(points, axis=(0.0, 0.0, 1.0), center=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Polar and azimuthal angle of ``points - center`` about ``axis``.

    Parameters
    ----------
    points : array_like, shape (N, 3) or (3,)
    axis : array_like, shape (3,)
        Polar axis (need not be normalised).
    center : array_like, shape (3,)

    Returns
    -------
    theta : ndarray, shape (N,)
        Angle in ``[0, pi]`` between ``d = p - center`` and ``axis``, computed as
        ``atan2(|d x a|, d . a)`` (accurate near the poles too).  ``d = 0`` gives ``theta = 0``.
    phi : ndarray, shape (N,)
        Azimuth in ``[0, 2 pi)``: ``atan2(d . e2, d . e1)`` with the frame ``(e1, e2, a)`` of
        :func:`pattern_frame` -- for ``axis = +z`` the usual ``phi = atan2(y, x)`` measured from
        +x toward +y.  On the axis itself ``phi = 0``.
    """
    p = np.atleast_2d(np.asarray(points, dtype=float))
    e1, e2, a = pattern_frame(axis)
    d = p - np.asarray(center, dtype=float).reshape(1, 3)
    dz = d @ a
    dx = d @ e1
    dy = d @ e2
    theta = np.arctan2(np.hypot(dx, dy), dz)
    phi = np.mod(np.arctan2(dy, dx), 2.0 * np.pi)
    phi = np.where(phi >= 2.0 * np.pi, 0.0, phi)  # -0.0 mod 2pi can round up to 2pi
    return theta, phi


# --------------------------------------------------------------------------------------------
# Real spherical harmonics
# --------------------------------------------------------------------------------------------
def _check_lm(l, m) -> tuple[int, int]:
    if isinstance(l, bool) or isinstance(m, bool):
        raise ValueError(f"l and m must be integers, got l={l!r}, m={m!r}")
    try:
        li, mi = int(l), int(m)
    except (TypeError, ValueError):
        raise ValueError(f"l and m must be integers, got l={l!r}, m={m!r}") from None
    if li != l or mi != m:
        raise ValueError(f"l and m must be integers, got l={l!r}, m={m!r}")
    if li < 0 or abs(mi) > li:
        raise ValueError(f"need l >= 0 and |m| <= l, got l={li}, m={mi}")
    return li, mi


def real_sph_harm(l: int, m: int, theta, phi) -> np.ndarray:
    r"""Orthonormal real spherical harmonic ``Y_lm(theta, phi)``, no Condon-Shortley phase.

    .. math::

        Y_{l0} = N_{l0} P_l(\cos\theta), \quad
        Y_{lm} = \sqrt2 N_{lm} P_l^m(\cos\theta)\cos m\phi \ (m>0), \quad
        Y_{lm} = \sqrt2 N_{l|m|} P_l^{|m|}(\cos\theta)\sin |m|\phi \ (m<0),

    with ``N_lm = sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!)`` and the associated Legendre functions
    *without* the Condon-Shortley phase, ``P_l^m(x) = (1-x^2)^{m/2} d^m P_l/dx^m`` (so
    ``P_1^1(cos t) = +sin t``).  ``int Y_lm Y_l'm' dOmega = delta_ll' delta_mm'`` over the
    unit sphere.  Examples on the unit sphere (x, y, z Cartesian):
    ``Y_00 = 1/sqrt(4 pi)``, ``Y_10 = sqrt(3/(4 pi)) z``, ``Y_11 = sqrt(3/(4 pi)) x``,
    ``Y_1-1 = sqrt(3/(4 pi)) y``, ``Y_20 = sqrt(5/(16 pi)) (3 z^2 - 1)``,
    ``Y_21 = sqrt(15/(4 pi)) x z``, ``Y_2-1 = sqrt(15/(4 pi)) y z``,
    ``Y_22 = sqrt(15/(16 pi)) (x^2 - y^2)``.

    Relation to the complex harmonics with the Condon-Shortley phase,
    ``Y_l^m = (-1)^m N_lm P_l^m(cos t) e^{i m phi}`` (``scipy.special.sph_harm_y(l, m, t, phi)``):
    for ``m > 0``, ``Y_lm = sqrt(2) (-1)^m Re Y_l^m`` and ``Y_l,-m = sqrt(2) (-1)^m Im Y_l^m``;
    e.g. ``Re Y_2^1 = -Y_21 / sqrt(2)``.  ``Y_l0 = Y_l^0``.

    Evaluated with ``scipy.special.sph_legendre_p`` (normalised, recurrence based: no overflow
    for l in the hundreds).

    Parameters
    ----------
    l, m : int
        Degree ``l >= 0`` and order ``|m| <= l``.
    theta, phi : array_like
        Polar angle from +z and azimuth from +x (broadcast together).

    Returns
    -------
    ndarray
        ``Y_lm`` with the broadcast shape of ``theta`` and ``phi``.
    """
    l, m = _check_lm(l, m)
    theta = np.asarray(theta, dtype=float)
    phi = np.asarray(phi, dtype=float)
    am = abs(m)
    # scipy's spherical Legendre function includes N_lm and the Condon-Shortley phase (-1)^m
    leg = np.asarray(_special().sph_legendre_p(l, am, theta))
    if leg.shape == (1,) + theta.shape:  # scipy >= 1.15 returns a leading axis of derivatives
        leg = leg[0]
    leg = (-1.0) ** am * leg
    if m == 0:
        return np.asarray(leg * np.ones_like(phi))
    if m > 0:
        return np.asarray(math.sqrt(2.0) * leg * np.cos(am * phi))
    return np.asarray(math.sqrt(2.0) * leg * np.sin(am * phi))


def real_sph_harms_at(lmax: int, points) -> np.ndarray:
    """Every :func:`real_sph_harm` up to degree ``lmax`` at the directions of ``points`` (seen from
    the origin), ``(N, (lmax + 1)^2)``, column ``l^2 + l + m`` holding ``Y_lm`` (m = -l..l).

    >>> p = np.array([[0.0, 0.0, 2.0], [1.0, 0.0, 0.0]])
    >>> y1 = math.sqrt(3 / (4 * math.pi)) * np.array([[0, 1, 0], [0, 0, 1]])  # Y_1-1 = c y, Y_10 = c z, Y_11 = c x
    >>> bool(np.allclose(real_sph_harms_at(1, p)[:, 1:], y1))
    True
    """
    lmax = int(lmax)
    if lmax < 0:
        raise ValueError(f"lmax must be >= 0, got {lmax}")
    theta, phi = direction_angles(points)
    out = np.empty((theta.shape[0], (lmax + 1) ** 2))
    for l in range(lmax + 1):
        for m in range(-l, l + 1):
            out[:, l * l + l + m] = real_sph_harm(l, m, theta, phi)
    return out


def _log_double_factorial_odd(m: int) -> float:
    """log((2m - 1)!!) = log((2m)! / (2^m m!)); 0 for m = 0."""
    return math.lgamma(2 * m + 1) - m * math.log(2.0) - math.lgamma(m + 1)


def real_sph_harm_surface_gradient(l: int, m: int, points, center=(0.0, 0.0, 0.0)) -> np.ndarray:
    r"""Surface gradient ``grad_s Y_lm`` on the sphere through each point, as Cartesian vectors.

    For a point ``p`` with ``d = p - center``, ``R = |d|``, ``u = d / R``, the value is the
    gradient along the sphere of radius ``R`` about ``center`` of the function
    ``Y_lm(theta(u), phi(u))`` (angles about +z from +x, as in :func:`real_sph_harm`).  It is
    tangent (``u . grad_s Y = 0``) and scales as ``1/R``.

    Method (analytic, stable at the poles): on the unit sphere
    ``Y_lm = K_lm G(u_z) A_m(u_x, u_y)`` exactly, with ``d^m P_l/dx^m = (2m-1)!! C^{(m+1/2)}_{l-m}``
    (Gegenbauer polynomial), so

    * ``G(z) = C^{(m+1/2)}_{l-|m|}(z)``, ``G'(z) = (2|m|+1) C^{(|m|+3/2)}_{l-|m|-1}(z)``,
    * ``A_m = Re (x + i y)^m`` (m > 0), ``Im (x + i y)^|m|`` (m < 0), ``1`` (m = 0),
      since ``sin^m t cos(m phi) = Re (x + i y)^m`` on the unit sphere,
    * ``K_lm = sqrt(2 - delta_m0) N_l|m| (2|m|-1)!!``.

    The 3D gradient of this polynomial extension, ``F = K (G'(z) A e_z + G (dA/dx, dA/dy, 0))``,
    is projected on the tangent plane: ``grad_s Y = (F - (u . F) u) / R``.  No division by
    ``sin(theta)`` occurs, so the poles are exact.

    Parameters
    ----------
    l, m : int
    points : array_like, shape (N, 3)
    center : array_like, shape (3,)

    Returns
    -------
    ndarray, shape (N, 3)
    """
    l, m = _check_lm(l, m)
    p = np.atleast_2d(np.asarray(points, dtype=float))
    d = p - np.asarray(center, dtype=float).reshape(1, 3)
    R = np.linalg.norm(d, axis=1)
    if np.any(R == 0.0):
        raise ValueError("surface gradient undefined at the center of the sphere")
    u = d / R[:, None]
    x, y, z = u[:, 0], u[:, 1], u[:, 2]
    am = abs(m)
    logN = 0.5 * (math.log((2 * l + 1) / (4.0 * math.pi)) + math.lgamma(l - am + 1) - math.lgamma(l + am + 1))
    K = math.exp(logN + _log_double_factorial_odd(am)) * (math.sqrt(2.0) if m != 0 else 1.0)

    G = _special().eval_gegenbauer(l - am, am + 0.5, z)
    if l - am - 1 >= 0:
        dG = (2 * am + 1) * _special().eval_gegenbauer(l - am - 1, am + 1.5, z)
    else:
        dG = np.zeros_like(z)

    w = x + 1j * y
    if m == 0:
        A = np.ones_like(x)
        Ax = np.zeros_like(x)
        Ay = np.zeros_like(x)
    else:
        wk1 = w ** (am - 1)
        if m > 0:
            A = (wk1 * w).real
            Ax = am * wk1.real
            Ay = -am * wk1.imag
        else:
            A = (wk1 * w).imag
            Ax = am * wk1.imag
            Ay = am * wk1.real
    F = np.empty_like(u)
    F[:, 0] = K * G * Ax
    F[:, 1] = K * G * Ay
    F[:, 2] = K * dG * A
    F -= np.sum(F * u, axis=1)[:, None] * u
    return F / R[:, None]


# --------------------------------------------------------------------------------------------
# Quadrature on the unit sphere
# --------------------------------------------------------------------------------------------
def sphere_quadrature(order: int, axis=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """Product quadrature on the unit sphere, aligned with ``axis``.

    Polar angle theta (from ``axis``): Gauss-Legendre in theta itself (weight ``sin theta``
    included), composite over ``[0, pi/2]`` and ``[pi/2, pi]`` with ``order`` nodes each.
    Azimuth: trapezoid rule with ``4 order`` equally spaced points (periodic: spectral).
    Gauss in theta rather than in ``cos theta`` keeps spectral convergence for patterns that
    are smooth in theta but not at the poles as functions on the sphere (Eq. 59 near its
    poles), and the split at the equator handles a kink there (Eq. 59 with odd p).

    Returns
    -------
    points : ndarray, shape (8 order^2, 3)
        Unit vectors (built in the frame of :func:`pattern_frame`).
    weights : ndarray, shape (8 order^2,)
        Sum to ``4 pi``; ``sum w f(points)`` approximates ``int f dOmega``.
    """
    n = int(order)
    if n < 1:
        raise ValueError("order must be >= 1")
    x, w = _special().roots_legendre(n)
    # two halves of [0, pi]
    th = np.concatenate([(x + 1.0) * (np.pi / 4.0), (x + 3.0) * (np.pi / 4.0)])
    wth = np.concatenate([w, w]) * (np.pi / 4.0) * np.sin(th)
    nphi = 4 * n
    ph = np.arange(nphi) * (2.0 * np.pi / nphi)
    wph = 2.0 * np.pi / nphi
    T, P = np.meshgrid(th, ph, indexing="ij")
    W = (wth[:, None] * wph) * np.ones_like(P)
    e1, e2, a = pattern_frame(axis)
    st = np.sin(T).ravel()
    pts = (
        (st * np.cos(P).ravel())[:, None] * e1 + (st * np.sin(P).ravel())[:, None] * e2 + np.cos(T).ravel()[:, None] * a
    )
    return pts, W.ravel()


def integrate_over_sphere(
    func, axis=(0.0, 0.0, 1.0), order: int | None = None, tol: float = 1e-13, max_order: int = 512
):
    """``int func(u) dOmega`` over the unit sphere by :func:`sphere_quadrature`.

    Parameters
    ----------
    func : callable
        ``func(points (N, 3)) -> (N,)`` or ``(N, k)`` array.
    axis : array_like
        Polar axis of the quadrature grid (choose the pattern's own axis).
    order : int, optional
        Fixed order (nodes per half of the theta range).  If ``None`` the order is doubled
        from 16 until two successive results differ by at most ``tol * max(1, |I|)``
        (a ``RuntimeWarning`` is issued if ``max_order`` is reached first).

    Returns
    -------
    float or ndarray of shape (k,)
    """

    def quad(n):
        pts, w = sphere_quadrature(n, axis)
        vals = np.asarray(func(pts), dtype=float)
        return np.tensordot(w, vals, axes=(0, 0))

    if order is not None:
        res = quad(order)
        return float(res) if np.ndim(res) == 0 else res
    n = 16
    prev = quad(n)
    while True:
        n *= 2
        cur = quad(n)
        diff = float(np.max(np.abs(cur - prev)))
        if diff <= tol * max(1.0, float(np.max(np.abs(cur)))):
            break
        if n >= max_order:
            warnings.warn(
                f"sphere quadrature not converged at order {n}: last change {diff:.3e}", RuntimeWarning, stacklevel=2
            )
            break
        prev = cur
    return float(cur) if np.ndim(cur) == 0 else cur
