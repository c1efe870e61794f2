r"""The fluids' single layer applied without a matrix: fmm3dpy's Stokes FMM plus sparse near corrections.

The dense path (:mod:`cortex_ti.physics.fluids`) builds the collocation matrix ``C`` of the single
layer (``(3N)^2`` doubles), its symmetrised, completed Galerkin form ``V' = (A C + C^T A) / 2 +
c w w^T`` and ``D = mu A V'^{-1} A``. This module applies the same ``V'`` to a vector in ``O(N log N)``
memory and time, so that ``D`` is never formed (the coupled Krylov solve of
:mod:`cortex_ti.solve.fluid_krylov` carries the traction density ``f = V'^{-1} A v`` as unknowns):

* ``C = C_7 + C_near``: ``C_7`` the 7-point rule of every triangle against every node (the plain far
  field), ``C_near`` the sparse correction on the pairs :func:`~cortex_ti.physics.stokes_bie.near_pairs`
  replaces (own triangles: Duffy; near triangles: subdivided), the accurate value minus the 7-point
  one. The dense matrix is ``C_7 + C_near`` exactly (:func:`~cortex_ti.physics.stokes_bie._layer`),
  so the two paths discretise the same operator and differ by the FMM's and the Krylov solve's
  tolerances only.
* ``C_7 f`` and ``C_7^T g`` in one call of ``fmm3dpy.stfmm3d`` with two densities: the sources are
  the ``7F`` quadrature points and the ``N`` nodes, the first density the quadrature weights times
  ``f`` at the quadrature points (read at the nodes: ``C_7 f``), the second ``g = A f`` at the nodes
  (read at the quadrature points and summed back by the weights: ``C_7^T g``; the Stokeslet is
  symmetric). fmm3dpy's Stokeslet is ``(1 / 8 pi) (I / r + r r^T / r^3)``, the factor of ``C`` at
  ``mu = 1``.
* ``V_local``: the diagonal of ``V'`` without the completion, ``A_i C_ii`` (a node's accurate
  self-interaction, Duffy quadrature on its own triangles): the local part of ``V'`` the
  preconditioner factorises. Measured on furrow_in_fluid (GMRES iterations to 1e-9, factorisation CPU
  s): the diagonal 20 / 24 iterations at 642 / 2562 nodes (0.04 / 0.35 s), all the near blocks 15 / 16
  (0.8 / 50 s: their LU fills in), the one-ring blocks 38 at 642 (a truncated kernel is a poorer
  approximation); docs/validation/fluids.md.

fmm3dpy is the optional extra ``fluids`` (``pip install 'cortex-ti[fluids]'``); without it
:func:`require_fmm` raises one :class:`~cortex_ti.errors.SolverError` naming the extra.
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .stokes_bie import near_pairs, node_areas, radon7

__all__ = ["DIRECT_BACKEND", "FMM_BACKEND", "FMM_EPS", "FmmFluid", "fmm_fluid", "require_fmm", "FMM_MISSING"]

#: the FMM's requested relative precision (below the Krylov tolerance of the coupled solve)
FMM_EPS = 1e-9

#: the name :class:`~cortex_ti.solve.system.SolveInfo` and the run summary report for this solve
FMM_BACKEND = "gmres-fmm"
#: ... and for the direct sums (``fluid.solver: direct``)
DIRECT_BACKEND = "gmres-direct"

#: the one line a run without fmm3dpy gets
FMM_MISSING = (
    "fluid.solver = fmm needs fmm3dpy (the Stokes FMM): install the extra fluids "
    "(pip install 'cortex-ti[fluids]') or set fluid.solver: dense"
)


def require_fmm():
    """The module ``fmm3dpy``, or one :class:`SolverError` naming the extra."""
    try:
        import fmm3dpy
    except ImportError:
        raise SolverError(FMM_MISSING) from None
    return fmm3dpy


class FmmFluid:
    """The fluids of equal viscosity ``mu`` on one shape, matrix-free (module docstring): ``V'``
    applied by :meth:`single`, its local part ``local`` (sparse), the nodes' areas ``areas3`` (3N,
    each node's area three times), ``far`` (3N) the far-field velocity at the nodes or None. The
    coupled solve (:class:`cortex_ti.solve.fluid_krylov.FluidKrylov`) reads these. ``backend``:
    ``fmm`` (fmm3dpy) or ``direct`` (every pair summed by a Taichi kernel,
    :mod:`cortex_ti.physics.stokes_kernel`: ``O(N^2)`` time, ``O(N)`` memory)."""

    def __init__(
        self, points, faces, normals, mu: float, far=None, eps: float = FMM_EPS, backend: str = "fmm", **quadrature
    ):
        self.backend = backend
        self.name = FMM_BACKEND if backend == "fmm" else DIRECT_BACKEND
        self._fmm = require_fmm() if backend == "fmm" else None
        t0 = time.perf_counter()
        x = np.ascontiguousarray(points, float)
        faces = np.asarray(faces, np.int64)
        n, nf = len(x), len(faces)
        self.mu = float(mu)
        self.eps = float(eps)
        area = node_areas(x, faces)
        self.areas3 = np.repeat(area, 3)
        tri = x[faces]
        tarea = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        bary, w = radon7()
        nq = len(w)
        y = np.einsum("qk,fkc->fqc", bary, tri).reshape(-1, 3)
        # quadrature weights: nodal values (N,) -> strengths at the quadrature points (7F,)
        self._weights = sp.csr_matrix(
            (
                (tarea[:, None, None] * w[None, :, None] * bary[None]).ravel(),
                (np.repeat(np.arange(nf * nq), 3), np.repeat(faces[:, None, :], nq, axis=1).ravel()),
            ),
            shape=(nf * nq, n),
        )
        self._sources = np.ascontiguousarray(np.concatenate([y, x]).T)  # (3, 7F + N)
        self._x, self._y = x, np.ascontiguousarray(y)
        self._nq = nf * nq
        pi, pf, corr, plain = near_pairs(x, faces, False, **quadrature)
        accurate = corr + plain
        self.correction = _scatter(pi, faces[pf], corr, n) / (8.0 * math.pi)
        # the local part: the diagonal of V' without its completion, A_i C_ii (the accurate self-blocks)
        c_local = _scatter(pi, faces[pf], accurate, n) / (8.0 * math.pi)
        self.local = sp.diags(self.areas3 * c_local.diagonal()).tocsc()
        self._correction_t = self.correction.T.tocsr()
        self._w = (area[:, None] * np.asarray(normals, float)).ravel()
        radius = math.sqrt(area.sum() / (4.0 * math.pi))
        self._c = area.mean() * radius / float(self._w @ self._w)  # the dense path's completion
        self.far = None if far is None else np.asarray(far, float).ravel()
        self.n_fmm = 0
        self.fmm_seconds = 0.0
        self.build_seconds = time.perf_counter() - t0

    @property
    def n_unknowns(self) -> int:
        return self.areas3.size

    def single(self, f: np.ndarray) -> np.ndarray:
        """``V' f = (A C f + C^T A f) / 2 + c w (w . f)`` for ``f`` (3N,)."""
        t0 = time.perf_counter()
        f = np.asarray(f, float)
        n = f.size // 3
        g = self.areas3 * f
        if self._fmm is None:
            cf, ctg = self._direct(f.reshape(n, 3), g.reshape(n, 3))
        else:
            cf, ctg = self._fmm_sums(f.reshape(n, 3), g.reshape(n, 3))
        cf = cf + self.correction @ f
        ctg = ctg + self._correction_t @ g
        self.n_fmm += 1
        self.fmm_seconds += time.perf_counter() - t0
        return 0.5 * (self.areas3 * cf + ctg) + self._c * self._w * (self._w @ f)

    def _direct(self, f, g):
        """``(C_7 f, C_7^T g)`` (3N each) by the direct sums."""
        from .stokes_kernel import stokeslet_sums

        s = np.ascontiguousarray(self._weights @ f)
        u = np.zeros_like(self._x)
        t = np.zeros_like(self._y)
        stokeslet_sums(self._x, self._y, s, np.ascontiguousarray(g), u, t)
        scale = 1.0 / (8.0 * math.pi)
        return scale * u.ravel(), scale * (self._weights.T @ t).ravel()

    def _fmm_sums(self, f, g):
        """``(C_7 f, C_7^T g)`` (3N each) by one FMM with two densities."""
        strength = np.zeros((2, self._sources.shape[1], 3))
        strength[0, : self._nq] = self._weights @ f
        strength[1, self._nq :] = g
        stoklet = np.ascontiguousarray(strength.transpose(0, 2, 1))
        pot = self._fmm.stfmm3d(eps=self.eps, sources=self._sources, stoklet=stoklet, ifppreg=1, nd=2).pot
        return pot[0][:, self._nq :].T.ravel(), (self._weights.T @ pot[1][:, : self._nq].T).ravel()

    def __matmul__(self, v: np.ndarray) -> np.ndarray:
        """``D v = mu A V'^-1 A v`` by a Krylov solve (diagnostics only: the runs never call it)."""
        import scipy.sparse.linalg as spla

        n3 = self.n_unknowns
        op = spla.LinearOperator((n3, n3), matvec=self.single)
        lu = spla.splu(self.local + sp.diags(np.full(n3, 1e-300)))
        pre = spla.LinearOperator((n3, n3), matvec=lu.solve)
        f, info = spla.gmres(op, self.areas3 * v, M=pre, rtol=1e-11, atol=0.0, restart=200, maxiter=10)
        if info != 0:
            raise SolverError(f"the fluids' single layer did not converge (GMRES info {info})")
        return self.mu * self.areas3 * f


