r"""Curved quadratic cells: the surface of formulation ``rayleigh_p2``.

A mesh for the curved cells is the 1-to-4 split of a coarser triangulation: each coarse triangle
``(a, b, c)`` with its edge midpoints ``ab, bc, ca`` is stored as the four flat triangles
``(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)``, consecutively (:func:`p2_cells` reads the
six-node cells back and refuses any other layout). Every icosphere from 42 nodes on is such a mesh
(its last subdivision), and :func:`split_mesh` makes one from any valid triangulation, placing the
new midpoints on the smooth surface the fits describe (each end's fitted Monge patch,
:attr:`~cortex_ti.surface.geometry.Geometry.height_poly`, evaluated over the straight midpoint, the
two averaged). So the run's nodes are all the cells' nodes: every field, output and mesh motion
works on them as on any mesh, and the flat triangles are the vertex view of the curved surface.

Each six-node cell is quadratic (isoparametric). Beside the cells' own geometry (their quadrature
points, area element, tangential gradients), the fits give at every node the smooth unit normal
``n`` and the curvature tensor as a 3x3 tangential tensor ``C = C^ab e_a (x) e_b`` (conventions:
``C_ab = -n . d_a d_b X``, so ``C = P / R`` on a sphere of radius R), interpolated to the quadrature
points with the same shape functions. Why the formulation needs that smooth normal and curvature,
and not the cells' own, is in :mod:`cortex_ti.physics.galerkin_p2`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from math import factorial

import numpy as np

from ..errors import MeshError
from .mesh import per_connectivity, split_faces

__all__ = [
    "GAUSS_POINTS",
    "NOT_SPLIT",
    "CurvedSurface",
    "curved_surface",
    "midpoint_mask",
    "node_curvature",
    "p2_cells",
    "p2_shape",
    "radon_rule",
    "split_mesh",
    "triangle_rule",
]

#: Gauss points per direction of the collapsed square on which the cells' fields (transport, bending
#: rigidity) are integrated: n^2 points, exact for polynomials of degree 2n - 2 on a flat cell (the
#: collapse adds one degree). For the dissipation, 3 gave the t = 0 ring flows of
#: benchmarks/t0_accuracy.py to the same three digits as 4 at 642-10242 nodes, 2 lost up to 3x
#: (docs/validation/curved.md). :func:`radon_rule` (degree 5 in 7 points) gave the same ring errors
#: in fewer points, but with it the two translation gauges' runs no longer differ by a translation to
#: round-off (1.3e-10 after 25 steps at 162 nodes, against 4.6e-16: some integral still uses this rule;
#: not found yet), so it is not the default
GAUSS_POINTS = 3


def triangle_rule(n: int = GAUSS_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Quadrature on the reference triangle ``{xi, eta >= 0, xi + eta <= 1}`` from an ``n x n`` Gauss
    rule on the square collapsed at one edge (Duffy): points (n^2, 2), weights (n^2,) summing to 1/2.

    >>> q, w = triangle_rule(3)
    >>> round(float(w.sum()), 15), round(float(w @ (q[:, 0] ** 2 * q[:, 1])), 15)  # 1/2 and 1/60
    (0.5, 0.016666666666667)
    """
    g, w = np.polynomial.legendre.leggauss(n)
    g, w = (g + 1.0) / 2.0, w / 2.0
    u, v = np.meshgrid(g, g, indexing="ij")
    wu, wv = np.meshgrid(w, w, indexing="ij")
    points = np.stack([u.ravel(), (v * (1.0 - u)).ravel()], axis=1)
    return points, (wu * wv * (1.0 - u)).ravel()


