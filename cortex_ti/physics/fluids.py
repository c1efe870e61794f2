r"""The cortex between two Stokes fluids: their dissipation as a dense block of the Rayleighian.

First step of issue 36; written here for equal viscosities ``mu_in = mu_out = mu`` (the single layer
alone; a viscosity contrast adds the double layer, :func:`fluid_operator`). The fluids answer a surface velocity ``v``
(relative to the far field ``u_inf``) with the force density ``f = S^{-1} (v - u_inf)`` the
surface puts on them, ``S`` the single layer (:mod:`cortex_ti.physics.stokes_bie`); they push
back with ``-f``, and the power ``oint (v - u_inf) . f dA`` is their dissipation, a positive
quadratic form of ``v``. Discretely (docs/method/fluids.md):

* ``C``: the collocation matrix of ``S`` (P1 density, nodes as targets);
* ``V = A C`` (``A``: the nodes' areas ``int phi_i dA``) approximates the Galerkin matrix
  ``int phi_i S[phi_j]``, which is symmetric; it is symmetrised, ``V_s = (V + V^T) / 2``;
* ``S`` annihilates a uniform normal force (a pressure inflates nothing in an incompressible
  fluid: every single-layer velocity has zero flux), so ``V_s`` is only nearly singular along
  ``w = A n``: the rank-one completion ``V_s + c w w^T`` makes it definite (the same
  velocity for every ``c > 0`` wherever ``oint v . n dA = 0``; the volume constraint, kept as
  the cortex's row whose multiplier is the pressure, enforces that);
* the fluids' dissipation matrix ``D = A (V_s + c w w^T)^{-1} A``, symmetric positive definite
  (checked: its Cholesky factorisation exists), is added to the cortex's dissipation ``K``.

The rigid translation and rotation are then fixed by the medium, so the gauge rows are dropped
(:func:`solve_with_fluids`). A body force ``b`` on the cytoplasm (relative to the medium) enters
as the hydrostatic pressure ``b . x`` of the cytoplasm pushing on the cortex, ``(b . x) n``
(:func:`body_force_nodes`); a far-field flow ``u_inf`` as ``mu_out A S^-1 A u_inf`` on the right-hand
side (its own traction and its disturbance's; ``D u_inf`` for equal viscosities).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..errors import SolverError
from ..solve.system import EnergySystem
from .stokes_bie import double_layer_matrix, node_areas, single_layer_matrix

__all__ = ["FluidOperator", "fluid_operator", "body_force_nodes", "shear_flow", "solve_with_fluids"]


@dataclass
class FluidOperator:
    """The fluids' dissipation ``D`` (3N, 3N) on one shape and what was measured building it."""

    dissipation: np.ndarray  # D, symmetric positive definite
    asymmetry: float  # |V - V^T| / |V| (max norms) before symmetrising: a measure of the quadrature
    mu_in: float
    mu_out: float
    seconds: float
    min_eigenvalue: float | None = None  # with a viscosity contrast (the symmetrised D is then not PSD by construction)
    far_map: np.ndarray | None = None  # mu_out A S^-1 A: the far field's force (a contrast only; else D)

    def far_force(self, far: np.ndarray) -> np.ndarray:
        """The force a far-field flow ``u_inf`` (N, 3) puts on the static cortex, ``mu_out A S^-1 A
        u_inf`` whatever the inner viscosity (the far field's own traction plus its disturbance's)."""
        mat = self.dissipation if self.far_map is None else self.far_map
        return mat @ np.asarray(far, float).ravel()

    def force(self, velocity: np.ndarray, far: np.ndarray | None = None) -> np.ndarray:
        """The nodal forces ``-D v + mu_out A S^-1 A u_inf`` the fluids put on the cortex (N, 3)."""
        out = -(self.dissipation @ np.asarray(velocity, float).ravel())
        if far is not None:
            out += self.far_force(far)
        return out.reshape(-1, 3)


