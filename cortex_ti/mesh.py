"""Closed triangulated surfaces: construction, loading, validation and connectivity.

The cortex is represented by a closed, orientable, vertex-manifold triangle
mesh with a single connected component. Every face is oriented so that the
right-hand rule gives the **outward** normal (signed enclosed volume > 0).

Public API
----------
Mesh, Topology
    Frozen containers for the surface and its one-/two-ring connectivity.
icosphere_sizes, icosphere
    Subdivided icosahedra with ``N = 10 * 4**k + 2`` nodes.
load_mesh
    Read any surface format meshio understands, then :func:`validate_mesh`.
validate_mesh
    Check and clean raw ``points``/``faces`` arrays; every problem raises
    :class:`~cortex_ti.errors.MeshError` with a concrete message.
build_topology
    Counter-clockwise ordered one-rings and two-rings (vectorised).
affine
    Apply ``x -> A x + b`` while keeping the faces outward.

All heavy work is vectorised numpy / scipy (sort-based edge matching, sparse
connected components); there are no Python loops over faces or nodes.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import warnings
from dataclasses import dataclass

import numpy as np

from .errors import MeshError

__all__ = [
    "Mesh",
    "Topology",
    "icosphere_sizes",
    "icosphere",
    "load_mesh",
    "read_meshio",
    "validate_mesh",
    "build_topology",
    "affine",
    "vertex_normals",
]

logger = logging.getLogger(__name__)

#: Points closer than this fraction of the bounding-box diagonal are merged.
MERGE_TOLERANCE = 1e-10
#: A face with area below this fraction of the mean face area is degenerate.
DEGENERATE_AREA = 1e-12
#: |enclosed volume| below this fraction of area**1.5 counts as "no volume".
FLAT_VOLUME = 1e-9
#: Largest subdivision level :func:`icosphere` accepts (10 * 4**10 + 2 nodes).
MAX_ICOSPHERE_LEVEL = 10


# ---------------------------------------------------------------------------
# containers
# ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Mesh:
    """A closed triangulated surface.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Node coordinates; stored as C-contiguous float64.
    faces : ndarray, shape (F, 3)
        Node indices of each triangle; stored as C-contiguous int32. The
        right-hand rule applied to ``(faces[f, 0], faces[f, 1], faces[f, 2])``
        gives the outward normal.

    Notes
    -----
    The constructor only normalises dtypes and checks array shapes. Use
    :func:`validate_mesh` (or :func:`load_mesh`, :func:`icosphere`) to obtain a
    mesh that is guaranteed closed, manifold, connected and outward oriented.
    Equality and hashing are by identity (``eq=False``), since numpy arrays
    have no truth value for ``==``.
    """

    points: np.ndarray
    faces: np.ndarray

    def __post_init__(self) -> None:
        try:
            points = np.ascontiguousarray(self.points, dtype=np.float64)
            faces = np.ascontiguousarray(self.faces, dtype=np.int32)
        except (TypeError, ValueError, OverflowError) as exc:
            raise MeshError(f"Mesh needs a numeric points array and an integer faces array: {exc}") from None
        if points.ndim != 2 or points.shape[1] != 3:
            raise MeshError(f"Mesh points must have shape (N, 3), got {points.shape}")
        if faces.ndim != 2 or faces.shape[1] != 3:
            raise MeshError(f"Mesh faces must have shape (F, 3), got {faces.shape}")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "faces", faces)

    @property
    def n_nodes(self) -> int:
        """Number of nodes ``N``."""
        return int(self.points.shape[0])

    @property
    def n_faces(self) -> int:
        """Number of triangles ``F`` (``F = 2N - 4`` for a closed sphere-like surface)."""
        return int(self.faces.shape[0])


@dataclass(frozen=True, eq=False)
class Topology:
    """One- and two-ring connectivity of a validated :class:`Mesh`.

    Attributes
    ----------
    ring : ndarray, shape (N, max_valence), int32
        One-ring neighbours of each node, ordered counter-clockwise seen from
        outside, starting at the neighbour with the smallest index, padded with
        -1. For node ``v`` with ring ``[a_0, ..., a_{k-1}]`` every consecutive
        pair ``(a_i, a_{(i+1) % k})`` is a face whose oriented vertex order is a
        cyclic rotation of ``(v, a_i, a_{i+1})``.
    valence : ndarray, shape (N,), int32
        Number of neighbours (= number of faces) of each node.
    ring2 : ndarray, shape (N, max_ring2), int32
        All nodes within graph distance 2, node itself excluded: first the
        one-ring in ring order, then the second ring in order of discovery
        (neighbours of ``a_0`` in ``a_0``'s ring order, then of ``a_1``, ...),
        padded with -1.
    ring2_size : ndarray, shape (N,), int32
        Number of valid entries in each row of ``ring2``.
    """

    ring: np.ndarray
    valence: np.ndarray
    ring2: np.ndarray
    ring2_size: np.ndarray


# ---------------------------------------------------------------------------
# icosphere
# ---------------------------------------------------------------------------


def icosphere_sizes(max_level: int = 7) -> list[int]:
    """Node counts of icospheres for subdivision levels ``0..max_level``.

    Parameters
    ----------
    max_level : int, optional
        Highest subdivision level included.

    Returns
    -------
    list of int
        ``[10 * 4**k + 2 for k in range(max_level + 1)]``, i.e.
        ``[12, 42, 162, 642, 2562, 10242, 40962, 163842]`` for the default.
    """
    return [10 * 4**k + 2 for k in range(int(max_level) + 1)]


def _icosahedron() -> tuple[np.ndarray, np.ndarray]:
    """Unit regular icosahedron with outward faces."""
    phi = (1.0 + np.sqrt(5.0)) / 2.0
    pts = np.array(
        [
            [-1, phi, 0], [1, phi, 0], [-1, -phi, 0], [1, -phi, 0],
            [0, -1, phi], [0, 1, phi], [0, -1, -phi], [0, 1, -phi],
            [phi, 0, -1], [phi, 0, 1], [-phi, 0, -1], [-phi, 0, 1],
        ],
        dtype=np.float64,
    )
    pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    faces = np.array(
        [
            [0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
            [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
            [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
            [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1],
        ],
        dtype=np.int64,
    )
    # enforce outward orientation face by face (normal . centroid > 0)
    p = pts[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    inward = np.einsum("ij,ij->i", normal, p.sum(axis=1)) < 0
    faces[inward] = faces[inward][:, [0, 2, 1]]
    return pts, faces


def _subdivide(pts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One midpoint subdivision on the unit sphere (each face -> 4 faces)."""
    n = pts.shape[0]
    a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
    lo = np.minimum(np.stack([a, b, c], axis=1), np.stack([b, c, a], axis=1))
    hi = np.maximum(np.stack([a, b, c], axis=1), np.stack([b, c, a], axis=1))
    keys = (lo * n + hi).ravel()
    ukeys, inv = np.unique(keys, return_inverse=True)
    mid = pts[ukeys // n] + pts[ukeys % n]
    mid /= np.linalg.norm(mid, axis=1, keepdims=True)
    m = (inv.reshape(-1, 3) + n)  # midpoints of edges ab, bc, ca
    ab, bc, ca = m[:, 0], m[:, 1], m[:, 2]
    new_faces = np.stack(
        [
            np.stack([a, ab, ca], axis=1),
            np.stack([b, bc, ab], axis=1),
            np.stack([c, ca, bc], axis=1),
            np.stack([ab, bc, ca], axis=1),
        ],
        axis=1,
    ).reshape(-1, 3)
    return np.vstack([pts, mid]), new_faces


def icosphere(n_nodes: int, radius: float = 1.0) -> Mesh:
    """Subdivided regular icosahedron projected onto a sphere.

    The icosahedron is subdivided ``k`` times by edge midpoints; each new
    point is projected onto the unit sphere, and the result is scaled by
    ``radius``. Node ordering is deterministic: the 12 icosahedron vertices
    come first (valence 5), then the midpoints of each level in order of their
    sorted edge keys (valence 6). Faces are outward oriented.

    Parameters
    ----------
    n_nodes : int
        Number of nodes, ``10 * 4**k + 2`` with ``0 <= k <= 10``
        (see :func:`icosphere_sizes`).
    radius : float, optional
        Sphere radius, positive and finite.

    Returns
    -------
    Mesh
        ``n_nodes`` nodes and ``2 * n_nodes - 4`` faces.

    Raises
    ------
    MeshError
        If ``n_nodes`` is not a valid icosphere size or ``radius`` is not a
        positive finite number.
    """
    valid = icosphere_sizes(MAX_ICOSPHERE_LEVEL)
    try:
        ok = float(n_nodes) == int(n_nodes) and not isinstance(n_nodes, bool)
        n = int(n_nodes)
    except (TypeError, ValueError, OverflowError):
        ok, n = False, -1
    if not ok or n not in valid:
        shown = ", ".join(str(s) for s in icosphere_sizes(7))
        raise MeshError(
            f"invalid icosphere node count {n_nodes!r}: the number of nodes must be "
            f"10 * 4**k + 2, i.e. one of {shown} (up to {valid[-1]})"
        )
    try:
        r = float(radius)
    except (TypeError, ValueError):
        r = float("nan")
    if not (np.isfinite(r) and r > 0):
        raise MeshError(f"invalid icosphere radius {radius!r}: must be a positive finite number")
    level = valid.index(n)
    pts, faces = _icosahedron()
    for _ in range(level):
        pts, faces = _subdivide(pts, faces)
    pts = pts / np.linalg.norm(pts, axis=1, keepdims=True) * r
    return Mesh(points=pts, faces=faces)


# ---------------------------------------------------------------------------
# loading
# ---------------------------------------------------------------------------


def read_meshio(path):
    """Read any file meshio understands and return the ``meshio.Mesh``, quietly.

    meshio prints diagnostics and may call ``sys.exit()`` on a failed read; both are caught
    here and turned into one :class:`MeshError` naming the file and meshio's reason.
    (Used by :func:`load_mesh` and by the ``field`` active-stress pattern.)
    """
    import meshio  # local import: only needed for files

    name = os.fspath(path)
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = meshio.read(name)
    except (Exception, SystemExit) as exc:
        printed = " ".join((out.getvalue() + " " + err.getvalue()).replace("Error:", " ").split())
        reason = f"{type(exc).__name__}: {str(exc).strip()}" if isinstance(exc, Exception) else ""
        reason = "; ".join(r for r in (reason, printed) if r) or "meshio gave no reason"
        raise MeshError(
            f"cannot read mesh file '{name}': {reason} (is the file extension right and the file intact?)"
        ) from None
    if out.getvalue().strip() or err.getvalue().strip():
        logger.debug("meshio output while reading %s: %s", name, out.getvalue() + err.getvalue())
    return m


def load_mesh(path) -> Mesh:
    """Read a closed triangle surface from any file format meshio can read.

    Parameters
    ----------
    path : str or os.PathLike
        Mesh file (``.obj``, ``.ply``, ``.stl``, ``.vtu``, ``.off``, ``.msh``, ...).

    Returns
    -------
    Mesh
        The cleaned, validated, outward-oriented surface (see
        :func:`validate_mesh`; the file name is used in error messages).

    Raises
    ------
    MeshError
        If the file does not exist, cannot be read, contains cells other than
        triangles, contains no triangles, or fails :func:`validate_mesh`.
    """
    name = os.fspath(path)
    if not os.path.exists(name):
        raise MeshError(f"mesh file '{name}' does not exist")
    if os.path.isdir(name):
        raise MeshError(f"mesh file '{name}' is a directory, not a file")
    m = read_meshio(name)

    counts: dict[str, int] = {}
    triangles = []
    for block in m.cells:
        counts[block.type] = counts.get(block.type, 0) + len(block.data)
        if block.type == "triangle":
            triangles.append(np.asarray(block.data))
    other = {t: c for t, c in counts.items() if t != "triangle" and c > 0}
    if other:
        desc = ", ".join(f"{c} {t}" for t, c in other.items())
        raise MeshError(
            f"mesh '{name}' contains non-triangle cells ({desc}); "
            "cortex-ti needs a surface made only of triangles"
        )
    if not triangles or sum(len(t) for t in triangles) == 0:
        raise MeshError(f"mesh '{name}' contains no triangles")
    faces = np.concatenate(triangles, axis=0)
    return validate_mesh(m.points, faces, name=name)


# ---------------------------------------------------------------------------
# validation
# ---------------------------------------------------------------------------


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
            f"{label} has {idx.size} non-finite point(s) (NaN or inf), "
            f"e.g. node {idx[0]} at {pts[idx[0]].tolist()}"
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
        raise MeshError(
            f"{label} faces have {raw.shape[1]} nodes each; only triangles (3 nodes) are supported"
        )
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
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

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


def _face_areas(pts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    p0, p1, p2 = pts[faces[:, 0]], pts[faces[:, 1]], pts[faces[:, 2]]
    return 0.5 * np.linalg.norm(np.cross(p1 - p0, p2 - p0), axis=1)


def vertex_normals(points, faces) -> np.ndarray:
    """Unit normals at the nodes: the sum of the (area-weighted) normals of the adjacent faces.

    A cheap normal for post-processing (plots, velocity profiles of stored frames); the solver
    uses the angle-weighted normal and the fitted surface of :mod:`cortex_ti.geometry`. For
    outward-oriented faces the normals point outward.
    """
    pts = np.asarray(points, dtype=float)
    f = np.asarray(faces)
    fn = np.cross(pts[f[:, 1]] - pts[f[:, 0]], pts[f[:, 2]] - pts[f[:, 0]])   # 2 * area * unit normal
    acc = np.zeros_like(pts)
    for k in range(3):
        np.add.at(acc, f[:, k], fn)
    norm = np.linalg.norm(acc, axis=1, keepdims=True)
    return acc / np.where(norm > 0.0, norm, 1.0)


def _signed_volume(pts: np.ndarray, faces: np.ndarray) -> float:
    used = _used_nodes(faces, pts.shape[0])
    c = pts[used].mean(axis=0)
    p0, p1, p2 = pts[faces[:, 0]] - c, pts[faces[:, 1]] - c, pts[faces[:, 2]] - c
    return float(np.einsum("ij,ij->", p0, np.cross(p1, p2)) / 6.0)


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
    """
    label = _label(str(name))
    pts = _as_points(points, label)
    n = pts.shape[0]
    if n > np.iinfo(np.int32).max:
        raise MeshError(f"{label} has {n} points; at most {np.iinfo(np.int32).max} are supported")
    fc0 = _as_faces(faces, n, label)
    n_faces = fc0.shape[0]

    # --- merge coincident points (triangle soups) ---------------------------
    fc = _merge_coincident(pts, fc0, label)

    # --- degenerate triangles ------------------------------------------------
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
    areas = _face_areas(pts, fc)
    mean_area = float(areas.mean())
    small = areas < DEGENERATE_AREA * mean_area
    if mean_area <= 0 or small.any():
        idx = np.flatnonzero(small) if mean_area > 0 else np.arange(n_faces)
        f = int(idx[0])
        raise MeshError(
            f"{label} has {idx.size} degenerate triangle(s) with near-zero area: face {f} = "
            f"{fc[f].tolist()} has area {areas[f]:.3g} (mean face area {mean_area:.3g})"
        )

    # --- duplicate faces -------------------------------------------------------
    sf = np.sort(fc, axis=1)
    fkey = (sf[:, 0] * n + sf[:, 1]) * n + sf[:, 2] if n < 2**20 else None
    if fkey is not None:
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
            f"{label} has {int(same.sum())} duplicate face(s): faces {f1} and {f2} both connect "
            f"nodes {sf[f1].tolist()}"
        )

    # --- edges: closed and edge-manifold ---------------------------------------
    heads = fc.ravel()                      # half-edge h = 3 f + k: faces[f, k] -> faces[f, k+1]
    tails = fc[:, [1, 2, 0]].ravel()
    lo = np.minimum(heads, tails)
    hi = np.maximum(heads, tails)
    ukey = lo * n + hi
    order = np.argsort(ukey, kind="stable")
    sk = ukey[order]
    start = np.flatnonzero(np.r_[True, sk[1:] != sk[:-1]])
    counts = np.diff(np.r_[start, sk.size])
    n_edges = start.size
    eid_sorted = np.repeat(np.arange(n_edges), counts)
    eid = np.empty_like(eid_sorted)
    eid[order] = eid_sorted                 # undirected edge id of each half-edge
    ekey = sk[start]
    if (counts > 2).any():
        bad = np.flatnonzero(counts > 2)
        e = int(bad[0])
        a, b = int(ekey[e] // n), int(ekey[e] % n)
        fl = sorted(int(h) // 3 for h in order[start[e]:start[e] + counts[e]])
        raise MeshError(
            f"{label} is not manifold (edge shared by {counts[e]} faces): {bad.size} edge(s) "
            f"belong to more than two faces, e.g. edge ({a}, {b}) in faces {fl}"
        )
    if (counts == 1).any():
        bad = np.flatnonzero(counts == 1)
        e = int(bad[0])
        a, b = int(ekey[e] // n), int(ekey[e] % n)
        raise MeshError(
            f"{label} is not closed: {bad.size} boundary edge(s) (in only one face), "
            f"e.g. between nodes {a} and {b} (face {int(order[start[e]]) // 3})"
        )

    # --- vertex-manifold: one closed fan of faces per node ----------------------
    # Link-graph nodes are the half-edges v->a (two per undirected edge: 2e for
    # lo->hi, 2e+1 for hi->lo); the corner of face f at v joins v->x and v->y.
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    direction = (heads > tails).astype(np.int64)            # 0 if heads is the low end
    out_id = 2 * eid + direction                             # link node (head -> tail) of half-edge h
    prev_h = (np.arange(3 * n_faces).reshape(-1, 3)[:, [2, 0, 1]]).ravel()
    in_id = 2 * eid[prev_h] + (1 - direction[prev_h])        # link node (head -> previous node)
    n_link = 2 * n_edges
    graph = coo_matrix((np.ones(out_id.size, dtype=np.int8), (out_id, in_id)), shape=(n_link, n_link))
    n_comp, lab = connected_components(graph, directed=False)
    link_vertex = np.empty(n_link, dtype=np.int64)
    link_vertex[0::2] = ekey // n
    link_vertex[1::2] = ekey % n
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

    # --- consistent orientation ------------------------------------------------
    dkey = heads * n + tails
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

    # --- single connected component --------------------------------------------
    used = _used_nodes(fc, n)
    adj = coo_matrix((np.ones(n_edges, dtype=np.int8), (ekey // n, ekey % n)), shape=(n, n))
    _, vlab = connected_components(adj, directed=False)
    comps, sizes = np.unique(vlab[used], return_counts=True)
    if comps.size > 1:
        desc = ", ".join(str(int(s)) for s in sorted(sizes, reverse=True)[:5])
        more = ", ..." if comps.size > 5 else ""
        raise MeshError(
            f"{label} has {comps.size} separate surfaces (with {desc}{more} nodes); "
            "cortex-ti simulates one closed surface"
        )

    # --- outward orientation ---------------------------------------------------
    volume = _signed_volume(pts, fc)
    area = float(areas.sum())
    if abs(volume) <= FLAT_VOLUME * area**1.5:
        raise MeshError(
            f"{label} encloses no volume: signed volume {volume:.3g} for surface area {area:.3g}; "
            "the surface is flat or folded onto itself"
        )
    if volume < 0:
        logger.info("%s: faces were oriented inward (volume %.6g); reversed all faces", label, volume)
        fc = fc[:, [0, 2, 1]]

    # --- drop unreferenced points -------------------------------------------------
    orphan = np.flatnonzero(np.bincount(fc0.ravel(), minlength=n) == 0)
    unref = orphan.size
    if unref:
        logger.warning(
            "%s: dropped %d point(s) not used by any face (e.g. node %d)", label, unref, int(orphan[0])
        )
    lookup = np.full(n, -1, dtype=np.int64)
    lookup[used] = np.arange(used.size)
    return Mesh(points=pts[used], faces=lookup[fc])


# ---------------------------------------------------------------------------
# topology
# ---------------------------------------------------------------------------


def build_topology(mesh: Mesh) -> Topology:
    """Counter-clockwise one-rings and two-rings of every node.

    Parameters
    ----------
    mesh : Mesh
        A validated mesh (closed, vertex-manifold, consistently oriented, no
        unreferenced nodes), e.g. from :func:`validate_mesh`.

    Returns
    -------
    Topology
        See :class:`Topology` for the ordering contract. Each ring starts at
        the neighbour with the smallest node index, so the result depends only
        on the mesh, not on the order of the faces.

    Raises
    ------
    MeshError
        If the mesh violates the assumptions (unreferenced node, repeated
        directed edge, open or multi-fan neighbourhood); run
        :func:`validate_mesh` first.
    """
    faces = mesh.faces.astype(np.int64)
    n = mesh.n_nodes
    # corner (v, x, y) of face rotation: successor of x in v's ring is y
    cv = faces.T.ravel()
    cx = faces[:, [1, 2, 0]].T.ravel()
    cy = faces[:, [2, 0, 1]].T.ravel()
    valence = np.bincount(cv, minlength=n)
    if n == 0 or (valence == 0).any():
        v = int(np.flatnonzero(valence == 0)[0]) if n else 0
        raise MeshError(f"cannot build topology: node {v} belongs to no face (run validate_mesh first)")
    key = cv * n + cx
    order = np.argsort(key, kind="stable")
    skey = key[order]
    if (skey[1:] == skey[:-1]).any():
        i = int(np.flatnonzero(skey[1:] == skey[:-1])[0])
        raise MeshError(
            f"cannot build topology: directed edge ({skey[i] // n}, {skey[i] % n}) occurs twice "
            "(mesh inconsistently oriented; run validate_mesh first)"
        )
    nkey = cv * n + cy
    pos = np.searchsorted(skey, nkey)
    pos_c = np.minimum(pos, skey.size - 1)
    found = skey[pos_c] == nkey
    if not found.all():
        c = int(np.flatnonzero(~found)[0])
        raise MeshError(
            f"cannot build topology: the faces around node {cv[c]} do not close at neighbour {cy[c]} "
            "(mesh not closed; run validate_mesh first)"
        )
    nxt = order[pos_c]                       # corner following each corner around its node
    first = np.r_[0, np.cumsum(valence)[:-1]]
    start = order[first]                     # corner with the smallest neighbour index
    max_val = int(valence.max())
    ring = np.full((n, max_val), -1, dtype=np.int64)
    ring[:, 0] = cx[start]
    cur = start
    closed_ok = np.zeros(n, dtype=bool)
    for k in range(1, max_val + 1):
        cur = nxt[cur]
        back = cur == start
        active = k < valence
        if (back & active).any():
            v = int(np.flatnonzero(back & active)[0])
            raise MeshError(
                f"cannot build topology: the faces around node {v} form more than one fan "
                "(not manifold; run validate_mesh first)"
            )
        closed_ok |= (k == valence) & back
        if k < max_val:
            ring[active, k] = cx[cur[active]]
    if not closed_ok.all():
        v = int(np.flatnonzero(~closed_ok)[0])
        raise MeshError(
            f"cannot build topology: the faces around node {v} do not form a single closed fan "
            "(run validate_mesh first)"
        )

    ring2, ring2_size = _two_ring(ring, n)
    return Topology(
        ring=np.ascontiguousarray(ring, dtype=np.int32),
        valence=valence.astype(np.int32),
        ring2=np.ascontiguousarray(ring2, dtype=np.int32),
        ring2_size=ring2_size.astype(np.int32),
    )


def _two_ring(ring: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Ordered, de-duplicated two-ring from the one-ring table (vectorised)."""
    max_val = ring.shape[1]
    padded = np.vstack([ring, np.full((1, max_val), -1, dtype=ring.dtype)])  # index -1 -> row of -1
    second = padded[ring].reshape(n, max_val * max_val)
    cand = np.concatenate([ring, second], axis=1)
    sentinel = n
    cand = np.where((cand < 0) | (cand == np.arange(n)[:, None]), sentinel, cand)
    srt = np.argsort(cand, axis=1, kind="stable")
    vals = np.take_along_axis(cand, srt, axis=1)
    keep_sorted = np.ones(vals.shape, dtype=bool)
    keep_sorted[:, 1:] = vals[:, 1:] != vals[:, :-1]      # stable sort: first occurrence kept
    keep_sorted &= vals != sentinel
    keep = np.empty_like(keep_sorted)
    np.put_along_axis(keep, srt, keep_sorted, axis=1)
    size = keep.sum(axis=1)
    width = int(size.max())
    pick = np.argsort(~keep, axis=1, kind="stable")[:, :width]
    ring2 = np.take_along_axis(cand, pick, axis=1)
    ring2[np.arange(width)[None, :] >= size[:, None]] = -1
    return ring2, size


# ---------------------------------------------------------------------------
# affine maps
# ---------------------------------------------------------------------------


def affine(mesh: Mesh, matrix, offset=(0.0, 0.0, 0.0)) -> Mesh:
    """Apply the affine map ``x -> matrix @ x + offset`` to every node.

    Parameters
    ----------
    mesh : Mesh
        Input surface (outward oriented).
    matrix : array_like, shape (3, 3)
        Linear part; must be finite and non-singular.
    offset : array_like, shape (3,), optional
        Translation.

    Returns
    -------
    Mesh
        New mesh with ``points @ matrix.T + offset``. If ``det(matrix) < 0``
        (a reflection) each face is reversed so the normals stay outward.

    Raises
    ------
    MeshError
        If ``matrix`` is not a finite non-singular 3 x 3 matrix or ``offset``
        is not a finite 3-vector.
    """
    try:
        a = np.array(matrix, dtype=np.float64)
        b = np.array(offset, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise MeshError(f"affine map needs a numeric 3x3 matrix and 3-vector offset: {exc}") from None
    if a.shape != (3, 3) or not np.isfinite(a).all():
        raise MeshError(f"affine matrix must be a finite 3x3 array, got shape {a.shape}")
    if b.shape != (3,) or not np.isfinite(b).all():
        raise MeshError(f"affine offset must be a finite 3-vector, got shape {b.shape}")
    det = float(np.linalg.det(a))
    scale = float(np.abs(a).max()) ** 3
    if not abs(det) > 1e-12 * scale:
        raise MeshError(f"affine matrix is singular (det = {det:.3g}); it would flatten the mesh")
    pts = mesh.points @ a.T + b
    faces = mesh.faces[:, [0, 2, 1]] if det < 0 else mesh.faces.copy()
    return Mesh(points=pts, faces=faces)
