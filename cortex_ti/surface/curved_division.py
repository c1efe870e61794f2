r"""The cut of a surface of curved six-node cells (formulation ``rayleigh_p2``) into two at a neck.

The flat cut (:func:`cortex_ti.surface.division.cut_at_plane`) done on the curved cells' terms:

1. **the sides' volumes** are those of the curved cells: the split mesh's flat sides
   (:func:`~cortex_ti.surface.division.side_volumes`, exact for its flat sub-triangles) plus each
   cell's excess, ``1/3 int (x - p0) . n dA`` over the curved cell minus the same over its four flat
   sub-triangles, given to the two sides in the shares of the cell's flat area on each
   (:func:`curved_side_volumes`). The excesses add to the curved volume minus the flat one, so the two
   sides add to the curved volume to round-off; a cell's excess is ``O(h^4)`` (a sagitta over a cell)
   plus the ``O(|x - p0| h^3)`` of its curved edges against the straight ones, so the sides converge
   at second order (docs/validation/division.md);
2. **each density's amount on each side** is ``sum c_i m_i`` (``m_i = int N_i dA`` over the cells,
   :func:`~cortex_ti.surface.curved_remesh.curved_masses`) over the nodes with ``s_i >= 0`` and
   ``s_i < 0``: the two add to the total over the cells to round-off;
3. the **corner mesh** (:func:`~cortex_ti.surface.curved_remesh.corner_mesh`) is clipped beyond the
   band, capped by a dome and remeshed to the run's options for corners
   (:func:`~cortex_ti.surface.curved_remesh.corner_options`) as the flat cut does, then split 1-to-4
   into curved cells. A new node on the lobe (``s`` beyond the band on its side) and the midpoint of a
   lobe edge go to their closest point on the old curved cells of that side
   (:func:`~cortex_ti.surface.curved_remesh.curved_closest`), as the curved remeshing places them; the
   cap's nodes stay on the dome, its midpoints on the chords (the cap is new surface). Cells folded
   over a crease get their midpoints on their chords (:func:`~cortex_ti.surface.curved_remesh.unfold`);
4. each daughter's **curved volume** is set to its side's by the uniform normal offset
   (:func:`~cortex_ti.surface.curved_remesh.restore_curved_volume`), every field takes its old cells'
   quadratic interpolant at the node's foot on its side, and each density is scaled so that its total
   over the daughter's cells is its side's amount (:func:`~cortex_ti.surface.remesh.keep_amount`).

Derivation and measurements: docs/validation/division.md ("The cut on curved cells").
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .curved import p2_cells
from .curved_remesh import (
    _cell_quadrature,
    _interpolate,
    corner_mesh,
    corner_options,
    curved_closest,
    curved_masses,
    restore_curved_volume,
    unfold,
)
from .division import CutResult, _clip_triangle, _tet, cut_inputs, side_amounts, side_surface, side_volumes
from .measures import min_angles
from .mesh import split_faces
from .remesh import RemeshOptions, keep_amount

__all__ = ["curved_side_volumes", "cut_curved"]


def curved_side_volumes(points: np.ndarray, faces: np.ndarray, p0, axis) -> tuple[float, float]:
    """``(V_minus, V_plus)`` of the curved cells of the split mesh ``(points, faces)`` on either side of
    the plane ``(x - p0) . axis = 0`` (module docstring, step 1); they add to
    :func:`~cortex_ti.surface.curved_remesh.curved_volume` to round-off.

    >>> from cortex_ti.surface.curved_remesh import curved_volume
    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(642)
    >>> lo, hi = curved_side_volumes(m.points, m.faces, (0, 0, 0), (0, 0, 1))
    >>> bool(abs(lo + hi - curved_volume(m.points, m.faces)) < 1e-13), bool(abs(lo - hi) < 1e-12)
    (True, True)
    """
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    p0 = np.asarray(p0, dtype=float)
    x = np.asarray(points, dtype=float) - p0
    flat = side_volumes(points, faces, p0, a)
    _, _, xq, nda = _cell_quadrature(x, faces)
    curved = np.einsum("tqc,tqc->t", xq, nda) / 3.0
    f = np.asarray(faces).reshape(-1, 4, 3)
    sub = _tet(x[f[..., 0]].reshape(-1, 3), x[f[..., 1]].reshape(-1, 3), x[f[..., 2]].reshape(-1, 3))
    excess = curved - sub.reshape(-1, 4).sum(axis=1)
    share = _plus_share(x, f, x @ a)
    return flat[0] + float(excess @ (1.0 - share)), flat[1] + float(excess @ share)


def _plus_share(x: np.ndarray, f: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(T,): the share of each cell's flat area (its four sub-triangles ``f`` (T, 4, 3)) on the side
    ``s >= 0``: 0 or 1 for a cell on one side, the clipped area's share for a cell across the plane (a
    cell cut in the middle gives half its excess to each side: a mirror-symmetric surface splits
    evenly)."""
    share = (s[f] >= 0.0).all(axis=(1, 2)).astype(float)
    across = np.flatnonzero((s[f] >= 0.0).any(axis=(1, 2)) & ~(s[f] >= 0.0).all(axis=(1, 2)))
    for c in across:
        whole = part = 0.0
        for tri in f[c]:
            whole += 0.5 * np.linalg.norm(np.cross(x[tri[1]] - x[tri[0]], x[tri[2]] - x[tri[0]]))
            poly = _clip_triangle(x[tri], s[tri])
            for k in range(1, len(poly) - 1):
                part += 0.5 * np.linalg.norm(np.cross(poly[k] - poly[0], poly[k + 1] - poly[0]))
        share[c] = part / whole
    return share


