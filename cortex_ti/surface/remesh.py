r"""Remeshing a closed triangulated surface: new triangles, the same surface, volume and amounts.

:func:`remesh` hands the surface to MMG's surface remesher (``mmgs``, through the ``mmgpy``
bindings of the ``remesh`` extra): edge splits, collapses, flips and vertex smoothing towards an
isotropic size field, with the new nodes kept within a Hausdorff distance ``hausd`` of the old
surface. Around it, this module does what MMG does not know about:

* the **size field**: ``h_i = clip(s / kappa_i, h_min, h_max)`` with ``kappa_i`` the
  largest normal curvature along the edges at node ``i`` (:func:`edge_curvature`), so that a circle
  of curvature ``kappa`` gets about ``2 pi / s`` edges (a furrow's neck stays resolved). With a
  **node budget** (``RemeshOptions.nodes``) the scale ``s`` is chosen so that the predicted node
  count of the new mesh, ``sum_i A_i 2 / (sqrt(3) h_i^2)`` over the dual areas with the field graded
  as MMG grades it (:func:`grade`), is the budget (:func:`budget_scale`), and corrected by the count
  MMG actually returned when that misses it by more than ``BUDGET_RTOL``: the nodes move from the
  flat parts into the curved ones, their number stays. Without it ``s = edge_angle``;
* the **enclosed volume** is restored afterwards by a uniform offset ``delta`` of every node along
  its normal, solved by Newton's method to round-off (:func:`restore_volume`);
* the **fields**: each new node takes the linear interpolant of every nodal field at its closest
  point on the old triangulated surface (:func:`closest_points`, exact in a brute-force sense,
  tested); a density (amount per area, :data:`~cortex_ti.surface.transport.DENSITY`) is then scaled
  so that its total ``sum_i c_i A_i`` (barycentric dual areas) equals the old total to round-off.

Derivation and error estimates: ``docs/derivations/remeshing.md``. Written by hand (numpy/scipy):
the curvature estimate, the closest-point query (a k-d tree of the old nodes picks candidate
triangles, the point-triangle distance is the standard region test, vectorised) and the volume
offset; MMG does the topology.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import CortexError
from .mesh import per_connectivity, vertex_normals
from .transport import DENSITY, dual_areas

__all__ = [
    "RemeshOptions",
    "RemeshResult",
    "remesh",
    "remesh_available",
    "min_angles",
    "edge_curvature",
    "grade",
    "predicted_nodes",
    "budget_scale",
    "sizes",
    "node_coarseness",
    "BUDGET_RTOL",
    "mean_edge_length",
    "enclosed_volume",
    "restore_volume",
    "closest_points",
    "flip_bad_edges",
    "smooth_bad_vertices",
    "transfer_fields",
    "keep_amount",
    "REMESH_EXTRA_HINT",
]

#: what to install when mmgpy is missing
REMESH_EXTRA_HINT = "remeshing needs mmgpy: python -m pip install 'cortex-ti[remesh]'"


def remesh_available() -> bool:
    """Whether the remesher (``mmgpy``) can be imported."""
    try:
        import mmgpy._mmgpy  # noqa: F401
    except ImportError:
        return False
    return True


#: ``RemeshOptions.h_min`` None: the smallest target edge length is the mean edge length divided by
#: this (a run takes its initial mesh's: 0.01 at 2562 nodes). A fixed floor held a 10242-node neck at
#: the 2562-node one's edges, and its convergence order fell below 1
#: (docs/validation/remesh_constriction.md).
H_MIN_DIVISOR = 7.5


@dataclass(frozen=True)
class RemeshOptions:
    """How to remesh (lengths in units of R0).

    ``edge_angle``: the angle (rad) a new edge subtends on a circle of the local curvature (the
    scale ``s`` of the size field without a budget); ``nodes``: the node budget (None: none, the
    scale is ``edge_angle``; else the scale is chosen so that the new mesh has about this many
    nodes, :func:`budget_scale`); ``h_min``/``h_max``: bounds of the target edge length (``h_min``
    None: that mean edge length divided by :data:`H_MIN_DIVISOR`; ``h_max``
    None: the mean edge length of the mesh being remeshed); ``hausd``: the largest distance of the
    new nodes from the old surface (None: ``max(0.05, 0.15 s) h_max``, looser than the sagitta
    ``h^2 kappa / 8 <= s h_max / 8`` of the size field, so that the size field decides); ``hgrad``:
    the largest ratio of neighbouring edge lengths; ``quality``: the smallest angle (deg) the repair
    after MMG (edge flips and tangential smoothing of the worst triangles' nodes) aims at.
    """

    edge_angle: float = 0.25
    h_min: float | None = None
    h_max: float | None = None
    hausd: float | None = None
    hgrad: float = 1.3
    quality: float = 30.0
    nodes: int | None = None


@dataclass(frozen=True)
class RemeshResult:
    """The new mesh and fields, and what was done: the volume offset and the node counts."""

    points: np.ndarray
    faces: np.ndarray
    fields: dict
    offset: float  # the normal offset that restored the volume
    n_before: int
    n_after: int
    scale: float = float("nan")  # the scale s of the size field h = clip(s / kappa, h_min, h_max)
    predicted: float = float("nan")  # the node count the (graded) size field predicted


# ---------------------------------------------------------------------------
# quality and geometry
# ---------------------------------------------------------------------------


def min_angles(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The smallest interior angle (degrees) of every triangle, ``(T,)``.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> bool(50.0 < min_angles(m.points, m.faces).min() < 60.0)
    True
    """
    x = np.asarray(points)[np.asarray(faces)]
    e = x[:, [1, 2, 0]] - x  # edge k: corner k -> k+1
    length = np.linalg.norm(e, axis=2)
    # angle at corner k between edges k (k -> k+1) and k-1 reversed (k -> k-1)
    prev = -e[:, [2, 0, 1]]
    cos = np.einsum("tkc,tkc->tk", e, prev) / (length * length[:, [2, 0, 1]])
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))).min(axis=1)


