r"""Stokes boundary integrals on a surface of revolution given on the meridian's spectral nodes, and
the axisymmetric cortex between a cytoplasm and a medium.

A cytoplasm (viscosity ``mu_in``) and a medium (``mu_out``, at rest far away) move the surface,
with ``Δf = sigma_out . n - sigma_in . n`` the force they exert on the cortex per area, by

.. math:: (\mu_{in} + \mu_{out})\,u + \frac{1}{4\pi}\int G\,\Delta f\,dA
          - \frac{\mu_{in} - \mu_{out}}{4\pi}\,\mathrm{PV}\!\int u\cdot T\cdot n\,dA = 0,
   \qquad G = \frac{I}{|\rho|} + \frac{\rho\rho}{|\rho|^3},\quad T = -6\frac{\rho\rho\rho}{|\rho|^5}

(the two Lorentz reciprocal identities of :func:`layers`, weighted by the viscosities and added;
equal viscosities leave the single layer alone, Pozrikidis 1992, Ch. 5). :func:`layers` returns the
matrices of both integrals at the collocation nodes for axisymmetric fields without swirl;
:func:`with_fluids` couples them to the cortex's force balance.

**Quadrature: the target at a rotated pole** (Graham & Sloan 2002; used for vesicles by Veerapaneni
et al. 2011). The surface is parametrised by the unit sphere: ``u`` (the meridian label, a polar
angle) and the azimuth ``phi``, ``dA = J(u) dOmega`` with ``J = r h / sin u`` (``h = |X_u|``;
smooth at the poles, where ``r`` vanishes like ``sin u``). For each target the parameter sphere is
rotated so the target sits at its north pole; in the rotated angles ``(theta', phi')`` the
Stokeslet's ``1 / rho`` times ``dOmega = sin theta' dtheta' dphi'`` is smooth (and the double layer's
kernel bounded), so Gauss-Legendre in ``theta'`` on ``[0, pi]`` and the trapezoid rule in ``phi'``
converge spectrally for a smooth surface and a smooth density (tested against Lamb's sphere,
:mod:`cortex_ti.truth.fluid_sphere`, and on deformed shapes by ``S n = 0`` and the enclosed volume).
The density and the shape are evaluated between the nodes by the Fourier bases of
:class:`~cortex_ti.axisymmetric.spectral.Spectral` (``Δf_r``, ``r``: class ``'R'``; ``Δf_z``,
``z``: class ``'Z'``). The cost is ``n`` targets times ``n_theta n_phi / 2`` points (the integrand
is even in ``phi'``) times ``n`` basis functions, O(n^4): 0.03 s at n = 16, 0.55 s at 32, 3.2 s
at 48 (this machine, loaded). The default ``n_theta = 2n``, ``n_phi = 4n`` resolves the density's
highest mode at every target. Static here (:func:`with_fluids`); the runs with fluids rebuild it on
every shape (:mod:`cortex_ti.axisymmetric.fluids`), where the basis evaluated by recurrence and the
geometry-independent parts cached would pay.
"""

from __future__ import annotations

import numpy as np

from .spectral import Spectral

__all__ = ["single_layer", "layers", "with_fluids"]


def single_layer(sp: Spectral, r: np.ndarray, z: np.ndarray, *, n_theta: int | None = None, n_phi: int | None = None):
    """``(2n, 2n)`` matrix ``S`` of ``int G . f dA`` at the nodes, ``f`` and the result stacked as
    ``[r-components, z-components]``: equal viscosities move the surface with ``u = -S Δf / (8 pi mu)``.
    ``r, z``: the shape at the nodes (classes ``'R'`` and ``'Z'``), full meridian or symmetric half."""
    return layers(sp, r, z, n_theta=n_theta, n_phi=n_phi, double=False)[0]


