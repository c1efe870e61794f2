r"""Several bodies on one triangulation, and the cut of one closed surface into two at a neck.

**Bodies** (:func:`body_labels`): the connected components of the triangulation (nodes joined by
the triangles' edges), labelled ``0, 1, ...`` in the order of their smallest node index; a
triangle's label is its nodes'. Without a surrounding fluid the bodies do not interact: each has its
own volume constraint and rigid-motion gauge (the simulation solves them one by one).

**The cut** (:func:`cut_at_plane`): a closed surface with a neck is split by the plane through the
neck perpendicular to the axis, ``s(x) = (x - p0) . a``:

1. the **volume of each side** is that of the surface clipped by the plane and closed by the plane's
   section: with the origin on the plane, the section's tetrahedra have no volume, so
   ``V_+ = sum over the clipped triangles' fans of x_a . (x_b x x_c) / 6`` (about ``p0``), and
   ``V_+ + V_- = V`` to round-off (:func:`side_volumes`);
2. the **amount of each density on each side** is the sum of ``c_i A_i`` (barycentric dual areas)
   over the nodes with ``s_i >= 0`` and ``s_i < 0``: the two add to the total to round-off;
3. the **neck band** (every triangle with a node within ``band`` of the plane) is removed, each of
   the two sides left is closed by a fan of triangles from the centroid of its boundary loop (the
   cap), and **remeshed** by MMG (:func:`cortex_ti.surface.remesh.triangulate`: the usual size
   field, repair and angle retries; a node budget shared by the sides' areas); each daughter's
   enclosed volume is then set to its side's volume by the uniform normal offset
   (:func:`~cortex_ti.surface.remesh.restore_volume`), its fields interpolated from the old surface's
   triangles on its side and each density scaled to its side's amount
   (:func:`~cortex_ti.surface.remesh.keep_amount`).

The daughters' volumes therefore add to the volume at the cut, and every density's total is kept, to
round-off. What the cut changes is the shape near the neck: a band of width ``~2 band`` and a cap of
the neck's radius, a volume of order ``r_neck^2 band`` moved by the offset (docs/guide/division.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..errors import CortexError
from .measures import min_angles
from .remesh import (
    RemeshOptions,
    RemeshResult,
    budget_scale,
    edge_curvature,
    enclosed_volume,
    keep_amount,
    predicted_nodes,
    remesh,
    restore_volume,
    sizes,
    transfer_fields,
    triangulate,
)
from .transport import DENSITY, dual_areas

__all__ = [
    "remesh_bodies",
    "body_labels",
    "face_labels",
    "euler_characteristic",
    "body_roundness",
    "side_volumes",
    "CutResult",
    "cut_at_plane",
    "cut_inputs",
    "side_amounts",
    "side_surface",
]


def body_labels(faces: np.ndarray, n_nodes: int) -> tuple[int, np.ndarray]:
    """``(n_bodies, labels)``: the connected components of the triangulation, one label per node
    (numbered in the order of their smallest node; a node in no triangle is a body of its own).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> n, lab = body_labels(np.concatenate([m.faces, m.faces + 162]), 324)
    >>> n, int(lab[0]), int(lab[200])
    (2, 0, 1)
    """
    f = np.asarray(faces, dtype=np.int64)
    rows = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    cols = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    graph = sp.coo_matrix((np.ones(rows.size, dtype=np.int8), (rows, cols)), shape=(n_nodes, n_nodes))
    n, lab = connected_components(graph, directed=False)
    return int(n), lab.astype(np.int64)  # scipy numbers them in the order of their first node


def face_labels(faces: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """The body label of each triangle (its first node's)."""
    return np.asarray(labels)[np.asarray(faces)[:, 0]]


def euler_characteristic(faces: np.ndarray) -> int:
    """``V - E + F`` of the triangulation (2 for one closed surface of genus 0)."""
    f = np.asarray(faces, dtype=np.int64)
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    return int(np.unique(f).size - e.shape[0] + f.shape[0])


def body_roundness(points: np.ndarray, faces: np.ndarray) -> list[tuple[float, float]]:
    """``(roundness, volume)`` of each body (in :func:`body_labels` order): the roundness the largest
    ``|r / mean r - 1|`` of its nodes' distances ``r`` from its area centroid (0 on a sphere).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> [(round(r, 12), round(v, 2)) for r, v in body_roundness(m.points, m.faces)]
    [(0.0, 4.05)]
    """
    from .measures import area_centroid

    points, faces = np.asarray(points, dtype=float), np.asarray(faces)
    n, labels = body_labels(faces, len(points))
    flab = face_labels(faces, labels)
    out = []
    for b in range(n):
        f = faces[flab == b]
        r = np.linalg.norm(points[labels == b] - area_centroid(points, f), axis=1)
        out.append((float(np.max(np.abs(r / r.mean() - 1.0))), float(enclosed_volume(points, f))))
    return out


def _tet(a, b, c) -> np.ndarray:
    return np.einsum("tc,tc->t", a, np.cross(b, c)) / 6.0


def side_volumes(points: np.ndarray, faces: np.ndarray, p0, axis) -> tuple[float, float]:
    r"""``(V_minus, V_plus)``: the volumes of the closed surface on either side of the plane
    ``(x - p0) . axis = 0`` (module docstring, step 1), each clipped piece closed by the plane.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(642)
    >>> lo, hi = side_volumes(m.points, m.faces, (0, 0, 0), (0, 0, 1))
    >>> bool(abs(lo - hi) < 1e-12 * hi)  # the icosphere is symmetric about z = 0
    True
    """
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    x = np.asarray(points, dtype=float)[np.asarray(faces)] - np.asarray(p0, dtype=float)  # (T, 3, 3)
    s = x @ a  # (T, 3)
    out = [0.0, 0.0]
    for side, sign in ((0, -1.0), (1, 1.0)):
        inside = sign * s >= 0.0  # a node on the plane counts on both sides: its tetrahedra have no volume there
        whole = inside.all(axis=1)
        out[side] += float(_tet(x[whole, 0], x[whole, 1], x[whole, 2]).sum())
        for t in np.flatnonzero(inside.any(axis=1) & ~whole):
            poly = _clip_triangle(x[t], sign * s[t])
            for k in range(1, len(poly) - 1):
                out[side] += float(_tet(poly[None, 0], poly[None, k], poly[None, k + 1])[0])
    return out[0], out[1]


def _clip_triangle(tri: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The part ``s >= 0`` of one triangle (its corners ``tri`` (3, 3), their signed distances ``s``),
    a convex polygon in the triangle's orientation."""
    poly = []
    for k in range(3):
        j = (k + 1) % 3
        if s[k] >= 0.0:
            poly.append(tri[k])
        if (s[k] >= 0.0) != (s[j] >= 0.0):
            w = s[k] / (s[k] - s[j])
            poly.append(tri[k] + w * (tri[j] - tri[k]))
    return np.array(poly)


@dataclass(frozen=True)
class CutResult:
    """Two daughters on one triangulation: the points, triangles and fields, the body label of each
    node, the volumes of the two sides at the cut (the daughters', in label order), each density's
    amounts on the two sides, and the smallest angle (deg) of the new triangles."""

    points: np.ndarray
    faces: np.ndarray
    fields: dict
    labels: np.ndarray
    volumes: tuple
    amounts: dict
    min_angle: float

    @classmethod
    def joined(cls, points, faces, labels, parts, volumes, amounts, smallest) -> CutResult:
        """The result from the two sides' lists (points, triangles already offset, labels, each
        field's values)."""
        return cls(
            np.vstack(points),
            np.ascontiguousarray(np.vstack(faces), dtype=np.int32),
            {name: np.concatenate(v) for name, v in parts.items()},
            np.concatenate(labels),
            volumes,
            amounts,
            smallest,
        )


def _clip(points: np.ndarray, faces: np.ndarray, t: np.ndarray, exact: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The part ``t >= 0`` of a triangulated surface (``t`` (N,) an affine function of the points,
    a signed distance), the triangles across ``t = 0`` cut there: ``(points, faces)`` with only the
    nodes used, the new nodes on the cut edges shared by the triangles on both sides of each edge.
    ``exact``: a node with ``t = 0`` lies on the cut (no new node on its edges; a triangle whose only
    nodes at ``t >= 0`` are on the cut is dropped); else such a node counts as just inside."""
    if not exact:
        t = np.where(np.abs(t) < 1e-12, 1e-12, t)  # no node exactly on the cut
    inside = t >= 0.0
    new_points = [p for p in points]
    on_edge: dict = {}

    def cross(i: int, j: int) -> int:
        key = (min(i, j), max(i, j))
        if key not in on_edge:
            w = t[i] / (t[i] - t[j])
            on_edge[key] = len(new_points)
            new_points.append(points[i] + w * (points[j] - points[i]))
        return on_edge[key]

    out = [faces[inside[faces].all(axis=1)]]
    for tri in faces[inside[faces].any(axis=1) & ~inside[faces].all(axis=1)]:
        poly = []
        for k in range(3):
            i, j = int(tri[k]), int(tri[(k + 1) % 3])
            if inside[i]:
                poly.append(i)
            if t[i] * t[j] < 0.0:
                poly.append(cross(i, j))
        out += [np.array([[poly[0], poly[k], poly[k + 1]]]) for k in range(1, len(poly) - 1)]
    f = np.concatenate(out).astype(np.int64)
    p = np.array(new_points)
    used = np.unique(f)
    local = np.full(len(p), -1, dtype=np.int64)
    local[used] = np.arange(used.size)
    return p[used], local[f]


def _cap(faces: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Close a surface with one planar boundary loop (the rim) by a flat fan from the rim's centroid
    (a new last node). Returns ``(points, faces, rim)``, ``rim`` the loop's nodes in order."""
    f = np.asarray(faces, dtype=np.int64)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    key = np.sort(directed, axis=1)
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    boundary = directed[counts[inverse.ravel()] == 1]
    if boundary.shape[0] < 3:
        raise CortexError("the cut left a side without a boundary loop to cap")
    nxt = dict(zip(boundary[:, 0].tolist(), boundary[:, 1].tolist(), strict=True))
    if len(nxt) != boundary.shape[0]:
        raise CortexError("the cut left a side whose boundary is not one simple loop")
    start = int(boundary[0, 0])
    loop = [start]
    while nxt[loop[-1]] != start and len(loop) <= len(nxt):
        loop.append(nxt[loop[-1]])
    if len(loop) != len(nxt):
        raise CortexError(f"the cut left a side with {len(nxt)} boundary edges in more than one loop")
    loop = np.array(loop)
    centre = len(points)
    cap = np.stack([np.roll(loop, -1), loop, np.full(loop.size, centre)], axis=1)  # the rim's edges reversed
    return np.vstack([points, points[loop].mean(axis=0)]), np.concatenate([f, cap]), loop


def _dome(points: np.ndarray, rim: np.ndarray, outward: np.ndarray, plane: float) -> np.ndarray:
    r"""Raise the flat cap in the plane ``x . outward = plane`` into a dome over its rim (the points
    ``rim`` (R, 3), in order): a point at distance ``rho`` from the rim's centroid ``c``, in the
    direction ``theta`` where the rim is at ``R(theta)`` (interpolated), goes to
    ``c + R sin(pi u / 2) e_theta + R cos(pi u / 2) outward``, ``u = rho / R``: the rim stays, a
    circular rim gets a hemisphere, which meets a neck running along the axis without a crease (a
    flat cap's right-angled rim starts a stiff transient)."""
    c = rim.mean(axis=0)
    e1 = rim[0] - c - ((rim[0] - c) @ outward) * outward
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(outward, e1)

    def polar(x):
        d = x - c
        return np.hypot(d @ e1, d @ e2), np.arctan2(d @ e2, d @ e1)

    r_rim, t_rim = polar(rim)
    order = np.argsort(t_rim)
    t_rim, r_rim = t_rim[order], r_rim[order]
    t_ext = np.concatenate([t_rim - 2 * math.pi, t_rim, t_rim + 2 * math.pi])
    r_ext = np.concatenate([r_rim, r_rim, r_rim])
    size = float(np.mean(r_rim))
    on_cap = points @ outward - plane >= -1e-3 * size  # the lobe lies behind the plane, the cap in it
    rho, theta = polar(points[on_cap])
    radius = np.interp(theta, t_ext, r_ext)
    inside = rho < radius * (1.0 - 1e-9)
    u = np.clip(rho / radius, 0.0, 1.0)
    e = np.cos(theta)[:, None] * e1 + np.sin(theta)[:, None] * e2
    lifted = (
        c + (radius * np.sin(0.5 * math.pi * u))[:, None] * e + (radius * np.cos(0.5 * math.pi * u))[:, None] * outward
    )
    out = points.copy()
    idx = np.flatnonzero(on_cap)[inside]
    out[idx] = lifted[inside]
    return out


def cut_at_plane(
    points: np.ndarray,
    faces: np.ndarray,
    p0,
    axis,
    band: float,
    fields: dict | None = None,
    kinds: dict | None = None,
    options: RemeshOptions | None = None,
) -> CutResult:
    """Cut the closed surface ``(points, faces)`` into two at the plane through ``p0`` perpendicular
    to ``axis``, removing the triangles within ``band`` of it (module docstring). ``options``: how the
    daughters are remeshed (a node budget is shared by the sides' areas). The daughter on the
    ``axis``' negative side is body 0. Raises :class:`~cortex_ti.errors.CortexError` when the plane
    does not split the surface into two pieces each with one boundary loop."""
    points, faces, p0, a, s, fields, kinds, options = cut_inputs(points, faces, p0, axis, band, fields, kinds, options)
    volumes = side_volumes(points, faces, p0, a)
    area = dual_areas(points, faces)
    plus_node = s >= 0.0
    amounts = side_amounts(fields, kinds, area, plus_node)
    face_side = s[faces].mean(axis=1) >= 0.0
    share = np.array([area[~plus_node].sum(), area[plus_node].sum()]) / area.sum()
    out_p, out_f, out_lab, parts = [], [], [], {name: [] for name in fields}
    offset, smallest = 0, math.inf
    for side in (0, 1):
        opts = (
            options
            if options.nodes is None
            else replace(options, nodes=max(int(round(options.nodes * share[side])), 12))
        )
        new = side_surface(points, faces, s, band, side, a, opts)
        new_points, _ = restore_volume(new.points, new.faces, volumes[side])
        old_faces = faces[face_side == bool(side)]  # the old surface on this side, band included
        moved = transfer_fields(points, old_faces, fields, {}, new_points, new.faces)
        new_area = dual_areas(new_points, new.faces)
        for name in fields:
            v = moved[name]
            if name in amounts:
                v = keep_amount(v, amounts[name][side], new_area)
            parts[name].append(v)
        smallest = min(smallest, float(min_angles(new_points, new.faces).min()))
        out_p.append(new_points)
        out_f.append(new.faces.astype(np.int64) + offset)
        out_lab.append(np.full(len(new_points), side, dtype=np.int64))
        offset += len(new_points)
    return CutResult.joined(out_p, out_f, out_lab, parts, volumes, amounts, smallest)


def cut_inputs(points, faces, p0, axis, band: float, fields, kinds, options):
    """The arguments of a cut as arrays (``points``, ``faces``, ``p0``, the unit axis, the nodes'
    signed distances ``s`` from the plane, the fields and kinds, the options); a plane with no node
    beyond ``band`` on one side is refused (:class:`~cortex_ti.errors.CortexError`)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    points = np.ascontiguousarray(points, dtype=float)
    p0 = np.asarray(p0, dtype=float)
    s = (points - p0) @ a
    if not (np.any(s < -band) and np.any(s > band)):
        raise CortexError("the cut plane leaves nothing on one side: there is no neck to cut there")
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    return points, faces, p0, a, s, dict(fields or {}), dict(kinds or {}), options or RemeshOptions()


def side_amounts(fields: dict, kinds: dict, weights: np.ndarray, plus: np.ndarray) -> dict:
    """Each density's amounts ``(sum over s < 0, sum over s >= 0)`` of ``c_i w_i`` (``plus``: the nodes
    with ``s >= 0``; ``weights``: dual areas, or the curved cells' ``int N_i dA``)."""
    return {
        name: (float(np.dot(v[~plus], weights[~plus])), float(np.dot(v[plus], weights[plus])))
        for name, v in fields.items()
        if kinds.get(name) == DENSITY
    }


def side_surface(points, faces, s, band: float, side: int, axis, options: RemeshOptions):
    """One side of the cut (:func:`cut_at_plane`, step 3): the surface ``(points, faces)`` beyond
    ``band`` on side ``side`` (0: ``s < 0``, 1: ``s > 0``, ``s`` the nodes' signed distances from the
    plane along the unit ``axis``), cut flat there, capped by a fan, the cap remeshed into small
    triangles and raised into a dome, the whole remeshed to ``options``
    (:func:`~cortex_ti.surface.remesh.triangulate`'s result)."""
    sign = 1.0 if side else -1.0
    sub_points, sub = _clip(points, np.asarray(faces, dtype=np.int64), sign * s - band)
    if body_labels(sub, len(sub_points))[0] != 1:
        raise CortexError("the cut plane meets the surface away from the neck: a side falls apart in pieces")
    outward = axis if side == 0 else -axis
    p, f, rim = _cap(sub, sub_points)
    flat = triangulate(p, f.astype(np.int32), replace(options, min_angle=None))  # the cap made of small triangles
    plane = float(sub_points[rim[0]] @ outward)
    domed = _dome(flat.points, sub_points[rim], outward, plane)  # then raised into a dome
    return triangulate(domed, flat.faces, options)  # and the whole remeshed to the usual quality


def budget_shares(points, faces, labels: np.ndarray, n: int, options: RemeshOptions) -> np.ndarray:
    """Each body's share (n,) of the node budget ``options.nodes``: what one size field over all the
    bodies gives it, ``clip(s / kappa, h_min, h_max)`` with the scale ``s`` of :func:`budget_scale` for
    the whole (:func:`~cortex_ti.surface.remesh.predicted_nodes` on each body). Where the clips do not
    act that is ``int kappa^2 dA``: two spheres get equal shares whatever their radii, so a small
    daughter is resolved by as many edges around as a large one (a share by area gave a daughter of a
    third of the radius a ninth of the nodes: three times coarser in angle). Without a budget or the
    lengths, the shares of the areas.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(642)
    >>> faces = np.concatenate([m.faces, m.faces + 642])
    >>> labels = np.repeat([0, 1], 642)
    >>> options = RemeshOptions(h_min=0.01, h_max=1.0, nodes=1284)
    >>> budget_shares(np.vstack([m.points, 0.3 * m.points]), faces, labels, 2, options).round(3).tolist()
    [0.5, 0.5]
    """
    area = dual_areas(points, faces)
    if options.nodes is None or options.h_min is None or options.h_max is None:
        return np.bincount(labels, area, n) / area.sum()
    kappa = edge_curvature(points, faces)
    h = sizes(
        kappa,
        budget_scale(points, faces, options.nodes, options.h_min, options.h_max, kappa=kappa),
        options.h_min,
        options.h_max,
    )
    want = np.array([predicted_nodes(area[labels == b], h[labels == b]) for b in range(n)])
    return want / want.sum()


def remesh_bodies(
    points: np.ndarray,
    faces: np.ndarray,
    fields: dict | None = None,
    kinds: dict | None = None,
    options: RemeshOptions | None = None,
    method=remesh,
) -> RemeshResult:
    """:func:`~cortex_ti.surface.remesh.remesh` (or ``method``, with its arguments: the curved cells'
    :func:`~cortex_ti.surface.curved_remesh.remesh_curved`) of each body of ``(points, faces)`` on its
    own: its own enclosed volume restored, a density's amount on it kept, the node budget shared as
    :func:`budget_shares` says; the bodies in the order of :func:`body_labels`."""
    options = options or RemeshOptions()
    fields, kinds = dict(fields or {}), dict(kinds or {})
    n, labels = body_labels(faces, len(points))
    flab = face_labels(faces, labels)
    shares = budget_shares(points, faces, labels, n, options)
    out_p, out_f, parts, offset, offsets = [], [], {name: [] for name in fields}, 0, 0.0
    scale, predicted = [], 0.0
    for b in range(n):
        nodes = np.flatnonzero(labels == b)
        local = np.full(len(points), -1, dtype=np.int64)
        local[nodes] = np.arange(nodes.size)
        share = float(shares[b])
        opts = options if options.nodes is None else replace(options, nodes=max(int(round(options.nodes * share)), 12))
        res = method(points[nodes], local[faces[flab == b]], {k: v[nodes] for k, v in fields.items()}, kinds, opts)
        out_p.append(res.points)
        out_f.append(res.faces.astype(np.int64) + offset)
        for name in fields:
            parts[name].append(res.fields[name])
        offset += len(res.points)
        offsets = max(offsets, abs(res.offset))
        scale.append(res.scale)
        predicted += res.predicted
    return RemeshResult(
        np.vstack(out_p),
        np.ascontiguousarray(np.vstack(out_f), dtype=np.int32),
        {name: np.concatenate(v) for name, v in parts.items()},
        offsets,
        len(points),
        offset,
        float(min(scale)),
        predicted,
    )


def body_volumes(points: np.ndarray, faces: np.ndarray, measure=enclosed_volume) -> list[float]:
    """The enclosed volume of each body (in the order of :func:`body_labels`); ``measure(points,
    faces)`` the volume of one (the curved cells':
    :func:`~cortex_ti.surface.curved_remesh.curved_volume`)."""
    n, labels = body_labels(faces, len(points))
    flab = face_labels(faces, labels)
    return [measure(points, faces[flab == b]) for b in range(n)]


def restore_body_volumes(points: np.ndarray, faces: np.ndarray, volumes, restore=restore_volume) -> np.ndarray:
    """Each body's nodes offset along their normals so that it encloses its ``volumes[b]``
    (``restore(points, faces, volume) -> (points, offset)`` body by body: by default
    :func:`~cortex_ti.surface.remesh.restore_volume`; the curved cells':
    :func:`~cortex_ti.surface.curved_remesh.restore_curved_volume`)."""
    n, labels = body_labels(faces, len(points))
    flab = face_labels(faces, labels)
    out = np.array(points, dtype=float)
    for b in range(n):
        nodes = np.flatnonzero(labels == b)
        local = np.full(len(points), -1, dtype=np.int64)
        local[nodes] = np.arange(nodes.size)
        out[nodes] = restore(out[nodes], local[faces[flab == b]], volumes[b])[0]
    return out
