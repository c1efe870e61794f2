"""The near corrections of the matrix-free fluids' lumped far field (:mod:`.fluids_fast` for the
single layer, :mod:`.fluids_double` for the double layer): the (node, triangle) pairs integrated
exactly and their accurate-minus-lumped blocks as a block-sparse matrix. A module below both, so that
neither imports the other."""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .stokes_bie import duffy_rule, radon7, split_rule

__all__ = ["lumped_pairs", "lumped_corrections"]


def lumped_pairs(x, faces, lump: float, *, near: float = 3.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The (node, triangle) pairs integrated exactly, ``(pi, pf, kind)``: the node within
    ``max(lump, near)`` triangle sizes ``rho`` (the largest centroid-vertex distance) of the triangle's
    centroid (so a triangle's own corners always); ``kind`` the rule
    (:func:`~cortex_ti.physics.stokes_kernel.near_blocks`): 0-2 the node is that corner (Duffy), 3
    within ``near`` sizes (split; :func:`~cortex_ti.physics.stokes_bie.near_pairs`'s test), 4 the 7-point
    rule."""
    tri = x[faces]
    cen = tri.mean(1)
    rho = np.linalg.norm(tri - cen[:, None, :], axis=2).max(1)
    radius = max(lump, near) * rho
    if np.isfinite(lump):
        found = cKDTree(cen).sparse_distance_matrix(cKDTree(x), radius.max(), output_type="ndarray")
        pf, pi, d = found["i"].astype(np.int64), found["j"].astype(np.int64), found["v"]
        keep = d < radius[pf]
        pf, pi, d = pf[keep], pi[keep], d[keep]
    else:
        pf, pi = (a.ravel() for a in np.meshgrid(np.arange(len(faces)), np.arange(len(x)), indexing="ij"))
        d = np.linalg.norm(x[pi] - cen[pf], axis=1)
    vert = faces[pf] == pi[:, None]
    kind = np.where(d < near * rho[pf], 3, 4)
    own = vert.any(1)
    kind[own] = np.argmax(vert[own], axis=1)
    return pi, pf, kind


def lumped_corrections(
    x,
    faces,
    lump: float,
    centroid: float = 0.0,
    *,
    near: float = 3.0,
    duffy_points: int = 8,
    near_levels: int = 2,
    double: bool = False,
) -> tuple[sp.bsr_matrix, int]:
    """The corrections of the lumped far field as a sparse (3N, 3N) matrix of 3 x 3 blocks (the
    accurate integrals of the pairs of :func:`lumped_pairs` minus their lumped values, summed over a
    node pair's triangles; ``1 / 8 pi`` included; a Taichi kernel) and the number of pairs. ``double``:
    the double layer's raw stresslet instead (:mod:`.fluids_double`: the 4-point rule, no factor)."""
    from .stokes_kernel import near_blocks, near_double_blocks

    x = np.ascontiguousarray(x, float)
    faces = np.asarray(faces, np.int64)
    n = len(x)
    pi, pf, kind = lumped_pairs(x, faces, lump, near=near)
    # the node pairs (i, corner j) as block slots: sorted keys i N + j, one slot per distinct pair
    key = (pi[:, None] * n + faces[pf]).ravel()
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    new = np.ones(len(key), bool)
    new[1:] = sorted_key[1:] != sorted_key[:-1]
    slot = np.empty(len(key), np.int32)
    slot[order] = np.cumsum(new) - 1
    pairs = sorted_key[new]
    data = np.zeros((len(pairs), 9))
    rules = [radon7(), duffy_rule(duffy_points), split_rule(near_levels)]
    args = [np.ascontiguousarray(a, float) for r in rules for a in r]
    i32 = [np.ascontiguousarray(a, np.int32) for a in (faces, pi, pf, kind)]
    if double:
        near_double_blocks(x, *i32, *args[:2], *args[4:], slot.reshape(-1, 3), data)
    else:
        near_blocks(x, *i32, *args, slot.reshape(-1, 3), float(centroid), data)
        data *= 1.0 / (8.0 * math.pi)
    indptr = np.searchsorted(pairs // n, np.arange(n + 1))
    mat = sp.bsr_matrix((data.reshape(-1, 3, 3), pairs % n, indptr), shape=(3 * n, 3 * n))
    return mat, len(pi)
