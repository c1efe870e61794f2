"""Active-stress patterns: the isotropic active tension ``zeta`` per node.

The active stress is isotropic, ``zeta^ab = zeta g^ab`` with ``zeta > 0`` a contractile
tension (``docs``/``conventions.md``).  A scene lists one or more *patterns* (the YAML
``active_stress`` list); each is a dict with a ``"type"`` and that type's parameters, and
``zeta`` is the sum of all patterns, evaluated at the node positions of the **initial** shape
(afterwards the values are carried with the nodes).

Pattern types (registry :data:`PATTERNS`, extensible with :func:`register_pattern`):

``"harmonics"``
    ``terms = [{"l": l, "m": m, "coeff": c}, ...]``:
    ``zeta = sum c Y_lm(theta, phi)`` with the orthonormal real harmonics of
    :func:`real_sph_harm`, (theta, phi) the direction of the point from the origin about +z.
``"ring"``
    ``zeta0, amplitude, sigma, p, axis=(0, 0, 1)``: paper Eq. 59,
    ``zeta = zeta0 + amplitude * exp(-sigma |theta - pi/2|^p)``, theta the polar angle of the
    point (seen from the origin) from ``axis``.
``"fold"``
    the ring with its amplitude modulated in phi (paper Sec. 4.3), see :func:`fold_pattern`.
``"field"``
    ``file, name=None, scale=1.0``: one value per node read from a file (``.npy``, ``.txt`` /
    ``.csv`` or any mesh file meshio reads), times ``scale``; see :func:`field_pattern`.
    It exists only at the mesh nodes (``per_node``): it cannot be integrated over the sphere
    by quadrature, so the analytic sphere solutions refuse it.
``"python"``
    ``function="package.module:func", params={}``: ``zeta = func(points, **params)``, a
    user's function imported with :mod:`importlib`; see :func:`python_pattern`.  A scene with
    such a pattern runs the user's code when it is evaluated (``cortex-ti run`` and
    ``cortex-ti check``).  From Python, ``function`` may also be the callable itself.

Spherical quadrature (:func:`sphere_quadrature`, :func:`integrate_over_sphere`,
:func:`mean_over_sphere`) is used for the exact mean ``zeta_bar`` of a pattern over the unit
sphere (it sets the pressure ``P = 2 zeta_bar / R`` and the analytic flow, see
:mod:`cortex_ti.analytic`).
"""

from __future__ import annotations

import importlib
import inspect
import math
import os
import warnings
from pathlib import Path
from typing import Callable

import numpy as np
from scipy import special

from .errors import SceneError

__all__ = [
    "scene_pattern_axis",
    "PATTERNS",
    "PER_NODE_PATTERNS",
    "direction_angles",
    "evaluate_active_stress",
    "field_pattern",
    "harmonic_terms",
    "integrate_over_sphere",
    "integrate_patterns",
    "mean_over_sphere",
    "pattern_frame",
    "python_pattern",
    "read_node_field",
    "real_sph_harm",
    "real_sph_harm_surface_gradient",
    "register_pattern",
    "resolve_function",
    "sphere_quadrature",
]


# --------------------------------------------------------------------------------------------
# Directions and frames
# --------------------------------------------------------------------------------------------
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


def scene_pattern_axis(scene) -> np.ndarray:
    """The unit axis of a scene's active-stress pattern: that of the first pattern with an
    ``axis`` (ring, fold), +z if none has one or the scene has no active stress."""
    patterns = scene["active_stress"] if scene.has("active_stress") else []
    for pat in patterns:
        if "axis" in pat:
            a = np.asarray(pat["axis"], dtype=float)
            return a / np.linalg.norm(a)
    return np.array([0.0, 0.0, 1.0])


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
    leg = np.asarray(special.sph_legendre_p(l, am, theta))
    if leg.shape == (1,) + theta.shape:  # scipy >= 1.15 returns a leading axis of derivatives
        leg = leg[0]
    leg = (-1.0) ** am * leg
    if m == 0:
        return np.asarray(leg * np.ones_like(phi))
    if m > 0:
        return np.asarray(math.sqrt(2.0) * leg * np.cos(am * phi))
    return np.asarray(math.sqrt(2.0) * leg * np.sin(am * phi))


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

    G = special.eval_gegenbauer(l - am, am + 0.5, z)
    if l - am - 1 >= 0:
        dG = (2 * am + 1) * special.eval_gegenbauer(l - am - 1, am + 1.5, z)
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
# Pattern registry
# --------------------------------------------------------------------------------------------
PATTERNS: dict[str, Callable[..., np.ndarray]] = {}
"""Registry ``type name -> function(points, **params) -> (N,) zeta``."""

