r"""Remeshing a surface of curved six-node cells (formulation ``rayleigh_p2``).

A mesh of curved cells is the 1-to-4 split of its corner mesh (:mod:`cortex_ti.surface.curved`).
:func:`remesh_curved` remeshes that corner mesh with the flat machinery
(:func:`cortex_ti.surface.remesh.triangulate`: MMG to the curvature size field, the node budget,
the repair and the retries), the sizes and the budget of the run's velocity nodes translated to the
corners (:func:`corner_options`: a cell's edge spans two of the split mesh's edges, and ``N``
velocity nodes are ``(N + 6) / 4`` corners on a closed surface). Then

* every new corner, and then every new cell's edge midpoint (the straight midpoint of the new
  corners), is placed at its **closest point on the old curved surface** (:func:`curved_closest`:
  the closest flat sub-triangle first, then Gauss-Newton on the quadratic map of its cell, the
  reference coordinates kept in the cell). So all new nodes lie on the old curved cells, whose
  distance from the true surface is the quadratic interpolation's O(h^3), where a node placed on
  the flat triangles is O(h^2) off (the sagitta);
* the enclosed volume of the new curved cells is made the old one by a uniform offset along the
  nodes' normals (Newton's method on the cells' exact volume, :func:`restore_curved_volume`);
* every field takes its old cells' quadratic interpolant at the node's foot point; a density
  (amount per area) is then scaled so that its total over the curved cells, ``int c_h dA =
  sum_i c_i int N_i dA`` (:func:`curved_masses`), is the old total to round-off.

``placement="flat"`` places every new node on the old flat sub-triangles instead (their closest
point, the fields linearly interpolated there): the comparison of
``benchmarks/investigations/curved_placement.py``. Derivation: docs/derivations/remeshing.md
("Curved cells").
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from .closest import closest_points
from .curved import CELL_EDGES, p2_cells, p2_shape, triangle_rule
from .measures import area_centroid, min_angles
from .mesh import split_faces
from .remesh import RemeshOptions, RemeshResult, edge_curvature, keep_amount, offset_to_volume, triangulate
from .transport import DENSITY

log = logging.getLogger(__name__)

__all__ = [
    "jacobian_ratio",
    "unfold",
    "PLACEMENTS",
    "corner_mesh",
    "corner_options",
    "curved_closest",
    "curved_masses",
    "curved_volume",
    "interpolate_at",
    "remesh_curved",
    "restore_curved_volume",
]

#: where the new nodes go: on the old curved cells, or on their flat sub-triangles
PLACEMENTS = ("curved", "flat")

#: reference coordinates of a cell's six nodes, and each flat sub-triangle's local nodes
#: (the split layout of :func:`cortex_ti.surface.curved.p2_cells`)
_REF = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]])
_SUB = np.array([[0, 3, 5], [1, 4, 3], [2, 5, 4], [3, 4, 5]])

#: MMG's default Hausdorff distance for the corner mesh is this times the flat one's of the same
#: sizes. That default grows with the scale s and h_max, both doubled for the corners: 4 times the
#: distance of a rayleigh_p1 run at the same velocity nodes, the corner triangles' sagitta at the
#: sizes asked (docs/derivations/remeshing.md), which the curved cells carry. Smaller factors make
#: MMG refine the flat parts for their sagitta: at amplitude 12's first remeshing (2562 nodes,
#: t = 0.64) 0.5 gave 3070 nodes for a budget of 2562; at its neck at t = 2.1 0.25 gave 3746
CORNER_HAUSD = 1.0

#: a new cell whose area element falls below this fraction of its corner triangle's (at a quadrature
#: point) gets its edges' midpoints back on the straight chords (a valid cell: four flat triangles):
#: a cell across a crease sharper than itself folds with midpoints on the surface
FOLD_RATIO = 0.1

#: Gauss-Newton iterations of the closest point on a cell (quadratic convergence from the flat
#: sub-triangle's foot, which is O(h^2) off: a few suffice; the last steps are below 1e-15 R0)
NEWTON_STEPS = 8


def corner_mesh(points: np.ndarray, faces: np.ndarray, ids: bool = False):
    """The corner triangulation of a split mesh: its corner nodes (C, 3) and the cells' corner
    triangles (T/4, 3) into them (``ids``: and the corners' node numbers in the split mesh)."""
    cells = p2_cells(faces)
    corners, inverse = np.unique(cells[:, :3], return_inverse=True)
    out = np.asarray(points, dtype=float)[corners], inverse.reshape(-1, 3).astype(np.int32)
    return (*out, corners) if ids else out


def corner_options(options: RemeshOptions) -> RemeshOptions:
    """The options of a run's remeshing (lengths and the node budget of its velocity nodes, i.e. of
    the split mesh) for its corner mesh: lengths and the scale ``s`` (an edge's angle) doubled, the
    budget ``(N + 6) / 4`` corners (a closed triangulation of V nodes has 3V - 6 edges, so its split
    has 4V - 6 nodes). ``hausd`` is a distance from the surface, not an edge: kept."""

    def twice(x):
        return None if x is None else 2.0 * x

    return RemeshOptions(
        edge_angle=2.0 * options.edge_angle,
        h_min=twice(options.h_min),
        h_max=twice(options.h_max),
        hausd=options.hausd,
        hgrad=options.hgrad,
        quality=options.quality,
        nodes=None if options.nodes is None else max(4, round((options.nodes + 6) / 4)),
        min_angle=options.min_angle,
    )


def _project(x: np.ndarray) -> np.ndarray:
    """Reference coordinates (K, 2) moved into the reference triangle (clipped at the legs, pulled back
    along (1, 1) over the hypotenuse)."""
    x = np.maximum(x, 0.0)
    over = np.maximum(x.sum(axis=1) - 1.0, 0.0)
    x = np.clip(x - 0.5 * over[:, None], 0.0, 1.0)
    total = x.sum(axis=1)
    return x / np.maximum(total, 1.0)[:, None]


def curved_closest(points: np.ndarray, faces: np.ndarray, queries: np.ndarray):
    """The closest point of the curved cells of the split mesh ``(points, faces)`` to each query
    (Q, 3): its cell (Q,), reference coordinates (Q, 2) and position (Q, 3). The flat sub-triangle
    closest to the query gives the cell and the start (:func:`cortex_ti.surface.closest.closest_points`);
    Gauss-Newton on the cell's quadratic map ``X(xi)`` (``(J^T J) d = J^T (q - X)``) moves it to the
    cell's closest point, the coordinates kept in the cell's reference triangle (a foot on the
    cell's edge lies on the curve the neighbouring cell shares: it is on the curved surface too)."""
    points = np.asarray(points, dtype=float)
    queries = np.asarray(queries, dtype=float)
    cells = p2_cells(faces)
    tri, bary = closest_points(points, np.asarray(faces), queries)
    cell = tri // 4
    ref = np.einsum("qk,qkd->qd", bary, _REF[_SUB[tri % 4]])
    xc = points[cells[cell]]  # (Q, 6, 3)
    for _ in range(NEWTON_STEPS):
        n, dn = p2_shape(ref)
        x = np.einsum("qi,qic->qc", n, xc)
        jac = np.einsum("qia,qic->qca", dn, xc)  # (Q, 3, 2)
        jtj = np.einsum("qca,qcb->qab", jac, jac)
        rhs = np.einsum("qca,qc->qa", jac, queries - x)
        ref = _project(ref + np.linalg.solve(jtj, rhs[..., None])[..., 0])
    n, _ = p2_shape(ref)
    return cell, ref, np.einsum("qi,qic->qc", n, xc)


def interpolate_at(points: np.ndarray, faces: np.ndarray, values: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """A nodal field (M, ...) of the curved cells at the closest points of the queries (Q, 3): its
    quadratic interpolant at their feet (:func:`curved_closest`)."""
    cell, ref, _ = curved_closest(points, faces, queries)
    return _interpolate(points, faces, values, cell, ref)


def jacobian_ratio(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(T,): the smallest ratio, over a cell's quadrature points, of its area element projected on its
    corner triangle's normal to the corner triangle's (1 on a flat cell, <= 0 where it folds)."""
    cells = p2_cells(faces)
    q, _ = triangle_rule(3)
    _, dn = p2_shape(q)
    xc = np.asarray(points, dtype=float)[cells]
    tang = np.einsum("qia,tic->tqac", dn, xc)
    x = xc[:, :3]
    flat = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    ratio = np.einsum("tqc,tc->tq", np.cross(tang[:, :, 0], tang[:, :, 1]), flat)
    return ratio.min(axis=1) / np.einsum("tc,tc->t", flat, flat)


def unfold(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, int]:
    """The midpoints of the cells below :data:`FOLD_RATIO` (:func:`jacobian_ratio`) put back on their
    straight chords, twice at most (a neighbour that shares such an edge may fold in turn). Returns
    the points and how many cells were unfolded."""
    cells = p2_cells(faces)
    nodes, count = np.asarray(points, dtype=float), 0
    for _ in range(2):
        bad = np.flatnonzero(jacobian_ratio(nodes, faces) < FOLD_RATIO)
        if bad.size == 0:
            break
        count += bad.size
        nodes = nodes.copy()
        for k, (a, b) in enumerate(CELL_EDGES):
            c = cells[bad]
            nodes[c[:, 3 + k]] = 0.5 * (nodes[c[:, a]] + nodes[c[:, b]])
        log.info("remeshing: %d curved cells folded over a crease: their midpoints on their chords", bad.size)
    return nodes, count


def _interpolate(points, faces, values, cell, ref) -> np.ndarray:
    """A nodal field's quadratic interpolant on the old cells at the foot points ``(cell, ref)``."""
    n, _ = p2_shape(ref)
    return np.einsum("qi,qi...->q...", n, np.asarray(values, dtype=float)[p2_cells(faces)[cell]])


def _cell_quadrature(points: np.ndarray, faces: np.ndarray):
    """Per cell and point of :func:`~cortex_ti.surface.curved.triangle_rule` (3 x 3, exact for the
    volume's degree-4 integrand): the shape functions (Q, 6), the positions (T, Q, 3) and the
    weighted area vector ``n dA`` (T, Q, 3) of the cells' own map."""
    cells = p2_cells(faces)
    q, w = triangle_rule(3)
    n, dn = p2_shape(q)
    xc = np.asarray(points, dtype=float)[cells]
    x = np.einsum("qi,tic->tqc", n, xc)
    tang = np.einsum("qia,tic->tqac", dn, xc)
    return cells, n, x, np.cross(tang[:, :, 0], tang[:, :, 1]) * w[None, :, None]


def curved_volume(points: np.ndarray, faces: np.ndarray) -> float:
    """The volume ``1/3 int x . n dA`` the curved cells enclose, exact (a polynomial of degree 4 in the
    reference coordinates, integrated by a rule of degree 5).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(2562)
    >>> round(curved_volume(m.points, m.faces) / (4.0 * np.pi / 3.0), 6)  # the cells' geometric error
    0.999991
    """
    _, _, x, nda = _cell_quadrature(points, faces)
    return float(np.einsum("tqc,tqc->", x, nda) / 3.0)


def _volume_rows(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(M, 3): ``int N_i n dA``, the derivative of :func:`curved_volume` along node ``i``'s motion."""
    cells, n, _, nda = _cell_quadrature(points, faces)
    part = np.einsum("qi,tqc->tic", n, nda)
    out = np.zeros((len(points), 3))
    np.add.at(out, cells.ravel(), part.reshape(-1, 3))
    return out


def curved_masses(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``int N_i dA`` over the curved cells for every node (M,): a density's total over the cells is
    ``sum_i c_i m_i`` (the corners' masses are small: ``int N_corner dA`` vanishes on a flat cell).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(642)
    >>> round(float(curved_masses(m.points, m.faces).sum()) / (4.0 * np.pi), 4)  # the cells' area
    0.9999
    """
    cells, n, _, nda = _cell_quadrature(points, faces)
    part = np.einsum("qi,tq->ti", n, np.linalg.norm(nda, axis=-1))
    return np.bincount(cells.ravel(), part.ravel(), minlength=len(points))


def restore_curved_volume(points, faces, volume: float, rtol: float = 1e-14, max_iter: int = 20):
    """Offset every node by the same distance ``delta`` along its (fixed, area-weighted vertex) normal
    so that the curved cells enclose ``volume``: Newton's method, ``dV/ddelta = sum_i n_i . int N_i
    n dA``. Returns ``(points, delta)``."""

    def measure(p: np.ndarray, normal: np.ndarray) -> tuple[float, float]:
        return curved_volume(p, faces), float(np.einsum("nc,nc->", _volume_rows(p, faces), normal))

    return offset_to_volume(points, faces, volume, measure, "the curved cells' volume", rtol, max_iter)


#: a placed corner mesh below ``RemeshOptions.min_angle`` is triangulated again with MMG's floor and the
#: repair's goal raised by this (deg), at most :data:`PLACED_RETRIES` times, the best placed mesh kept
PLACED_RAISE = 4.0
PLACED_RETRIES = 2


def _placed_corners(points, faces, corners, corner_faces, kappa, options: RemeshOptions, mirror, p0):
    """The new corner triangulation (:func:`~cortex_ti.surface.remesh.triangulate`, or mirrored) and its
    nodes placed on the old curved cells (a node on the mirror plane kept on it). MMG's floor
    ``options.min_angle`` holds on the flat corner mesh it makes; the placement moves each node by up
    to the cells' sagitta, which at a neck skews a few triangles by several degrees. A placed mesh below
    the floor is made again with the floor and the repair's goal raised by :data:`PLACED_RAISE` (at most
    :data:`PLACED_RETRIES` times; the placed mesh with the largest smallest angle is kept). Returns the
    triangulation, the placed corners' cells and reference coordinates on the old cells and positions."""
    opts = corner_options(options)
    best = None
    for attempt in range(PLACED_RETRIES + 1):
        if mirror is None:
            new = triangulate(corners, corner_faces, opts, kappa, CORNER_HAUSD)
        else:
            from .mirror import mirror_triangulate

            new = mirror_triangulate(corners, corner_faces, p0, mirror, opts, kappa, CORNER_HAUSD)
        cell, ref, at = curved_closest(points, faces, new.points)
        if mirror is not None:
            from .mirror import keep_on_plane

            at = keep_on_plane(at, new.points, p0, mirror)
        angle = float(min_angles(at, new.faces).min())
        if best is None or angle > best[0]:
            best = (angle, new, cell, ref, at)
        if options.min_angle is None or best[0] >= options.min_angle or attempt == PLACED_RETRIES:
            break
        log.info("remeshing: the placed corners' smallest angle %.2f deg < %g: made again", angle, options.min_angle)
        raised = (opts.min_angle or options.min_angle) + PLACED_RAISE
        opts = replace(opts, min_angle=raised, quality=max(opts.quality, raised + 5.0))
    return best[1:]


def remesh_curved(
    points: np.ndarray,
    faces: np.ndarray,
    fields: dict | None = None,
    kinds: dict | None = None,
    options: RemeshOptions | None = None,
    volume: float | None = None,
    placement: str = "curved",
    restore: bool = True,
    mirror=None,
) -> RemeshResult:
    """A new split mesh of the curved surface ``(points, faces)`` with its fields (module docstring).

    ``options``: the run's (lengths and budget of the velocity nodes; :func:`corner_options` turns
    them into the corner mesh's); ``volume``: the volume to restore (None: the curved cells' own);
    ``kinds``: field name -> ``density`` or ``property``; ``placement``: ``curved`` or ``flat``;
    ``restore``: False leaves the volume as the placement made it (``offset`` 0); ``mirror``: an axis
    (3,): the corner mesh made mirror-symmetric about the plane through the cells' area centroid
    perpendicular to it (:func:`cortex_ti.surface.mirror.mirror_triangulate`)."""
    if placement not in PLACEMENTS:
        raise ValueError(f"placement must be one of {PLACEMENTS}, not {placement!r}")
    points = np.ascontiguousarray(points, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    target = curved_volume(points, faces) if volume is None else float(volume)
    corners, corner_faces, corner_ids = corner_mesh(points, faces, ids=True)
    # the size field's curvature from the split mesh (its edges are half the corner mesh's: a deep
    # neck's meridian, ~80 / R0 at amplitude 12, is smoothed away by the corner mesh's own estimate)
    kappa = edge_curvature(points, faces)[corner_ids]
    p0 = None if mirror is None else area_centroid(points, faces)
    new, cell, ref, at = _placed_corners(
        points, faces, corners, corner_faces, kappa, options or RemeshOptions(), mirror, p0
    )
    edges, split = split_faces(new.faces, len(new.points))
    new_faces = np.ascontiguousarray(split, dtype=np.int32)
    if placement == "curved":
        mids = 0.5 * (at[edges[:, 0]] + at[edges[:, 1]])
        cell_m, ref_m, at_m = curved_closest(points, faces, mids)
        cell, ref, nodes = np.concatenate([cell, cell_m]), np.vstack([ref, ref_m]), np.vstack([at, at_m])
    else:
        tri, bary = closest_points(points, faces, new.points)
        at = np.einsum("qk,qkc->qc", bary, points[faces[tri]])
        mids = 0.5 * (at[edges[:, 0]] + at[edges[:, 1]])
        tri_m, bary_m = closest_points(points, faces, mids)
        tri, bary = np.concatenate([tri, tri_m]), np.vstack([bary, bary_m])
        nodes = np.einsum("qk,qkc->qc", bary, points[faces[tri]])
    if mirror is not None:  # a midpoint on the plane stays there (cortex_ti.surface.mirror; corners: _placed_corners)
        from .mirror import keep_on_plane

        straight = np.vstack([new.points, 0.5 * (new.points[edges[:, 0]] + new.points[edges[:, 1]])])
        nodes = keep_on_plane(nodes, straight, p0, mirror)
    nodes, _ = unfold(nodes, new_faces)
    nodes, delta = restore_curved_volume(nodes, new_faces, target) if restore else (nodes, 0.0)
    out, kinds = {}, dict(kinds or {})
    m_old = m_new = None
    for name, values in (fields or {}).items():
        if placement == "curved":
            v = _interpolate(points, faces, values, cell, ref)
        else:
            v = np.einsum("qk,qk...->q...", bary, np.asarray(values, dtype=float)[faces[tri]])
        if kinds.get(name) == DENSITY:
            if m_old is None:
                m_old, m_new = curved_masses(points, faces), curved_masses(nodes, new_faces)
            v = keep_amount(v, float(np.dot(np.asarray(values, dtype=float), m_old)), m_new)
        out[name] = v
    # the corner mesh's predicted count in velocity nodes (4 V - 6); the scale is the corner mesh's
    predicted = 4.0 * new.predicted - 6.0
    return RemeshResult(nodes, new_faces, out, delta, len(points), len(nodes), new.scale, predicted, new.passes)
