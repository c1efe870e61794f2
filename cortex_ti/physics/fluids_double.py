r"""The fluids' double layer applied without a matrix: the viscosity contrast of the matrix-free path.

The dense path (:mod:`cortex_ti.physics.fluids`) builds the double layer's collocation matrix ``Kd``
(:func:`~cortex_ti.physics.stokes_bie.double_layer_matrix`): ``Kd u = (3 / 4 pi) (R u - diag(R 1) u) +
u / 2``, ``R`` the raw stresslet integrals ``R[i, j] = sum_T int_T r r^T (r . n_T) / |r|^5 phi_j dA``
(``r = y - x_i``; the 7-point rule, the node's own triangles by Duffy, the near ones subdivided),
``diag(R 1)`` the row sums that subtract the singularity (a rigid motion gives half itself). Here
``R = R_far + R_near`` as the single layer's (:mod:`.fluids_fast`, docs/derivations/lumped_far_field.md):

* ``R_far``: every triangle by the 4-point rule (1/12 of its area on each corner, 3/4 on its centroid,
  exact for quadratics), the kernel's normal the triangle's own: a stresslet sum over the ``N`` nodes
  (normal weight ``m_j = sum_T |T| n_T / 12``, density ``u_j``) and the ``F`` centroids (``(3/4) |T|
  n_T``, the mean of the corners' ``u``), ``3 N^2`` pairs (Taichi, :func:`~.stokes_kernel.stresslet_sums`);
  a node's own source skipped (its own flat triangles give zero, ``r . n_T = 0``).
* ``R_near``: on every (node, triangle) pair within 3 triangle sizes (the dense build's near radius,
  :func:`~cortex_ti.physics.stokes_bie.near_pairs`) the dense build's accurate value minus the 4-point
  value: a block-sparse matrix (a Taichi kernel, :func:`~.stokes_kernel.near_double_blocks`, by
  :func:`~.fluids_near.lumped_corrections`; the node's own flat triangles give zero both ways).
* ``diag(R 1)``: ``R`` applied to the three uniform fields, three products in the build.

The far rule's error on a triangle at distance ``r`` is ``O(rho^3 |k''' |)``, the stresslet's third
derivatives ``O(r^-5)``: ``O(rho^3 / r^5)`` a triangle, one order above the single layer's
(docs/derivations/lumped_far_field.md, "The double layer").

With it the fluids' force is the dense path's unsymmetrised ``-A V'^-1 A (M v - mu_out u_inf)``, ``M =
mu_out (1/2 + Kd) + mu_in (1/2 - Kd)`` (:class:`~cortex_ti.solve.fluid_krylov.FluidKrylov` carries one
traction unknown); the dense path symmetrises ``A V'^-1 A M`` (both converge to the same symmetric
continuum operator; docs/validation/fluids.md measures the difference against Lamb's solutions).
"""

from __future__ import annotations

import math

import numpy as np

from .fluids_near import lumped_corrections

__all__ = ["DoubleLayer"]


class DoubleLayer:
    """``Kd`` on the shape ``points`` (N, 3) applied without a matrix (module docstring): :meth:`apply`,
    and ``diagonal`` (3N) its diagonal (the preconditioner's local part)."""

    def __init__(self, points, faces, **quadrature):
        x = np.ascontiguousarray(points, float)
        faces = np.asarray(faces, np.int64)
        n = len(x)
        tri = x[faces]
        an = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # 2 |T| n_T
        self._x = x
        self._faces = faces
        node_m = np.zeros_like(x)
        for k in range(3):
            np.add.at(node_m, faces[:, k], an / 24.0)
        self._sources = np.ascontiguousarray(np.concatenate([x, tri.mean(1)]))
        self._weights = np.ascontiguousarray(np.concatenate([node_m, 0.375 * an]))
        self.correction, self.n_pairs = lumped_corrections(x, faces, 3.0, double=True, **quadrature)
        ones = np.zeros((3, n, 3))
        for b in range(3):
            ones[b, :, b] = 1.0
        self._rows = np.stack([self._raw(ones[b].ravel()).reshape(n, 3) for b in range(3)], axis=2)  # (N, 3, 3)
        scale = 3.0 / (4.0 * math.pi)
        rdiag = self.correction.diagonal().reshape(n, 3) - np.einsum("naa->na", self._rows)
        self.diagonal = (0.5 + scale * rdiag).ravel()

    def _raw(self, u: np.ndarray) -> np.ndarray:
        """``R u`` (3N,) for ``u`` (3N,): the far sum and the corrections."""
        from .stokes_kernel import stresslet_sums

        un = u.reshape(-1, 3)
        dens = np.ascontiguousarray(np.concatenate([un, un[self._faces].mean(1)]))
        out = np.zeros_like(self._x)
        stresslet_sums(self._x, self._sources, self._weights, dens, out)
        return out.ravel() + self.correction @ u

    def apply(self, u: np.ndarray) -> np.ndarray:
        """``Kd u`` (3N,) for ``u`` (3N,)."""
        u = np.asarray(u, float)
        un = u.reshape(-1, 3)
        rows_u = np.einsum("nab,nb->na", self._rows, un).ravel()
        return (3.0 / (4.0 * math.pi)) * (self._raw(u) - rows_u) + 0.5 * u
