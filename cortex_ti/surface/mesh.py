"""Closed triangulated surfaces: the :class:`Mesh` container, icospheres, affine maps.

The cortex is a closed, orientable, vertex-manifold triangle mesh with a single connected
component, every face oriented so that the right-hand rule gives the **outward** normal
(signed enclosed volume > 0). :func:`icosphere` builds such meshes directly; a user's mesh is
read by :func:`cortex_ti.surface.reading.load_mesh` and checked by
:func:`cortex_ti.surface.validation.validate_mesh`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MeshError

__all__ = [
    "Mesh",
    "icosphere_sizes",
    "icosphere",
    "affine",
    "vertex_normals",
    "per_connectivity",
    "MAX_ICOSPHERE_LEVEL",
]

#: Largest subdivision level :func:`icosphere` accepts (10 * 4**10 + 2 nodes).
MAX_ICOSPHERE_LEVEL = 10


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

    Examples
    --------
    >>> icosphere_sizes(4)
    [12, 42, 162, 642, 2562]
    """
    return [10 * 4**k + 2 for k in range(int(max_level) + 1)]


def _icosahedron() -> tuple[np.ndarray, np.ndarray]:
    """Unit regular icosahedron with outward faces."""
    phi = (1.0 + np.sqrt(5.0)) / 2.0
    pts = np.array(
        [
            [-1, phi, 0],
            [1, phi, 0],
            [-1, -phi, 0],
            [1, -phi, 0],
            [0, -1, phi],
            [0, 1, phi],
            [0, -1, -phi],
            [0, 1, -phi],
            [phi, 0, -1],
            [phi, 0, 1],
            [-phi, 0, -1],
            [-phi, 0, 1],
        ],
        dtype=np.float64,
    )
    pts /= np.linalg.norm(pts, axis=1, keepdims=True)
    faces = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ],
        dtype=np.int64,
    )
    # enforce outward orientation face by face (normal . centroid > 0)
    p = pts[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    inward = np.einsum("ij,ij->i", normal, p.sum(axis=1)) < 0
    faces[inward] = faces[inward][:, [0, 2, 1]]
    return pts, faces


def split_faces(faces: np.ndarray, n_nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """The 1-to-4 split of a triangulation: its edges (E, 2), sorted (the new node ``n_nodes + e`` is
    edge e's midpoint), and the new triangles, each old face ``(a, b, c)`` with its midpoints ``ab, bc,
    ca`` becoming ``(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)`` in this order (the layout the
    curved cells read back, :func:`cortex_ti.surface.curved.p2_cells`)."""
    n = n_nodes
    a, b, c = faces[:, 0], faces[:, 1], faces[:, 2]
    lo = np.minimum(np.stack([a, b, c], axis=1), np.stack([b, c, a], axis=1))
    hi = np.maximum(np.stack([a, b, c], axis=1), np.stack([b, c, a], axis=1))
    keys = (lo.astype(np.int64) * n + hi).ravel()
    ukeys, inv = np.unique(keys, return_inverse=True)
    m = inv.reshape(-1, 3) + n  # midpoints of edges ab, bc, ca
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
    return np.stack([ukeys // n, ukeys % n], axis=1), new_faces


def _subdivide(pts: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One midpoint subdivision on the unit sphere (each face -> 4 faces)."""
    edges, new_faces = split_faces(faces, pts.shape[0])
    mid = pts[edges[:, 0]] + pts[edges[:, 1]]
    mid /= np.linalg.norm(mid, axis=1, keepdims=True)
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


def vertex_normals(points, faces) -> np.ndarray:
    """Unit normals at the nodes: the sum of the (area-weighted) normals of the adjacent faces.

    A cheap normal for post-processing (plots, velocity profiles of stored frames); the solver
    uses the angle-weighted normal and the fitted surface of :mod:`cortex_ti.surface.geometry`. For
    outward-oriented faces the normals point outward.
    """
    pts = np.asarray(points, dtype=float)
    f = np.asarray(faces)
    fn = np.cross(pts[f[:, 1]] - pts[f[:, 0]], pts[f[:, 2]] - pts[f[:, 0]])  # 2 * area * unit normal
    acc = np.zeros_like(pts)
    for k in range(3):
        np.add.at(acc, f[:, k], fn)
    norm = np.linalg.norm(acc, axis=1, keepdims=True)
    return acc / np.where(norm > 0.0, norm, 1.0)


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


def per_connectivity(cache: dict, faces: np.ndarray, n_nodes: int, make, keep: int):
    """What ``make()`` builds for one connectivity ``(faces, n_nodes)``, built once and kept in
    ``cache``: at most ``keep`` connectivities (a remeshing run moves on to new ones, the cache is
    then emptied).

    >>> cache = {}
    >>> m = icosphere(42)
    >>> a = per_connectivity(cache, m.faces, 42, object, keep=2)
    >>> per_connectivity(cache, m.faces.copy(), 42, object, keep=2) is a
    True
    """
    key = (n_nodes, np.shape(faces), hash(np.asarray(faces).tobytes()))
    if key not in cache:
        if len(cache) >= keep:
            cache.clear()
        cache[key] = make()
    return cache[key]
