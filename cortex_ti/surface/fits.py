"""Local Taylor fits: the fit schemes (registry :data:`FIT_SCHEMES`) and each node's stencil.

A fit scheme says which Taylor polynomial is fitted on which ring of neighbours (paper Sec.
3.5); :class:`StencilChooser` picks each node's stencil and widens it where the fit is rank
deficient. The fit operators themselves are computed per shape by
:func:`cortex_ti.surface.geometry.compute_geometry`. No Taichi here: the scene loader reads
this registry.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .topology import Topology

__all__ = ["FitScheme", "FIT_SCHEMES", "register_fit", "StencilChooser", "lowered", "quadratic_fallback"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FitScheme:
    """A fit of the local Taylor polynomial of degree ``order`` on the ``rings``-ring.

    ``quadratic`` is the paper's method (one-ring, Sec. 3.5): second derivatives are
    accurate to O(h^2) (error ~ h^2/12 times the fourth derivative). ``quartic`` fits
    all 14 monomials up to degree 4 on the two-ring: the five derivatives A..E it
    returns are accurate to O(h^3) or better, for a wider stencil (more nonzeros,
    dearer solve). The monomials are Taylor-normalised, ``u^a w^b / (a! b!)``, so the
    first five coefficients are the derivatives A..E themselves.
    """

    name: str
    order: int
    rings: int

    @property
    def powers(self) -> np.ndarray:
        out = [(1, 0), (0, 1), (2, 0), (0, 2), (1, 1)]
        for d in range(3, self.order + 1):
            out += [(a, d - a) for a in range(d, -1, -1)]
        return np.array(out, dtype=np.int32)

    @property
    def n_terms(self) -> int:
        return len(self.powers)


#: The fit schemes by name (the scene key ``numerics.fit``).
FIT_SCHEMES: dict[str, FitScheme] = {}


def register_fit(scheme: FitScheme) -> FitScheme:
    """Add a fit scheme to :data:`FIT_SCHEMES` (and so to the scene schema's choices)."""
    FIT_SCHEMES[scheme.name] = scheme
    return scheme


register_fit(FitScheme("quadratic", 2, 1))
register_fit(FitScheme("quartic", 4, 2))


def _k_ring_lists(topo: Topology, k: int) -> list[np.ndarray]:
    """Nodes within ``k`` edges of each node (node itself excluded), nearest rings first."""
    n = len(topo.valence)
    mask = topo.ring >= 0
    rows = np.repeat(np.arange(n), mask.sum(1))
    adj = sp.csr_matrix((np.ones(rows.size, dtype=np.int8), (rows, topo.ring[mask])), shape=(n, n))
    dist = sp.identity(n, format="csr", dtype=np.int8)
    hop = dist.copy()
    levels = {}
    reach = dist.copy()
    for level in range(1, k + 1):
        hop = (hop @ adj).tocsr()
        hop.data[:] = 1
        new = (hop - hop.multiply(reach)).tocsr()
        new.eliminate_zeros()
        levels[level] = new
        reach = ((reach + new) > 0).astype(np.int8).tocsr()
        hop = new
    out = []
    for i in range(n):
        parts = [levels[lv].indices[levels[lv].indptr[i] : levels[lv].indptr[i + 1]] for lv in range(1, k + 1)]
        out.append(np.concatenate(parts).astype(np.int32))
    return out


def _pad(rows: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    size = np.array([len(r) for r in rows], dtype=np.int32)
    out = np.full((len(rows), int(size.max())), -1, dtype=np.int32)
    for i, r in enumerate(rows):
        out[i, : len(r)] = r
    return out, size


class StencilChooser:
    """Chooses each node's fit stencil and widens it where the fit is rank deficient.

    A scheme with ``P`` monomials needs at least ``P`` stencil nodes in general
    position. Nodes start on the scheme's ring (one ring wider if it has fewer than
    ``P + 1`` nodes); a node whose fit turns out rank deficient (e.g. one-ring
    neighbours on a conic through the node) is moved one ring out and stays there.
    The stencil is topological, so it is fixed while the shape evolves unless such a
    degeneracy appears.

    ``apart`` (a boolean mask of the nodes, optional, with the node positions ``points`` it is
    chosen on): those nodes are fitted through each other only, on the :attr:`APART_SIZE` masked
    nodes nearest to them (by distance on ``points``) within a ring one wider than the others'
    (the curved cells' edge midpoints, :func:`cortex_ti.surface.curved.midpoint_mask`: why, in
    :mod:`cortex_ti.physics.galerkin_p2`). The other nodes keep their whole ring.
    """

    MAX_EXTRA_RINGS = 2
    #: how many of the masked nodes a masked node is fitted on (the quartic fit's 14 monomials and two
    #: more: 16 gave the t = 0 rings 1.0e-3 / 8.9e-5 at 642 / 2562 nodes, all 24-26 of the three-ring
    #: 2.4e-3 / 1.7e-4, 18 and 20 in between; docs/validation/curved.md, "The late-furrow drift")
    APART_SIZE = 16

    def __init__(
        self,
        topo: Topology,
        scheme: FitScheme | str = "quadratic",
        apart: np.ndarray | None = None,
        points: np.ndarray | None = None,
    ):
        self.topo = topo
        self.scheme = FIT_SCHEMES[scheme] if isinstance(scheme, str) else scheme
        self._rings: dict[int, list[np.ndarray]] = {}
        n = len(topo.valence)
        self.apart = None if apart is None else np.asarray(apart, dtype=bool)
        if self.apart is not None and (self.apart.shape != (n,) or points is None or len(points) != n):
            raise ValueError(f"a mask of {self.apart.shape} for {n} nodes, and their positions")
        self.points = None if points is None else np.asarray(points, dtype=float)
        self.level = np.full(n, self.scheme.rings, dtype=np.int32)
        small = np.array([len(r) for r in self._rows(self.level)]) < self.scheme.n_terms
        self.level[small] += 1
        self._cache = None

    def _rows(self, level: np.ndarray) -> list[np.ndarray]:
        """Each node's stencil at its ring ``level`` (the masked nodes: the nearest masked nodes one ring wider)."""
        if self.apart is None:
            return [self._ring(int(lv))[i] for i, lv in enumerate(level)]
        rows = []
        for i, lv in enumerate(level):
            if self.apart[i]:
                r = self._ring(int(lv) + 1)[i]
                r = r[self.apart[r]]
                near = np.argsort(np.linalg.norm(self.points[r] - self.points[i], axis=1), kind="stable")
                rows.append(r[near[: self.APART_SIZE]].astype(np.int32))
            else:
                rows.append(self._ring(int(lv))[i])
        return rows

    def _ring(self, k: int) -> list[np.ndarray]:
        if k not in self._rings:
            if k == 1:
                t = self.topo
                self._rings[k] = [t.ring[i, : t.valence[i]] for i in range(len(t.valence))]
            else:
                self._rings[k] = _k_ring_lists(self.topo, k)
        return self._rings[k]

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        if self._cache is None:
            self._cache = _pad(self._rows(self.level))
        return self._cache

    def widen(self, nodes: np.ndarray) -> bool:
        """Move ``nodes`` one ring out; False if they are already at the widest stencil."""
        can = nodes[self.level[nodes] < self.scheme.rings + self.MAX_EXTRA_RINGS]
        self.level[can] += 1
        self._cache = None
        return can.size > 0


_LOWERED = {"calls": 0}


def lowered(name: str, bad: np.ndarray, quality: np.ndarray) -> None:
    """Say (the first time, then every 1000th) that nodes took :func:`quadratic_fallback`."""
    _LOWERED["calls"] += 1
    if _LOWERED["calls"] % 1000 == 1:
        log.info(
            "the %s fit is rank deficient at %d node(s) even on the widest stencil (first: node %d, scaled pivot "
            "%.2e): those take its quadratic terms alone (second order there)",
            name,
            bad.size,
            bad[0],
            quality[bad[0]],
        )


def quadratic_fallback(design: np.ndarray, ssize: np.ndarray, nodes: np.ndarray, distance: np.ndarray, qmin=1e-8):
    """The fit operators ``(len(nodes), P, S)`` of ``nodes`` from the first five (quadratic) columns of
    their ``design`` alone, the higher coefficients zero, on each node's nearest stencil nodes (by
    ``distance`` (N, S), from five on, as few as give a well-posed quadratic: a wide stencil's far side
    folds over the node's tangent plane), and their quality (the scaled pivot of the 5 x 5 normal
    matrix, as ``Geometry.fit_quality``); None if no number of them determines a quadratic.

    Points on two circles through the node determine no quartic (the product of the circles' equations,
    of degree 4 and without a constant term, vanishes on them) but every quadratic:

    >>> t = np.linspace(0.0, 2.0 * np.pi, 9)[:-1] + 0.2
    >>> u = np.r_[1.0 + np.cos(t), np.cos(t)]  # the circles about (1, 0) and (0, 1), radius 1
    >>> w = np.r_[np.sin(t), 1.0 + np.sin(t)]
    >>> pw = FIT_SCHEMES["quartic"].powers
    >>> from math import factorial
    >>> d = np.stack([u**a * w**b / (factorial(a) * factorial(b)) for a, b in pw], 1)[None]
    >>> bool(np.linalg.matrix_rank(d[0]) < len(pw))
    True
    >>> op, q = quadratic_fallback(d, np.array([16]), np.array([0]), np.hypot(u, w)[None])
    >>> h = 0.3 * u - 0.1 * w + 0.5 * 0.7 * u * u - 0.5 * 0.2 * w * w + 0.4 * u * w  # A..E = .3 -.1 .7 -.2 .4
    >>> np.round(op[0] @ h, 12)[:6].tolist()
    [0.3, -0.1, 0.7, -0.2, 0.4, 0.0]
    """
    k = FIT_SCHEMES["quadratic"].n_terms
    out = np.zeros((len(nodes), design.shape[2], design.shape[1]))
    quality = np.zeros(len(nodes))
    for m, i in enumerate(nodes):
        order = np.argsort(distance[i, : ssize[i]], kind="stable")
        for size in range(k, ssize[i] + 1):
            rows = order[:size]
            d = design[i, rows, :k]
            normal = d.T @ d
            diag = np.diag(normal)
            try:
                pivots = np.diag(np.linalg.cholesky(normal)) ** 2
            except np.linalg.LinAlgError:
                continue
            quality[m] = float(pivots.min() / diag.max())
            if quality[m] > qmin:
                out[m, :k, rows] = np.linalg.solve(normal, d.T).T
                break
        else:
            return None
    return out, quality