def fluid_operator(
    points: np.ndarray,
    faces: np.ndarray,
    normals: np.ndarray,
    *,
    mu_in: float,
    mu_out: float,
    completion: float = 1.0,
    measure: bool = True,
    **quadrature,
) -> FluidOperator:
    """The fluids' dissipation matrix on the shape ``points`` (module docstring); ``normals``
    (N, 3) the nodes' unit normals of the completion ``w = A n``, ``completion`` a factor of its
    weight ``c`` (the lifted eigenvalue is ``completion * mean(A) R``, R the radius of the sphere
    of the same area), ``quadrature`` the keywords of
    :func:`~cortex_ti.physics.stokes_bie.single_layer_matrix`. Equal viscosities need the single
    layer alone; a contrast adds the double layer (``D = A V^-1 A [mu_out (1/2 + Kd) + mu_in (1/2 -
    Kd)]``, symmetrised; its smallest eigenvalue is kept in ``min_eigenvalue`` when ``measure``: the runs
    skip it, their dense Cholesky factorisation of the whole dissipation refuses an indefinite one)."""
    import time

    if not (mu_in >= 0 and mu_out > 0):
        raise SolverError(f"the fluids' viscosities must be positive (outer) and >= 0 (inner), got {mu_in}, {mu_out}")
    t0 = time.perf_counter()
    x = np.asarray(points, float)
    area = node_areas(x, faces)
    a3 = np.repeat(area, 3)
    v = a3[:, None] * single_layer_matrix(x, faces, 1.0, **quadrature)
    asym = float(np.abs(v - v.T).max() / np.abs(v).max())
    v = 0.5 * (v + v.T)
    w = (area[:, None] * normals).ravel()
    radius = math.sqrt(area.sum() / (4.0 * math.pi))
    c = completion * area.mean() * radius / float(w @ w)
    v += c * np.outer(w, w)
    try:
        chol = sla.cho_factor(v, lower=True, overwrite_a=True, check_finite=False)
    except np.linalg.LinAlgError as err:
        raise SolverError(f"the fluids' single-layer matrix is not positive definite ({err})") from err
    # the inverse from the Cholesky factor (LAPACK potri: a third of the flops of solving against the
    # identity, and no identity matrix in memory), its lower triangle mirrored
    inv, info = sla.lapack.dpotri(chol[0], lower=1, overwrite_c=1)
    if info != 0:
        raise SolverError(f"the fluids' single-layer matrix could not be inverted (LAPACK dpotri info {info})")
    for s in range(0, len(a3), 512):  # in blocks: no index arrays of the matrix's size
        e = min(len(a3), s + 512)
        inv[s:e, e:] = inv[e:, s:e].T
        inv[s:e, s:e] = np.tril(inv[s:e, s:e]) + np.tril(inv[s:e, s:e], -1).T
    inv *= a3[:, None]
    inv *= a3[None, :]
    d = inv
    min_ev = far = None
    if mu_in == mu_out:
        d = mu_out * d
    else:
        far = mu_out * 0.5 * (d + d.T)
        kd = double_layer_matrix(x, faces, **quadrature)
        mix = (0.5 * (mu_in + mu_out)) * np.eye(len(a3)) + (mu_out - mu_in) * kd
        d = d @ mix
    d = 0.5 * (d + d.T)
    if mu_in != mu_out and measure:
        min_ev = float(sla.eigvalsh(d, subset_by_index=[0, 0])[0])
    return FluidOperator(
        dissipation=d,
        asymmetry=asym,
        mu_in=float(mu_in),
        mu_out=float(mu_out),
        seconds=time.perf_counter() - t0,
        min_eigenvalue=min_ev,
        far_map=far,
    )


def body_force_nodes(points: np.ndarray, faces: np.ndarray, body_force) -> np.ndarray:
    """``int (b . x) n phi_i dA`` on the flat triangles (N, 3): the cytoplasm's hydrostatic
    pressure ``b . x`` (the body force ``b`` relative to the medium) pushing on the cortex; its
    total is ``b V`` (exactly, on the triangulated volume)."""
    x = np.asarray(points, float)
    b = np.asarray(body_force, float)
    tri = x[faces]
    an = 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # area times unit normal
    h = tri @ b  # (F, 3) b . x at the corners
    # int phi_i phi_j dA = |T| (1 + delta_ij) / 12
    coef = (h.sum(1)[:, None] + h) / 12.0  # (F, 3)
    out = np.zeros_like(x)
    for k in range(3):
        np.add.at(out, faces[:, k], coef[:, k, None] * an)
    return out


def shear_flow(points: np.ndarray, rate: float) -> np.ndarray:
    """The simple shear ``u = G y e_x`` at the points (N, 3) (vorticity ``-G e_z``)."""
    u = np.zeros_like(np.asarray(points, float))
    u[:, 0] = rate * points[:, 1]
    return u


def solve_with_fluids(
    system: EnergySystem,
    fluid: FluidOperator,
    far: np.ndarray | None = None,
    node_force: np.ndarray | None = None,
) -> tuple[np.ndarray, float, np.ndarray]:
    """Velocity (N, 3), pressure and multipliers of ``system`` (a ``rayleigh_p1`` system with
    Cartesian unknowns) with the fluids' dissipation added: ``(K + D) v + F^T lambda = f + mu_out A S^-1 A u_inf
    + node_force``, ``G v = 0`` over the constraints but the rigid-body gauge (the medium fixes
    the rigid motions). Dense: one LU of the ``3N + m`` bordered matrix."""
    basis = system.basis
    if not (basis.shape[1] == 3 and np.array_equal(basis[0], np.eye(3))):
        raise SolverError("the fluids need the normal force balance (Cartesian unknowns), not a fixed normal velocity")
    keep = [k for k, name in enumerate(system.constraint_names) if not name.startswith("momentum")]
    g = system.constraints[keep]
    fr = g if system.force_rows is None else system.force_rows[keep]
    n3 = system.n_unknowns
    m = len(keep)
    kkt = np.zeros((n3 + m, n3 + m))
    kkt[:n3, :n3] = system.stiffness.toarray() + fluid.dissipation
    kkt[:n3, n3:] = fr.T
    kkt[n3:, :n3] = g
    rhs = np.zeros(n3 + m)
    rhs[:n3] = system.rhs
    if far is not None:
        rhs[:n3] += fluid.far_force(far)
    if node_force is not None:
        rhs[:n3] += np.asarray(node_force, float).ravel()
    sol = np.linalg.solve(kkt, rhs)
    lam = sol[n3:]
    pressure = 0.0
    names = [system.constraint_names[k] for k in keep]
    if system.pressure_index is not None:
        pressure = float(system.pressure_sign * lam[names.index(system.constraint_names[system.pressure_index])])
    return sol[:n3].reshape(-1, 3), pressure, lam
