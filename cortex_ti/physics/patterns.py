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
    ``zeta0, amplitude, sigma, p, axis=(0, 0, 1), center=pi/2``: paper Eq. 59,
    ``zeta = zeta0 + amplitude * exp(-sigma |theta - center|^p)``, theta the polar angle of the
    point (seen from the origin) from ``axis``; ``center`` (radians) places the ring off the
    equator (``center < pi/2``: toward the pole ``axis`` points to).
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

Each pattern type registers its parameters as a JSON-schema fragment
(:func:`pattern_schemas`); the scene schema's pattern section is built from this registry
(:mod:`cortex_ti.scene.schema`), so a registered pattern is a valid scene pattern.

:func:`integrate_patterns` and :func:`mean_over_sphere` integrate patterns over the unit
sphere by quadrature (the exact mean ``zeta_bar`` sets the pressure ``P = 2 zeta_bar / R`` and
the analytic flow, see :mod:`cortex_ti.truth.analytic`).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable

import numpy as np

from ..errors import SceneError
from .spherical import direction_angles, integrate_over_sphere, real_sph_harm

__all__ = [
    "PATTERNS",
    "pattern_schemas",
    "PER_NODE_PATTERNS",
    "evaluate_active_stress",
    "harmonic_terms",
    "integrate_patterns",
    "mean_over_sphere",
    "pattern_axis",
    "register_pattern",
]


def pattern_axis(patterns) -> np.ndarray:
    """The unit axis of a list of active-stress patterns: that of the first pattern with an
    ``axis`` (ring, fold), +z if none has one (or the list is empty)."""
    for pat in patterns:
        if "axis" in pat:
            a = np.asarray(pat["axis"], dtype=float)
            return a / np.linalg.norm(a)
    return np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------------------------
# Pattern registry
# --------------------------------------------------------------------------------------------
PATTERNS: dict[str, Callable[..., np.ndarray]] = {}
"""Registry ``type name -> function(points, **params) -> (N,) zeta``."""

PER_NODE_PATTERNS: set[str] = set()
"""Pattern types whose values exist only at the mesh nodes (in mesh order), not as a function
of position: they cannot be evaluated at other points (e.g. quadrature points)."""


def pattern_schemas() -> dict[str, dict]:
    """``type name -> JSON-schema fragment of its parameters`` of every registered pattern (the
    scene schema's ``$defs/<name>``, built into it by :mod:`cortex_ti.scene.schema`); the
    fragment travels with the function in :data:`PATTERNS` (``func.pattern_schema``), so the
    two cannot disagree."""
    return {name: func.pattern_schema for name, func in PATTERNS.items()}


_OPEN_SCHEMA = {
    "type": "object",
    "required": ["type"],
    "description": "A pattern registered without a schema: its parameters are checked against "
    "the function's signature when it is evaluated.",
}