def cut_curved(
    points: np.ndarray,
    faces: np.ndarray,
    p0,
    axis,
    band: float,
    fields: dict | None = None,
    kinds: dict | None = None,
    options: RemeshOptions | None = None,
) -> CutResult:
    """:func:`~cortex_ti.surface.division.cut_at_plane` for the curved cells of the split mesh
    ``(points, faces)`` (module docstring); ``band`` and ``options`` are the velocity nodes' (the
    corner mesh's are twice and a quarter). Body 0 is the daughter on the ``axis``' negative side."""
    points, faces, p0, a, s, fields, kinds, options = cut_inputs(points, faces, p0, axis, band, fields, kinds, options)
    volumes = curved_side_volumes(points, faces, p0, a)
    mass = curved_masses(points, faces)
    plus_node = s >= 0.0
    amounts = side_amounts(fields, kinds, mass, plus_node)
    cells = p2_cells(faces)
    cell_plus = s[cells[:, :3]].mean(axis=1) >= 0.0
    corners, corner_faces = corner_mesh(points, faces)
    sc = (corners - p0) @ a
    share = np.array([mass[~plus_node].sum(), mass[plus_node].sum()]) / mass.sum()
    copts = corner_options(options)
    out_p, out_f, out_lab, parts = [], [], [], {name: [] for name in fields}
    offset, smallest = 0, math.inf
    for side in (0, 1):
        sign = 1.0 if side else -1.0
        nodes = None if options.nodes is None else max(int(round(options.nodes * share[side])), 24)
        opts = copts if nodes is None else replace(copts, nodes=max(4, round((nodes + 6) / 4)))
        new = side_surface(corners, corner_faces, sc, band, side, a, opts)  # the daughter's corner mesh
        edges, split = split_faces(new.faces, len(new.points))
        split = np.ascontiguousarray(split, dtype=np.int64)
        mids = 0.5 * (new.points[edges[:, 0]] + new.points[edges[:, 1]])
        x = np.vstack([new.points, mids])
        # the old cells on this side (the band included): where the lobe's nodes and every field come from
        old = (cells[cell_plus == bool(side)][:, [0, 3, 5, 1, 4, 3, 2, 5, 4, 3, 4, 5]]).reshape(-1, 3)
        lobe_c = sign * ((new.points - p0) @ a) >= band - 1e-9 * max(band, 1.0)
        lobe = np.concatenate([lobe_c, lobe_c[edges[:, 0]] & lobe_c[edges[:, 1]]])
        cell, ref, at = curved_closest(points, old, x)
        x[lobe] = at[lobe]
        x, _ = unfold(x, split)
        x, _ = restore_curved_volume(x, split, volumes[side])
        m_new = curved_masses(x, split)
        for name in fields:
            v = _interpolate(points, old, fields[name], cell, ref)
            if name in amounts:
                v = keep_amount(v, amounts[name][side], m_new)
            parts[name].append(v)
        smallest = min(smallest, float(min_angles(new.points, new.faces).min()))
        out_p.append(x)
        out_f.append(split + offset)
        out_lab.append(np.full(len(x), side, dtype=np.int64))
        offset += len(x)
    return CutResult.joined(out_p, out_f, out_lab, parts, volumes, amounts, smallest)
