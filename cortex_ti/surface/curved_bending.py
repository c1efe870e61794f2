r"""The Helfrich energy of the curved six-node cells and its exact gradient through the nodes.

The cells are those of :mod:`cortex_ti.surface.curved` (the quadratic isoparametric surface through
the mesh's nodes ``X``). The curvature is a mixed variable (Dziuk 2008; Barrett, Garcke, Nürnberg):
the quadratic vector field ``H_h`` with

.. math:: M(X)\,H_h = -L(X)\,X \qquad\text{(each Cartesian component)},

``M_ij = int N_i N_j dA`` and ``L_ij = int grad N_i . grad N_j dA`` on the cells, both taken with the
cells' quadrature. ``H_h`` approximates ``Lap X = -C n`` (``C = k1 + k2``, 2/R on a sphere), and the
discrete energy is

.. math:: E_h(X) = \frac{\kappa}{2}\Big[H_h^T M H_h + 2 c_0\, b^T H_h + c_0^2 A\Big],
   \qquad b_i = \int N_i\, n_h\, dA,

``n_h`` the cells' own unit normal and ``A`` their area: ``kappa/2 int (C - c0)^2 dA`` with
``|H|^2 + 2 c0 H . n + c0^2`` for ``(C - c0)^2``. Every integral is a sum over the quadrature points
of a function of ``J = dX/dxi`` (linear in the nodes) times the rule's weight, so its derivative
with respect to the nodes is exact; ``H_h`` enters through the solve, whose derivative costs one
adjoint: with ``Z = H_h + c0 Y``, ``M Y = b`` (a second solve with ``M`` when ``c0 != 0``),

.. math:: \frac{dE_h}{\kappa} = -\tfrac12 H^T dM\,H - c_0 Y^T dM\,H - Z^T dL\,X - Z^T L\,dX
   + c_0\, H^T db + \tfrac{c_0^2}{2}\, dA

(derivation: ``docs/derivations/bending_rigidity.md``, Sec. 7). The force on the nodes is
``-dE_h/dX``: the shape dynamics of :mod:`cortex_ti.physics.galerkin_p2` with it is a gradient flow
of ``E_h`` up to the time scheme's error. ``E_h`` does not change under rigid motions (zero net force
and torque, exactly) and, with ``c0 = 0``, under a scaling (``X . dE_h/dX = 0``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .curved import GAUSS_POINTS, p2_shape, triangle_rule

__all__ = ["BendingEnergy", "bending_energy", "cell_matrices"]


@dataclass
class BendingEnergy:
    """The discrete Helfrich energy of one shape (module docstring): ``energy``, the curvature vector
    ``curvature`` (M, 3) at the nodes (``H_h``, ``-C n`` on a sphere) and ``gradient`` (M, 3),
    ``dE_h/dX`` (the force on the nodes is minus it)."""

    energy: float
    curvature: np.ndarray
    gradient: np.ndarray


def _jacobians(points: np.ndarray, cells: np.ndarray, dshape: np.ndarray):
    """``J`` (T, Q, 3, 2), the metric's inverse (T, Q, 2, 2) and ``sqrt det J^T J`` (T, Q)."""
    jac = np.einsum("qia,tic->tqca", dshape, points[cells])
    metric = np.einsum("tqca,tqcb->tqab", jac, jac)
    det = metric[..., 0, 0] * metric[..., 1, 1] - metric[..., 0, 1] ** 2
    inv = np.empty_like(metric)
    inv[..., 0, 0] = metric[..., 1, 1] / det
    inv[..., 1, 1] = metric[..., 0, 0] / det
    inv[..., 0, 1] = inv[..., 1, 0] = -metric[..., 0, 1] / det
    return jac, inv, np.sqrt(det)


def _assemble(cells: np.ndarray, local: np.ndarray, n: int) -> sp.csr_matrix:
    rows = np.repeat(cells, 6, axis=1).ravel()
    cols = np.tile(cells, (1, 6)).ravel()
    return sp.csr_matrix((local.ravel(), (rows, cols)), shape=(n, n))


def cell_matrices(points: np.ndarray, cells: np.ndarray, gauss_points: int = GAUSS_POINTS):
    """``(M, L)``: the mass and Laplace-Beltrami stiffness matrices (M, M sparse) of the quadratic
    cells through ``points``.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> from cortex_ti.surface.curved import p2_cells
    >>> m = icosphere(162)
    >>> mass, stiff = cell_matrices(m.points, p2_cells(m.faces))
    >>> abs(float(mass.sum()) - 4 * np.pi) < 0.02, float(abs(stiff @ np.ones(162)).max()) < 1e-12
    (True, True)
    """
    return _matrices(np.asarray(points, dtype=float), np.asarray(cells), gauss_points)[2:]