def radon_rule() -> tuple[np.ndarray, np.ndarray]:
    """Radon's seven-point rule on the reference triangle (Stroud T2:5-1), exact for polynomials of
    degree 5 (the 3 x 3 collapsed rule of :func:`triangle_rule` is exact to degree 4 only, in 9 points):
    a rule for the cells' dissipation (:func:`curved_surface` with ``rule=radon_rule()``; not its default,
    see :data:`GAUSS_POINTS`). Points (7, 2), weights summing to 1/2.
    On the t = 0 rings of ``furrow_p8_a1`` / ``furrow_p4_a3`` it gives the 3 x 3 rule's errors to
    1 % at 642 nodes and to 3 digits at 2562 (docs/validation/curved_cost.md).

    >>> q, w = radon_rule()
    >>> round(float(w.sum()), 15), round(float(w @ (q[:, 0] ** 3 * q[:, 1] ** 2)) * 420, 13)  # 1/2 and 1/420
    (0.5, 1.0)
    """
    r = np.sqrt(15.0)
    a, b = (6.0 - r) / 21.0, (6.0 + r) / 21.0
    points = np.array([[1 / 3, 1 / 3], [a, a], [1 - 2 * a, a], [a, 1 - 2 * a], [b, b], [1 - 2 * b, b], [b, 1 - 2 * b]])
    weights = np.array([9 / 40] + [(155.0 - r) / 1200.0] * 3 + [(155.0 + r) / 1200.0] * 3) / 2.0
    return points, weights


#: the cell's local edges, in the order of its nodes 3, 4, 5
CELL_EDGES = ((0, 1), (1, 2), (2, 0))