#: the edge lists of the last few connectivities (a remeshing asks for one mesh's edges ~10 times)
_EDGES: dict = {}


def _edges(faces: np.ndarray) -> np.ndarray:
    """The sorted unique edges ``(E, 2)`` of ``faces`` (shared: read, do not modify)."""

    def make():
        e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        out = np.unique(np.sort(e, axis=1), axis=0)
        out.flags.writeable = False
        return out

    return per_connectivity(_EDGES, faces, 0, make, keep=4)


def edge_curvature(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    r"""The largest absolute normal curvature at each node along its edges, ``(N,)``: the edge
    estimate ``|(n_i - n_j) . (x_i - x_j)| / |x_i - x_j|^2`` (the mean of the curvatures of the two
    circles through one end tangent to the surface at the other; exactly ``1/R`` on a sphere of
    radius ``R`` with exact normals). With the area-weighted normals of
    :func:`~cortex_ti.surface.mesh.vertex_normals` it is a size indicator, not a convergent
    estimate: on icospheres it is within 10 % of ``1/R`` at every resolution (9.3 %, 8.9 %, 8.8 % at
    642, 2562, 10242 nodes), as the normal's O(h) error divided by the edge's O(h) length suggests.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> k = edge_curvature(icosphere(642, radius=2.0).points, icosphere(642).faces)
    >>> bool(np.abs(k / 0.5 - 1.0).max() < 0.1)
    True
    """
    n = vertex_normals(points, faces)
    e = _edges(faces)
    d = points[e[:, 0]] - points[e[:, 1]]
    k = np.abs(np.einsum("ec,ec->e", n[e[:, 0]] - n[e[:, 1]], d)) / np.einsum("ec,ec->e", d, d)
    out = np.zeros(points.shape[0])
    np.maximum.at(out, e[:, 0], k)
    np.maximum.at(out, e[:, 1], k)
    return out


def mean_edge_length(points: np.ndarray, faces: np.ndarray) -> float:
    e = _edges(faces)
    return float(np.linalg.norm(points[e[:, 0]] - points[e[:, 1]], axis=1).mean())


def sizes(kappa: np.ndarray, scale, h_min: float, h_max: float) -> np.ndarray:
    """``clip(scale / kappa, h_min, h_max)``; ``scale`` a number or a column ``(S, 1)`` of them."""
    with np.errstate(divide="ignore"):
        h = np.where(kappa > 0.0, scale / np.where(kappa > 0.0, kappa, 1.0), h_max)
    return np.clip(h, min(h_min, h_max), h_max)


#: MMG's calibration: a surface remeshed afresh to a uniform size ``h`` gets ``2 A / (sqrt(3) h^2)``
#: nodes (equilateral triangles of side ``h``) times this (measured 0.97 - 1.05 on spheres from 642
#: and 2562 nodes to h = 0.04 and 0.1; docs/derivations/remeshing.md)
MMG_DENSITY = 1.0
#: the relative miss of the node budget past which the scale is corrected by MMG's own count
BUDGET_RTOL = 0.1


def grade(points: np.ndarray, faces: np.ndarray, h: np.ndarray, hgrad: float) -> np.ndarray:
    r"""The size field limited as MMG grades it (``MMG5_gradsiz_iso``): along every edge ``ij`` of
    length ``l_ij``, ``h_j <= h_i + ln(hgrad) l_ij``, swept until nothing changes. ``h`` may be
    ``(N,)`` or ``(S, N)`` (several fields at once).

    >>> import numpy as np
    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> h = np.full(162, 1.0); h[0] = 0.01
    >>> g = grade(m.points, m.faces, h, 1.3)
    >>> bool(g[0] == 0.01 and g.max() < 1.0 and np.all(g <= h))
    True
    """
    e = _edges(faces)
    slope = math.log(hgrad) * np.linalg.norm(points[e[:, 0]] - points[e[:, 1]], axis=1)
    h = np.array(h, dtype=float)
    for _ in range(10 * len(points)):
        a, b = h[..., e[:, 0]], h[..., e[:, 1]]
        new = h.copy()
        if h.ndim == 1:
            np.minimum.at(new, e[:, 1], a + slope)
            np.minimum.at(new, e[:, 0], b + slope)
        else:
            for row in range(h.shape[0]):
                np.minimum.at(new[row], e[:, 1], a[row] + slope)
                np.minimum.at(new[row], e[:, 0], b[row] + slope)
        if np.array_equal(new, h):
            break
        h = new
    return h


def predicted_nodes(area: np.ndarray, h: np.ndarray) -> np.ndarray | float:
    """The node count of a mesh of equilateral triangles of the local side ``h`` (``(N,)`` or
    ``(S, N)``) over the dual areas ``area``: ``MMG_DENSITY sum_i A_i 2 / (sqrt(3) h_i^2)``."""
    return MMG_DENSITY * np.sum(area * 2.0 / (math.sqrt(3.0) * h * h), axis=-1)


def budget_scale(
    points: np.ndarray,
    faces: np.ndarray,
    nodes: float,
    h_min: float,
    h_max: float,
    hgrad: float | None = None,
    kappa: np.ndarray | None = None,
) -> float:
    r"""The scale ``s`` of the size field ``clip(s / kappa, h_min, h_max)`` (graded by ``hgrad``;
    None: not graded) whose :func:`predicted_nodes` is ``nodes``. The count falls monotonically
    with ``s`` (grading only lowers sizes, monotonically in them); it is bracketed by the clips
    (``s`` below ``h_min kappa_min`` asks ``h_min`` everywhere, above ``h_max kappa_max`` ``h_max``
    everywhere, returned when the budget lies outside) and bisected in ``log s`` to 1e-3.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> from cortex_ti.surface.transport import dual_areas
    >>> m = icosphere(642)
    >>> s = budget_scale(m.points, m.faces, 2562, 0.01, 1.0)
    >>> k = edge_curvature(m.points, m.faces)
    >>> n = predicted_nodes(dual_areas(m.points, m.faces), sizes(k, s, 0.01, 1.0))
    >>> bool(abs(n / 2562 - 1.0) < 2e-3)
    True
    """
    area = dual_areas(points, faces)
    kappa = edge_curvature(points, faces) if kappa is None else kappa
    pos = kappa[kappa > 0.0]
    if pos.size == 0:
        return float("inf")
    lo, hi = math.log(h_min * pos.min()), math.log(h_max * pos.max())

    def count(log_s):
        h = sizes(kappa, np.exp(np.atleast_1d(log_s))[:, None], h_min, h_max)
        if hgrad is not None:
            h = grade(points, faces, h, hgrad)
        return predicted_nodes(area, h)

    if count(np.array([hi]))[0] >= nodes:
        return float(math.exp(hi))
    if count(np.array([lo]))[0] <= nodes:
        return float(math.exp(lo))
    # bisection, 8 points at a time: each pass shrinks the bracket 9-fold
    while hi - lo > 1e-3:
        grid = np.linspace(lo, hi, 10)[1:-1]
        above = count(grid) > nodes  # too many nodes: s too small
        k = int(np.count_nonzero(above))
        lo, hi = (grid[k - 1] if k else lo), (grid[k] if k < grid.size else hi)
    return float(math.exp(0.5 * (lo + hi)))


def node_coarseness(points: np.ndarray, faces: np.ndarray, h: np.ndarray) -> float:
    """The largest ratio of a node's mean edge length to its target length ``h``: how much
    coarser than the size field the mesh is where it is coarsest (the mean over a node's edges
    smooths the noise of the curvature estimate that a single edge's ratio carries)."""
    e = _edges(faces)
    length = np.linalg.norm(points[e[:, 0]] - points[e[:, 1]], axis=1)
    total = np.bincount(e[:, 0], length, len(points)) + np.bincount(e[:, 1], length, len(points))
    count = np.bincount(e[:, 0], minlength=len(points)) + np.bincount(e[:, 1], minlength=len(points))
    return float(np.max(total / count / h))


def enclosed_volume(points: np.ndarray, faces: np.ndarray) -> float:
    """The signed volume enclosed by outward-oriented triangles."""
    x = points[faces]
    return float(np.einsum("tc,tc->", x[:, 0], np.cross(x[:, 1], x[:, 2])) / 6.0)


def restore_volume(points: np.ndarray, faces: np.ndarray, volume: float, rtol: float = 1e-14, max_iter: int = 20):
    r"""Offset every node by the same distance ``delta`` along its (fixed) normal so that the enclosed
    volume is ``volume``: Newton's method on the cubic ``V(delta)``. Returns ``(points, delta)``.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> p, d = restore_volume(m.points, m.faces, 4.0 * np.pi / 3.0)
    >>> bool(abs(enclosed_volume(p, m.faces) / (4.0 * np.pi / 3.0) - 1.0) < 1e-13)
    True
    """
    n = vertex_normals(points, faces)
    delta = 0.0
    for _ in range(max_iter):
        p = points + delta * n
        v = enclosed_volume(p, faces)
        if abs(v - volume) <= rtol * abs(volume):
            return p, delta
        x = p[faces]
        nf = n[faces]
        # dV/ddelta = sum_T (n_a . x_b x x_c + x_a . n_b x x_c + x_a . x_b x n_c) / 6
        dv = (
            np.einsum("tc,tc->", nf[:, 0], np.cross(x[:, 1], x[:, 2]))
            + np.einsum("tc,tc->", x[:, 0], np.cross(nf[:, 1], x[:, 2]))
            + np.einsum("tc,tc->", x[:, 0], np.cross(x[:, 1], nf[:, 2]))
        ) / 6.0
        delta -= (v - volume) / dv
    raise CortexError(f"remeshing could not restore the enclosed volume {volume:.6g} (Newton did not converge)")


# ---------------------------------------------------------------------------
# closest points and the transfer of fields
# ---------------------------------------------------------------------------


def _closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(..., 3)`` of the closest point of triangle ``abc`` to ``p``
    (all ``(..., 3)``): the point-triangle region test (Voronoi regions of vertices, edges, face)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("...c,...c->...", ab, ap), np.einsum("...c,...c->...", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("...c,...c->...", ab, bp), np.einsum("...c,...c->...", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("...c,...c->...", ab, cp), np.einsum("...c,...c->...", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v_face, w_face = vb / denom, vc / denom
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    u = 1.0 - v_face - w_face
    v, w = v_face, w_face
    # the order of the tests matters: the first region that holds wins
    regions = [
        ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), (0.0, 1.0 - t_bc, t_bc)),  # edge bc
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), (1.0 - t_ac, 0.0, t_ac)),  # edge ac
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), (1.0 - t_ab, t_ab, 0.0)),  # edge ab
        ((d6 >= 0) & (d5 <= d6), (0.0, 0.0, 1.0)),  # vertex c
        ((d3 >= 0) & (d4 <= d3), (0.0, 1.0, 0.0)),  # vertex b
        ((d1 <= 0) & (d2 <= 0), (1.0, 0.0, 0.0)),  # vertex a
    ]
    for mask, (ru, rv, rw) in regions:
        u = np.where(mask, ru, u)
        v = np.where(mask, rv, v)
        w = np.where(mask, rw, w)
    return np.stack([u, v, w], axis=-1)