def _matrices(x: np.ndarray, cells: np.ndarray, gauss_points: int):
    """The rule (weights, shape functions, derivatives), ``J``, ``G^-1``, ``sqrt g`` and ``(M, L)``."""
    q, w = triangle_rule(gauss_points)
    shape, dshape = p2_shape(q)
    jac, inv, sq = _jacobians(x, cells, dshape)
    wq = w * sq
    n = len(x)
    mass = _assemble(cells, np.einsum("tq,qi,qj->tij", wq, shape, shape), n)
    stiff = _assemble(cells, np.einsum("tq,qia,tqab,qjb->tij", wq, dshape, inv, dshape), n)
    return (w, shape, dshape), (jac, inv, sq), mass, stiff


def bending_energy(
    points: np.ndarray,
    cells: np.ndarray,
    kappa: float,
    c0: float = 0.0,
    gauss_points: int = GAUSS_POINTS,
    gradient: bool = True,
) -> BendingEnergy:
    """The discrete Helfrich energy ``E_h`` of the quadratic cells ``cells`` (T, 6) through ``points``
    (M, 3), its curvature vector and (``gradient``) its exact gradient (module docstring).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> from cortex_ti.surface.curved import p2_cells
    >>> m = icosphere(642)
    >>> e = bending_energy(m.points, p2_cells(m.faces), kappa=1.0)
    >>> abs(e.energy / (8 * np.pi) - 1) < 1e-3   # 8 pi kappa for any sphere
    True
    >>> float(abs((m.points * e.gradient).sum())) < 1e-12   # nor does a scaling change it (c0 = 0)
    True
    """
    x = np.asarray(points, dtype=float)
    cells = np.asarray(cells)
    (w, shape, dshape), (jac, inv, sq), mass, stiff = _matrices(x, cells, gauss_points)
    wq = w * sq
    n = len(x)
    solve = spla.factorized(mass.tocsc())
    lx = stiff @ x
    h = np.column_stack([solve(-lx[:, c]) for c in range(3)])
    # the cells' area vector J1 x J2 (unit normal times the area element) at every quadrature point
    area_vec = np.cross(jac[..., 0], jac[..., 1])
    hq = np.einsum("qi,tic->tqc", shape, h[cells])
    energy = float((h * (mass @ h)).sum())
    if c0:
        b = np.zeros((n, 3))
        np.add.at(b, cells.ravel(), np.einsum("q,qi,tqc->tic", w, shape, area_vec).reshape(-1, 3))
        energy += 2.0 * c0 * float((b * h).sum()) + c0 * c0 * float(wq.sum())
    energy *= 0.5 * kappa
    if not gradient:
        return BendingEnergy(energy, h, np.zeros_like(x))
    y = np.column_stack([solve(b[:, c]) for c in range(3)]) if c0 else np.zeros_like(x)
    z = h + c0 * y
    yq = np.einsum("qi,tic->tqc", shape, y[cells])
    # d/dJ of the integrand at every quadrature point (T, Q, 3, 2), then through dJ = sum_k dX_k dN_k
    jginv = np.einsum("tqca,tqab->tqcb", jac, inv)  # J G^-1: d sqrt(g)/dJ per sqrt(g)
    scalar = -0.5 * np.einsum("tqc,tqc->tq", hq, hq) - c0 * np.einsum("tqc,tqc->tq", yq, hq) + 0.5 * c0 * c0
    dj = (scalar * sq)[..., None, None] * jginv
    a = np.einsum("qia,tic->tqca", dshape, z[cells])  # dZ/dxi
    aginv = np.einsum("tqca,tqab->tqcb", a, inv)
    div = np.einsum("tqca,tqca->tq", aginv, jac)  # tr(A G^-1 J^T)
    bsym = np.einsum("tqca,tqcb->tqab", jginv, aginv)  # G^-1 J^T A G^-1
    bsym = bsym + np.swapaxes(bsym, -1, -2)
    dj -= sq[..., None, None] * (div[..., None, None] * jginv - np.einsum("tqca,tqab->tqcb", jac, bsym))
    if c0:
        dj[..., 0] += c0 * np.cross(jac[..., 1], hq)
        dj[..., 1] += c0 * np.cross(hq, jac[..., 0])
    part = np.einsum("q,tqca,qia->tic", w, dj, dshape)
    grad = np.zeros((n, 3))
    np.add.at(grad, cells.ravel(), part.reshape(-1, 3))
    grad -= stiff @ z
    return BendingEnergy(energy, h, kappa * grad)