def layers(sp: Spectral, r, z, *, n_theta: int | None = None, n_phi: int | None = None, double: bool = True):
    r"""``(S, D)``: the single layer ``S f = int G . f dA`` and the double layer
    ``(D u)_j = int u_i T_ijk n_k dA`` (``T_ijk = -6 rho_i rho_j rho_k / |rho|^5``, ``rho = x - y``,
    ``n`` outward; ``D`` is ``None`` unless ``double``) at the nodes, as ``(2n, 2n)`` matrices on
    ``[r-components, z-components]``. With ``f = sigma . n`` the Lorentz reciprocal identities on a
    smooth surface read ``u = (S f_in / mu_in + D u) / (4 pi)`` for the cytoplasm and
    ``u = -(S f_out / mu_out + D u) / (4 pi)`` for a medium at rest far away (``D`` as a principal
    value; the quadrature centred on the target takes it, e.g. ``D 1 = 4 pi``; tested on Lamb's fields)."""
    n = sp.n
    n_theta = 2 * n if n_theta is None else int(n_theta)
    n_phi = 4 * n if n_phi is None else int(n_phi)
    xg, wg = np.polynomial.legendre.leggauss(n_theta)
    tp = 0.5 * np.pi * (xg + 1.0)
    wt = 0.5 * np.pi * wg * np.sin(tp)
    # the integrands are even in phi' (the fields have no swirl, the target sits at y = 0): the
    # trapezoid rule on [0, pi], its two ends with half weight
    n_phi += n_phi % 2
    pp = 2.0 * np.pi * np.arange(n_phi // 2 + 1) / n_phi
    wp = np.full(pp.size, 4.0 * np.pi / n_phi)
    wp[[0, -1]] *= 0.5
    T, P = np.meshgrid(tp, pp, indexing="ij")
    W = (wt[:, None] * wp[None, :]).ravel()
    local = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], -1).reshape(-1, 3)
    S = np.zeros((2 * n, 2 * n))
    D = np.zeros((2 * n, 2 * n)) if double else None
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
        h = np.hypot(dr, dz)
        w = W * ru * h / np.sin(u)
        cos, sin = np.cos(phi), np.sin(phi)
        rho = np.stack([r[i] - ru * cos, -ru * sin, z[i] - zu], -1)
        d = np.linalg.norm(rho, axis=1)
        rho_er = rho[:, 0] * cos + rho[:, 1] * sin  # rho . e_r(phi)
        # G . e_r(phi) and G . e_z, on the target's e_x (= e_r at phi = 0) and e_z; integrated
        # against the basis, then mapped from coefficients back to nodal values
        S[i, :n] = ((w * (cos / d + rho[:, 0] * rho_er / d**3)) @ Ir) @ Br
        S[i, n:] = ((w * rho[:, 0] * rho[:, 2] / d**3) @ Iz) @ Bz
        S[n + i, :n] = ((w * rho[:, 2] * rho_er / d**3) @ Ir) @ Br
        S[n + i, n:] = ((w * (1.0 / d + rho[:, 2] ** 2 / d**3)) @ Iz) @ Bz
        if double:
            rho_n = (-dz * rho_er + dr * rho[:, 2]) / h  # rho . n(y), n = (-z_u e_r + r_u e_z) / h
            wk = -6.0 * w * rho_n / d**5
            for row, comp in ((i, rho[:, 0]), (n + i, rho[:, 2])):
                D[row, :n] = ((wk * rho_er * comp) @ Ir) @ Br
                D[row, n:] = ((wk * rho[:, 2] * comp) @ Iz) @ Bz
    return S, D


def _basis(sp: Spectral, cls: str, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(len(u), n)``: the basis functions of class ``cls`` and their u-derivatives at ``u``."""
    kind, m = sp.waves[cls]
    ph = np.outer(u, m)
    c, s = np.cos(ph), np.sin(ph)
    return (c, -s * m) if kind == "c" else (s, c * m)


def with_fluids(
    A: np.ndarray,
    b: np.ndarray,
    sp: Spectral,
    g: dict,
    *,
    mu_in: float,
    mu_out: float,
    body_force=0.0,
    far_field=None,
    layer_matrices=None,
):
    """The axisymmetric force balance ``A x = b`` (:meth:`~cortex_ti.axisymmetric.balance.ForceBalance.assemble`,
    ``x = [v_s, v_n, P(, lam)]``) coupled to a cytoplasm (viscosity ``mu_in``) and a medium (``mu_out``).

    Returns ``(A', b')`` for ``x' = [v_s, v_n, P(, lam), Δf_r, Δf_z]``: the fluids' force ``Δf`` (the
    traction jump ``sigma_out . n - sigma_in . n``, the cytoplasm's hydrostatic part ``body_force z``
    taken out) joins the cortex's balance, ``grad_a t^as + Δf . e_s = 0`` and
    ``C_ab t^ab = Δf . n + body_force z``, and the two reciprocal identities of :func:`layers`,
    weighted by the viscosities and added, tie it to the velocity:

        (mu_in + mu_out) v + S Δf / (4 pi) - (mu_in - mu_out) D v / (4 pi) = 2 mu_out u_inf.

    ``far_field``: ``None`` (the medium at rest far away) or the far-field flow ``u_inf`` at the
    nodes, ``(u_r, u_z)`` stacked (an axisymmetric Stokes flow without swirl, regular inside the
    cell: a uniform flow along the axis, an axisymmetric extension); its identity
    ``u_inf = (S f_inf / mu_out + D u_inf) / 4 pi`` turns the medium's into
    ``u = 2 u_inf - (S f_out / mu_out + D u) / 4 pi``.

    ``layer_matrices``: ``(S, D)`` of :func:`layers` on this shape, if already built.

    The pressure jump is now the fluids' (``P = 0``) and the medium fixes the translation
    (``lam = 0``); the enclosed volume is kept by the inner flow, to the quadrature's accuracy.
    """
    n = sp.n
    nx = A.shape[0]
    r, z, rs, zs = g["r"], g["z"], g["rs"], g["zs"]
    S, D = layers(sp, r, z, double=mu_in != mu_out) if layer_matrices is None else layer_matrices
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
    # the boundary integral equation on v = (v_r, v_z) = Q (v_s, v_n)
    Q = np.block([[np.diag(rs), np.diag(-zs)], [np.diag(zs), np.diag(rs)]])
    M = (mu_in + mu_out) * np.eye(2 * n)
    if D is not None:
        M = M - (mu_in - mu_out) / (4.0 * np.pi) * D
    rows = slice(nx, nx + 2 * n)
    out[rows, : 2 * n] = M @ Q
    out[rows, nx:] = S / (4.0 * np.pi)
    if far_field is not None:
        rhs[rows] = 2.0 * mu_out * np.asarray(far_field, float)
    return out, rhs