def closest_points(points: np.ndarray, faces: np.ndarray, queries: np.ndarray, k: int = 4):
    """The closest point of the triangulated surface ``(points, faces)`` to each query ``(Q, 3)``:
    its triangle ``(Q,)`` and barycentric coordinates ``(Q, 3)``.

    The candidates are the triangles around the ``k`` nearest nodes (a k-d tree): the closest point
    of a surface to a point within about an edge length of it lies in one of them unless the surface
    folds back closer than that. Tested against a brute-force search over every triangle.
    """
    n = points.shape[0]
    k = min(k, n)
    from scipy.spatial import cKDTree  # only a remeshing needs it (a tenth of a second to import)

    _, near = cKDTree(points).query(queries, k=k)
    near = near.reshape(len(queries), k)
    # node -> its triangles, padded with the first one
    order = np.argsort(faces.ravel(), kind="stable")
    node_of = faces.ravel()[order]
    start = np.searchsorted(node_of, np.arange(n))
    count = np.bincount(node_of, minlength=n)
    width = int(count.max())
    slot = np.minimum(np.arange(width)[None, :], count[:, None] - 1)
    incident = (order[start[:, None] + slot] // 3).astype(np.int64)  # (N, width)
    cand = incident[near].reshape(len(queries), k * width)  # (Q, C)
    x = points[faces[cand]]  # (Q, C, 3, 3)
    q = queries[:, None, :]
    bary = _closest_on_triangles(np.broadcast_to(q, x[:, :, 0].shape), x[:, :, 0], x[:, :, 1], x[:, :, 2])
    foot = np.einsum("qck,qckd->qcd", bary, x)
    dist = np.einsum("qcd,qcd->qc", foot - q, foot - q)
    best = np.argmin(dist, axis=1)
    rows = np.arange(len(queries))
    return cand[rows, best], bary[rows, best]


def transfer_fields(
    old_points: np.ndarray,
    old_faces: np.ndarray,
    fields: dict,
    kinds: dict,
    new_points: np.ndarray,
    new_faces: np.ndarray,
) -> dict:
    """Every nodal field on the new mesh: the linear interpolant at the closest point of the old
    surface; a density (``kinds[name] == DENSITY``) then scaled so that ``sum c A`` is kept (module
    docstring; a density whose interpolant has no content is shifted by a constant instead)."""
    if not fields:
        return {}
    tri, bary = closest_points(old_points, old_faces, new_points)
    corners = old_faces[tri]
    out = {}
    a_old = a_new = None
    for name, values in fields.items():
        v = np.einsum("qk,qk->q", bary, np.asarray(values, dtype=float)[corners])
        if kinds.get(name) == DENSITY:
            if a_old is None:
                a_old, a_new = dual_areas(old_points, old_faces), dual_areas(new_points, new_faces)
            v = keep_amount(v, float(np.dot(values, a_old)), a_new)
        out[name] = v
    return out


def keep_amount(density: np.ndarray, total: float, area: np.ndarray) -> np.ndarray:
    """``density`` on cells of ``area`` with its amount ``sum c A`` made ``total``: scaled, or, when
    it has no content (or a scale would flip its sign), shifted by a constant."""
    got = float(np.dot(density, area))
    if got != 0.0 and math.isfinite(total / got) and total / got > 0.0:
        return density * (total / got)
    return density + (total - got) / float(area.sum())


# ---------------------------------------------------------------------------
# flips of the worst triangles
# ---------------------------------------------------------------------------


def _pair_quality(points: np.ndarray, tris: list) -> float:
    return float(min_angles(points, np.asarray(tris)).min())


def flip_bad_edges(points: np.ndarray, faces: np.ndarray, goal: float, sweeps: int = 5) -> np.ndarray:
    """Flip the longest edge of every triangle whose smallest angle is below ``goal`` (degrees) when
    that raises the smallest angle of the two triangles sharing it, keeps both triangles facing the
    way the old pair faced and creates no edge that exists already. A few triangles at the
    transitions of the size field come out of MMG obtuse (an angle near 120 deg opposite an edge
    too long for its neighbours); the flip is the local Delaunay repair. Returns new faces."""
    faces = np.array(faces, dtype=np.int64)
    for _ in range(sweeps):
        bad = np.flatnonzero(min_angles(points, faces) < goal)
        if bad.size == 0:
            break
        half = {}
        for t, (a, b, c) in enumerate(faces.tolist()):
            half[(a, b)], half[(b, c)], half[(c, a)] = t, t, t
        neighbours = {}
        for a, b in half:
            neighbours.setdefault(a, set()).add(b)
        flipped = 0
        for t in bad.tolist():
            tri = faces[t].tolist()
            x = points[tri]
            length = np.linalg.norm(x[[1, 2, 0]] - x, axis=1)
            k = int(np.argmax(length))  # edge k: corner k -> k+1
            a, b, c = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
            s = half.get((b, a))
            if s is None or faces[t].tolist() != tri:
                continue
            d = next(v for v in faces[s].tolist() if v not in (a, b))
            if d in neighbours.get(c, ()) or c == d:
                continue
            old = [[a, b, c], [b, a, d]]
            new = [[c, a, d], [d, b, c]]
            n_old = sum(np.cross(points[q[1]] - points[q[0]], points[q[2]] - points[q[0]]) for q in old)
            if any(
                np.dot(np.cross(points[q[1]] - points[q[0]], points[q[2]] - points[q[0]]), n_old) <= 0.0 for q in new
            ):
                continue
            if _pair_quality(points, new) <= _pair_quality(points, old):
                continue
            faces[t], faces[s] = new
            for q, f in ((new[0], t), (new[1], s)):
                half[(q[0], q[1])], half[(q[1], q[2])], half[(q[2], q[0])] = f, f, f
            half.pop((a, b), None)
            half.pop((b, a), None)
            neighbours[a].discard(b)
            neighbours[b].discard(a)
            neighbours.setdefault(c, set()).add(d)
            neighbours.setdefault(d, set()).add(c)
            flipped += 1
        if flipped == 0:
            break
    return faces.astype(np.int32)


def smooth_bad_vertices(points: np.ndarray, faces: np.ndarray, goal: float, sweeps: int = 5) -> np.ndarray:
    """Move each node of a triangle with an angle below ``goal`` (degrees) to the centroid of its
    neighbours, in its tangent plane and then back onto the surface (the closest point of the
    triangulation before the move), when that raises the smallest angle of its triangles.
    Returns the new points."""
    reference = np.array(points, dtype=float)
    points = reference.copy()
    normals = vertex_normals(points, faces)
    order = np.argsort(faces.ravel(), kind="stable")
    bounds = np.searchsorted(faces.ravel()[order], np.arange(points.shape[0] + 1))
    for _ in range(sweeps):
        angles = min_angles(points, faces)
        bad = np.flatnonzero(angles < goal)
        if bad.size == 0:
            break
        nodes = np.unique(faces[bad])
        trials = np.empty((nodes.size, 3))
        for j, i in enumerate(nodes.tolist()):
            ring = np.setdiff1d(faces[order[bounds[i] : bounds[i + 1]] // 3], [i])
            step = points[ring].mean(axis=0) - points[i]
            trials[j] = points[i] + step - np.dot(step, normals[i]) * normals[i]
        tri, bary = closest_points(reference, faces, trials)
        trials = np.einsum("qk,qkc->qc", bary, reference[faces[tri]])
        moved = 0
        for j, i in enumerate(nodes.tolist()):
            star = order[bounds[i] : bounds[i + 1]] // 3
            before = min_angles(points, faces[star]).min()
            saved = points[i].copy()
            points[i] = trials[j]
            if min_angles(points, faces[star]).min() <= before:
                points[i] = saved
            else:
                moved += 1
        if moved == 0:
            break
    return points


# ---------------------------------------------------------------------------
# remeshing
# ---------------------------------------------------------------------------


def remesh(
    points: np.ndarray,
    faces: np.ndarray,
    fields: dict | None = None,
    kinds: dict | None = None,
    options: RemeshOptions | None = None,
    volume: float | None = None,
) -> RemeshResult:
    """A new triangulation of the closed surface ``(points, faces)`` with its fields (module docstring).

    ``volume``: the enclosed volume to restore (None: the volume of the input); ``kinds``: field
    name -> ``density`` or ``property`` (an intensive field; the default).
    """
    try:
        from mmgpy._mmgpy import MmgMeshS
    except ImportError:
        raise CortexError(REMESH_EXTRA_HINT) from None
    options = options or RemeshOptions()
    points = np.ascontiguousarray(points, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    target = enclosed_volume(points, faces) if volume is None else float(volume)
    mean = mean_edge_length(points, faces)
    h_max = mean if options.h_max is None else float(options.h_max)
    h_min = mean / H_MIN_DIVISOR if options.h_min is None else float(options.h_min)
    kappa = edge_curvature(points, faces)
    area = dual_areas(points, faces)
    scale = options.edge_angle
    if options.nodes is not None:
        scale = budget_scale(points, faces, options.nodes, h_min, h_max, options.hgrad, kappa)

    def mmg(scale):
        h = grade(points, faces, sizes(kappa, scale, h_min, h_max), options.hgrad)
        hausd = options.hausd if options.hausd is not None else max(0.05, 0.15 * min(scale, 1.0)) * h_max
        mesh = MmgMeshS(points, faces)
        mesh.set_field("metric", h[:, None])
        info = mesh.remesh(hausd=hausd, hgrad=options.hgrad, angle=0, verbose=-1)
        if info.get("return_code", 0) != 0:
            raise CortexError(f"remeshing failed (MMG return code {info.get('return_code')})")
        got = np.ascontiguousarray(mesh.get_vertices(), dtype=np.float64)
        return got, np.ascontiguousarray(mesh.get_triangles(), dtype=np.int32), float(predicted_nodes(area, h))

    new_points, new_faces, predicted = mmg(scale)
    if options.nodes is not None:
        # MMG leaves an edge alone within a factor sqrt(2) of its target and may refine for hausd:
        # the count it returns is the calibration; the scale is corrected by it (N ~ 1 / s^2)
        for _ in range(2):
            miss = len(new_points) / options.nodes
            if abs(miss - 1.0) <= BUDGET_RTOL:
                break
            trial = mmg(scale * math.sqrt(miss))
            if abs(len(trial[0]) / options.nodes - 1.0) >= abs(miss - 1.0):
                break
            scale *= math.sqrt(miss)
            new_points, new_faces, predicted = trial
    if enclosed_volume(new_points, new_faces) < 0:
        new_faces = np.ascontiguousarray(new_faces[:, [0, 2, 1]])
    new_faces = flip_bad_edges(new_points, new_faces, options.quality)
    new_points = smooth_bad_vertices(new_points, new_faces, options.quality)
    new_faces = flip_bad_edges(new_points, new_faces, options.quality)
    new_points, delta = restore_volume(new_points, new_faces, target)
    new_fields = transfer_fields(points, faces, dict(fields or {}), dict(kinds or {}), new_points, new_faces)
    return RemeshResult(
        new_points, new_faces, new_fields, delta, points.shape[0], new_points.shape[0], scale, predicted
    )