def register_pattern(name: str, *, per_node: bool = False, schema: dict | None = None):
    """Decorator registering ``func(points, **params) -> (N,) array`` as pattern type ``name``.

    The function's keyword parameters are the pattern's parameters (those without a default
    are required); :func:`evaluate_active_stress` checks a scene's dict against them.
    ``schema`` is the JSON-schema fragment of a pattern item (``type`` included, with
    descriptions and defaults, which the scene loader fills in); without it any parameters
    pass the schema and only the signature check applies.
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
            raise ValueError(
                f"active-stress pattern type {name!r} is already registered ({old.__module__}.{old.__qualname__})"
            )
        func.pattern_schema = schema if schema is not None else dict(_OPEN_SCHEMA)
        PATTERNS[name] = func
        if per_node:
            PER_NODE_PATTERNS.add(name)
        else:
            PER_NODE_PATTERNS.discard(name)
        return func

    return deco


def _scalar(value, what: str, integer: bool = False):
    """``value`` as a float (finite) or an int, or a :class:`SceneError` naming ``what``."""
    kind = "an integer" if integer else "a number"
    if isinstance(value, bool):
        raise SceneError(f"{what} must be {kind}, got {value!r}")
    try:
        v = int(value) if integer else float(value)
    except (TypeError, ValueError):
        raise SceneError(f"{what} must be {kind}, got {value!r}") from None
    if integer and v != value:
        raise SceneError(f"{what} must be an integer, got {value!r}")
    if not integer and not math.isfinite(v):
        raise SceneError(f"{what} must be finite, got {value!r}")
    return v


def finite_number(value, what: str) -> float:
    """A pattern parameter as a finite float, or a :class:`SceneError` naming it."""
    return _scalar(value, what)


def _axis_param(axis, what: str) -> np.ndarray:
    try:
        a = np.asarray(axis, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise SceneError(f"{what} must be a list of 3 numbers, got {axis!r}") from None
    if a.shape != (3,) or not np.all(np.isfinite(a)) or not np.any(a != 0.0):
        raise SceneError(f"{what} must be a nonzero finite 3-vector, got {axis!r}")
    return a


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
        l = _scalar(t["l"], f"harmonics terms[{i}].l", integer=True)
        m = _scalar(t["m"], f"harmonics terms[{i}].m", integer=True)
        if l < 0 or abs(m) > l:
            raise SceneError(f"harmonics terms[{i}]: need l >= 0 and |m| <= l, got l={l}, m={m}")
        c = finite_number(t["coeff"], f"harmonics terms[{i}].coeff")
        out.append((l, m, c))
    return out


_HARMONICS_SCHEMA = {
    "description": "Real spherical harmonics sum_lm coeff * Y_lm(theta, phi) about the z axis.",
    "type": "object",
    "additionalProperties": False,
    "required": ["type", "terms"],
    "properties": {
        "type": {"const": "harmonics"},
        "terms": {
            "type": "array",
            "minItems": 1,
            "items": {
                "type": "object",
                "additionalProperties": False,
                "required": ["l", "m", "coeff"],
                "properties": {
                    "l": {"description": "Degree, >= 0.", "type": "integer", "minimum": 0},
                    "m": {"description": "Order, |m| <= l.", "type": "integer"},
                    "coeff": {"description": "Coefficient zeta_lm.", "type": "number"},
                },
            },
        },
    },
}


@register_pattern("harmonics", schema=_HARMONICS_SCHEMA)
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


def _pattern_schema(name: str, description: str, required=(), **parameters) -> dict:
    """The JSON-schema fragment of a pattern type: its ``type`` and its parameters (no others)."""
    return {
        "description": description,
        "type": "object",
        "additionalProperties": False,
        "required": ["type", *required],
        "properties": {"type": {"const": name}, **parameters},
    }


def _number(description: str, default=None, **bounds) -> dict:
    out = {"description": description, "type": "number", **bounds}
    return out if default is None else {**out, "default": default}


#: The equator's polar angle: the default ``center`` of a ring (paper Eq. 59).
EQUATOR = 0.5 * np.pi


def _ring_parameters(amplitude: float, sigma: float, p: float) -> dict:
    """The parameters of Eq. 59 (shared by the ring and the fold), with a pattern's defaults."""
    return {
        "zeta0": _number("Uniform background tension.", 1.0),
        "amplitude": _number("Extra tension on the ring.", amplitude),
        "sigma": _number("Sharpness of the ring.", sigma, minimum=0),
        "p": _number("Exponent of the ring profile.", p, exclusiveMinimum=0),
        "axis": {
            "description": "Axis through the poles (not all zero; normalised by the user of the scene).",
            "type": "array",
            "items": {"type": "number"},
            "minItems": 3,
            "maxItems": 3,
            "default": [0, 0, 1],
        },
        "center": _number(
            "Polar angle of the ring's centre line from axis, in radians (a cone's angle: independent of the "
            "radius, and the label the axisymmetric model's meridian carries): pi/2 the equator (paper Eq. 59), "
            "smaller toward the pole axis points to. 0 < center < pi.",
            EQUATOR,
            exclusiveMinimum=0,
            exclusiveMaximum=np.pi,
        ),
    }


_RING_SCHEMA = _pattern_schema(
    "ring",
    "Contractile ring, paper Eq. 59: zeta0 + amplitude * exp(-sigma |theta - center|^p), theta the polar angle "
    "from axis, center (default pi/2, the equator) the ring's.",
    **_ring_parameters(amplitude=1.0, sigma=10.0, p=8),
)


