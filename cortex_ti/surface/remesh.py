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
the curvature estimate, the closest-point query (:mod:`cortex_ti.surface.closest`), the repair of
the worst triangles after MMG (:mod:`cortex_ti.surface.quality`) and the volume offset; MMG does
the topology.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from ..errors import CortexError
from .closest import closest_points
from .measures import enclosed_volume as enclosed_volume_about
from .mesh import per_connectivity, vertex_normals
from .quality import flip_bad_edges, min_angles, repair, smooth_bad_vertices
from .transport import DENSITY, dual_areas

__all__ = [
    "RemeshOptions",
    "RemeshResult",
    "remesh",
    "remesh_available",
    "triangulate",
    "min_angles",
    "edge_curvature",
    "grade",
    "predicted_nodes",
    "budget_scale",
    "sizes",
    "node_coarseness",
    "BUDGET_RTOL",
    "RETRIES",
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

log = logging.getLogger(__name__)

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
    after MMG (edge flips and tangential smoothing of the worst triangles' nodes) aims at;
    ``min_angle``: the smallest angle (deg) the new mesh must have (a run's trigger
    ``mesh.remesh.min_angle``): below it MMG remeshes its own output again, at most :data:`RETRIES`
    times (:func:`_meet_angle`); None: one pass.
    """

    edge_angle: float = 0.25
    h_min: float | None = None
    h_max: float | None = None
    hausd: float | None = None
    hgrad: float = 1.3
    quality: float = 30.0
    nodes: int | None = None
    min_angle: float | None = None


#: how many more MMG passes (each from the last one's output) a new mesh below
#: ``RemeshOptions.min_angle`` gets
RETRIES = 2


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
    passes: int = 1  # MMG's passes: more than one when the first left an angle below options.min_angle


# ---------------------------------------------------------------------------
# geometry and the size field (the smallest angles and their repair: surface/quality.py)
# ---------------------------------------------------------------------------


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
    """The signed volume enclosed by outward-oriented triangles (:func:`.measures.enclosed_volume`
    about the origin; :func:`offset_to_volume` hands it points about their mean, to round-off the same
    volume on a closed surface)."""
    return enclosed_volume_about(points, faces, origin=np.zeros(3))


def restore_volume(points: np.ndarray, faces: np.ndarray, volume: float, rtol: float = 1e-14, max_iter: int = 20):
    r"""Offset every node by the same distance ``delta`` along its (fixed) normal so that the enclosed
    volume is ``volume``: Newton's method on the cubic ``V(delta)``. Returns ``(points, delta)``.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> p, d = restore_volume(m.points, m.faces, 4.0 * np.pi / 3.0)
    >>> bool(abs(enclosed_volume(p, m.faces) / (4.0 * np.pi / 3.0) - 1.0) < 1e-13)
    True
    """

    def measure(p: np.ndarray, n: np.ndarray) -> tuple[float, float]:
        x = p[faces]
        nf = n[faces]
        # dV/ddelta = sum_T (n_a . x_b x x_c + x_a . n_b x x_c + x_a . x_b x n_c) / 6
        dv = (
            np.einsum("tc,tc->", nf[:, 0], np.cross(x[:, 1], x[:, 2]))
            + np.einsum("tc,tc->", x[:, 0], np.cross(nf[:, 1], x[:, 2]))
            + np.einsum("tc,tc->", x[:, 0], np.cross(x[:, 1], nf[:, 2]))
        ) / 6.0
        return enclosed_volume(p, faces), dv

    return offset_to_volume(points, faces, volume, measure, "the enclosed volume", rtol, max_iter)


def offset_to_volume(points, faces, volume: float, measure, what: str, rtol: float, max_iter: int):
    """Newton's method for the one offset ``delta`` along the nodes' (fixed) vertex normals ``n`` that
    makes a surface enclose ``volume``; ``measure(p, n)`` gives the volume of ``p`` and its derivative
    in ``delta``, ``what`` names the volume in the error. Returns ``(points, delta)``.

    ``measure`` sees the points about their mean: a closed surface's volume is the same about any point,
    and about a far origin its terms carry round-off (a body of radius 0.3 at 3 R0 from it: 2e-14
    against the 1e-15 asked)."""
    points = np.asarray(points, dtype=float)
    n = vertex_normals(points, faces)
    origin = points.mean(axis=0)
    delta = 0.0
    for _ in range(max_iter):
        p = points + delta * n
        v, dv = measure(p - origin, n)
        if abs(v - volume) <= rtol * abs(volume):
            return p, delta
        delta -= (v - volume) / dv
    raise CortexError(f"remeshing could not restore {what} {volume:.6g} (Newton did not converge)")


# ---------------------------------------------------------------------------
# the transfer of fields (the closest point query: surface/closest.py)
# ---------------------------------------------------------------------------


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
    options = options or RemeshOptions()
    points = np.ascontiguousarray(points, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    target = enclosed_volume(points, faces) if volume is None else float(volume)
    new = triangulate(points, faces, options)
    new_points, delta = restore_volume(new.points, new.faces, target)
    new_fields = transfer_fields(points, faces, dict(fields or {}), dict(kinds or {}), new_points, new.faces)
    return RemeshResult(
        new_points,
        new.faces,
        new_fields,
        delta,
        points.shape[0],
        new_points.shape[0],
        new.scale,
        new.predicted,
        new.passes,
    )


def triangulate(
    points: np.ndarray,
    faces: np.ndarray,
    options: RemeshOptions | None = None,
    kappa: np.ndarray | None = None,
    hausd_scale: float = 1.0,
) -> RemeshResult:
    """The new triangulation of :func:`remesh` alone: MMG to the size field (its node budget
    corrected by MMG's count), the repair and the retries of ``options.min_angle``; the nodes where
    MMG and the repair left them (no volume restored, no fields: ``fields`` empty, ``offset`` 0).
    The curved cells' remeshing (:mod:`cortex_ti.surface.curved_remesh`) starts from it, with the
    curvature ``kappa`` (N,) of its finer mesh (None: :func:`edge_curvature` of this one) and the
    default ``hausd`` times ``hausd_scale``."""
    if not remesh_available():
        raise CortexError(REMESH_EXTRA_HINT)
    options = options or RemeshOptions()
    points = np.ascontiguousarray(points, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int32)
    mean = mean_edge_length(points, faces)
    h_max = mean if options.h_max is None else float(options.h_max)
    h_min = mean / H_MIN_DIVISOR if options.h_min is None else float(options.h_min)
    kappa = edge_curvature(points, faces) if kappa is None else np.asarray(kappa, dtype=float)
    area = dual_areas(points, faces)
    scale = options.edge_angle
    if options.nodes is not None:
        scale = budget_scale(points, faces, options.nodes, h_min, h_max, options.hgrad, kappa)

    def field(scale):
        return grade(points, faces, sizes(kappa, scale, h_min, h_max), options.hgrad)

    def hausd(scale):
        if options.hausd is not None:
            return options.hausd
        return hausd_scale * max(0.05, 0.15 * min(scale, 1.0)) * h_max

    def mmg(scale):
        h = field(scale)
        return *_mmg(points, faces, h, hausd(scale), options.hgrad), float(predicted_nodes(area, h))

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
    new_points, new_faces = repair(new_points, new_faces, options.quality)
    new_points, new_faces, passes = _meet_angle(
        points, faces, field(scale), hausd(scale), options, new_points, new_faces
    )
    return RemeshResult(new_points, new_faces, {}, 0.0, points.shape[0], new_points.shape[0], scale, predicted, passes)


def _mmg(points: np.ndarray, faces: np.ndarray, h: np.ndarray, hausd: float, hgrad: float):
    """MMG's surface remeshing of ``(points, faces)`` to the nodal sizes ``h``: the new ``(points,
    faces)``, the triangles facing out (ridge detection off: the cortex is smooth)."""
    from mmgpy._mmgpy import MmgMeshS

    mesh = MmgMeshS(points, faces)
    mesh.set_field("metric", np.ascontiguousarray(h, dtype=np.float64)[:, None])
    info = mesh.remesh(hausd=hausd, hgrad=hgrad, angle=0, verbose=-1)
    if info.get("return_code", 0) != 0:
        raise CortexError(f"remeshing failed (MMG return code {info.get('return_code')})")
    new_points = np.ascontiguousarray(mesh.get_vertices(), dtype=np.float64)
    new_faces = np.ascontiguousarray(mesh.get_triangles(), dtype=np.int32)
    if enclosed_volume(new_points, new_faces) < 0:
        new_faces = np.ascontiguousarray(new_faces[:, [0, 2, 1]])
    return new_points, new_faces


def _meet_angle(points, faces, h, hausd, options: RemeshOptions, new_points, new_faces):
    """The accept rule: while the new mesh's smallest angle is below ``options.min_angle``, MMG
    remeshes its own (repaired) output again, to the size field ``h`` of the old nodes taken at the
    new nodes' closest points of the old surface, and the repair follows; at most :data:`RETRIES`
    more passes, the mesh with the largest smallest angle kept (one warning if none meets it).
    Returns ``(points, faces, passes)``.

    A single pass from a surface whose triangles the flow has sheared leaves a few needles where the
    size field is finest (a deep neck's short edges next to long ones); a pass from MMG's own output,
    already near the size field, does not (docs/validation/remesh_constriction.md)."""
    best = (float(min_angles(new_points, new_faces).min()), new_points, new_faces)
    passes = 1
    while options.min_angle is not None and best[0] < options.min_angle and passes <= RETRIES:
        tri, bary = closest_points(points, faces, best[1])
        at = np.einsum("qk,qk->q", bary, h[faces[tri]])
        trial = repair(*_mmg(best[1], best[2], at, hausd, options.hgrad), options.quality)
        passes += 1
        angle = float(min_angles(*trial).min())
        if angle > best[0]:
            best = (angle, *trial)
    if options.min_angle is not None and best[0] < options.min_angle:
        log.warning(
            "remeshing: the smallest angle %.2f deg is below %g after %d MMG passes", best[0], options.min_angle, passes
        )
    return best[1], best[2], passes
