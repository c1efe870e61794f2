r"""The force balance as the stationary point of the Rayleighian on curved quadratic cells
(formulation ``rayleigh_p2``): symmetric positive semidefinite by construction, third order.

The functional is ``rayleigh_p1``'s (:mod:`cortex_ti.physics.galerkin`),

.. math::
    \mathcal R[v] = \int \big[\eta_s\,|\tilde u|^2 + \tfrac{\eta_b}{2}(\mathrm{tr}\,u)^2\big]\,dA
      + \int \zeta\,\mathrm{tr}\,u\,dA - P\,\dot V[v] + \mathcal R_b[v],

discretised in another space: the surface is made of curved six-node cells
(:mod:`cortex_ti.surface.curved`: a mesh in the 1-to-4 split layout, every four flat triangles one
quadratic cell) and the velocity is quadratic on them, three Cartesian unknowns per node. Every
integral is taken with a Gauss rule on the curved cells.

**Why the normal velocity goes through the smooth normal.** The rate of strain of a surface
velocity ``v = v_t + v_n n`` is ``u = sym(P grad v_t P) + v_n C`` (conventions: ``C`` the
curvature tensor): the normal speed enters *without a derivative*, multiplied by the curvature.
On a sphere at t = 0 the bulk viscosity makes ``tr u`` follow the tension, so ``v_n`` is read off
``tr u / C``, and any error of the discrete curvature that ``u`` feels goes straight into
``v_n``, with no gain from Galerkin orthogonality. Interpolating the Cartesian velocity on the
cells makes that curvature the derivative of the interpolated normal field, one order worse
than the field itself: quadratic cells then converge at second order only (measured: 2.0e-2
and 5.2e-3 at 2562 and 10242 nodes on ``furrow_p8_a1``, worse than ``rayleigh_p1``'s 1.5e-2 and
3.9e-3; an established library's order-2 elements show the same, docs/validation/curved.md).
Here each node's velocity is split along its smooth normal ``n_i`` (the fitted surface's), and
the velocity field is

.. math:: v(x) = \sum_i N_i(x)\,P_i v_i + \Big(\sum_i N_i(x)\,n_i\cdot v_i\Big)\,n(x),

``P_i = I - n_i n_i^T`` and ``n(x)``, ``C(x)`` the smooth normal and curvature interpolated from
the nodes. Its rate of strain is ``u = sym(P sum_i (P_i v_i) grad N_i^T P) + v_n C``, with the
curvature that of the fitted surface instead of a derivative of the discretisation: the
t = 0 ring flows converge at third order (validation page). Whatever ``n`` and ``C``, ``u`` is
linear in the unknowns and the dissipation a sum of squares: the matrix is symmetric positive
semidefinite, so no mode can grow spuriously, as with ``rayleigh_p1``.

The terms of :mod:`cortex_ti.physics.terms` declare what they add in their ``rayleigh_p2``
method (:class:`~cortex_ti.physics.terms.P2Context`); this module integrates it: the viscosities
as ``int [2 eta_s u:u + (eta_b - eta_s) (tr u)^2] / 2 dA``, the tension's power ``int zeta tr u dA``
(``zeta`` interpolated quadratically from the cells' nodes), the normal forms
``1/2 int [B : grad v_n grad v_n + beta_0 v_n^2] dA`` (bending viscosity, the semi-implicit
tension; ``B`` clipped to its positive semidefinite part at each quadrature point), and the
constraint rows. The solution is the velocity at every node of the mesh.
"""

from __future__ import annotations

import numpy as np

from ..solve.system import EnergySystem
from ..surface.curved import CurvedSurface, curved_surface
from ..surface.geometry import Geometry
from .galerkin import block_pattern
from .model import Physics
from .terms import P2Context, terms_for
from .terms.base import check_inputs, constraint_names

__all__ = ["CHUNK", "assemble_p2", "cell_blocks", "strain_maps"]

#: cells per chunk of the per-cell integrals (bounds the memory of the strain maps, ~70 MB)
CHUNK = 2048