def p2_shape(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Quadratic Lagrange shape functions (Q, 6) and their reference derivatives (Q, 6, 2) at
    reference points (Q, 2); nodes 0-2 the corners, 3-5 the midpoints of edges 01, 12, 20.

    >>> n, dn = p2_shape(np.array([[0.5, 0.0], [1 / 3, 1 / 3]]))
    >>> (n[0].round(12) + 0.0).tolist(), float(n[1].sum()), float(abs(dn.sum(1)).max())
    ([0.0, 0.0, 0.0, 1.0, 0.0, 0.0], 1.0, 0.0)
    """
    xi, eta = points[:, 0], points[:, 1]
    lam = np.stack([1.0 - xi - eta, xi, eta], axis=1)
    dlam = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    n = np.empty((len(points), 6))
    dn = np.empty((len(points), 6, 2))
    for i in range(3):
        n[:, i] = lam[:, i] * (2.0 * lam[:, i] - 1.0)
        dn[:, i] = (4.0 * lam[:, i] - 1.0)[:, None] * dlam[i]
    for k, (a, b) in enumerate(CELL_EDGES):
        n[:, 3 + k] = 4.0 * lam[:, a] * lam[:, b]
        dn[:, 3 + k] = 4.0 * (lam[:, a][:, None] * dlam[b] + lam[:, b][:, None] * dlam[a])
    return n, dn


def p2_cells(faces: np.ndarray) -> np.ndarray:
    """The six-node cells (T/4, 6) of a mesh in the split layout (module docstring): corners, then the
    midpoints of edges ab, bc, ca; one :class:`~cortex_ti.errors.MeshError` for any other mesh.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> p2_cells(icosphere(42).faces).shape
    (20, 6)
    """
    f = np.asarray(faces)
    return per_connectivity(_CELL_CACHE, f, -1, lambda: _read_cells(f), keep=8)


_CELL_CACHE: dict = {}

#: what a mesh that is not in the split layout is told
NOT_SPLIT = (
    "formulation rayleigh_p2 runs on curved six-node cells, stored as the 1-to-4 split of a coarser mesh "
    "(an icosphere of at least 42 nodes, or a mesh file, which is split when the run starts)"
)


def _read_cells(f: np.ndarray) -> np.ndarray:
    if f.ndim != 2 or f.shape[1] != 3 or len(f) % 4:
        raise MeshError(f"{NOT_SPLIT}: {len(f)} triangles are not groups of four")
    g = f.reshape(-1, 4, 3)
    cells = np.stack([g[:, 0, 0], g[:, 1, 0], g[:, 2, 0], g[:, 0, 1], g[:, 1, 1], g[:, 2, 1]], axis=1)
    expect = np.stack([cells[:, [0, 3, 5]], cells[:, [1, 4, 3]], cells[:, [2, 5, 4]], cells[:, [3, 4, 5]]], axis=1)
    bad = np.flatnonzero(np.any(g != expect, axis=(1, 2)))
    if bad.size:
        raise MeshError(f"{NOT_SPLIT}: triangles {4 * bad[0]}-{4 * bad[0] + 3} are not one split cell")
    corners = np.unique(cells[:, :3])
    mids = np.unique(cells[:, 3:])
    if np.intersect1d(corners, mids).size:
        raise MeshError(f"{NOT_SPLIT}: a node is both a corner and a midpoint")
    return np.ascontiguousarray(cells)


def midpoint_mask(faces: np.ndarray, n_nodes: int) -> np.ndarray:
    """(N,) bool: the nodes of the split mesh ``faces`` that are the curved cells' edge midpoints (the
    others are their corners). ``rayleigh_p2`` fits the midpoints' surface through midpoints only
    (:class:`~cortex_ti.surface.fits.StencilChooser`, ``apart``; why: :mod:`cortex_ti.physics.galerkin_p2`).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> int(midpoint_mask(m.faces, 162).sum())     # 120 edges of the 42-node mesh
    120
    """
    mask = np.zeros(n_nodes, dtype=bool)
    mask[p2_cells(faces)[:, 3:].ravel()] = True
    return mask


def split_mesh(points: np.ndarray, faces: np.ndarray, geometry) -> tuple[np.ndarray, np.ndarray]:
    """The 1-to-4 split of a triangulation (its ``geometry`` from :func:`compute_geometry`) in the
    layout of :func:`p2_cells`: the nodes (the old ones first, then one per edge, placed on the fitted
    surface) and the triangles."""
    edges, split = split_faces(np.asarray(faces), len(points))
    straight = 0.5 * (points[edges[:, 0]] + points[edges[:, 1]])
    on_patches = 0.5 * (_patch_point(geometry, edges[:, 0], straight) + _patch_point(geometry, edges[:, 1], straight))
    return np.vstack([points, on_patches]), split


def _patch_point(geometry, vertex: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Vertex ``vertex[k]``'s fitted Monge patch over the point ``points[k]`` (projected on its
    tangent plane): ``x_v + xi e_xi + eta e_eta + h(xi, eta) n`` (K, 3), ``h`` the whole fitted
    polynomial."""
    frame = geometry.frame[vertex]
    exi, eeta, n0 = frame[:, 0], frame[:, 1], frame[:, 2]
    d = points - geometry.points[vertex]
    xi = np.einsum("kc,kc->k", d, exi)
    eta = np.einsum("kc,kc->k", d, eeta)
    coef = geometry.height_poly[vertex]
    h = sum(coef[:, t] * xi**a * eta**b / (factorial(a) * factorial(b)) for t, (a, b) in enumerate(geometry.fit_powers))
    return geometry.points[vertex] + xi[:, None] * exi + eta[:, None] * eeta + h[:, None] * n0


