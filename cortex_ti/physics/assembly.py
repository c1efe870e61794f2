r"""Compose the terms the effects call for into one sparse least-squares system.

The discrete force balance (paper Eqs. 34, 38) is the overdetermined linear system

.. math::  M x + p\,P \approx r, \qquad G x = 0

with ``x`` the velocity unknowns, ``P`` the pressure (only with the
``incompressibility`` effect; ``p`` is -1 on the normal rows) and ``G`` the dense
constraint rows. With the ``fixed_normal_velocity`` effect the normal rows are not
assembled and the velocity of node ``i`` is written ``v_i = u_1 e_xi + u_2 e_eta``,
so ``v_n = 0`` holds exactly and the unknowns are the two tangential components;
otherwise the unknowns are the Cartesian components.

:func:`assemble` runs the ``paper`` method of the terms of the enabled effects
(:func:`cortex_ti.physics.terms.terms_for`); the geometry-dependent weights of every term are
summed first and turned into matrix entries by one
Taichi kernel (:func:`_scatter_kernel`), writing COO triplets that SciPy converts
to CSR.
"""

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..runtime import f64_1, f64_2, f64_3, f64_4, i32_1, i32_2, kernel, ti
from ..solve.system import LinearSystem
from ..surface.geometry import Geometry
from .model import Physics
from .terms import PaperContext, terms_for
from .terms.base import check_inputs, constraint_names, velocity_basis

__all__ = ["assemble", "check_inputs", "velocity_basis", "fit_residual_rows"]

i64_1 = ti.types.ndarray(dtype=ti.i64, ndim=1)


@ti.func
def _emit(rows: ti.template(), cols: ti.template(), vals: ti.template(), basis: ti.template(), base, row, node, coef):
    for b in range(basis.shape[1]):
        bv = ti.Vector([basis[node, b, 0], basis[node, b, 1], basis[node, b, 2]])
        rows[base + b] = row
        cols[base + b] = node * basis.shape[1] + b
        vals[base + b] = coef.dot(bv)


@kernel
def _scatter_kernel(
    stencil: i32_2,
    ssize: i32_1,
    fit: f64_3,
    normal: f64_2,
    basis: f64_3,
    W: f64_4,
    W0: f64_3,
    Wn: f64_3,
    Wn0: f64_2,
    offsets: i64_1,
    rows: i64_1,
    cols: i64_1,
    vals: f64_1,
):
    """Row r of node i: sum_k W[k] . V_k + W0 . v_i + sum_k Wn[k] d_k v_n + Wn0 v_n,i,
    with V_k = sum_a F[k, a] (v_a - v_i) and d_k v_n = sum_a F[k, a] (n_a . v_a - n_i . v_i).
    Slot 0 of each row holds node i, slot j > 0 the stencil node j - 1."""
    nrow = W.shape[1]
    for i in range(stencil.shape[0]):
        s = ssize[i]
        ni = ti.Vector([normal[i, 0], normal[i, 1], normal[i, 2]])
        for r in range(nrow):
            center = ti.Vector([W0[i, r, 0], W0[i, r, 1], W0[i, r, 2]]) + Wn0[i, r] * ni
            row_base = offsets[i] + r * (s + 1) * basis.shape[1]
            for j in range(s):
                a = stencil[i, j]
                cv = ti.Vector([0.0, 0.0, 0.0])
                cn = 0.0
                for k in ti.static(range(5)):
                    f = fit[i, k, j]
                    cv += f * ti.Vector([W[i, r, k, 0], W[i, r, k, 1], W[i, r, k, 2]])
                    cn += f * Wn[i, r, k]
                na = ti.Vector([normal[a, 0], normal[a, 1], normal[a, 2]])
                center -= cv + cn * ni
                _emit(rows, cols, vals, basis, row_base + (j + 1) * basis.shape[1], i * nrow + r, a, cv + cn * na)
            _emit(rows, cols, vals, basis, row_base, i * nrow + r, i, center)


