r"""Shape-mode relaxation of a viscous shell with Helfrich bending rigidity (closed form).

Derivation: ``docs/derivations/bending_rigidity.md``. A sphere of radius ``R`` carrying a uniform
active tension ``zeta0``, enclosing an incompressible volume (pressure multiplier) and no outer
fluid, with the energy ``E = kappa/2 oint (C - c0)^2 dA`` (``C = k1 + k2``, ``C = 2/R`` on a sphere
with the outward normal). A normal displacement ``u(t) Y_lm`` relaxes as ``du/dt = lambda_l u`` with

    lambda_l = -M_l K_l,
    K_l = (L - 2)/R^2 * [zeta0 + kappa (L/R^2 - 2 c0/R + c0^2/2)],      L = l (l + 1),
    1/M_l = 4 eta_s eta_b (L - 2) / (R^2 (eta_s (L - 2) + eta_b L)) + kappa_l,
    kappa_l = (2 eta_bar_b L + 8 eta_bar - 4 eta_bar_b) / R^3   (bending viscosity).

``K_l`` is the second variation of ``E + zeta0 A - P0 V`` per ``oint (u Y)^2 dA`` (the base sphere
is an equilibrium for ``P0 = 2 zeta0/R - kappa c0 (2/R - c0)/R``), ``M_l`` the normal velocity per
unit normal force density of degree ``l`` (tangential force zero). Imports nothing of the package.

>>> round(stiffness(2, kappa=1.0), 12)   # kappa (l-1) l (l+1) (l+2) / R^4
24.0
>>> round(stiffness(3, kappa=0.0, zeta0=1.0), 12)   # the tension alone: (L - 2) zeta0 / R^2
10.0
>>> round(mobility(2, eta_s=1.0, eta_b=1.0), 12)    # (eta_s 4 + eta_b 6) / (4 * 4)
0.625
>>> round(rate(2, kappa=1.0, eta_s=1.0, eta_b=1.0), 12)
-15.0
"""

from __future__ import annotations

import math

__all__ = ["stiffness", "mobility", "rate", "base_pressure", "normal_force_sphere"]


def _L(l: int) -> float:
    if l < 2:
        raise ValueError(f"degree l = {l}: the modes l = 0, 1 are a volume change and a translation, not shape modes")
    return float(l * (l + 1))


def stiffness(l: int, *, kappa: float, c0: float = 0.0, zeta0: float = 0.0, radius: float = 1.0) -> float:
    """``K_l``: the restoring normal force density per unit amplitude of a degree-``l`` normal
    displacement (the second variation of ``E + zeta0 A - P0 V``), units of force per area per length."""
    L, R = _L(l), float(radius)
    return (L - 2.0) / R**2 * (zeta0 + kappa * (L / R**2 - 2.0 * c0 / R + 0.5 * c0 * c0))


def mobility(
    l: int, *, eta_s: float, eta_b: float, eta_bar: float = 0.0, eta_bar_b: float = 0.0, radius: float = 1.0
) -> float:
    """``M_l``: the normal velocity of the shell per unit outward normal force density ``F Y_l``
    (no tangential force, the volume constraint inactive for ``l >= 2``)."""
    L, R = _L(l), float(radius)
    kl = (2.0 * eta_bar_b * L + 8.0 * eta_bar - 4.0 * eta_bar_b) / R**3
    den = eta_s * (L - 2.0) + eta_b * L
    shell = 4.0 * eta_s * eta_b * (L - 2.0) / (R**2 * den) if den > 0 else 0.0
    stiff = shell + kl
    if stiff <= 0:
        return math.inf
    return 1.0 / stiff


def rate(
    l: int,
    *,
    kappa: float,
    eta_s: float,
    eta_b: float,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    c0: float = 0.0,
    zeta0: float = 0.0,
    radius: float = 1.0,
) -> float:
    """``lambda_l = -M_l K_l`` (1/t_a): the growth rate of the degree-``l`` shape mode (< 0: decays)."""
    return -mobility(l, eta_s=eta_s, eta_b=eta_b, eta_bar=eta_bar, eta_bar_b=eta_bar_b, radius=radius) * stiffness(
        l, kappa=kappa, c0=c0, zeta0=zeta0, radius=radius
    )


def base_pressure(*, kappa: float, c0: float = 0.0, zeta0: float = 0.0, radius: float = 1.0) -> float:
    """``P0 = p_in - p_out`` holding the sphere: ``2 zeta0/R - kappa c0 (2/R - c0)/R``.

    >>> base_pressure(kappa=1.0, c0=2.0)   # the sphere of the spontaneous curvature is stress free
    0.0
    """
    R = float(radius)
    return 2.0 * zeta0 / R - normal_force_sphere(kappa=kappa, c0=c0, radius=R)


def normal_force_sphere(*, kappa: float, c0: float = 0.0, radius: float = 1.0) -> float:
    """The outward Helfrich force density ``kappa [Lap C + (C - c0) C~ - (C - c0)^2 C / 2]`` on a
    sphere: ``kappa c0 (2/R - c0)/R`` (zero without spontaneous curvature: the energy is scale free).

    >>> normal_force_sphere(kappa=1.0)
    0.0
    """
    R = float(radius)
    return kappa * c0 * (2.0 / R - c0) / R
