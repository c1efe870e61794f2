r"""The Stokes single layer on a surface of revolution given on the meridian's spectral nodes.

For a traction jump ``Δf = sigma_out . n - sigma_in . n`` (the force the fluids exert on the cortex,
per area) carried by the surface, equal viscosities ``mu`` inside and outside move the surface with

.. math:: u(x) = u_\infty(x) - \frac{1}{8\pi\mu}\int G(x - y)\,\Delta f(y)\,dA_y,
   \qquad G(\rho) = \frac{I}{|\rho|} + \frac{\rho\rho}{|\rho|^3}

(Pozrikidis 1992, Ch. 5, viscosity ratio 1: the double layer drops out). :func:`single_layer`
returns the matrix of this integral at the collocation nodes, ``(u_r, u_z) = S (Δf_r, Δf_z) / mu``,
for axisymmetric fields without swirl.

**Quadrature: the target at a rotated pole** (Graham & Sloan 2002; used for vesicles by Veerapaneni
et al. 2011). The surface is parametrised by the unit sphere: ``u`` (the meridian label, a polar
angle) and the azimuth ``phi``, ``dA = J(u) dOmega`` with ``J = r h / sin u`` (``h = |X_u|``;
smooth at the poles, where ``r`` vanishes like ``sin u``). For each target the parameter sphere is
rotated so the target sits at its north pole; in the rotated angles ``(theta', phi')`` the
Stokeslet's ``1 / rho`` times ``dOmega = sin theta' dtheta' dphi'`` is smooth, so Gauss-Legendre
in ``theta'`` on ``[0, pi]`` and the trapezoid rule in ``phi'`` converge spectrally for a smooth
surface and a smooth density (tested against Lamb's sphere, :mod:`cortex_ti.truth.fluid_sphere`).
The density and the shape are evaluated between the nodes by the spectral interpolation of
:class:`~cortex_ti.axisymmetric.spectral.Spectral` (``Δf_r``, ``r``: class ``'R'``; ``Δf_z``,
``z``: class ``'Z'``). The cost is ``n`` targets times ``n_theta n_phi / 2`` points (the integrand
is even in ``phi'``) times ``n`` basis functions, O(n^4): 0.03 s at n = 16, 0.55 s at 32, 3.2 s
at 48 (this machine, loaded). The default ``n_theta = 2n``, ``n_phi = 4n`` resolves the density's
highest mode at every target. Used so far as a static solver (:func:`with_fluids`); a dynamic run
would want the basis evaluated by recurrence and the geometry-independent parts cached.
"""

from __future__ import annotations

import numpy as np

from .spectral import Spectral

__all__ = ["single_layer"]


def single_layer(sp: Spectral, r: np.ndarray, z: np.ndarray, *, n_theta: int | None = None, n_phi: int | None = None):
    """``(2n, 2n)`` matrix ``S`` with ``u = -S Δf / (8 pi mu)`` at the nodes, both stacked as
    ``[r-components, z-components]`` (the single layer of the module docstring, without its factor).

    ``r, z``: the shape at the nodes (classes ``'R'`` and ``'Z'``). Full meridian or the symmetric
    half (then the mirror image below the equator is included, for up-down symmetric fields).
    """
    n = sp.n
    n_theta = 2 * n if n_theta is None else int(n_theta)
    n_phi = 4 * n if n_phi is None else int(n_phi)
    xg, wg = np.polynomial.legendre.leggauss(n_theta)
    tp = 0.5 * np.pi * (xg + 1.0)
    wt = 0.5 * np.pi * wg * np.sin(tp)
    # the integrand is even in phi' (the fields have no swirl, the target sits at y = 0): the
    # trapezoid rule on [0, pi], its two ends with half weight
    n_phi += n_phi % 2
    pp = 2.0 * np.pi * np.arange(n_phi // 2 + 1) / n_phi
    wp = np.full(pp.size, 4.0 * np.pi / n_phi)
    wp[[0, -1]] *= 0.5
    T, P = np.meshgrid(tp, pp, indexing="ij")
    W = (wt[:, None] * wp[None, :]).ravel()
    local = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    S = np.zeros((2 * n, 2 * n))
    Br, Bz = sp.Binv["R"], sp.Binv["Z"]  # nodal values -> coefficients
    cr, cz = Br @ r, Bz @ z
    for i, ui in enumerate(sp.u):
        # rotate: the target's parameter direction (sin ui, 0, cos ui) becomes the pole
        e3 = np.array([np.sin(ui), 0.0, np.cos(ui)])
        e1 = np.array([np.cos(ui), 0.0, -np.sin(ui)])
        e2 = np.array([0.0, 1.0, 0.0])
        p = local @ np.stack([e1, e2, e3])
        u = np.arccos(np.clip(p[:, 2], -1.0, 1.0))
        phi = np.arctan2(p[:, 1], p[:, 0])
        Ir, dIr = _basis(sp, "R", u)  # (npts, n): the basis functions (and d/du) at u
        Iz, dIz = _basis(sp, "Z", u)
        ru, zu, dr, dz = Ir @ cr, Iz @ cz, dIr @ cr, dIz @ cz
        jac = ru * np.hypot(dr, dz) / np.sin(u)
        y = np.stack([ru * np.cos(phi), ru * np.sin(phi), zu], -1)
        x = np.array([r[i], 0.0, z[i]])
        rho = x - y
        d = np.linalg.norm(rho, axis=1)
        w = W * jac
        # G . e_r(phi) and G . e_z, projected on the target's e_x (= e_r at phi = 0) and e_z
        er = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], -1)
        rho_er = np.einsum("kj,kj->k", rho, er)
        g_xr = er[:, 0] / d + rho[:, 0] * rho_er / d**3
        g_zr = er[:, 2] / d + rho[:, 2] * rho_er / d**3
        g_xz = rho[:, 0] * rho[:, 2] / d**3
        g_zz = 1.0 / d + rho[:, 2] ** 2 / d**3
        # integrate against the basis, then map coefficients back to nodal values
        S[i, :n] = ((w * g_xr) @ Ir) @ Br
        S[i, n:] = ((w * g_xz) @ Iz) @ Bz
        S[n + i, :n] = ((w * g_zr) @ Ir) @ Br
        S[n + i, n:] = ((w * g_zz) @ Iz) @ Bz
    return S


