r"""Exact linear responses of a spherical viscous cortex between two Stokes fluids (Lamb's solution).

Independent reference for the coupling of the cortex to a cytoplasm (viscosity ``mu_in``) and a
medium (``mu_out``), written from its own derivation (``docs/derivations/fluid_sphere.md``); it
imports nothing of the package but :func:`~cortex_ti.truth.sphere_exact.bending_kappa`, the
bending-viscosity normal force that both references share. Conventions (docs/method/conventions.md):
outward normal ``n``, surface stress ``t^ab = 2 eta_s (v^ab - v^c_c g^ab / 2) + eta_b v^c_c g^ab +
zeta g^ab``, no slip on the cortex, lengths in R0, viscosities in eta_s, so ``mu`` is in eta_s / R0.

A surface velocity of one degree ``l`` is written with the real orthonormal ``Y = Y_lm`` (any m: the
sphere is isotropic) as

.. math:: v = a\,Y\,n + b\,R\,\nabla_s Y,

and every force density on the cortex as ``F_n Y n + F_t R grad_s Y``. The fluid on either side
answers with a traction ``sigma . n = (mu / R) K (a, b)`` (:func:`traction_matrices`, Lamb's
regular interior and decaying exterior solutions); the fluids push on the cortex with
``sigma_out . n - sigma_in . n``. The cortex adds its own viscous force (:func:`shell_matrix`),
and the balance per degree is a 2 x 2 linear system (:func:`mode_velocity`).

What this gives, each a closed form the 3D and axisymmetric fluid couplings are tested against:

* :func:`flow_coefficients`: the flow driven by an active tension ``zeta_lm Y`` on a static sphere,
  ``v = zeta_lm (alpha_l grad_s Y + beta_l Y n)`` (as :func:`sphere_exact.flow_coefficients`, to which
  it reduces when both viscosities vanish), now also for l = 1, which the outer fluid makes gauge-free.
* :func:`relaxation_rate`: the linear rate of a shape mode ``delta r = eps Y`` under a uniform tension
  (and optionally a bending rigidity's stiffness), Lamb's drop relaxation with surface viscosities.
* :func:`sedimentation_velocity`: the terminal velocity of a cell whose cytoplasm carries a body force
  (Boussinesq-Scriven: only the dilatational viscosity ``eta_b`` enters).
* :func:`strain_response` and :func:`faxen`: a sphere in a linear far-field flow ``u = W x + E x``:
  the mean surface velocity is the flow at the centre and the surface rotates with the vorticity's
  half (Faxén's laws for linear flows), and the degree-2 surface velocity the strain ``E`` drives.

>>> K_in, K_out = traction_matrices(2)
>>> K_in.tolist(), K_out.tolist()
([[6.5, -9.0], [-1.5, 5.0]], [[-6.0, 6.0], [1.0, -5.0]])
>>> round(relaxation_rate(2, tension=1.0, mu_in=1.0, mu_out=1.0, eta_s=0.0, eta_b=0.0), 12)  # Taylor's drop
-0.457142857143
"""

from __future__ import annotations

import math

import numpy as np

from .sphere_exact import bending_kappa

__all__ = [
    "traction_matrices",
    "shell_matrix",
    "mode_velocity",
    "flow_coefficients",
    "relaxation_rate",
    "sedimentation_velocity",
    "boussinesq_scriven_velocity",
    "strain_response",
    "faxen",
]


def traction_matrices(l: int) -> tuple[np.ndarray, np.ndarray]:
    r"""``(K_in, K_out)``: the traction ``sigma . n = (mu / R) K (a, b)`` of the inner (regular at the
    centre) and outer (decaying) Stokes flow that takes the surface velocity ``a Y n + b R grad_s Y``
    of degree ``l >= 1`` on the sphere of radius R (``(Tn, Tt)``: ``sigma . n = (mu/R)(Tn Y n + Tt R grad_s Y)``).

    ::

        K_in  = [[(2l^2 + l + 3) / l,      -3 (l + 1)],
                 [-3 / l,                   2l + 1   ]]
        K_out = [[-(2l^2 + 3l + 4) / (l+1), 3 l      ],
                 [3 / (l + 1),             -(2l + 1) ]]

    With ``W = diag(1, l(l+1))`` (the norms of ``Y n`` and ``R grad_s Y``), ``W K_in`` and ``-W K_out``
    are symmetric positive definite: the power the surface puts into either fluid is its dissipation.
    Degree 1 of ``K_out`` holds the Stokeslet: a rigid translation ``a = b = U`` meets the drag
    ``-6 pi mu R U``.
    """
    if l < 1:
        raise ValueError(f"degree must be >= 1, got {l}")
    k_in = np.array([[(2.0 * l * l + l + 3.0) / l, -3.0 * (l + 1)], [-3.0 / l, 2.0 * l + 1.0]])
    k_out = np.array([[-(2.0 * l * l + 3.0 * l + 4.0) / (l + 1), 3.0 * l], [3.0 / (l + 1), -(2.0 * l + 1.0)]])
    return k_in, k_out