def strain_maps(surface: CurvedSurface, cells: slice) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For the cells ``cells``: the rate of strain of each unit nodal velocity (t, Q, 18, 3, 3), the
    normal speed it gives (t, Q, 18) and the tangential gradient of that speed (t, Q, 18, 3); the
    18 columns are (node, Cartesian component)."""
    g = surface.grads[cells]  # (t, Q, 6, 3)
    n = surface.qnormal[cells]
    c = surface.qcurvature[cells]
    ni = surface.normal[surface.cells[cells]]  # (t, 6, 3)
    t, q = g.shape[:2]
    proj = np.eye(3) - n[..., :, None] * n[..., None, :]
    proj_i = np.eye(3) - ni[..., :, None] * ni[..., None, :]
    tangential = np.einsum("tqab,tibc->tqica", proj, proj_i)  # [.., i, c, :] = P P_i e_c
    u = np.einsum("tqica,tqib->tqicab", tangential, g)
    u = 0.5 * (u + np.swapaxes(u, -1, -2))
    speed = np.einsum("qi,tic->tqic", surface.shape, ni)  # v_n of e_c at node i
    u += speed[..., None, None] * c[:, :, None, None]
    grad_speed = np.einsum("tqia,tic->tqica", g, ni)
    return u.reshape(t, q, 18, 3, 3), speed.reshape(t, q, 18), grad_speed.reshape(t, q, 18, 3)


def _psd(b: np.ndarray) -> np.ndarray:
    """The positive semidefinite part of symmetric 3x3 tensors (..., 3, 3)."""
    lam, vec = np.linalg.eigh(0.5 * (b + np.swapaxes(b, -1, -2)))
    return np.einsum("...ak,...k,...bk->...ab", vec, np.clip(lam, 0.0, None), vec)


def cell_blocks(ctx: P2Context) -> tuple[np.ndarray, np.ndarray]:
    """Per curved cell the (18, 18) second derivative of the dissipation and the (18,) force."""
    surf = ctx.surface
    ncell = surf.cells.shape[0]
    blocks = np.zeros((ncell, 18, 18))
    force = np.zeros((ncell, 18))
    zeta_q = None if ctx.tension is None else surf.at_quadrature(ctx.tension)
    forms = [(_psd(b), b0, None if r is None else r[surf.cells]) for b, b0, r in ctx.normal_forms]
    for start in range(0, ncell, CHUNK):
        s = slice(start, min(start + CHUNK, ncell))
        w = surf.weight[s]
        u, speed, grad_speed = strain_maps(surf, s)
        t, q = w.shape
        tr = np.trace(u, axis1=-2, axis2=-1)  # (t, Q, 18)
        flat = u.reshape(t, q, 18, 9)
        if ctx.shear:
            scaled = flat * (2.0 * ctx.shear * w)[:, :, None, None]
            blocks[s] += np.einsum("tqim,tqjm->tij", scaled, flat, optimize=True)
        if ctx.bulk != ctx.shear:
            blocks[s] += np.einsum("tq,tqi,tqj->tij", (ctx.bulk - ctx.shear) * w, tr, tr, optimize=True)
        if zeta_q is not None:
            force[s] -= np.einsum("tq,tqi->ti", w * zeta_q[s], tr)
        for bform, beta0, centre in forms:
            k = np.einsum("tq,tqia,tqab,tqjb->tij", w, grad_speed, bform[s], grad_speed, optimize=True)
            if beta0 is not None:
                k += np.einsum("tq,tqi,tqj->tij", w * beta0[s], speed, speed, optimize=True)
            blocks[s] += k
            if centre is not None:
                force[s] += np.einsum("tij,tj->ti", k, centre[s].reshape(len(k), 18))
    return blocks, force


def assemble_p2(
    geometry: Geometry,
    physics: Physics,
    zeta: np.ndarray,
    faces: np.ndarray,
    implicit_dt: float = 0.0,
    implicit_rate: np.ndarray | None = None,
) -> EnergySystem:
    """The Rayleighian system of the effects in ``physics`` on the curved cells of ``geometry``
    (module docstring); ``implicit_dt > 0``: the semi-implicit tension of a step of that length,
    centred on the nodes' rate ``implicit_rate`` (N, 3) when given. Its unknowns are the velocities
    of all the mesh's nodes (the cells' corners and midpoints)."""
    zeta = check_inputs(physics, zeta, implicit_dt)
    faces = np.asarray(faces)
    surf = curved_surface(geometry, faces)
    ctx = P2Context(
        geometry,
        physics,
        zeta,
        implicit_dt=float(implicit_dt),
        implicit_rate=implicit_rate,
        surface=surf,
        zeta_nodes=zeta,
    )
    terms = terms_for(ctx)
    for term in terms:
        term.rayleigh_p2(ctx)
    m = surf.n_nodes
    blocks, force = cell_blocks(ctx)
    pattern = block_pattern(surf.cells, m)
    kmat = pattern.matrix(blocks)
    f = np.bincount(pattern.dof.ravel(), weights=force.ravel(), minlength=3 * m)
    if ctx.node_force is not None:
        f = f + ctx.node_force.ravel()
    cons = np.concatenate([c.rows for c in ctx.constraints])
    force_rows = None
    if any(c.force_rows is not None for c in ctx.constraints):
        force_rows = np.concatenate([c.rows if c.force_rows is None else c.force_rows for c in ctx.constraints])
    offsets = np.cumsum([0] + [c.rows.shape[0] for c in ctx.constraints])
    pidx = next((int(offsets[k]) for k, c in enumerate(ctx.constraints) if c.pressure), None)
    if physics.normal_balance:
        basis = np.broadcast_to(np.eye(3), (m, 3, 3)).copy()
    else:  # v_n = 0: the tangent frames of the smooth normals at every node
        basis = _tangent_frames(surf.normal)
        bmat = _block_basis(basis)
        kmat = (bmat.T @ kmat @ bmat).tocsr()
        f = bmat.T @ f
    def on_unknowns(rows):
        return np.einsum("mnc,nbc->mnb", rows, basis).reshape(rows.shape[0], -1)

    return EnergySystem(
        stiffness=kmat,
        rhs=f,
        constraints=on_unknowns(cons),
        constraint_names=constraint_names(ctx.constraints),
        basis=basis,
        pressure_index=pidx,
        pressure_sign=-1.0,
        terms=[t.name for t in terms],
        force_rows=None if force_rows is None else on_unknowns(force_rows),
    )


def _tangent_frames(normal: np.ndarray) -> np.ndarray:
    """Orthonormal tangent pairs (M, 2, 3) perpendicular to unit normals (M, 3)."""
    helper = np.where(np.abs(normal[:, :1]) < 0.9, np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
    t1 = np.cross(normal, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return np.ascontiguousarray(np.stack([t1, np.cross(normal, t1)], axis=1))


def _block_basis(basis: np.ndarray):
    import scipy.sparse as sp

    m, nb, _ = basis.shape
    rows = (np.arange(m)[:, None, None] * 3 + np.arange(3)[None, None, :]).repeat(nb, axis=1)
    cols = (np.arange(m)[:, None, None] * nb + np.arange(nb)[None, :, None]).repeat(3, axis=2)
    return sp.csr_matrix((basis.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * m, nb * m))