def _basis(sp: Spectral, cls: str, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(len(u), n)``: the basis functions of class ``cls`` and their u-derivatives at ``u``."""
    kind, m = sp.waves[cls]
    ph = np.outer(u, m)
    c, s = np.cos(ph), np.sin(ph)
    return (c, -s * m) if kind == "c" else (s, c * m)


def with_fluids(A: np.ndarray, b: np.ndarray, sp: Spectral, g: dict, *, mu: float, body_force: float = 0.0, S=None):
    """The axisymmetric force balance ``A x = b`` (:meth:`~cortex_ti.axisymmetric.balance.ForceBalance.assemble`,
    ``x = [v_s, v_n, P(, lam)]``) coupled to a cytoplasm and a medium of equal viscosity ``mu``.

    Returns ``(A', b')`` for ``x' = [v_s, v_n, P(, lam), Δf_r, Δf_z]``: the fluids' force ``Δf`` (the
    traction jump, with the cytoplasm's hydrostatic part ``body_force z`` taken out) joins the cortex's
    balance, ``grad_a t^as + Δf . e_s = 0`` and ``C_ab t^ab = Δf . n + body_force z``, and the
    single layer ties it to the velocity, ``v = -S Δf / (8 pi mu)`` at the nodes (a medium at rest
    far away). The pressure jump is now the fluids' (``P = 0``) and the medium fixes the
    translation (``lam = 0``); the enclosed volume is kept by the single layer's velocity being
    divergence-free inside, to the quadrature's accuracy. ``S``: a precomputed :func:`single_layer`.
    """
    n = sp.n
    nx = A.shape[0]
    r, z, rs, zs = g["r"], g["z"], g["rs"], g["zs"]
    if S is None:
        S = single_layer(sp, r, z)
    out = np.zeros((nx + 2 * n, nx + 2 * n))
    rhs = np.zeros(nx + 2 * n)
    out[:nx, :nx] = A
    rhs[:nx] = b
    Bo = sp.Binv["O"]
    # tangential rows (as 'O' coefficients; the last one is v_s's Nyquist closure)
    out[:n, nx : nx + n] = Bo * rs[None, :]
    out[:n, nx + n :] = Bo * zs[None, :]
    out[n - 1, nx:] = 0.0
    # normal rows: C t - Δf . n = body_force z, with n = (-zs, rs)
    out[n : 2 * n, nx : nx + n] = np.diag(zs)
    out[n : 2 * n, nx + n :] = np.diag(-rs)
    rhs[n : 2 * n] += body_force * z
    # P = 0 (and lam = 0): the fluids carry the pressure and fix the translation
    out[:, 2 * n : nx] = 0.0
    out[2 * n : nx, :] = 0.0
    out[2 * n : nx, 2 * n : nx] = np.eye(nx - 2 * n)
    rhs[2 * n : nx] = 0.0
    # single layer: v_r, v_z + S Δf / (8 pi mu) = 0
    rows = slice(nx, nx + 2 * n)
    out[rows, :n] = np.vstack([np.diag(rs), np.diag(zs)])
    out[rows, n : 2 * n] = np.vstack([np.diag(-zs), np.diag(rs)])
    out[rows, nx:] = S / (8.0 * np.pi * mu)
    return out, rhs