def shell_matrix(
    l: int, *, radius: float = 1.0, eta_s: float = 1.0, eta_b: float = 1.0, eta_bar: float = 0.0, eta_bar_b: float = 0.0
) -> np.ndarray:
    r"""The cortex's own viscous force ``(F_n, F_t) = S (a, b)`` for the surface velocity
    ``a Y n + b R grad_s Y`` of degree ``l`` on a sphere of radius R (``L = l(l+1)``)::

        F_t = [2 eta_b a + (2 eta_s - (eta_s + eta_b) L) b] / R^2      (grad_a t^ab)
        F_n = -2 eta_b (2 a - L b) / R^2 - kappa_l a                  (-C_ab t^ab - C_ab t_b^ab)

    ``kappa_l`` is the bending viscosity's normal force per normal speed
    (:func:`~cortex_ti.truth.sphere_exact.bending_kappa`).
    """
    R = float(radius)
    L = l * (l + 1)
    kap = bending_kappa(l, R, eta_bar, eta_bar_b) if (eta_bar or eta_bar_b) else 0.0
    return np.array(
        [
            [-4.0 * eta_b / R**2 - kap, 2.0 * eta_b * L / R**2],
            [2.0 * eta_b / R**2, (2.0 * eta_s - (eta_s + eta_b) * L) / R**2],
        ]
    )


def _system(l, radius, mu_in, mu_out, shell):
    k_in, k_out = traction_matrices(l)
    return shell_matrix(l, radius=radius, **shell) + (mu_out * k_out - mu_in * k_in) / float(radius)


def mode_velocity(
    l: int, force_n: float, force_t: float, *, radius: float = 1.0, mu_in: float = 1.0, mu_out: float = 1.0, **shell
) -> tuple[float, float]:
    r"""``(a, b)``: the surface velocity ``a Y n + b R grad_s Y`` that balances an applied force density
    ``force_n Y n + force_t R grad_s Y`` on the cortex (shell + both fluids; ``shell``: the keywords
    of :func:`shell_matrix`)."""
    a, b = np.linalg.solve(_system(l, radius, mu_in, mu_out, shell), -np.array([force_n, force_t], float))
    return float(a), float(b)


def flow_coefficients(
    l: int, *, radius: float = 1.0, mu_in: float = 1.0, mu_out: float = 1.0, **shell
) -> tuple[float, float]:
    r"""``(alpha_l, beta_l)`` of ``v = zeta_lm (alpha_l grad_s Y_lm + beta_l Y_lm n)``: the flow an active
    tension ``zeta_lm Y_lm`` drives on a static sphere. The tension pushes with ``grad_s zeta`` along
    the surface and ``-2 zeta / R`` along the normal, so ``F_t = zeta_lm / R``, ``F_n = -2 zeta_lm / R``.
    ``l = 0`` only changes the pressure: ``(0, 0)``. Degree 1 is a translation plus a dilatation,
    gauge-free as soon as the outer fluid is there (``mu_out > 0``)."""
    if l == 0:
        return 0.0, 0.0
    R = float(radius)
    a, b = mode_velocity(l, -2.0 / R, 1.0 / R, radius=R, mu_in=mu_in, mu_out=mu_out, **shell)
    return b * R, a


def relaxation_rate(
    l: int,
    *,
    tension: float,
    stiffness: float = 0.0,
    radius: float = 1.0,
    mu_in: float = 1.0,
    mu_out: float = 1.0,
    **shell,
) -> float:
    r"""Growth rate ``lambda_l`` (negative: relaxation) of a shape mode ``delta r = eps Y_lm``, l >= 2,
    under a uniform tension ``tension`` (an active ``zeta_0`` or a surface tension), plus an optional
    extra normal stiffness (force per unit ``eps``, e.g. a bending rigidity's). The perturbed mean
    curvature is ``2H = 2/R + eps (l-1)(l+2) Y / R^2``, so the tension pushes with
    ``F_n = -tension (l-1)(l+2) eps / R^2`` (and ``-stiffness eps``); ``d eps / dt = a``.

    Without surface viscosities this is Lamb's (and Taylor's, for l = 2) viscous drop:
    ``lambda_2 = -40 (1 + lam) gamma / (mu R (2 lam + 3)(19 lam + 16))``, ``lam = mu_in / mu``.
    """
    if l < 2:
        raise ValueError("shape modes start at degree 2 (l = 0 is the volume, l = 1 a translation)")
    R = float(radius)
    k = tension * (l - 1) * (l + 2) / R**2 + stiffness
    a, _ = mode_velocity(l, -k, 0.0, radius=R, mu_in=mu_in, mu_out=mu_out, **shell)
    return a