def _scatter(pi: np.ndarray, corners: np.ndarray, blocks: np.ndarray, n: int) -> sp.csr_matrix:
    """Blocks (P, 3 corners, 3, 3) of (node pi, corner node) pairs as a sparse (3N, 3N) matrix."""
    a = np.arange(3)
    rows = np.broadcast_to(pi[:, None, None, None] * 3 + a[None, None, :, None], blocks.shape)
    cols = np.broadcast_to(corners[:, :, None, None] * 3 + a[None, None, None, :], blocks.shape)
    return sp.csr_matrix((blocks.ravel(), (rows.ravel(), cols.ravel())), shape=(3 * n, 3 * n))


def fmm_fluid(points, faces, normals, *, mu_in: float, mu_out: float, far=None, backend="fmm", **kw) -> FmmFluid:
    """:class:`FmmFluid` for equal viscosities; a viscosity contrast (the double layer) is the dense
    path's only (the scene rules refuse it with ``fluid.solver: fmm``)."""
    if mu_in != mu_out:
        raise SolverError(
            f"fluid.solver = {backend} with fluid.inner = {mu_in:g} != fluid.outer = {mu_out:g}: the matrix-free path "
            "has the single layer only (equal viscosities); use fluid.solver: dense"
        )
    return FmmFluid(points, faces, normals, mu_out, far=far, backend=backend, **kw)
