r"""Test-side tools, independent of ``sphere_exact``'s internals.

* the paper's patterns re-implemented from their definitions (Eq. 59 ring, Sec. 4.3 fold),
* closed forms of Y_20, Y_21 and their surface gradients,
* ``fd_balance_residual``: the tangential and normal force-balance residuals of a velocity
  field on a sphere, by finite differences in the embedding space (no use of the harmonic
  expansion or of the per-degree formulas), including the bending-viscosity normal force of
  the 3D code written from its general tensor form (``D^a_b = -nabla^a nabla_b v_n -
  v_n C^a_c C^c_b``, ``t_b^ab = 2 eta_bar (D^ab + C v_n C^ab) + (eta_bar_b - eta_bar) D^c_c g^ab``).
* ``sphere_grid``: Gauss-Legendre x uniform grid for integrals over the sphere.
"""

from __future__ import annotations

import math

import numpy as np

# ------------------------------------------------------------------ patterns (paper definitions)


def _unit(x):
    x = np.atleast_2d(np.asarray(x, dtype=float))
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def pattern_frame(axis=(0.0, 0.0, 1.0)):
    """(e1, e2, a): e1 = image of +x under the minimal rotation +z -> a (a = -z: rotation by pi
    about +x), as in the project's pattern convention."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    if 1.0 + a[2] < 1e-12:
        e1 = np.array([1.0, 0.0, 0.0])
    else:
        e1 = np.array([1.0 - a[0] ** 2 / (1.0 + a[2]), -a[0] * a[1] / (1.0 + a[2]), -a[0]])
    e1 = e1 - (e1 @ a) * a
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1), a


def ring(p=8.0, amplitude=1.0, sigma=10.0, zeta0=1.0, axis=(0.0, 0.0, 1.0)):
    """Eq. 59: ``zeta0 + amplitude exp(-sigma |theta - pi/2|^p)``, theta the angle from axis."""
    e1, e2, a = pattern_frame(axis)

    def f(x):
        u = _unit(x)
        th = np.arctan2(np.hypot(u @ e1, u @ e2), u @ a)
        return zeta0 + amplitude * np.exp(-sigma * np.abs(th - 0.5 * np.pi) ** p)

    return f


def fold(amplitude=3.5, sigma_phi=200.0, sigma=1.5, p=4.0, zeta0=1.0, axis=(0.0, 0.0, 1.0)):
    """Sec. 4.3: the ring's amplitude term times ``exp(-sigma_phi d^4)``, d the azimuthal
    distance from the nearest of phi = pi/2, 3 pi/2."""
    e1, e2, a = pattern_frame(axis)

    def f(x):
        u = _unit(x)
        th = np.arctan2(np.hypot(u @ e1, u @ e2), u @ a)
        phi = np.mod(np.arctan2(u @ e2, u @ e1), 2.0 * np.pi)
        d = np.minimum(np.abs(phi - 0.5 * np.pi), np.abs(phi - 1.5 * np.pi))
        return zeta0 + amplitude * np.exp(-sigma * np.abs(th - 0.5 * np.pi) ** p) * np.exp(-sigma_phi * d**4)

    return f


def ring_mean(p, amplitude, sigma=10.0, zeta0=1.0) -> float:
    """Mean of the ring over the unit sphere by adaptive quadrature in theta (scipy.quad)."""
    from scipy.integrate import quad

    def g(t):
        return amplitude * math.exp(-sigma * abs(t - 0.5 * math.pi) ** p) * math.sin(t)

    lo = quad(g, 0.0, 0.5 * math.pi, epsabs=1e-14, epsrel=1e-13, limit=400)[0]
    hi = quad(g, 0.5 * math.pi, math.pi, epsabs=1e-14, epsrel=1e-13, limit=400)[0]
    return zeta0 + 0.5 * (lo + hi)


# ------------------------------------------------------------------ closed-form harmonics

C20 = math.sqrt(5.0 / (16.0 * math.pi))
C21 = math.sqrt(15.0 / (4.0 * math.pi))


def y20(x):
    u = _unit(x)
    return C20 * (3.0 * u[:, 2] ** 2 - 1.0)


def y21(x):
    u = _unit(x)
    return C21 * u[:, 0] * u[:, 2]


def tangential_part(g, u):
    return g - np.sum(g * u, axis=1)[:, None] * u


def grad_y20(x, R):
    u = _unit(x)
    g = np.zeros_like(u)
    g[:, 2] = 6.0 * C20 * u[:, 2]
    return tangential_part(g, u) / R


def grad_y21(x, R):
    u = _unit(x)
    g = np.stack([C21 * u[:, 2], np.zeros(len(u)), C21 * u[:, 0]], axis=1)
    return tangential_part(g, u) / R


# ------------------------------------------------------------------ quadrature


def sphere_grid(n: int, R: float = 1.0):
    """Points (n * 2n, 3) on the sphere of radius R and area weights (sum = 4 pi R^2)."""
    z, w = np.polynomial.legendre.leggauss(n)
    nphi = 2 * n
    phi = np.arange(nphi) * 2.0 * np.pi / nphi
    s = np.sqrt(1.0 - z * z)
    pts = np.stack([np.outer(s, np.cos(phi)), np.outer(s, np.sin(phi)), np.repeat(z[:, None], nphi, 1)], -1)
    wts = np.repeat(w[:, None], nphi, 1) * (2.0 * np.pi / nphi) * R * R
    return R * pts.reshape(-1, 3), wts.reshape(-1)


# ------------------------------------------------------------------ finite-difference residual

_FD = ((-2, 1.0 / 12.0), (-1, -8.0 / 12.0), (1, 8.0 / 12.0), (2, -1.0 / 12.0))  # 4th order


def _stencil(x, h):
    """Points x + k h e_j (j = 0..2, k in -2, -1, 1, 2), shape (N, 3, 4, 3)."""
    E = np.eye(3)
    return x[:, None, None, :] + h * np.array([k for k, _ in _FD])[None, None, :, None] * E[None, :, None, :]


def _d(vals, h):
    """vals (N, 3, 4, ...) at the stencil -> derivatives (N, 3, ...)."""
    c = np.array([c for _, c in _FD])
    return np.einsum("njk...,k->nj...", vals, c) / h


def fd_balance_residual(vfun, zfun, X, *, R, eta_s, eta_b, eta_bar=0.0, eta_bar_b=0.0, P=0.0, h=2e-3):
    r"""Force-balance residuals at points X on the sphere of radius R, by finite differences.

    All fields are extended off the sphere by ``F(x) = F(R x / |x|)`` (0-homogeneous), so their
    3D derivatives at the surface are tangential derivatives. With ``G_kj = d_k v_j``:
    ``E = P (G + G^T) P / 2`` (the strain rate ``v_ab`` incl. ``C_ab v_n``),
    ``T = 2 eta_s (E - tr E P / 2) + eta_b tr E P + zeta P``, ``f = div_s T = d_i T_ij``
    (``= nabla_a t^ab e_b - C_ab t^ab n``). Bending: ``v_n`` Hessian ``H = P d(P grad v_n) P``,
    ``C = P / R`` (sphere, ``C_ab = -n . d_a d_b X``), ``D = -H - v_n C C``,
    ``t_b = 2 eta_bar (D + tr(C) v_n C) + (eta_bar_b - eta_bar) tr(D) P``.

    Returns ``(r_t (N, 3), r_n (N,), scale)``: the tangential force ``P f`` and the normal
    residual ``-n . f + C : t_b - P`` (the normal balance ``C_ab (t^ab + t_b^ab) = P``), and a
    force scale (max of |grad zeta| and 2 |zeta| / R) to judge them by.
    """
    X = np.atleast_2d(X)
    N = X.shape[0]

    def proj(x):
        return R * x / np.linalg.norm(x, axis=-1, keepdims=True)

    Y = proj(_stencil(X, h)).reshape(-1, 3)  # outer stencil, (N*12, 3)
    Yall = np.concatenate([Y, X])
    Z = proj(_stencil(Yall, h)).reshape(-1, 3)  # inner stencil
    vz = vfun(np.concatenate([Z, Yall])).reshape(-1, 3)
    vZ = vz[: Z.shape[0]].reshape(Yall.shape[0], 3, 4, 3)
    vY = vz[Z.shape[0] :]
    uZ = Z.reshape(Yall.shape[0], 3, 4, 3) / R
    uY = Yall / R
    G = _d(vZ, h)  # (M, 3, 3): d_k v_j
    Pm = np.eye(3)[None] - uY[:, :, None] * uY[:, None, :]
    E = 0.5 * Pm @ (G + np.swapaxes(G, 1, 2)) @ Pm
    trE = np.trace(E, axis1=1, axis2=2)
    zY = zfun(Yall)
    T = 2 * eta_s * (E - 0.5 * trE[:, None, None] * Pm) + (eta_b * trE + zY)[:, None, None] * Pm
    gvn = _d(np.einsum("nkqj,nkqj->nkq", vZ, uZ), h)  # grad v_n (tangential), (M, 3)
    nY = N * 12
    TY = T[:nY].reshape(N, 3, 4, 3, 3)
    dT = _d(TY, h)  # (N, 3(k), 3, 3): d_k T_ij
    f = np.einsum("niij->nj", dT)  # d_i T_ij
    u = X / R
    PX = Pm[nY:]
    vn = np.sum(vY[nY:] * u, axis=1)
    H = PX @ _d(gvn[:nY].reshape(N, 3, 4, 3), h) @ PX
    C = PX / R
    D = -H - vn[:, None, None] * C @ C
    trC = np.trace(C, axis1=1, axis2=2)
    trD = np.trace(D, axis1=1, axis2=2)
    tb = 2 * eta_bar * (D + (trC * vn)[:, None, None] * C) + (eta_bar_b - eta_bar) * trD[:, None, None] * PX
    r_t = np.einsum("nij,nj->ni", PX, f)
    r_n = -np.sum(f * u, axis=1) + np.einsum("nij,nij->n", C, tb) - P
    gz = _d(zfun(proj(_stencil(X, h)).reshape(-1, 3)).reshape(N, 3, 4), h)
    scale = max(np.max(np.linalg.norm(gz, axis=1)), 2 * np.max(np.abs(zY)) / R)
    return r_t, r_n, scale
