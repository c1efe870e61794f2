r"""Helfrich bending rigidity on the axisymmetric meridian: the energy, its normal force, and the
power the cortex dissipates (docs/derivations/bending_rigidity.md, Sec. 4).

``E = kappa/2 oint (C - c0)^2 dA`` with ``C = k1 + k2`` (``C = 2/R`` on a sphere, outward normal).
Its first variation for a normal displacement ``w n`` is ``dE = -oint f w dA`` with the outward
normal force density

    f = kappa [Lap C + (C - c0) C~ - (C - c0)^2 C / 2],     C~ = k1^2 + k2^2,
    Lap C = d_s d_s C + (r_s / r) d_s C,

evaluated with the spectral derivatives of the meridian (the curvatures of :func:`geometry`), so
``dE/dt = -oint f v_n dA`` holds to the spectral accuracy of the quadrature. The force enters the
normal balance as ``C_ab t^ab = P + f`` (the force moves to the right-hand side: it depends on the
shape only). Batched over leading axes and complex-step safe (the Jacobian of the time stepping).
"""

from __future__ import annotations

import numpy as np

from .spectral import Spectral

__all__ = ["helfrich_force", "helfrich_energy", "dissipation", "area_weights", "rigidity"]

ArrayF = np.ndarray


def area_weights(sp: Spectral, g: dict) -> ArrayF:
    """Quadrature weights of ``oint . dA`` for an integrand of class E at the nodes (full ``2 pi``,
    both halves with symmetry)."""
    scale = 2.0 if sp.symmetric else 1.0  # [0, pi/2] holds half the surface
    return 2.0 * np.pi * scale * sp.wR * g["r"] * g["h"]


def helfrich_force(sp: Spectral, g: dict, kappa: float, c0: float = 0.0) -> ArrayF:
    """The outward normal force density ``-dE/dw`` at the nodes (units of kappa / R0^3)."""
    k1, k2, h, rs, r = g["k1"], g["k2"], g["h"], g["rs"], g["r"]
    C = k1 + k2
    dC = (C @ sp.D["E"].T) / h  # d C / ds (class O)
    lap = (dC @ sp.D["O"].T) / h + (rs / r) * dC
    Cc = C - c0
    return kappa * (lap + Cc * (k1 * k1 + k2 * k2) - 0.5 * Cc * Cc * C)


def helfrich_energy(sp: Spectral, g: dict, kappa: float, c0: float = 0.0) -> ArrayF:
    """``kappa/2 oint (C - c0)^2 dA`` by the meridian's quadrature."""
    Cc = g["k1"] + g["k2"] - c0
    return 0.5 * kappa * (Cc * Cc * area_weights(sp, g)).sum(-1)


def dissipation(sp: Spectral, g: dict, vs: ArrayF, vn: ArrayF, eta_s: float, eta_b: float) -> ArrayF:
    """The in-plane viscous dissipation ``oint t_visc : v dA = oint [eta_s (v_ss - v_pp)^2 + eta_b
    (v_ss + v_pp)^2] dA`` (the bending viscosity's own is left out: with it on, the power balance
    of the test is taken without it)."""
    a = (vs @ sp.D["O"].T) / g["h"]
    vss = a + g["k1"] * vn
    vpp = vs * g["rs"] / g["r"] + g["k2"] * vn
    dens = eta_s * (vss - vpp) ** 2 + eta_b * (vss + vpp) ** 2
    return (dens * area_weights(sp, g)).sum(-1)


def rigidity(settings) -> dict:
    """A scene's rigidity (:class:`~cortex_ti.scene.settings.RunSettings`) as the keywords of
    :func:`~cortex_ti.axisymmetric.evolve.simulate`: empty without the effect ``bending_rigidity``, so
    a run without it takes exactly the code path it took before the effect existed."""
    if not settings.has("bending_rigidity"):
        return {}
    r = settings.rigidity
    return dict(kappa=r.bending, spontaneous_curvature=r.spontaneous_curvature)