def sedimentation_velocity(
    body_force: float, *, radius: float = 1.0, mu_in: float = 1.0, mu_out: float = 1.0, **shell
) -> float:
    r"""Terminal velocity (of the centroid, along the force) of a spherical cell whose cytoplasm
    carries a uniform body force density ``body_force`` (relative to the medium), from the degree-1
    balance: the inner pressure ``p + f . x`` pushes the cortex with ``F_n = body_force R``
    (``Y = P_1``-shaped), total ``f V``. The shape translates with the normal part ``a``; the
    tangential part ``b`` differs from ``a`` by the cortex's own circulation, so the mean surface
    velocity ``(a + 2 b) / 3`` is not the cell's velocity (it is Stokes' ``F / (6 pi mu R)`` for any
    cell: the outer fluid's drag depends on it alone). Equals :func:`boussinesq_scriven_velocity`."""
    R = float(radius)
    a, _ = mode_velocity(1, body_force * R, 0.0, radius=R, mu_in=mu_in, mu_out=mu_out, **shell)
    return a


def boussinesq_scriven_velocity(
    body_force: float, *, radius: float = 1.0, mu_in: float = 1.0, mu_out: float = 1.0, eta_b: float = 1.0
) -> float:
    r"""Boussinesq's (1913) and Scriven's (1960) terminal velocity of a drop with a dilatational surface
    viscosity, from the literature (an independent check of :func:`sedimentation_velocity`)::

        U = F / (2 pi mu R) (mu + mu_in + 2 eta_b / (3 R)) / (2 mu + 3 mu_in + 2 eta_b / R),  F = f 4 pi R^3 / 3.

    ``eta_b -> inf`` or ``mu_in -> inf``: Stokes' ``F / (6 pi mu R)``; ``eta_b = 0``: Hadamard-Rybczynski.
    """
    R, mu = float(radius), float(mu_out)
    F = body_force * 4.0 * math.pi * R**3 / 3.0
    ratio = (mu + mu_in + 2.0 * eta_b / (3.0 * R)) / (2.0 * mu + 3.0 * mu_in + 2.0 * eta_b / R)
    return F / (2.0 * math.pi * mu * R) * ratio


def strain_response(*, radius: float = 1.0, mu_in: float = 1.0, mu_out: float = 1.0, **shell) -> tuple[float, float]:
    r"""``(a, b)`` per unit ``q``: the surface velocity ``a q n + b R grad_s q`` of a static sphere in the
    far-field strain ``u = E x`` (``E`` symmetric, traceless), ``q(n) = n . E . n`` (a degree-2
    field). The far field alone has ``(a, b) = (R, R / 2)`` and traction ``2 mu_out E n``, i.e.
    ``(Tn, Tt) = (2 mu_out, mu_out)``; the disturbance flow is the decaying solution for the
    difference."""
    R = float(radius)
    _, k_out = traction_matrices(2)
    far_v = np.array([R, R / 2.0])
    far_t = np.array([2.0 * mu_out, mu_out])
    # sigma_out . n = (mu_out / R) K_out (v - far_v) + far_t
    rhs = far_t - (mu_out / R) * (k_out @ far_v)
    a, b = mode_velocity(2, *rhs, radius=R, mu_in=mu_in, mu_out=mu_out, **shell)
    return a, b


def faxen(velocity_gradient, centre_velocity=(0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    r"""Faxén's laws for a force- and torque-free sphere (any surface and fluid viscosities, mu_out > 0)
    in a linear far field ``u(x) = U + G x``: the mean surface velocity is ``U`` and the surface
    rotation ``3 / (8 pi R^4) oint x cross v dA`` is half the vorticity of ``G``. The rotation part
    of ``G`` turns the whole system rigidly (no stress anywhere); its strain part drives only degree
    2, which has no mean and no rotation."""
    G = np.asarray(velocity_gradient, float)
    w = np.array([G[2, 1] - G[1, 2], G[0, 2] - G[2, 0], G[1, 0] - G[0, 1]])
    return np.asarray(centre_velocity, float), 0.5 * w