@dataclass
class CurvedSurface:
    """The curved six-node cells of one shape and what their integrals need (module docstring).

    ``cells`` (T, 6) into the mesh's ``nodes`` (M, 3); at every node the smooth ``normal`` (M, 3) and
    ``curvature`` (M, 3, 3); per cell and quadrature point: the area weight ``weight`` (T, Q) (rule
    weight times area element), the position ``qpoint`` (T, Q, 3), the cell's own unit normal
    ``cell_normal`` (T, Q, 3), the smooth normal ``qnormal`` (T, Q, 3) and curvature ``qcurvature``
    (T, Q, 3, 3) interpolated from the nodes, and ``grads`` (T, Q, 6, 3): the gradients of the
    shape functions along the cell, projected on the smooth tangent plane.
    """

    cells: np.ndarray
    nodes: np.ndarray
    normal: np.ndarray
    curvature: np.ndarray
    shape: np.ndarray  # (Q, 6)
    weight: np.ndarray
    qpoint: np.ndarray
    cell_normal: np.ndarray
    qnormal: np.ndarray
    qcurvature: np.ndarray
    grads: np.ndarray
    #: rigid_motion_rows by gauge (the constraints and the rigid projection both ask, once a solve)
    _rigid_rows: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    def at_quadrature(self, nodal: np.ndarray) -> np.ndarray:
        """A nodal field (M, ...) interpolated to the quadrature points (T, Q, ...)."""
        return np.einsum("qi,ti...->tq...", self.shape, nodal[self.cells])

    def node_integral(self, integrand: np.ndarray | None = None) -> np.ndarray:
        """``int N_i f dA`` for every node (M, ...), ``f`` given at the quadrature points (T, Q, ...)
        (none: ``f = 1``)."""
        t, nq = self.weight.shape
        if integrand is None:
            wf = self.weight[:, :, None]
        else:
            wf = (self.weight.reshape(t, nq, *([1] * (integrand.ndim - 2))) * integrand).reshape(t, nq, -1)
        part = np.matmul(self.shape.T, wf)  # (T, 6, K): sum_q N_i(q) w f
        rest = () if integrand is None else integrand.shape[2:]
        idx = self.cells.ravel()
        out = np.stack(
            [np.bincount(idx, weights=part[:, :, k].ravel(), minlength=self.n_nodes) for k in range(part.shape[2])],
            axis=-1,
        )
        return out.reshape((self.n_nodes,) + rest)

    @property
    def area(self) -> float:
        """The curved cells' area."""
        return float(self.weight.sum())

    def rigid_motion_rows(self, centroid_gauge: bool) -> np.ndarray:
        """Rows (6, M, 3) of the rigid-body gauge on the curved cells, integrated exactly (the
        velocity quadratic): zero total velocity ``int v dA = 0`` or, with ``centroid_gauge``, the
        enclosed volume's centroid held, ``int (x - x_c) (n . v) dA = 0`` with the cells' own normal (a
        rigid translation U moves it at U exactly); zero angular momentum ``int (x - x_c) x v dA = 0``,
        ``x_c`` the area centroid."""
        key = bool(centroid_gauge)
        if key not in self._rigid_rows:
            self._rigid_rows[key] = self._rigid_motion_rows(key)
        return self._rigid_rows[key].copy()

    def _rigid_motion_rows(self, centroid_gauge: bool) -> np.ndarray:
        mass = self.node_integral()
        first = self.node_integral(self.qpoint)
        centre = first.sum(0) / mass.sum()
        arm = first - mass[:, None] * centre
        rows = np.zeros((6, self.n_nodes, 3))
        eye = np.eye(3)
        rel = self.qpoint - centre
        for k in range(3):
            if centroid_gauge:
                rows[k] = self.node_integral(rel[..., k : k + 1] * self.cell_normal)
            else:
                rows[k, :, k] = mass
            rows[3 + k] = np.cross(eye[k], arm)
        return rows

    def cell_grads(self) -> np.ndarray:
        """(T, Q, 6, 3): the shape functions' gradients along the cell itself (in its own tangent
        plane, the isoparametric surface gradient), recovered from :attr:`grads` (their projection on
        the smooth tangent plane) by restoring the component along the smooth normal that makes them
        tangent to the cell: ``g + alpha n`` with ``alpha = -(g . n_c) / (n . n_c)`` (``n . n_c > 0``
        wherever the cell is valid)."""
        nc = self.cell_normal[:, :, None, :]
        n = self.qnormal[:, :, None, :]
        alpha = -np.einsum("tqic,tqic->tqi", self.grads, np.broadcast_to(nc, self.grads.shape))
        alpha = alpha / np.einsum("tqc,tqc->tq", self.qnormal, self.cell_normal)[:, :, None]
        return self.grads + alpha[..., None] * n

    def energy_gradient(self, zeta: np.ndarray) -> np.ndarray:
        r"""(M, 3): the exact gradient ``dE_h/dx_i`` of the discrete energy ``E_h = int zeta dA`` over
        the curved cells (``zeta`` (M,) carried by the nodes, interpolated with the shape functions;
        the integral with the cells' quadrature), ``int zeta grad_h N_i dA``: the derivative of the
        area element along a node's motion is the isoparametric surface divergence of ``N_i e_c``.
        Its sum over the nodes is zero and so is ``sum_i x_i x dE_h/dx_i`` (the energy does not
        change under a rigid motion): exactly, since ``sum_i grad_h N_i = 0`` and ``sum_i x_i (x)
        grad_h N_i`` is the cell's symmetric tangential projector."""
        zeta = np.asarray(zeta, dtype=float)
        w = self.weight * self.at_quadrature(zeta)
        part = np.einsum("tq,tqic->tic", w, self.cell_grads())
        out = np.zeros((self.n_nodes, 3))
        np.add.at(out, self.cells.ravel(), part.reshape(-1, 3))
        return out

    def volume_rows(self) -> np.ndarray:
        """(M, 3): ``int N_i n dA`` with the cells' own normal, the exact rate of the volume the curved
        cells enclose when their nodes move with ``v``."""
        return self.node_integral(self.cell_normal)

    def normal_rows(self) -> np.ndarray:
        """(M, 3): ``(int N_i dA) n_i`` with the smooth nodal normals: ``int v_n dA`` of the normal speed
        the formulation interpolates (:mod:`cortex_ti.physics.galerkin_p2`), along which a uniform
        pressure balances a uniform tension exactly."""
        return self.node_integral()[:, None] * self.normal


