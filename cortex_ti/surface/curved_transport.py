r"""A density carried on the curved six-node cells (formulation ``rayleigh_p2``): quadratic Galerkin.

On a mesh in the split layout of :mod:`cortex_ti.surface.curved` every node is a node of a
quadratic cell, and the density ``c`` is the quadratic interpolant ``c_h = sum_j c_j N_j`` on the
isoparametric cells (the cells' map ``X(xi) = sum_k N_k(xi) x_k``). What the flat dual cells of
:mod:`cortex_ti.surface.transport` measure becomes here (derivation and the measured error of each
candidate: ``docs/derivations/curved_transport.md``):

* the **content** of a node, ``m_i = int N_i c_h dA = (M c)_i``, ``M`` the consistent mass on the
  curved cells: ``sum_i m_i = int c_h dA`` is the amount (``sum_i N_i = 1``), and it is what a time
  step keeps. No lumped mass: the quadratic corner functions integrate to about zero on a cell;
* the **dilution** is the change of ``M`` with the shape: a step stores ``M_old c_old + dt r`` and
  reads ``c`` back with the new shape's ``M``; the continuous-time rate (the spectrum) has
  ``dM/dt c = int N_i c_h div_h(w_h) dA`` (:func:`curved_mass_rate`), exact for the moving
  isoparametric cells since ``d(dA)/dt = div_h(w_h) dA``;
* the **transport** by the velocity relative to the mesh ``u = v - w``:
  ``dm_i/dt = int c_h u_h . grad_h N_i dA`` (:func:`curved_advective_rate`), the weak form of
  ``-div(c u)``; its sum over the nodes is zero (``sum_i grad_h N_i = 0``), so the amount is kept to
  round-off whatever the motion;
* **diffusion and turnover** backward Euler with the curved mass and stiffness,
  ``(M (1 + dt k) + dt D K) c = m + dt k c_* M 1`` (:func:`curved_implicit_diffusion_reaction`),
  ``K_ij = int grad_h N_i . grad_h N_j dA``.

``grad_h`` is the isoparametric surface gradient (along the cell itself), computed here in numpy
from the node positions alone (:func:`cell_quadrature`; the same cells and Gauss rule as
:class:`~cortex_ti.surface.curved.CurvedSurface`, without its fitted normals and curvature, which
the transport does not need): a time scheme measures a state's content on any shape it visits
without a geometry.

The Galerkin transport is central: without diffusion it neither damps nor limits (a sharp front
oscillates; the flat dual cells' limited upwind values do not), which the myosin scenes' diffusion
covers at the cell Peclet numbers they reach (the derivation page says when it would not).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .curved import GAUSS_POINTS, p2_cells, p2_shape, triangle_rule
from .mesh import per_connectivity

__all__ = [
    "CURVED",
    "FLAT",
    "cell_quadrature",
    "curved_mass",
    "curved_stiffness",
    "curved_mass_rate",
    "curved_content",
    "curved_advective_rate",
    "curved_implicit_diffusion_reaction",
]

#: the cells a density's content is measured on: the flat dual cells (rayleigh_p1, paper) or the
#: curved six-node cells (a formulation whose ``curved`` is set)
FLAT, CURVED = "flat", "curved"


def cell_quadrature(points: np.ndarray, faces: np.ndarray, gauss_points: int = GAUSS_POINTS):
    """``(cells, shape, weight, grads)`` of the isoparametric quadratic cells of the split mesh
    ``faces``: the cells (T, 6), the shape functions at the quadrature points (Q, 6), the area weights
    (T, Q) (rule weight times area element) and the isoparametric surface gradients of the shape
    functions (T, Q, 6, 3), ``grad_h N_k = g^ab d_b N_k a_a``.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(642)
    >>> _, _, weight, grads = cell_quadrature(m.points, m.faces)
    >>> float(weight.sum()) / (4 * np.pi) - 1                      # the cells' area: O(h^4) short of 4 pi
    -9.5...e-05
    >>> bool(np.abs(grads.sum(axis=2)).max() < 1e-12)             # sum_k grad_h N_k = 0
    True
    """
    points = np.ascontiguousarray(points, dtype=float)
    key = (points.tobytes(), np.asarray(faces).tobytes(), points.shape, gauss_points)  # the content, no hash alone
    if key not in _QUADRATURE:
        if len(_QUADRATURE) >= 4:  # a step visits a few shapes: keep those, not a run's
            _QUADRATURE.clear()
        _QUADRATURE[key] = _quadrature(points, faces, gauss_points)
    return _QUADRATURE[key]


#: the quadrature of the last few shapes (a step measures a state's content, its rate and its
#: implicit part on the same shape)
_QUADRATURE: dict = {}


def _quadrature(points: np.ndarray, faces: np.ndarray, gauss_points: int):
    cells = p2_cells(faces)
    q, rule = triangle_rule(gauss_points)
    shape, dshape = p2_shape(q)
    x = np.asarray(points, dtype=float)[cells]  # (T, 6, 3)
    # the tangent vectors a_1, a_2 (T, Q, 3) (tensordot: BLAS, where an einsum here takes 10x longer)
    a1 = np.tensordot(x, dshape[:, :, 0], axes=([1], [1])).transpose(0, 2, 1)
    a2 = np.tensordot(x, dshape[:, :, 1], axes=([1], [1])).transpose(0, 2, 1)
    g11, g12, g22 = (a1 * a1).sum(-1), (a1 * a2).sum(-1), (a2 * a2).sum(-1)
    det = g11 * g22 - g12 * g12
    weight = rule * np.sqrt(det)
    d1, d2 = dshape[None, :, :, 0], dshape[None, :, :, 1]  # (1, Q, 6)
    c1 = (g22[..., None] * d1 - g12[..., None] * d2) / det[..., None]  # g^1b d_b N_k (T, Q, 6)
    c2 = (g11[..., None] * d2 - g12[..., None] * d1) / det[..., None]
    grads = c1[..., None] * a1[:, :, None, :] + c2[..., None] * a2[:, :, None, :]
    return cells, shape, weight, grads


def _assemble(cells: np.ndarray, local: np.ndarray, n: int) -> sp.csr_matrix:
    rows = np.repeat(cells, 6, axis=1).ravel()
    cols = np.tile(cells, (1, 6)).ravel()
    return sp.csr_matrix((local.ravel(), (rows, cols)), shape=(n, n))


def curved_mass(points: np.ndarray, faces: np.ndarray, quad=None) -> sp.csr_matrix:
    """The consistent mass ``M_ij = int N_i N_j dA`` (N, N) on the curved cells (symmetric positive
    definite; its entries sum to the cells' area)."""
    cells, shape, weight, _ = quad if quad is not None else cell_quadrature(points, faces)
    local = np.einsum("tq,qi,qj->tij", weight, shape, shape)
    return _assemble(cells, local, len(points))


def curved_stiffness(points: np.ndarray, faces: np.ndarray, quad=None) -> sp.csr_matrix:
    """The stiffness ``K_ij = int grad_h N_i . grad_h N_j dA`` (N, N) on the curved cells (symmetric
    positive semidefinite, its rows summing to zero)."""
    cells, _, weight, grads = quad if quad is not None else cell_quadrature(points, faces)
    t, nq = weight.shape
    g = grads.transpose(0, 1, 3, 2).reshape(t, 3 * nq, 6)  # (T, Q*3, 6): batched BLAS, not einsum
    local = np.matmul(g.transpose(0, 2, 1), g * np.repeat(weight, 3, axis=1)[:, :, None])
    return _assemble(cells, local, len(points))


def curved_mass_rate(points: np.ndarray, faces: np.ndarray, w: np.ndarray, quad=None) -> sp.csr_matrix:
    """``dM/dt`` (N, N) when the nodes move with ``w`` (N, 3): ``int N_i N_j div_h(w_h) dA``, exact for
    the isoparametric cells (module docstring).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> rate = curved_mass_rate(m.points, m.faces, m.points)   # a uniform dilation x -> (1 + t) x
    >>> bool(abs(rate - 2.0 * curved_mass(m.points, m.faces)).max() < 1e-14)
    True
    """
    cells, shape, weight, grads = quad if quad is not None else cell_quadrature(points, faces)
    div = np.einsum("tqkc,tkc->tq", grads, np.asarray(w, dtype=float)[cells])
    local = np.einsum("tq,qi,qj->tij", weight * div, shape, shape)
    return _assemble(cells, local, len(points))


def curved_content(values: np.ndarray, points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The content ``M c`` (N,) of a density on the curved cells; its sum is ``int c_h dA``."""
    return curved_mass(points, faces) @ np.asarray(values, dtype=float)


def curved_advective_rate(values: np.ndarray, points: np.ndarray, faces: np.ndarray, u: np.ndarray, quad=None):
    """``dm_i/dt = int c_h u_h . grad_h N_i dA`` (N,): the rate of a density's content carried by the
    velocity relative to the mesh ``u`` (N, 3) (module docstring); it sums to zero.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> spin = np.cross([0.0, 0.0, 1.0], m.points)      # a rigid rotation about z
    >>> rate = curved_advective_rate(1.0 + m.points[:, 0], m.points, m.faces, spin)
    >>> bool(abs(rate.sum()) < 1e-14)
    True
    """
    cells, shape, weight, grads = quad if quad is not None else cell_quadrature(points, faces)
    c_q = weight * (shape @ np.asarray(values, dtype=float)[cells].T).T  # (T, Q): w c_h
    u_q = np.einsum("qk,tkc->tqc", shape, np.asarray(u, dtype=float)[cells])
    part = np.einsum("tqkc,tqc->tk", grads, c_q[:, :, None] * u_q)
    return np.bincount(cells.ravel(), weights=part.ravel(), minlength=len(points))


def curved_implicit_diffusion_reaction(
    content: np.ndarray,
    points: np.ndarray,
    faces: np.ndarray,
    dt: float,
    diffusion: float = 0.0,
    rate: float = 0.0,
    target: float = 0.0,
) -> np.ndarray:
    """The density on the shape ``points`` after the implicit part of a step ``dt`` from the content
    ``content`` (N,): ``(M (1 + dt k) + dt D K) c = m + dt k c_* M 1`` on the curved cells (``M c = m``
    without diffusion and turnover: the dilution)."""
    quad = cell_quadrature(points, faces)
    mass = curved_mass(points, faces, quad)
    lhs = mass * (1.0 + dt * rate)
    if diffusion:
        lhs = lhs + (dt * diffusion) * curved_stiffness(points, faces, quad)
    rhs = np.asarray(content, dtype=float)
    if rate:
        rhs = rhs + dt * rate * target * np.asarray(mass.sum(axis=1)).ravel()
    factor = per_connectivity(_FACTORS, faces, len(points), _factorization, keep=4)
    factor.factorize(lhs.tocsr())
    return factor.solve(rhs)


_FACTORS: dict = {}


def _factorization():
    """The solver's default sparse SPD factorisation (its symbolic analysis kept over a run: the
    pattern of the cells is the mesh's every step)."""
    from ..solve.factorizations import choose_factorization

    return choose_factorization("auto")()
