r"""The myosin density of the axisymmetric model: the same field as the 3D code's ``fields.myosin``.

A density ``c`` (amount per area) on the meridian, carried by the cortex's full velocity (so
diluted where the surface stretches), diffusing along the surface and turning over toward
``c0``, that makes the active tension ``zeta(c)`` with the 3D laws
(:data:`cortex_ti.physics.fields.TENSION_LAWS`)::

    d_t c + c v^a_a = D Lap c - k (c - c0)        (d_t following a material point)

The state carries the amount per unit parameter, ``q = c r h`` (``h = |dX/dsigma|``; the
amount between two parameter values is ``2 pi int q dsigma``), at the computational points,
which move with ``v_n n + w e_s`` (``w = 0`` in the lagrangian parametrisation). Its balance is
a conservation law in flux form (derivation: ``docs/derivations/axisymmetric_myosin.md``)::

    d_t q |_sigma = -d_sigma F - k (q - c0 r h),    F = r (c (v_s - w) - D d_s c),

``F`` the amount crossing a parameter circle per unit time per radian of azimuth (it vanishes at
the poles). ``F`` is expanded in the basis ``'Z'`` (cosines), ``q`` in ``'R'`` (sines), so the
class-'R' quadrature integrates ``d_sigma F`` exactly; the interpolant of ``F`` is corrected by
its lowest mode ``cos(sigma)`` so that it vanishes at both poles (a change of the order of the
interpolation error): the total ``M = 2 pi int q dsigma`` then obeys ``dM/dt = -k (M - c0 A)``
to round-off at every state, ``A`` the area of the same quadrature, and scipy's Runge-Kutta
(Radau) keeps that linear invariant to round-off for ``k = 0``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..physics.fields import TENSION_LAWS

__all__ = ["Myosin"]


@dataclass(frozen=True)
class Myosin:
    """The myosin field's parameters (the scene's ``fields.myosin``) and its initial density as
    a function of the polar angle on the initial sphere, ``initial(theta0) -> c`` (vectorised;
    ``None``: uniform ``c0``)."""

    c0: float = 1.0
    diffusion: float = 0.0
    turnover: float = 0.0
    law: str = "linear"
    zeta0: float = 1.0
    gamma: float = 1.0
    initial: Callable | None = None

    def __post_init__(self):
        if self.law not in TENSION_LAWS:
            raise ValueError(f"myosin tension law must be one of {sorted(TENSION_LAWS)}, got {self.law!r}")
        for name in ("c0", "diffusion", "turnover", "zeta0", "gamma"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float, np.floating)) and np.isfinite(v) and v >= 0):
                raise ValueError(f"myosin {name} must be a finite number >= 0, got {v!r}")
        if not self.c0 > 0:
            raise ValueError(f"myosin c0 must be > 0, got {self.c0!r}")

    def tension(self, c):
        """``zeta(c)`` (works for complex ``c``: the Jacobian's complex step)."""
        return TENSION_LAWS[self.law](c, float(self.c0), float(self.zeta0), float(self.gamma))

    def density(self, theta: np.ndarray) -> np.ndarray:
        """The initial density at the polar angles ``theta``."""
        th = np.asarray(theta, dtype=float)
        if self.initial is None:
            return np.full(th.shape, float(self.c0))
        c = np.asarray(self.initial(th), dtype=float)
        c = np.broadcast_to(c, th.shape).copy()
        if not np.all(np.isfinite(c)):
            raise ValueError("the initial myosin density is not finite")
        return c

    def symmetric(self) -> bool:
        """Whether the initial density is even under ``z -> -z``."""
        t = np.linspace(0.0, np.pi / 2, 401)
        a, b = self.density(t), self.density(np.pi - t)
        return bool(np.max(np.abs(a - b)) <= 1e-13 * max(1.0, float(np.max(np.abs(a)))))


def pole_rows(sp) -> tuple[np.ndarray, np.ndarray]:
    """Row vectors giving the class-'Z' interpolant's values at ``sigma = 0`` and ``pi`` from
    nodal values."""
    _, m = sp.waves["Z"]
    return np.ones(len(m)) @ sp.Binv["Z"], np.cos(m * np.pi) @ sp.Binv["Z"]


def rate(sp, my: Myosin, g: dict, vs, w, poles) -> np.ndarray:
    """``d q / dt`` at fixed parameter (batched over leading axes), module docstring."""
    c, r, h = g["c"], g["r"], g["h"]
    cs = (c @ sp.D["E"].T) / h  # d c / ds (class O)
    F = r * (c * (vs - w) - my.diffusion * cs)  # class Z, 0 at the poles in the continuum
    p0, pi_ = poles
    beta = 0.5 * (F @ p0 - F @ pi_)  # F_Z - alpha - beta cos(sigma) vanishes at both poles
    dF = F @ sp.D["Z"].T + np.asarray(beta)[..., None] * np.sin(sp.u)
    return -dF - my.turnover * (g["q"] - my.c0 * r * h)