PER_NODE_PATTERNS: set[str] = set()
"""Pattern types whose values exist only at the mesh nodes (in mesh order), not as a function
of position: they cannot be evaluated at other points (e.g. quadrature points)."""


def register_pattern(name: str, *, per_node: bool = False):
    """Decorator registering ``func(points, **params) -> (N,) array`` as pattern type ``name``.

    The function's keyword parameters are the pattern's parameters (those without a default
    are required); :func:`evaluate_active_stress` checks a scene's dict against them.
    Registering a different function under an existing name raises ``ValueError``
    (re-registering the same function, e.g. on module reload, is allowed).
    ``per_node=True`` declares that the values exist only at the mesh nodes (one per node,
    in mesh order, whatever the points are): :func:`integrate_patterns` then refuses it.
    """
    if not isinstance(name, str) or not name:
        raise ValueError("pattern name must be a non-empty string")

    def deco(func):
        old = PATTERNS.get(name)
        if old is not None and (old.__module__, old.__qualname__) != (func.__module__, func.__qualname__):
            raise ValueError(f"active-stress pattern type {name!r} is already registered ({old.__module__}.{old.__qualname__})")
        PATTERNS[name] = func
        if per_node:
            PER_NODE_PATTERNS.add(name)
        else:
            PER_NODE_PATTERNS.discard(name)
        return func

    return deco