def fit_residual_rows(geometry: Geometry, basis: np.ndarray, weight: float, eta_s: float) -> sp.csr_matrix:
    r"""Rows that ask the velocity to be locally what the fits assume: a Taylor polynomial.

    The force balance sees the velocity only through each node's fitted derivatives; a
    pattern the local fit does not reproduce (its residual ``(I - D F)(v_a - v_i)`` on the
    stencil) is invisible to it, and on coarse or sheared meshes such patterns couple to the
    normal motion as spurious modes that grow (:func:`cortex_ti.dynamics.spectrum.normal_spectrum`
    measures them: largest Re lambda = +1.2e5 /t_a for a uniform tension on a 642-node sphere).
    They shift those modes but do not remove them (with the rows at 1e-3, 287 modes still grow,
    the largest +862): formulation ``rayleigh_p1`` has none to remove. These rows
    add ``weight * eta_s^2 / h_i^4 * |(I - D F)(v_a - v_i)|^2`` to the least squares, per node and
    Cartesian component, ``h_i`` the node's mean edge length, i.e. the same scale as the force
    rows. They vanish for any velocity the fit reproduces exactly, so the discretisation stays
    consistent (the residual of a smooth field is O(h^3)). Since ``I - D F`` is a projector,
    the penalty uses an orthonormal basis ``Q`` of its range: ``S - P`` rows per node and
    component instead of ``S`` (one for a valence-6 node and the quadratic fit).
    """
    res = geometry.fit_residual
    if res is None:
        raise SolverError("fit-residual rows need the geometry computed with residual=True")
    n, smax, _ = res.shape
    w_eig, vec = np.linalg.eigh(res)  # ascending; the range has eigenvalue 1
    k = int((w_eig > 0.5).sum(axis=1).max()) if n else 0
    if k == 0 or weight <= 0.0:
        return sp.csr_matrix((0, n * basis.shape[1]))
    q = vec[:, :, smax - k :] * (w_eig[:, None, smax - k :] > 0.5)  # (N, S, k), zero where absent
    scale = np.sqrt(weight) * eta_s / geometry.edge_length**2  # (N,)
    q = q * scale[:, None, None]
    nb = basis.shape[1]
    st = geometry.stencil
    valid = st >= 0
    nodes = np.where(valid, st, 0)
    # rows (i, k, c); columns: the stencil nodes and the node itself, each with nb unknowns
    row = (np.arange(n)[:, None, None] * k + np.arange(k)[None, :, None]) * 3 + np.arange(3)[None, None, :]  # (N,k,3)
    nbr_val = np.einsum("nsk,nsbc->nkcsb", q * valid[:, :, None], basis[nodes])  # (N,k,3,S,nb)
    nbr_col = nodes[:, :, None] * nb + np.arange(nb)[None, None, :]  # (N,S,nb)
    ctr_val = -np.einsum("nk,nbc->nkcb", q.sum(axis=1), basis)  # (N,k,3,nb)
    ctr_col = np.arange(n)[:, None] * nb + np.arange(nb)[None, :]  # (N,nb)
    rows = np.concatenate(
        [
            np.broadcast_to(row[..., None, None], nbr_val.shape).ravel(),
            np.broadcast_to(row[..., None], ctr_val.shape).ravel(),
        ]
    )
    cols = np.concatenate(
        [
            np.broadcast_to(nbr_col[:, None, None], nbr_val.shape).ravel(),
            np.broadcast_to(ctr_col[:, None, None, :], ctr_val.shape).ravel(),
        ]
    )
    vals = np.concatenate([nbr_val.ravel(), ctr_val.ravel()])
    keep = vals != 0.0
    return sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n * k * 3, n * nb))


def assemble(
    geometry: Geometry, physics: Physics, zeta: np.ndarray, fit_residual_weight: float = 0.0, implicit_dt: float = 0.0
) -> LinearSystem:
    """Build the least-squares system of the effects in ``physics`` on this shape.

    ``fit_residual_weight > 0`` appends the rows of :func:`fit_residual_rows`;
    ``implicit_dt > 0`` evaluates the active tension's curvature at the end of a step of
    that length (:mod:`cortex_ti.physics.terms.implicit_tension`).
    """
    zeta = check_inputs(physics, zeta, implicit_dt)
    ctx = PaperContext(geometry, physics, zeta, implicit_dt=float(implicit_dt))
    terms = terms_for(ctx)
    for term in terms:
        term.paper(ctx)
    n, nrow = geometry.n_nodes, physics.rows_per_node
    basis = velocity_basis(geometry, physics)
    nb = basis.shape[1]
    per_node = nrow * (geometry.stencil_size.astype(np.int64) + 1) * nb
    offsets = np.zeros(n, dtype=np.int64)
    np.cumsum(per_node[:-1], out=offsets[1:])
    nnz = int(per_node.sum())
    rows = np.empty(nnz, dtype=np.int64)
    cols = np.empty(nnz, dtype=np.int64)
    vals = np.empty(nnz)
    _scatter_kernel(
        geometry.stencil,
        geometry.stencil_size,
        geometry.fit,
        geometry.normal,
        basis,
        ctx.W,
        ctx.W0,
        ctx.Wn,
        ctx.Wn0,
        offsets,
        rows,
        cols,
        vals,
    )
    rhs = ctx.rhs
    if physics.normal_balance:
        # Row equilibration: the tangential rows hold second derivatives (~1/h^2), the
        # normal row first derivatives (~1/h). Scaling the normal row by 1/h_i gives both
        # the same weight in the least squares; the (nearly consistent) solution is
        # unchanged but spurious modes of wide stencils are suppressed and the
        # conditioning improves by ~1/h.
        weight = np.ones((n, nrow))
        weight[:, 2] = 1.0 / geometry.edge_length
        vals *= weight.ravel()[rows]
        rhs = rhs * weight
    matrix = sp.csr_matrix((vals, (rows, cols)), shape=(n * nrow, n * nb))
    pcol = None
    if ctx.pressure:
        pcol = np.zeros(n * nrow)
        pcol[2::nrow] = -1.0 / geometry.edge_length
    rhs = rhs.ravel()
    row_node = np.repeat(np.arange(n), nrow)
    if fit_residual_weight > 0.0:
        extra = fit_residual_rows(geometry, basis, fit_residual_weight, physics.eta_s)
        row_node = np.concatenate([row_node, np.arange(extra.shape[0]) // (extra.shape[0] // n)])
        matrix = sp.vstack([matrix, extra], format="csr")
        rhs = np.concatenate([rhs, np.zeros(extra.shape[0])])
        if pcol is not None:
            pcol = np.concatenate([pcol, np.zeros(extra.shape[0])])
    if ctx.constraints:
        dense = np.concatenate([c.rows for c in ctx.constraints], axis=0)
        gmat = np.einsum("mnc,nbc->mnb", dense, basis).reshape(dense.shape[0], -1)
    else:
        gmat = np.zeros((0, n * nb))
    names = constraint_names(ctx.constraints)
    return LinearSystem(
        matrix=matrix,
        rhs=rhs,
        pressure_column=pcol,
        constraints=gmat,
        constraint_names=names,
        basis=basis,
        terms=[t.name for t in terms],
        row_node=row_node,
    )
