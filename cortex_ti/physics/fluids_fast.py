r"""The fluids' single layer applied without a matrix: a far field on nodes and centroids plus sparse corrections.

The dense path (:mod:`cortex_ti.physics.fluids`) builds the collocation matrix ``C`` of the single
layer (``(3N)^2`` doubles), its symmetrised, completed Galerkin form ``V' = (A C + C^T A) / 2 +
c w w^T`` and ``D = mu A V'^{-1} A``. This module applies ``V'`` to a vector in ``O(N)`` memory (and
``O(N^2)`` time by direct sums or ``O(N log N)`` by the FMM), so that ``D`` is never formed (the coupled Krylov solve of
:mod:`cortex_ti.solve.fluid_krylov` carries the traction density ``f = V'^{-1} A v`` as unknowns):

* ``C = C_far + C_near``. ``C_far``, the far field, needs no 7-point rule per triangle: every triangle
  is integrated by the 4-point rule with weights 1/4 on its corners (the vertex rule, the P1 mass
  lumped onto the nodes) and 3/4 on its centroid, exact for quadratics, so its error on a triangle
  at distance ``r`` is ``O(rho^3 / r^4)`` (docs/derivations/lumped_far_field.md). ``C_near``
  (:func:`lumped_corrections`, a Taichi kernel) is sparse: on every (node, triangle) pair within
  :data:`LUMP_RADIUS` triangle sizes (the node's own triangles: Duffy; the near ones: subdivided; the
  rest of the radius: the 7-point rule, as the dense build) the accurate value minus the far field's.
  With an infinite radius ``C`` is the dense path's matrix to round-off (checked in
  tests/physics/test_fluids_fast.py); with the default 3 (the dense build's own near radius) it
  differs from it by the far rule's error, measured 1e-5 of ``|V' f|`` for smooth densities at 642
  nodes and 2.3e-6 in the furrow radius of furrow_in_fluid to t = 3 (its discretisation error 8.9e-4;
  the vertex rule alone, 1.6 times cheaper a product, moved it by 2.3e-4).
* The far field in two sums over the nodes and the ``F`` centroids (``W`` (F, N): ``|T| / 3`` at a
  triangle's corners): ``(A C_far f + C_far^T A f) / 2 = A [(1 - c) G_nn A f + (c / 2) G_nc W f] +
  W^T (c / 2) G_cn A f``, ``c`` = :data:`FAR_CENTROID`, ``G`` the Stokeslet between the points (no
  self term): ``N (N + F) + F N``, about ``5 N^2`` pairs, against ``28 N^2`` for the 7-point rule at
  both ends. By the Taichi kernel :func:`~cortex_ti.physics.stokes_kernel.stokeslet_sums`
  (``direct``; 0.08 CPU s at 2562 nodes) or one call of ``fmm3dpy.stfmm3d`` with two densities
  (``fmm``: sources the nodes and the centroids; its Stokeslet is ``(1 / 8 pi) (I / r + r r^T /
  r^3)``, the factor of ``C`` at ``mu = 1``).
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
from .fluids_near import lumped_corrections, lumped_pairs
from .stokes_bie import node_areas

__all__ = [
    "LUMP_RADIUS",
    "lumped_pairs",
    "lumped_corrections",
    "DIRECT_BACKEND",
    "FMM_BACKEND",
    "FMM_EPS",
    "FmmFluid",
    "fmm_fluid",
    "require_fmm",
    "FMM_MISSING",
]

#: the radius (in triangle sizes) of the exact pairs around the lumped far field (docs/method)
LUMP_RADIUS = 3.0

#: the far field's weight on the triangles' centroids (0: the vertex rule; 3/4: with the vertices' 1/4,
#: exact for quadratics)
FAR_CENTROID = 0.75

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
    :mod:`cortex_ti.physics.stokes_kernel`: ``O(N^2)`` time, ``O(N)`` memory). ``lump``: the radius,
    in units of a triangle's size ``rho``, within which a (node, triangle) pair is integrated exactly
    (as the dense path does) and beyond which the far field's rule takes it (:data:`LUMP_RADIUS`;
    ``math.inf``: every pair exact, the dense path's operator); the centroids' weight in that rule is
    :data:`FAR_CENTROID` when the operator is built."""

    def __init__(
        self,
        points,
        faces,
        normals,
        mu: float,
        far=None,
        eps: float = FMM_EPS,
        backend: str = "fmm",
        lump: float | None = None,
        mu_in: float | None = None,
        **quadrature,
    ):
        self.backend = backend
        self.name = FMM_BACKEND if backend == "fmm" else DIRECT_BACKEND
        self._fmm = require_fmm() if backend == "fmm" else None
        t0 = time.perf_counter()
        x = np.ascontiguousarray(points, float)
        faces = np.asarray(faces, np.int64)
        self.mu = float(mu)
        self.eps = float(eps)
        self.lump = LUMP_RADIUS if lump is None else float(lump)
        area = node_areas(x, faces)
        self.areas3 = np.repeat(area, 3)
        self._x = x
        self.centroid = FAR_CENTROID
        self.correction, self.n_pairs = lumped_corrections(x, faces, self.lump, self.centroid, **quadrature)
        tri = x[faces]
        tarea = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
        self._centroids = np.ascontiguousarray(tri.mean(1))
        self._sources = np.ascontiguousarray(np.concatenate([x, self._centroids]))
        n = len(x)
        self._wc = sp.csr_matrix(
            (np.repeat(tarea / 3.0, 3), (np.repeat(np.arange(len(faces)), 3), faces.ravel())), shape=(len(faces), n)
        )
        # the local part: the diagonal of V' without its completion, A_i C_ii (the accurate self-blocks:
        # the lumped far field has no self term, so the correction's diagonal is the accurate one)
        self.local = sp.diags(self.areas3 * self.correction.diagonal()).tocsc()
        self._correction_t = self.correction.T.tobsr()
        self._w = (area[:, None] * np.asarray(normals, float)).ravel()
        radius = math.sqrt(area.sum() / (4.0 * math.pi))
        self._c = area.mean() * radius / float(self._w @ self._w)  # the dense path's completion
        self.far = None if far is None else np.asarray(far, float).ravel()
        self.mu_in = self.mu if mu_in is None else float(mu_in)
        self.double = None  # a viscosity contrast: the double layer (:mod:`.fluids_double`)
        if self.mu_in != self.mu:
            from .fluids_double import DoubleLayer

            self.double = DoubleLayer(x, faces, **quadrature)
        self.n_fmm = 0
        self.fmm_seconds = 0.0
        self.build_seconds = time.perf_counter() - t0

    @property
    def points(self) -> np.ndarray:
        """The shape (N, 3) the operator is built on (the coupled solve reads its motion)."""
        return self._x

    @property
    def n_unknowns(self) -> int:
        return self.areas3.size

    def mix(self, v: np.ndarray) -> np.ndarray:
        """``M v / mu_out``, ``M = mu_out (1/2 + Kd) + mu_in (1/2 - Kd)`` (``v`` itself for equal
        viscosities): the coupled solve's traction row is ``V' f = A (M v / mu_out - u_inf)``."""
        if self.double is None:
            return v
        mean = 0.5 * (self.mu_in + self.mu) / self.mu
        return mean * v + ((self.mu - self.mu_in) / self.mu) * self.double.apply(v)

    @property
    def mix_diagonal(self) -> np.ndarray | float:
        """The diagonal of ``M / mu_out`` (the preconditioner's local part of it; 1 for equal viscosities)."""
        if self.double is None:
            return 1.0
        return 0.5 * (self.mu_in + self.mu) / self.mu + ((self.mu - self.mu_in) / self.mu) * self.double.diagonal

    def single(self, f: np.ndarray) -> np.ndarray:
        """``V' f = (A C f + C^T A f) / 2 + c w (w . f)`` for ``f`` (3N,), ``C = C_far + C_near``: the far
        field (module docstring) and the corrections."""
        t0 = time.perf_counter()
        f = np.asarray(f, float)
        g = self.areas3 * f
        a = self._far_sums(g.reshape(-1, 3), self._wc @ f.reshape(-1, 3))
        out = self.areas3 * (a[0] + 0.5 * (self.correction @ f)) + 0.5 * (self._correction_t @ g)
        if self.centroid:
            out += (self._wc.T @ a[1]).ravel()
        self.n_fmm += 1
        self.fmm_seconds += time.perf_counter() - t0
        return out + self._c * self._w * (self._w @ f)

    def _far_sums(self, g, wf):
        """The far field's two sums (module docstring), with ``g = A f`` (N, 3) and ``wf = W f`` (F,
        3): at the nodes ``(1 - c) G_nn g + (c / 2) G_nc wf`` (3N,), at the centroids ``(c / 2) G_cn g``
        (F, 3), ``c`` the centroids' weight, ``1 / 8 pi`` included."""
        c, n = self.centroid, len(self._x)
        if c:
            sources = self._sources
            density = np.concatenate([(1.0 - c) * g, (0.5 * c) * wf])
        else:
            sources, density = self._x, g
        if self._fmm is not None:  # one FMM, two densities; fmm3dpy's Stokeslet has the 1 / 8 pi
            both = np.zeros((2, len(sources), 3))
            both[0] = density
            both[1, :n] = (0.5 * c) * g
            pot = self._fmm.stfmm3d(
                eps=self.eps,
                sources=np.ascontiguousarray(sources.T),
                stoklet=np.ascontiguousarray(both.transpose(0, 2, 1)),
                ifppreg=1,
                nd=2,
            ).pot
            return pot[0][:, :n].T.ravel(), pot[1][:, n:].T
        from .stokes_kernel import stokeslet_sums

        u = np.zeros_like(self._x)
        stokeslet_sums(self._x, sources, np.ascontiguousarray(density), u)
        t = np.zeros_like(self._centroids)
        if c:
            stokeslet_sums(self._centroids, self._x, np.ascontiguousarray((0.5 * c) * g), t)
        return u.ravel() / (8.0 * math.pi), t / (8.0 * math.pi)

    def __matmul__(self, v: np.ndarray) -> np.ndarray:
        """``D v = mu A V'^-1 A M v / mu`` by a Krylov solve (diagnostics only: the runs never call it)."""
        return self._dissipate(self.mix(np.asarray(v, float)))

    def resistance(self, v: np.ndarray) -> np.ndarray:
        """``mu A V'^-1 A (M v / mu - u_inf)``: minus the fluids' force on the cortex moving at ``v``
        (``D (v - u_inf)`` for equal viscosities; diagnostics only)."""
        w = self.mix(np.asarray(v, float))
        return self._dissipate(w if self.far is None else w - self.far)

    def _dissipate(self, w: np.ndarray) -> np.ndarray:
        """``mu A V'^-1 A w`` by a Krylov solve."""
        import scipy.sparse.linalg as spla

        v = w
        n3 = self.n_unknowns
        op = spla.LinearOperator((n3, n3), matvec=self.single)
        lu = spla.splu(self.local + sp.diags(np.full(n3, 1e-300)))
        pre = spla.LinearOperator((n3, n3), matvec=lu.solve)
        f, info = spla.gmres(op, self.areas3 * v, M=pre, rtol=1e-11, atol=0.0, restart=200, maxiter=10)
        if info != 0:
            raise SolverError(f"the fluids' single layer did not converge (GMRES info {info})")
        return self.mu * self.areas3 * f


def fmm_fluid(points, faces, normals, *, mu_in: float, mu_out: float, far=None, backend="fmm", **kw) -> FmmFluid:
    """:class:`FmmFluid`; a viscosity contrast (the double layer, :mod:`.fluids_double`) with the
    ``direct`` backend only (the scene rules refuse it with ``fluid.solver: fmm``)."""
    if mu_in != mu_out and backend == "fmm":
        raise SolverError(
            f"fluid.solver = fmm with fluid.inner = {mu_in:g} != fluid.outer = {mu_out:g}: the FMM path "
            "has the single layer only (equal viscosities); use fluid.solver: direct or dense"
        )
    return FmmFluid(points, faces, normals, mu_out, far=far, backend=backend, mu_in=mu_in, **kw)