def _finite_number(value, what: str) -> float:
    if isinstance(value, bool):
        raise SceneError(f"{what} must be a number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise SceneError(f"{what} must be finite, got {value!r}")
    return v


def _axis_param(axis, what: str) -> np.ndarray:
    try:
        a = np.asarray(axis, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise SceneError(f"{what} must be a list of 3 numbers, got {axis!r}") from None
    if a.shape != (3,) or not np.all(np.isfinite(a)) or not np.any(a != 0.0):
        raise SceneError(f"{what} must be a nonzero finite 3-vector, got {axis!r}")
    return a


def _integer(value, what: str) -> int:
    if isinstance(value, bool):
        raise SceneError(f"{what} must be an integer, got {value!r}")
    try:
        iv = int(value)
    except (TypeError, ValueError):
        raise SceneError(f"{what} must be an integer, got {value!r}") from None
    if iv != value:
        raise SceneError(f"{what} must be an integer, got {value!r}")
    return iv


def harmonic_terms(terms) -> list[tuple[int, int, float]]:
    """Validate a ``terms`` list ``[{"l", "m", "coeff"}, ...]`` -> list of ``(l, m, coeff)``.

    Raises :class:`~cortex_ti.errors.SceneError` naming the bad entry.
    """
    if isinstance(terms, dict) or not isinstance(terms, (list, tuple)):
        raise SceneError(f"harmonics 'terms' must be a list of {{l, m, coeff}} items, got {terms!r}")
    out = []
    for i, t in enumerate(terms):
        if not isinstance(t, dict):
            raise SceneError(f"harmonics terms[{i}] must be a mapping with keys l, m, coeff, got {t!r}")
        extra = set(t) - {"l", "m", "coeff"}
        missing = {"l", "m", "coeff"} - set(t)
        if extra or missing:
            raise SceneError(
                f"harmonics terms[{i}] needs exactly the keys l, m, coeff"
                + (f"; missing {sorted(missing)}" if missing else "")
                + (f"; unknown {sorted(extra)}" if extra else "")
            )
        l = _integer(t["l"], f"harmonics terms[{i}].l")
        m = _integer(t["m"], f"harmonics terms[{i}].m")
        if l < 0 or abs(m) > l:
            raise SceneError(f"harmonics terms[{i}]: need l >= 0 and |m| <= l, got l={l}, m={m}")
        c = _finite_number(t["coeff"], f"harmonics terms[{i}].coeff")
        out.append((l, m, c))
    return out


@register_pattern("harmonics")
def harmonics_pattern(points, terms) -> np.ndarray:
    """``zeta = sum_terms coeff * Y_lm(theta, phi)``, angles of the point seen from the origin.

    ``theta`` from +z, ``phi`` from +x toward +y; ``Y_lm`` from :func:`real_sph_harm`
    (orthonormal, real, no Condon-Shortley phase).  Note ``coeff = sqrt(4 pi)`` for ``l = 0``
    gives a uniform tension 1 (the paper's "zeta_00 = 4 pi").
    """
    tl = harmonic_terms(terms)
    theta, phi = direction_angles(points)
    out = np.zeros(theta.shape)
    for l, m, c in tl:
        out += c * real_sph_harm(l, m, theta, phi)
    return out


@register_pattern("ring")
def ring_pattern(points, zeta0, amplitude, sigma, p, axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Contractile ring, paper Eq. 59: ``zeta0 + amplitude * exp(-sigma |theta - pi/2|^p)``.

    ``theta`` is the polar angle of the point (seen from the origin) from ``axis``; the ring
    sits on the great circle perpendicular to ``axis``.  Requires ``sigma >= 0`` and ``p > 0``.
    """
    z0 = _finite_number(zeta0, "ring zeta0")
    amp = _finite_number(amplitude, "ring amplitude")
    sig = _finite_number(sigma, "ring sigma")
    pp = _finite_number(p, "ring p")
    if sig < 0.0:
        raise SceneError(f"ring sigma must be >= 0, got {sigma!r}")
    if pp <= 0.0:
        raise SceneError(f"ring p must be > 0, got {p!r}")
    a = _axis_param(axis, "ring axis")
    theta, _ = direction_angles(points, axis=a)
    return z0 + amp * np.exp(-sig * np.abs(theta - 0.5 * np.pi) ** pp)


@register_pattern("fold")
def fold_pattern(points, zeta0, amplitude, sigma, p, sigma_phi, axis=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Fold stripe, paper Sec. 4.3 (conventions.md): the ring of Eq. 59 with its amplitude term
    modulated in phi, ``zeta0 + amplitude exp(-sigma |theta - pi/2|^p) exp(-sigma_phi d^4)``.

    ``d`` is the azimuthal distance (in radians, about ``axis``) from the nearest of the meridians
    ``phi = pi/2`` and ``phi = 3 pi/2``: together one great circle through both poles (the
    y-z plane for the default axis). The paper: sigma = 1.5, p = 4, zeta_hat = 3.5 with
    sigma_phi = 200, and zeta_hat = 4.5 with sigma_phi = 12.
    """
    sphi = _finite_number(sigma_phi, "fold sigma_phi")
    if sphi < 0.0:
        raise SceneError(f"fold sigma_phi must be >= 0, got {sigma_phi!r}")
    base = ring_pattern(points, 0.0, amplitude, sigma, p, axis)        # amplitude term only
    _, phi = direction_angles(points, axis=_axis_param(axis, "fold axis"))
    d = np.abs(np.mod(phi - 0.5 * np.pi + 0.5 * np.pi, np.pi) - 0.5 * np.pi)   # distance to pi/2 or 3 pi/2
    return _finite_number(zeta0, "fold zeta0") + base * np.exp(-sphi * d ** 4)


# --------------------------------------------------------------------------------------------
# User-supplied patterns: a per-node field from a file, a Python function
# --------------------------------------------------------------------------------------------
#: Suffixes read with numpy; any other suffix is read with meshio (``point_data``).
_TEXT_DELIMITERS = {".txt": None, ".csv": ","}


def read_node_field(path, name: str | None = None) -> np.ndarray:
    """Read one number per node from a file: the values of a ``field`` pattern.

    Parameters
    ----------
    path : str or path-like
        ``.npy``: a 1-D array (``numpy.save``); ``.txt`` / ``.csv``: one number per line
        (``numpy.loadtxt``, ``#`` comments allowed); any other suffix: a mesh file meshio
        reads (``.vtu``, ``.vtk``, ``.ply``, ...), whose point data holds the values.
        A relative path is taken relative to the working directory (a scene makes its
        ``file`` absolute first, relative to the scene file's folder).
    name : str, optional
        Mesh files only: the point-data array to use.  Without it the file must hold
        exactly one point-data array.  An ``(N, 1)`` array counts as ``(N,)``.

    Returns
    -------
    ndarray, shape (n,), float64
        The values in file order (the count and finiteness are checked by the pattern).

    Raises
    ------
    SceneError
        Missing or unreadable file, a ``name`` for a numpy file, an unknown or ambiguous
        point-data array, or values that are not one number per node.
    """
    from .errors import MeshError
    from .mesh import read_meshio

    file = Path(os.fspath(path)).expanduser()
    label = f"field file '{file}'"
    if not file.is_file():
        raise SceneError(f"{label} {'is a folder, not a file' if file.is_dir() else 'does not exist'}")
    suffix = file.suffix.lower()
    if suffix == ".npy" or suffix in _TEXT_DELIMITERS:
        if name is not None:
            raise SceneError(
                f"{label}: 'name' ({name!r}) selects a point-data array of a mesh file, but a {suffix} "
                "file holds a single array: remove 'name'"
            )
        if suffix == ".npy":
            try:
                arr = np.load(file, allow_pickle=False)
            except (OSError, ValueError, EOFError) as exc:
                raise SceneError(f"cannot read {label} as a numpy array: {exc}") from None
            if not isinstance(arr, np.ndarray) or arr.dtype.kind not in "biuf":
                raise SceneError(f"{label} holds {getattr(arr, 'dtype', type(arr).__name__)} values, not numbers")
            if arr.ndim != 1:
                raise SceneError(f"{label} holds an array of shape {arr.shape}; need a 1-D array, one value per node")
        else:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")   # numpy warns about an empty file; reported below
                    arr = np.loadtxt(file, dtype=float, delimiter=_TEXT_DELIMITERS[suffix], ndmin=2)
            except (OSError, ValueError, UnicodeDecodeError) as exc:
                raise SceneError(f"cannot read {label} as one number per line: {exc}") from None
            if arr.size and arr.shape[1] != 1:
                raise SceneError(f"{label} has {arr.shape[1]} numbers per line; need one number per line")
            arr = arr.reshape(-1)
    else:
        try:
            mesh = read_meshio(file)
        except MeshError as exc:
            raise SceneError(str(exc)) from None
        data = mesh.point_data
        names = ", ".join(repr(k) for k in data) or "none"
        if name is None:
            if len(data) != 1:
                raise SceneError(
                    f"{label} has {len(data)} point-data arrays ({names}): give 'name' to choose one"
                    if data else f"{label} has no point data (one value per node is needed)"
                )
            name = next(iter(data))
        elif name not in data:
            raise SceneError(f"{label} has no point-data array {name!r}; it has: {names}")
        arr = np.asarray(data[name])
        if arr.ndim == 2 and arr.shape[1] == 1:
            arr = arr[:, 0]
        if arr.ndim != 1 or arr.dtype.kind not in "biuf":
            raise SceneError(
                f"point-data array {name!r} of {label} has shape {arr.shape} ({arr.dtype}); "
                "need one number per node"
            )
    if arr.size == 0:
        raise SceneError(f"{label} holds no values")
    return arr.astype(np.float64)


@register_pattern("field", per_node=True)
def field_pattern(points, file, name=None, scale=1.0) -> np.ndarray:
    """A user's per-node field: ``zeta = scale * values``, the values read from ``file``
    (:func:`read_node_field`: ``.npy``, ``.txt``/``.csv`` or a mesh file's point data ``name``).

    The values belong to the nodes in mesh order (the order of the scene's mesh, i.e. of
    ``points``); the positions themselves are not used, so the pattern is defined only on
    that mesh (``per_node``: it cannot be integrated by quadrature).  There must be exactly
    one finite value per node.
    """
    values = read_node_field(file, name)
    n = len(points)
    if values.shape[0] != n:
        raise SceneError(
            f"field file '{file}' has {values.shape[0]} values but the mesh has {n} nodes "
            "(one value per node, in mesh order)"
        )
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise SceneError(
            f"field file '{file}' has {bad.size} non-finite value(s) (NaN or inf), the first at node {bad[0]}"
        )
    return _finite_number(scale, "field scale") * values


def resolve_function(function) -> tuple[Callable, str]:
    """The callable of a ``python`` pattern and the name to use in messages.

    ``function`` is a callable (Python API only) or a string ``"package.module:func"``
    (``func`` may be dotted, ``module:Class.method``), imported with
    :func:`importlib.import_module`; the module must be importable (installed, or on
    ``sys.path`` / ``PYTHONPATH``).  Importing it runs the module's code.

    Raises
    ------
    SceneError
        A malformed target, a module that cannot be imported (whatever the reason), a missing
        attribute, or an attribute that is not callable; the message names the target.
    """
    if callable(function):
        return function, getattr(function, "__qualname__", repr(function))
    if not isinstance(function, str):
        raise SceneError(f"python pattern 'function' must be 'package.module:function' or a callable, got {function!r}")
    module, sep, attr = (part.strip() for part in function.partition(":"))
    if not sep or not module or not attr:
        raise SceneError(f"python pattern function {function!r} must look like 'package.module:function'")
    try:
        obj = importlib.import_module(module)
    except Exception as exc:  # ImportError, or anything the module raised while being imported
        raise SceneError(
            f"python pattern function '{function}': cannot import module '{module}' ({type(exc).__name__}: {exc})"
        ) from None
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise SceneError(f"python pattern function '{function}': module '{module}' has no attribute '{attr}'") from None
    if not callable(obj):
        raise SceneError(f"python pattern function '{function}' is a {type(obj).__name__}, not a callable")
    return obj, function


@register_pattern("python")
def python_pattern(points, function, params=None) -> np.ndarray:
    """A user's function: ``zeta = func(points, **params)``, ``func`` from :func:`resolve_function`.

    ``points`` is an ``(N, 3)`` float64 copy of the positions (the function cannot change the
    mesh); the result must be ``N`` finite numbers.  Unlike the ``field`` pattern it is a
    function of position, so the sphere quadrature (mean tension, analytic sphere solutions)
    can use it.  The keyword names in ``params`` are checked against the function's signature
    before the call; an exception raised inside the function is the user's and propagates
    unchanged (with its traceback).

    A callable as ``function`` works wherever a pattern list is used directly
    (:func:`evaluate_active_stress`, :func:`integrate_patterns`, :mod:`cortex_ti.analytic`), not
    in a :class:`~cortex_ti.scene.Scene`: a scene is stored as YAML text with every trajectory,
    so its ``function`` must be the ``"module:func"`` string.
    """
    func, target = resolve_function(function)
    params = {} if params is None else params
    if not isinstance(params, dict):
        raise SceneError(f"python pattern '{target}': params must be a mapping of keyword arguments, got {params!r}")
    pts = np.array(points, dtype=np.float64)   # a copy
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):   # no signature available (some builtins): just call it
        sig = None
    if sig is not None:
        try:
            sig.bind(pts, **params)
        except TypeError as exc:
            kw = "".join(f", {k}=..." for k in params)
            raise SceneError(f"python pattern '{target}' cannot be called as {target}(points{kw}): {exc}") from None
    out = func(pts, **params)
    try:
        val = np.asarray(out, dtype=np.float64)
    except (TypeError, ValueError):
        raise SceneError(f"python pattern '{target}' returned {type(out).__name__}, not an array of numbers") from None
    if val.shape != (len(pts),):
        raise SceneError(
            f"python pattern '{target}' returned an array of shape {val.shape}; need ({len(pts)},), one value per point"
        )
    bad = np.flatnonzero(~np.isfinite(val))
    if bad.size:
        raise SceneError(
            f"python pattern '{target}' returned {bad.size} non-finite value(s) (NaN or inf), the first at point {bad[0]}"
        )
    return val


def _split_pattern(i: int, pat) -> tuple[Callable, dict]:
    if not isinstance(pat, dict):
        raise SceneError(f"active_stress[{i}] must be a mapping with a 'type', got {pat!r}")
    if "type" not in pat:
        raise SceneError(f"active_stress[{i}] has no 'type'; known types: {', '.join(sorted(PATTERNS))}")
    name = pat["type"]
    if not isinstance(name, str) or name not in PATTERNS:
        raise SceneError(f"active_stress[{i}]: unknown pattern type {name!r}; known types: {', '.join(sorted(PATTERNS))}")
    func = PATTERNS[name]
    params = {k: v for k, v in pat.items() if k != "type"}
    sig = inspect.signature(func)
    names = list(sig.parameters)[1:]  # first parameter is the points
    has_var_kw = any(q.kind is inspect.Parameter.VAR_KEYWORD for q in sig.parameters.values())
    accepted = [n for n in names if sig.parameters[n].kind is not inspect.Parameter.VAR_KEYWORD]
    required = [n for n in accepted if sig.parameters[n].default is inspect.Parameter.empty]
    unknown = sorted(set(params) - set(accepted)) if not has_var_kw else []
    missing = [n for n in required if n not in params]
    if unknown or missing:
        msg = f"active_stress[{i}] (type {name!r})"
        if missing:
            msg += f": missing parameter(s) {', '.join(missing)}"
        if unknown:
            msg += f"{';' if missing else ':'} unknown parameter(s) {', '.join(unknown)}"
        msg += f"; accepted: {', '.join(accepted)}"
        raise SceneError(msg)
    return func, params


def evaluate_active_stress(points, patterns: list[dict]) -> np.ndarray:
    """Active tension ``zeta`` at ``points``: the sum of all patterns.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Node positions (of the initial shape).
    patterns : list of dict
        The scene's ``active_stress`` list: each item has ``"type"`` (a key of
        :data:`PATTERNS`) and that type's parameters.  An empty list gives ``zeta = 0``.

    Returns
    -------
    ndarray, shape (N,)

    Raises
    ------
    SceneError
        Unknown type (the message lists the known types), missing/unknown parameters, bad
        values, or a non-finite result.
    """
    p = np.atleast_2d(np.asarray(points, dtype=float))
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {np.shape(points)}")
    if isinstance(patterns, dict) or not isinstance(patterns, (list, tuple)):
        raise SceneError(f"active_stress must be a list of patterns, got {patterns!r}")
    zeta = np.zeros(p.shape[0])
    for i, pat in enumerate(patterns):
        func, params = _split_pattern(i, pat)
        val = np.asarray(func(p, **params), dtype=float)
        if val.shape != (p.shape[0],):
            val = np.broadcast_to(val, (p.shape[0],))
        if not np.all(np.isfinite(val)):
            raise SceneError(f"active_stress[{i}] (type {pat['type']!r}) gives non-finite values")
        zeta = zeta + val
    return zeta


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
    x, w = special.roots_legendre(n)
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
    pts = (st * np.cos(P).ravel())[:, None] * e1 + (st * np.sin(P).ravel())[:, None] * e2 + np.cos(T).ravel()[:, None] * a
    return pts, W.ravel()


def integrate_over_sphere(func, axis=(0.0, 0.0, 1.0), order: int | None = None, tol: float = 1e-13,
                          max_order: int = 512):
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


def _pattern_axis(pat: dict) -> np.ndarray:
    ax = pat.get("axis", (0.0, 0.0, 1.0)) if isinstance(pat, dict) else (0.0, 0.0, 1.0)
    try:
        return _axis_param(ax, "axis")
    except SceneError:
        return np.array([0.0, 0.0, 1.0])  # the evaluation itself reports the bad axis


def integrate_patterns(patterns: list[dict], weight=None, order: int | None = None):
    """``int zeta(u) weight(u) dOmega`` over the unit sphere for a pattern list.

    By linearity the integral is the sum over patterns, each integrated on a grid aligned with
    its own ``axis`` parameter (default +z), where the pattern is smooth in the grid's theta.
    ``weight(points) -> (N,)`` or ``(N, k)``; ``None`` means 1.

    Raises :class:`~cortex_ti.errors.SceneError` for a per-node pattern (``field``, see
    :data:`PER_NODE_PATTERNS`): it has no values off the mesh.
    """
    if isinstance(patterns, dict) or not isinstance(patterns, (list, tuple)):
        raise SceneError(f"active_stress must be a list of patterns, got {patterns!r}")
    total = 0.0
    for i, pat in enumerate(patterns):
        func, params = _split_pattern(i, pat)
        if pat["type"] in PER_NODE_PATTERNS:
            raise SceneError(
                f"active_stress[{i}]: the analytic sphere solution needs a pattern defined off the mesh; "
                f"{pat['type']!r} is per node (its values exist only at the mesh nodes, so the sphere "
                "quadrature cannot evaluate it)"
            )

        def f(pts, func=func, params=params):
            z = np.asarray(func(pts, **params), dtype=float)
            if weight is None:
                return z
            wv = np.asarray(weight(pts), dtype=float)
            return z.reshape((-1,) + (1,) * (wv.ndim - 1)) * wv

        total = total + integrate_over_sphere(f, axis=_pattern_axis(pat), order=order)
    return total


def mean_over_sphere(patterns: list[dict], order: int | None = None) -> float:
    """Mean of ``zeta`` over the unit sphere, ``(1 / 4 pi) int zeta dOmega``.

    Computed pattern by pattern on a grid aligned with the pattern's axis (see
    :func:`sphere_quadrature`), by default with the order doubled until converged to ~1e-13
    (Eq. 59, p = 8, sigma = 10, zeta0 = amplitude = 1: 1.6454810...; p = 4: 1.48299...).
    For a ``harmonics`` pattern the mean is ``coeff_00 / sqrt(4 pi)``.
    """
    return float(integrate_patterns(patterns, order=order)) / (4.0 * np.pi)
