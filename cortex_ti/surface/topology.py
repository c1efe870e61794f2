"""Connectivity of a validated mesh: counter-clockwise one-rings and two-rings of every node.

All work is vectorised numpy (sort-based edge matching); there are no Python loops over faces
or nodes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MeshError
from .mesh import Mesh

__all__ = ["Topology", "build_topology"]


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
    nxt = order[pos_c]  # corner following each corner around its node
    first = np.r_[0, np.cumsum(valence)[:-1]]
    start = order[first]  # corner with the smallest neighbour index
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
    keep_sorted[:, 1:] = vals[:, 1:] != vals[:, :-1]  # stable sort: first occurrence kept
    keep_sorted &= vals != sentinel
    keep = np.empty_like(keep_sorted)
    np.put_along_axis(keep, srt, keep_sorted, axis=1)
    size = keep.sum(axis=1)
    width = int(size.max())
    pick = np.argsort(~keep, axis=1, kind="stable")[:, :width]
    ring2 = np.take_along_axis(cand, pick, axis=1)
    ring2[np.arange(width)[None, :] >= size[:, None]] = -1
    return ring2, size