def node_curvature(geometry) -> np.ndarray:
    """The fitted curvature tensor of every node as a 3x3 tangential tensor ``C^ab e_a (x) e_b``
    (M, 3, 3) (``P / R`` on a sphere)."""
    gi = geometry.metric_inv
    cup = gi @ geometry.curvature @ gi
    e = geometry.tangents
    return np.ascontiguousarray(e.transpose(0, 2, 1) @ cup @ e)


def curved_surface(geometry, faces: np.ndarray, rule: tuple[np.ndarray, np.ndarray] | None = None) -> CurvedSurface:
    """The curved six-node cells of the shape ``geometry`` on the split triangulation ``faces`` (one
    Taichi kernel, :mod:`.curved_kernel`), integrated with ``rule`` (points, weights on the reference
    triangle; default :func:`triangle_rule`)."""
    from .curved_kernel import curved_quadrature_kernel  # starts Taichi

    cells = p2_cells(faces)
    nodes = np.ascontiguousarray(geometry.points, dtype=float)
    normal = np.ascontiguousarray(geometry.normal, dtype=float)
    curvature = np.ascontiguousarray(node_curvature(geometry))
    q, w = triangle_rule() if rule is None else rule
    shape, dshape = p2_shape(q)
    t, nq = len(cells), len(w)
    out = dict(
        weight=np.empty((t, nq)),
        qpoint=np.empty((t, nq, 3)),
        cell_normal=np.empty((t, nq, 3)),
        qnormal=np.empty((t, nq, 3)),
        qcurvature=np.empty((t, nq, 3, 3)),
        grads=np.empty((t, nq, 6, 3)),
    )
    curved_quadrature_kernel(
        nodes, normal, curvature, cells.astype(np.int32), shape, np.ascontiguousarray(dshape), w, *out.values()
    )
    bad = np.flatnonzero(~(out["weight"] > 0).all(axis=1))
    if bad.size:
        c = int(bad[0])
        raise MeshError(
            f"curved cell {c} (triangles {4 * c}-{4 * c + 3}) is inverted or folds over: its area element turns "
            f"against the fitted surface's normal ({bad.size} such cells; the mesh is too distorted for its curvature)"
        )
    return CurvedSurface(cells=cells, nodes=nodes, normal=normal, curvature=curvature, shape=shape, **out)
