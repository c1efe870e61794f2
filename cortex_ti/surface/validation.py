"""Checking and cleaning a user's triangle surface (:func:`validate_mesh`).

Every problem raises :class:`~cortex_ti.errors.MeshError` with a concrete message (counts and
an example node, edge or face, numbered as in the input). All heavy work is vectorised numpy /
scipy (sort-based edge matching, sparse connected components).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..errors import MeshError
from .measures import enclosed_volume, face_areas
from .mesh import Mesh

__all__ = ["validate_mesh", "MERGE_TOLERANCE", "DEGENERATE_AREA", "FLAT_VOLUME"]

logger = logging.getLogger(__name__)

#: Points closer than this fraction of the bounding-box diagonal are merged.
MERGE_TOLERANCE = 1e-10
#: A face with area below this fraction of the mean face area is degenerate.
DEGENERATE_AREA = 1e-12
#: ``|enclosed volume|`` below this fraction of area**1.5 counts as "no volume".
FLAT_VOLUME = 1e-9


def _label(name: str) -> str:
    return "mesh" if name == "mesh" else f"mesh '{name}'"


def _as_points(points, label: str) -> np.ndarray:
    try:
        pts = np.array(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MeshError(f"{label} points are not a numeric (N, 3) array: {exc}") from None
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise MeshError(f"{label} points must have shape (N, 3), got shape {pts.shape}")
    if pts.shape[0] == 0:
        raise MeshError(f"{label} has no points")
    bad = ~np.isfinite(pts).all(axis=1)
    if bad.any():
        idx = np.flatnonzero(bad)
        raise MeshError(
            f"{label} has {idx.size} non-finite point(s) (NaN or inf), e.g. node {idx[0]} at {pts[idx[0]].tolist()}"
        )
    return pts


def _as_faces(faces, n_points: int, label: str) -> np.ndarray:
    try:
        raw = np.asarray(faces)
    except (TypeError, ValueError) as exc:  # ragged input
        raise MeshError(f"{label} faces are not an (F, 3) array: {exc}") from None
    if raw.dtype == object:
        raise MeshError(f"{label} faces are not an (F, 3) array of node indices (ragged or non-numeric)")
    if raw.ndim != 2:
        raise MeshError(f"{label} faces must have shape (F, 3), got shape {raw.shape}")
    if raw.shape[0] == 0:
        raise MeshError(f"{label} contains no triangles")
    if raw.shape[1] != 3:
        raise MeshError(f"{label} faces have {raw.shape[1]} nodes each; only triangles (3 nodes) are supported")
    if np.issubdtype(raw.dtype, np.integer):
        fc = raw.astype(np.int64)
    elif np.issubdtype(raw.dtype, np.floating):
        ok = np.isfinite(raw) & (raw == np.round(raw)) if raw.size else np.ones(raw.shape, bool)
        if not ok.all():
            f = int(np.flatnonzero(~ok.all(axis=1))[0])
            raise MeshError(f"{label} faces must hold integer node indices; face {f} is {raw[f].tolist()}")
        fc = raw.astype(np.int64)
    else:
        raise MeshError(f"{label} faces must hold integer node indices, got dtype {raw.dtype}")
    bad = (fc < 0) | (fc >= n_points)
    if bad.any():
        rows = np.flatnonzero(bad.any(axis=1))
        f = int(rows[0])
        raise MeshError(
            f"{label} has {rows.size} face(s) with node indices out of range 0..{n_points - 1}, "
            f"e.g. face {f} = {fc[f].tolist()}"
        )
    return fc


def _merge_coincident(pts: np.ndarray, faces: np.ndarray, label: str) -> np.ndarray:
    """Remap faces so that coincident referenced points share one index.

    The representative of a group of coincident points is its smallest index,
    so messages keep the caller's numbering.
    """
    ref = _used_nodes(faces, pts.shape[0])
    p = pts[ref]
    diag = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    tol = MERGE_TOLERANCE * diag
    from scipy.spatial import cKDTree

    pairs = cKDTree(p).query_pairs(r=tol, output_type="ndarray")
    if len(pairs) == 0:
        return faces
    m = len(ref)
    graph = coo_matrix((np.ones(len(pairs), dtype=np.int8), (pairs[:, 0], pairs[:, 1])), shape=(m, m))
    n_comp, lab = connected_components(graph, directed=False)
    rep = np.full(n_comp, np.iinfo(np.int64).max, dtype=np.int64)
    np.minimum.at(rep, lab, ref)
    mapping = np.arange(pts.shape[0], dtype=np.int64)
    mapping[ref] = rep[lab]
    logger.info("%s: merged %d coincident point(s) (tolerance %.3g)", label, m - n_comp, tol)
    return mapping[faces]


def _used_nodes(faces: np.ndarray, n: int) -> np.ndarray:
    """Sorted indices of the nodes referenced by ``faces`` (faster than np.unique)."""
    return np.flatnonzero(np.bincount(faces.ravel(), minlength=n))


def _signed_volume(pts: np.ndarray, faces: np.ndarray) -> float:
    """The enclosed volume (:func:`~cortex_ti.surface.measures.enclosed_volume`) about the mean of the used nodes."""
    return enclosed_volume(pts, faces, origin=pts[_used_nodes(faces, pts.shape[0])].mean(axis=0))


def validate_mesh(points, faces, name: str = "mesh") -> Mesh:
    """Check a triangle surface and return it cleaned and outward oriented.

    Checks, in order (each failure raises :class:`MeshError` naming the
    problem with counts and an example node, edge or face):

    1. points finite ``(N, 3)``; faces integer ``(F, 3)`` with indices in range;
    2. coincident points (distance <= 1e-10 x bounding-box diagonal of the
       referenced points) are merged, so triangle soups (STL) are accepted;
    3. degenerate triangles: a repeated node or area < 1e-12 x mean area;
    4. duplicate faces (same three nodes, either orientation);
    5. closed and edge-manifold: each undirected edge in exactly two faces;
    6. vertex-manifold: the faces around each node form a single closed fan;
    7. consistent orientation: each directed edge occurs exactly once;
    8. a single connected component;
    9. outward orientation: if the signed enclosed volume is negative every
       face is reversed (logged at INFO); a (near-)zero volume is an error.

    Points not used by any face are dropped with a logged warning. Node and
    face numbers in error messages refer to the input arrays.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Node coordinates.
    faces : array_like, shape (F, 3)
        Triangles as node indices (any orientation, as long as consistent).
    name : str, optional
        Name used in messages (e.g. the file name).

    Returns
    -------
    Mesh
        Cleaned mesh: merged and unreferenced points removed (remaining nodes
        keep their relative order), faces in input order, outward oriented.

    Raises
    ------
    MeshError
        For any of the problems listed above.

    Examples
    --------
    >>> import numpy as np
    >>> tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    >>> validate_mesh(tet, [[0, 1, 2], [0, 1, 3], [1, 2, 3], [0, 2, 3]]).n_faces
    Traceback (most recent call last):
    ...
    cortex_ti.errors.MeshError: mesh is inconsistently oriented: faces 0 and 1 traverse edge (0, 1) ...
    >>> validate_mesh(tet, [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]).n_faces
    4
    """
    label = _label(str(name))
    pts = _as_points(points, label)
    n = pts.shape[0]
    if n > np.iinfo(np.int32).max:
        raise MeshError(f"{label} has {n} points; at most {np.iinfo(np.int32).max} are supported")
    fc0 = _as_faces(faces, n, label)
    fc = _merge_coincident(pts, fc0, label)
    areas = _check_degenerate(pts, fc, fc0, label)
    _check_duplicate_faces(fc, n, label)
    edges = _Edges.of(fc, n)
    _check_closed_manifold_edges(edges, label)
    _check_single_fans(edges, n, label)
    _check_consistent_orientation(edges, label)
    _check_connected(fc, edges, label)
    fc = _orient_outward(pts, fc, areas, label)
    return _drop_unreferenced(pts, fc, fc0, label)


def _check_degenerate(pts: np.ndarray, fc: np.ndarray, fc0: np.ndarray, label: str) -> np.ndarray:
    """Step 3: no triangle repeats a node or has near-zero area. Returns the face areas."""
    rep = (fc[:, 0] == fc[:, 1]) | (fc[:, 1] == fc[:, 2]) | (fc[:, 2] == fc[:, 0])
    if rep.any():
        idx = np.flatnonzero(rep)
        f = int(idx[0])
        merged = ""
        if not np.array_equal(fc[f], fc0[f]):
            merged = f" after merging coincident points (input {fc0[f].tolist()})"
        raise MeshError(
            f"{label} has {idx.size} degenerate triangle(s): face {f} = {fc[f].tolist()} "
            f"uses the same node twice{merged}"
        )
    areas = face_areas(pts, fc)
    mean_area = float(areas.mean())
    small = areas < DEGENERATE_AREA * mean_area
    if mean_area <= 0 or small.any():
        idx = np.flatnonzero(small) if mean_area > 0 else np.arange(fc.shape[0])
        f = int(idx[0])
        raise MeshError(
            f"{label} has {idx.size} degenerate triangle(s) with near-zero area: face {f} = "
            f"{fc[f].tolist()} has area {areas[f]:.3g} (mean face area {mean_area:.3g})"
        )
    return areas


def _check_duplicate_faces(fc: np.ndarray, n: int, label: str) -> None:
    """Step 4: no two faces connect the same three nodes."""
    sf = np.sort(fc, axis=1)
    if n < 2**20:
        fkey = (sf[:, 0] * n + sf[:, 1]) * n + sf[:, 2]
        order = np.argsort(fkey, kind="stable")
        same = fkey[order][1:] == fkey[order][:-1]
    else:
        order = np.lexsort((sf[:, 2], sf[:, 1], sf[:, 0]))
        s = sf[order]
        same = (s[1:] == s[:-1]).all(axis=1)
    if same.any():
        i = int(np.flatnonzero(same)[0])
        f1, f2 = sorted((int(order[i]), int(order[i + 1])))
        raise MeshError(
            f"{label} has {int(same.sum())} duplicate face(s): faces {f1} and {f2} both connect nodes {sf[f1].tolist()}"
        )


@dataclass(frozen=True)
class _Edges:
    """The half-edges ``h = 3 f + k`` (``faces[f, k] -> faces[f, k+1]``) matched into undirected edges."""

    n: int  # number of nodes (edge keys are lo * n + hi)
    heads: np.ndarray  # (3F,) start node of each half-edge
    tails: np.ndarray  # (3F,) end node
    eid: np.ndarray  # (3F,) undirected edge of each half-edge
    key: np.ndarray  # (E,) lo * n + hi of each undirected edge
    count: np.ndarray  # (E,) half-edges per undirected edge
    order: np.ndarray  # half-edges sorted by edge key
    start: np.ndarray  # (E,) first position of each edge in ``order``

    @classmethod
    def of(cls, fc: np.ndarray, n: int) -> _Edges:
        heads = fc.ravel()
        tails = fc[:, [1, 2, 0]].ravel()
        ukey = np.minimum(heads, tails) * n + np.maximum(heads, tails)
        order = np.argsort(ukey, kind="stable")
        sk = ukey[order]
        start = np.flatnonzero(np.r_[True, sk[1:] != sk[:-1]])
        count = np.diff(np.r_[start, sk.size])
        eid = np.empty(sk.size, dtype=np.int64)
        eid[order] = np.repeat(np.arange(start.size), count)
        return cls(n, heads, tails, eid, sk[start], count, order, start)

    def nodes(self, e: int) -> tuple[int, int]:
        return int(self.key[e] // self.n), int(self.key[e] % self.n)


def _check_closed_manifold_edges(edges: _Edges, label: str) -> None:
    """Step 5: every undirected edge belongs to exactly two faces."""
    if (edges.count > 2).any():
        bad = np.flatnonzero(edges.count > 2)
        e = int(bad[0])
        a, b = edges.nodes(e)
        fl = sorted(int(h) // 3 for h in edges.order[edges.start[e] : edges.start[e] + edges.count[e]])
        raise MeshError(
            f"{label} is not manifold (edge shared by {edges.count[e]} faces): {bad.size} edge(s) "
            f"belong to more than two faces, e.g. edge ({a}, {b}) in faces {fl}"
        )
    if (edges.count == 1).any():
        bad = np.flatnonzero(edges.count == 1)
        e = int(bad[0])
        a, b = edges.nodes(e)
        raise MeshError(
            f"{label} is not closed: {bad.size} boundary edge(s) (in only one face), "
            f"e.g. between nodes {a} and {b} (face {int(edges.order[edges.start[e]]) // 3})"
        )


def _check_single_fans(edges: _Edges, n: int, label: str) -> None:
    """Step 6 (vertex-manifold): the faces around each node form one closed fan.

    Link-graph nodes are the half-edges v->a (two per undirected edge: 2e for lo->hi, 2e+1 for
    hi->lo); the corner of face f at v joins v->x and v->y."""
    heads, tails, eid = edges.heads, edges.tails, edges.eid
    direction = (heads > tails).astype(np.int64)  # 0 if heads is the low end
    out_id = 2 * eid + direction  # link node (head -> tail) of half-edge h
    prev_h = (np.arange(heads.size).reshape(-1, 3)[:, [2, 0, 1]]).ravel()
    in_id = 2 * eid[prev_h] + (1 - direction[prev_h])  # link node (head -> previous node)
    n_link = 2 * edges.key.size
    graph = coo_matrix((np.ones(out_id.size, dtype=np.int8), (out_id, in_id)), shape=(n_link, n_link))
    n_comp, lab = connected_components(graph, directed=False)
    link_vertex = np.empty(n_link, dtype=np.int64)
    link_vertex[0::2] = edges.key // n
    link_vertex[1::2] = edges.key % n
    comp_vertex = np.empty(n_comp, dtype=np.int64)
    comp_vertex[lab] = link_vertex
    fans = np.bincount(comp_vertex, minlength=n)
    if (fans > 1).any():
        bad = np.flatnonzero(fans > 1)
        v = int(bad[0])
        raise MeshError(
            f"{label} is not manifold at node {v}: its faces form {fans[v]} separate fans "
            f"({bad.size} such node(s); e.g. two surfaces touching at a single point)"
        )


def _check_consistent_orientation(edges: _Edges, label: str) -> None:
    """Step 7: each directed edge occurs exactly once."""
    n = edges.n
    dkey = edges.heads * n + edges.tails
    dorder = np.argsort(dkey, kind="stable")
    dsk = dkey[dorder]
    dup = np.flatnonzero(dsk[1:] == dsk[:-1])
    if dup.size:
        i = int(dup[0])
        f1, f2 = sorted((int(dorder[i]) // 3, int(dorder[i + 1]) // 3))
        a, b = int(dsk[i] // n), int(dsk[i] % n)
        raise MeshError(
            f"{label} is inconsistently oriented: faces {f1} and {f2} traverse edge ({a}, {b}) "
            f"in the same direction ({dup.size} such edge(s); the surface may be non-orientable "
            "or some faces are flipped)"
        )


def _check_connected(fc: np.ndarray, edges: _Edges, label: str) -> None:
    """Step 8: a single connected component."""
    n = edges.n
    used = _used_nodes(fc, n)
    adj = coo_matrix((np.ones(edges.key.size, dtype=np.int8), (edges.key // n, edges.key % n)), shape=(n, n))
    _, vlab = connected_components(adj, directed=False)
    comps, sizes = np.unique(vlab[used], return_counts=True)
    if comps.size > 1:
        desc = ", ".join(str(int(s)) for s in sorted(sizes, reverse=True)[:5])
        more = ", ..." if comps.size > 5 else ""
        raise MeshError(
            f"{label} has {comps.size} separate surfaces (with {desc}{more} nodes); "
            "cortex-ti simulates one closed surface"
        )


def _orient_outward(pts: np.ndarray, fc: np.ndarray, areas: np.ndarray, label: str) -> np.ndarray:
    """Step 9: faces reversed if the enclosed volume is negative; no volume is an error."""
    volume = _signed_volume(pts, fc)
    area = float(areas.sum())
    if abs(volume) <= FLAT_VOLUME * area**1.5:
        raise MeshError(
            f"{label} encloses no volume: signed volume {volume:.3g} for surface area {area:.3g}; "
            "the surface is flat or folded onto itself"
        )
    if volume < 0:
        logger.info("%s: faces were oriented inward (volume %.6g); reversed all faces", label, volume)
        return fc[:, [0, 2, 1]]
    return fc


def _drop_unreferenced(pts: np.ndarray, fc: np.ndarray, fc0: np.ndarray, label: str) -> Mesh:
    """The cleaned mesh without the points no face uses (logged)."""
    n = pts.shape[0]
    orphan = np.flatnonzero(np.bincount(fc0.ravel(), minlength=n) == 0)
    if orphan.size:
        logger.warning(
            "%s: dropped %d point(s) not used by any face (e.g. node %d)", label, orphan.size, int(orphan[0])
        )
    used = _used_nodes(fc, n)
    lookup = np.full(n, -1, dtype=np.int64)
    lookup[used] = np.arange(used.size)
    return Mesh(points=pts[used], faces=lookup[fc])