@register_pattern("ring", schema=_RING_SCHEMA)
def ring_pattern(points, zeta0, amplitude, sigma, p, axis=(0.0, 0.0, 1.0), center=EQUATOR) -> np.ndarray:
    """Contractile ring, paper Eq. 59: ``zeta0 + amplitude * exp(-sigma |theta - center|^p)``.

    ``theta`` is the polar angle of the point (seen from the origin) from ``axis``; the ring
    sits on the cone ``theta = center`` (default ``pi/2``: the great circle perpendicular to
    ``axis``; smaller: nearer the pole ``axis`` points to).  Requires ``sigma >= 0``, ``p > 0``
    and ``0 < center < pi``.

    >>> pts = np.array([[np.sin(1.2), 0.0, np.cos(1.2)], [1.0, 0.0, 0.0]])
    >>> ring_pattern(pts, 1.0, 5.0, 10.0, 4, center=1.2).round(6).tolist()
    [6.0, 5.138789]
    """
    z0 = finite_number(zeta0, "ring zeta0")
    amp = finite_number(amplitude, "ring amplitude")
    sig = finite_number(sigma, "ring sigma")
    pp = finite_number(p, "ring p")
    if sig < 0.0:
        raise SceneError(f"ring sigma must be >= 0, got {sigma!r}")
    if pp <= 0.0:
        raise SceneError(f"ring p must be > 0, got {p!r}")
    c = finite_number(center, "ring center")
    if not 0.0 < c < np.pi:
        raise SceneError(f"ring center must lie in (0, pi) (a polar angle from axis, radians), got {center!r}")
    a = _axis_param(axis, "ring axis")
    theta, _ = direction_angles(points, axis=a)
    return z0 + amp * np.exp(-sig * np.abs(theta - c) ** pp)


_FOLD_SCHEMA = _pattern_schema(
    "fold",
    "Fold stripe, paper Sec. 4.3: the ring of Eq. 59 whose amplitude term is modulated in phi by "
    "exp(-sigma_phi d^4), d the azimuthal distance from the nearest of the meridians phi = pi/2 and "
    "phi = 3 pi/2 (one great circle through both poles); phi measured about axis.",
    **_ring_parameters(amplitude=3.5, sigma=1.5, p=4),
    sigma_phi=_number("Sharpness of the stripe in phi (200 narrow, 12 broad in the paper).", 200.0, minimum=0),
)


@register_pattern("fold", schema=_FOLD_SCHEMA)
def fold_pattern(points, zeta0, amplitude, sigma, p, sigma_phi, axis=(0.0, 0.0, 1.0), center=EQUATOR) -> np.ndarray:
    """Fold stripe, paper Sec. 4.3 (conventions.md): the ring of Eq. 59 with its amplitude term
    modulated in phi, ``zeta0 + amplitude exp(-sigma |theta - center|^p) exp(-sigma_phi d^4)``.

    ``d`` is the azimuthal distance (in radians, about ``axis``) from the nearest of the meridians
    ``phi = pi/2`` and ``phi = 3 pi/2``: together one great circle through both poles (the
    y-z plane for the default axis). The paper: sigma = 1.5, p = 4, zeta_hat = 3.5 with
    sigma_phi = 200, and zeta_hat = 4.5 with sigma_phi = 12.
    """
    sphi = finite_number(sigma_phi, "fold sigma_phi")
    if sphi < 0.0:
        raise SceneError(f"fold sigma_phi must be >= 0, got {sigma_phi!r}")
    base = ring_pattern(points, 0.0, amplitude, sigma, p, axis, center)  # amplitude term only
    _, phi = direction_angles(points, axis=_axis_param(axis, "fold axis"))
    d = np.abs(np.mod(phi - 0.5 * np.pi + 0.5 * np.pi, np.pi) - 0.5 * np.pi)  # distance to pi/2 or 3 pi/2
    return finite_number(zeta0, "fold zeta0") + base * np.exp(-sphi * d**4)


def _split_pattern(i: int, pat) -> tuple[Callable, dict]:
    if not isinstance(pat, dict):
        raise SceneError(f"active_stress[{i}] must be a mapping with a 'type', got {pat!r}")
    if "type" not in pat:
        raise SceneError(f"active_stress[{i}] has no 'type'; known types: {', '.join(sorted(PATTERNS))}")
    name = pat["type"]
    if not isinstance(name, str) or name not in PATTERNS:
        raise SceneError(
            f"active_stress[{i}]: unknown pattern type {name!r}; known types: {', '.join(sorted(PATTERNS))}"
        )
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
    (Eq. 59, p = 8, sigma = 10, zeta0 = amplitude = 1: 1.6454788579...; p = 4: 1.4829937138...;
    the tests check it against :func:`cortex_ti.truth.sphere_exact.sphere_mean`).
    For a ``harmonics`` pattern the mean is ``coeff_00 / sqrt(4 pi)``.
    """
    return float(integrate_patterns(patterns, order=order)) / (4.0 * np.pi)
