r"""The force balance as the stationary point of the discrete Rayleighian on the flat triangles
(formulation ``rayleigh_p1``): symmetric positive semidefinite by construction.

The paper's model is a gradient flow: the velocity makes the Rayleighian stationary,

.. math::
    \mathcal R[v] = \int \big[\eta_s\,|\tilde u|^2 + \tfrac{\eta_b}{2}(\mathrm{tr}\,u)^2\big]\,dA
      + \int \zeta\,\mathrm{tr}\,u\,dA - P\,\dot V[v] + \mathcal R_b[v],

``u`` the surface strain rate, ``u~`` its traceless part (so the stress is
``t = 2 eta_s u~ + eta_b tr u g``), ``P`` the multiplier of the volume constraint and ``R_b``
the bending viscosity. Its stationarity conditions are the weak form of the force balance the
paper solves in strong form by least squares (:mod:`cortex_ti.physics.assembly`).

Here the velocity is interpolated linearly on each flat triangle ``T`` and every term is
integrated exactly over the triangles. Each term of :mod:`cortex_ti.physics.terms` says what it
adds in its method ``rayleigh_p1`` (:class:`~cortex_ti.physics.terms.P1Context`), and
:func:`assemble_p1` loops over the terms of the enabled effects and turns what they add into
one system:

* **dissipation**: the in-plane viscosities give ``sum_T A_T [eta_s |U~_T|^2 + eta_b/2 (tr U_T)^2]``,
  ``U_T = (P G + G^T P)/2``, ``G = sum_k v_k (x) grad psi_k`` the in-plane gradient of the
  linear velocity, ``P = I - n_T n_T^T``: a symmetric positive semidefinite ``K`` whose kernel
  on a closed mesh is the rigid motions and nothing else (no hourglass modes, no penalty)
  (:func:`viscous_blocks`, from the viscous terms); the dissipations in the gradient of the
  normal speed ``1/2 int B^cd d_c v_n d_d v_n dA`` (bending viscosity, semi-implicit tension),
  summed, then integrated per triangle with ``B`` averaged over the corners, projected on the
  triangle and clipped to its positive semidefinite part (:func:`normal_blocks`); a lumped
  drag ``1/2 sum_k A_k beta_k v_n,k^2``; any further per-triangle blocks a term gives;
* **power of the forces** (the active tension's): per-triangle forces summed into the nodes;
* **constraints**, each with a multiplier (the rigid-body gauge, the volume whose multiplier is
  the pressure, :mod:`cortex_ti.physics.terms.constraints` and its ``numerics.pressure_weights``).

The fits (:mod:`cortex_ti.surface.geometry`) give only the normals (the direction of ``v_n``
and of the advection) and the curvature of the bending term. What this formulation pays is the
accuracy of a flat-triangle geometry: second order, where the paper's quartic fit reaches
fourth on smooth shapes.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..solve.system import EnergySystem
from ..surface.geometry import Geometry
from ..surface.mesh import per_connectivity
from ..surface.transport import triangle_gradients  # the flat triangles' P1 gradients (one definition)
from .model import Physics
from .p1_blocks import normal_blocks, normal_form_force, viscous_blocks
from .terms import P1Context, terms_for
from .terms.active import ACTIVE_FORCES
from .terms.base import check_inputs, constraint_names, velocity_basis
from .terms.constraints import PRESSURE_WEIGHTS

__all__ = [
    "PRESSURE_WEIGHTS",
    "assemble_p1",
    "block_pattern",
    "energy_system",
    "normal_blocks",
    "normal_form_force",
    "triangle_gradients",
    "viscous_blocks",
]


class _Pattern:
    """CSR structure of a (3N, 3N) matrix assembled from per-cell blocks (9x9 for a triangle's
    three nodes, 18x18 for a curved cell's six) and the position of every block entry in its data
    array (the connectivity is fixed over a run)."""

    def __init__(self, faces: np.ndarray, n_nodes: int):
        k = 3 * faces.shape[1]
        dof = (faces[:, :, None] * 3 + np.arange(3)[None, None, :]).reshape(-1, k)
        rows = np.broadcast_to(dof[:, :, None], (len(faces), k, k)).ravel()
        cols = np.broadcast_to(dof[:, None, :], (len(faces), k, k)).ravel()
        size = 3 * n_nodes
        key = rows.astype(np.int64) * size + cols
        uniq, self.position = np.unique(key, return_inverse=True)
        self.indices = (uniq % size).astype(np.int32)
        self.indptr = np.searchsorted(uniq // size, np.arange(size + 1)).astype(np.int32)
        self.shape = (size, size)
        self.nnz = uniq.size
        self.dof = dof

    def matrix(self, local: np.ndarray) -> sp.csr_matrix:
        data = np.bincount(self.position, weights=local.ravel(), minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=self.shape)


_PATTERNS: dict = {}


def block_pattern(faces: np.ndarray, n_nodes: int) -> _Pattern:
    """The block pattern of a connectivity, computed once (a few kept)."""
    return per_connectivity(_PATTERNS, faces, n_nodes, lambda: _Pattern(faces, n_nodes), keep=8)


def _lumped_normal(geometry: Geometry, beta0: np.ndarray) -> sp.csr_matrix:
    """``sum_k A_k beta_0,k (n_k . v_k)^2`` as a (3N, 3N) block-diagonal matrix."""
    n, nrm = geometry.n_nodes, geometry.normal
    nn = (beta0 * geometry.area)[:, None, None] * nrm[:, :, None] * nrm[:, None, :]
    r = np.repeat(np.arange(n)[:, None] * 3 + np.arange(3)[None, :], 3, axis=1).reshape(n, 3, 3)
    return sp.csr_matrix((nn.ravel(), (r.ravel(), r.transpose(0, 2, 1).ravel())), shape=(3 * n, 3 * n))


def assemble_p1(
    geometry: Geometry,
    physics: Physics,
    zeta: np.ndarray,
    faces: np.ndarray,
    implicit_dt: float = 0.0,
    pressure_weights: str = "petrov",
    active_force: str = "balanced",
    implicit_rate: np.ndarray | None = None,
    implicit_weight: float = 1.0,
) -> EnergySystem:
    """The Rayleighian system of the effects in ``physics`` on the shape ``geometry`` (module
    docstring): the ``rayleigh_p1`` method of each of their terms, then one matrix;
    ``implicit_dt > 0``: the semi-implicit tension of a step of that length, acting on the change
    of the normal velocity from the nodes' rate ``implicit_rate`` (N, 3) when given, its drag
    times ``implicit_weight`` (:mod:`cortex_ti.physics.terms.implicit_tension`)."""
    if pressure_weights not in PRESSURE_WEIGHTS:
        raise SolverError(f"unknown pressure_weights {pressure_weights!r}: choose one of {', '.join(PRESSURE_WEIGHTS)}")
    if active_force not in ACTIVE_FORCES:
        raise SolverError(f"unknown active_force {active_force!r}: choose one of {', '.join(ACTIVE_FORCES)}")
    zeta = check_inputs(physics, zeta, implicit_dt)
    n = geometry.n_nodes
    faces = np.asarray(faces)
    area, tnormal, grads = triangle_gradients(geometry.points, faces)
    ctx = P1Context(
        geometry,
        physics,
        zeta,
        implicit_dt=float(implicit_dt),
        implicit_rate=implicit_rate,
        implicit_weight=float(implicit_weight),
        faces=faces,
        area=area,
        tnormal=tnormal,
        grads=grads,
        pressure_weights=pressure_weights,
        active_force=active_force,
    )
    terms = terms_for(ctx)
    for term in terms:
        term.rayleigh_p1(ctx)

    pattern = block_pattern(faces, n)
    local = viscous_blocks(area, tnormal, grads, ctx.shear, ctx.bulk)
    if ctx.normal_form is not None:
        local = local + normal_blocks(geometry, faces, ctx.normal_form, tnormal, grads, area)
    if ctx.blocks is not None:
        local = local + ctx.blocks
    kmat = pattern.matrix(local)
    if ctx.normal_drag is not None and np.any(ctx.normal_drag):
        kmat = (kmat + _lumped_normal(geometry, ctx.normal_drag)).tocsr()
    f = np.zeros(3 * n)
    if ctx.triangle_force is not None:
        f = np.bincount(pattern.dof.ravel(), weights=ctx.triangle_force.ravel(), minlength=3 * n)
    if ctx.node_force is not None:
        f = f + ctx.node_force.ravel()

    system = energy_system(kmat, f, ctx.constraints, velocity_basis(geometry, physics), terms)
    system.dense = ctx.dense
    system.fluid_operator = ctx.fluid_operator
    return system


def energy_system(kmat, f: np.ndarray, constraints: list, basis: np.ndarray, terms) -> EnergySystem:
    """The :class:`EnergySystem` of a Rayleighian formulation from its Cartesian matrix and force (3 per
    node), its constraints (rows, force rows, the pressure's) and the velocity basis (N, nb, 3): with
    tangential unknowns only (``nb = 2``) the matrix, force and rows are taken onto the basis."""
    n = basis.shape[0]
    cons = np.concatenate([c.rows for c in constraints])
    force = None
    if any(c.force_rows is not None for c in constraints):
        force = np.concatenate([c.rows if c.force_rows is None else c.force_rows for c in constraints])
    offsets = np.cumsum([0] + [c.rows.shape[0] for c in constraints])
    pidx = next((int(offsets[k]) for k, c in enumerate(constraints) if c.pressure), None)
    cartesian = basis.shape[1] == 3 and np.array_equal(basis[0], np.eye(3))
    if basis.shape[1] != 3:  # tangential unknowns only (fixed_normal_velocity)
        bmat = sp.block_diag([basis[i].T for i in range(n)], format="csr")  # (3N, nb N)
        kmat = (bmat.T @ kmat @ bmat).tocsr()
        f = bmat.T @ f

    def on_unknowns(rows):
        if cartesian:
            return rows.reshape(rows.shape[0], -1)
        return np.einsum("mnc,nbc->mnb", rows, basis).reshape(rows.shape[0], -1)

    return EnergySystem(
        stiffness=kmat,
        rhs=f,
        constraints=on_unknowns(cons),
        constraint_names=constraint_names(constraints),
        basis=basis,
        pressure_index=pidx,
        pressure_sign=-1.0,
        terms=[t.name for t in terms],
        force_rows=None if force is None else on_unknowns(force),
    )
