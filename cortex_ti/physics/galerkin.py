r"""The force balance as the stationary point of the discrete Rayleighian on the flat triangles
(formulation ``rayleigh_p1``): symmetric positive semidefinite by construction.

The paper's model is a gradient flow: the velocity makes the Rayleighian stationary,

.. math::
    \mathcal R[v] = \int \big[\eta_s\,|\tilde u|^2 + \tfrac{\eta_b}{2}(\mathrm{tr}\,u)^2\big]\,dA
      + \int \zeta\,\mathrm{tr}\,u\,dA - P\,\dot V[v] + \mathcal R_b[v],

``u`` the surface strain rate, ``u~`` its traceless part (so the stress is
``t = 2 eta_s u~ + eta_b tr u g``), ``P`` the multiplier of the volume constraint and ``R_b``
the bending viscosity. Its stationarity conditions are the weak form of the force balance the
paper solves in strong form by least squares (:mod:`cortex_ti.physics.assembly`).

Here the velocity is interpolated linearly on each flat triangle ``T`` and every term is
integrated exactly over the triangles:

* **dissipation** ``sum_T A_T [eta_s |U~_T|^2 + eta_b/2 (tr U_T)^2]``, ``U_T = (P G + G^T P)/2``,
  ``G = sum_k v_k (x) grad psi_k`` the in-plane gradient of the linear velocity,
  ``P = I - n_T n_T^T``: a symmetric positive semidefinite ``K`` whose kernel on a closed mesh
  is the rigid motions and nothing else (no hourglass modes, no penalty);
* **active power** ``sum_T A_T zeta_T tr U_T`` (``zeta_T`` the mean of the corner values): exactly
  the rate of the discrete energy ``E(X) = sum_T zeta_T A_T(X)``, so the active force is the exact
  gradient ``-dE/dX`` and the shape dynamics is a gradient flow;
* **pressure**: the multiplier of a volume constraint. The triangulated volume's exact gradient
  ``dV/dx_k`` weighs node k with its barycentric area, the tension's (the cotangent formula)
  with its Voronoi area; they differ by up to 13 % on an icosphere, so a uniform tension would
  drive an O(h) flow at t = 0 if the pressure pushed along ``dV/dx_k``. By default
  (``numerics.pressure_weights: petrov``) the pressure pushes on the Meyer areas,
  ``P A_k n_k`` (the paper's Eq. 35, consistent with the tension's force to O(h^2)), while the
  constraint it enforces is the exact one, ``sum_k W_k v_n,k = 0`` with ``W_k = n_k . dV/dx_k``,
  so the triangulated volume is stationary under the normal advection of the nodes.
  ``area``: both on the Meyer areas; ``exact``: both on ``W`` (then the force is exactly minus
  the gradient of ``E - P V``, at the price of that O(h) error);
* **rigid-body gauge** as the paper's (zero mean velocity, or the centroid held: scene key
  ``translation``);
* **bending viscosity** as the dissipation ``1/2 int [B^cd d_c v_n d_d v_n + beta_0 v_n^2] dA``
  with ``B = -beta``, ``beta`` and ``beta_0`` the paper's Eq. 45 coefficients
  (:func:`cortex_ti.physics.terms.bending.bending_tensors`, from the fitted curvature). Its
  Euler-Lagrange force is ``-nabla_c (B^cd nabla_d v_n) + beta_0 v_n``; Eq. 45 is
  ``-B^cd nabla_c nabla_d v_n + beta_0 v_n``: they differ by ``-(nabla_c B^cd) nabla_d v_n``,
  zero on a sphere and wherever the curvature is uniform. ``v_n`` is interpolated linearly and
  its gradient integrated exactly per triangle, ``B`` averaged over the corners, projected on
  the triangle and clipped to its positive semidefinite part; ``beta_0 v_n^2`` is lumped at the
  nodes;
* **semi-implicit tension** (a step ``dt``): ``dt zeta |grad v_n|^2`` integrated the same way,
  the leading part of the tension's Hessian (the paper's ``-zeta dt Lap v_n``, without its
  indefinite ``-zeta dt C~ v_n``), so the step's matrix stays definite whatever ``dt``.

The fits (:mod:`cortex_ti.surface.geometry`) give only the normals (the direction of ``v_n``
and of the advection) and the curvature of the bending term. What this formulation pays is the
accuracy of a flat-triangle geometry: second order, where the paper's quartic fit reaches
fourth on smooth shapes.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..solve.system import EnergySystem
from ..surface.geometry import Geometry
from .assembly import check_inputs, velocity_basis
from .model import Physics
from .terms.bending import bending_tensors
from .terms.constraints import gauge_rows

__all__ = ["assemble_p1", "PRESSURE_WEIGHTS", "triangle_gradients"]

#: How the pressure enters (``numerics.pressure_weights``, see the module docstring).
PRESSURE_WEIGHTS = {
    "petrov": "force on the Meyer areas, constraint on the exact rate of the triangulated volume",
    "area": "force and constraint on the Meyer areas (the paper's Eq. 35)",
    "exact": "force and constraint on the exact gradient of the triangulated volume",
}


def triangle_gradients(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Areas ``(T,)``, unit normals ``(T, 3)`` and the in-plane gradients of the three
    barycentric functions ``(T, 3, 3)`` (corner, xyz) of the flat triangles."""
    x = points[faces]
    cr = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    twice = np.linalg.norm(cr, axis=1)
    n = cr / twice[:, None]
    grads = np.empty((faces.shape[0], 3, 3))
    for k in range(3):
        a, b = x[:, (k + 1) % 3], x[:, (k + 2) % 3]
        grads[:, k] = np.cross(n, b - a) / twice[:, None]
    return 0.5 * twice, n, grads


class _Pattern:
    """CSR structure of a (3N, 3N) matrix assembled from per-triangle 9x9 blocks and the
    position of every block entry in its data array (the connectivity is fixed over a run)."""

    def __init__(self, faces: np.ndarray, n_nodes: int):
        dof = (faces[:, :, None] * 3 + np.arange(3)[None, None, :]).reshape(-1, 9)
        rows = np.broadcast_to(dof[:, :, None], (len(faces), 9, 9)).ravel()
        cols = np.broadcast_to(dof[:, None, :], (len(faces), 9, 9)).ravel()
        size = 3 * n_nodes
        key = rows.astype(np.int64) * size + cols
        uniq, self.position = np.unique(key, return_inverse=True)
        self.indices = (uniq % size).astype(np.int32)
        self.indptr = np.searchsorted(uniq // size, np.arange(size + 1)).astype(np.int32)
        self.shape = (size, size)
        self.nnz = uniq.size
        self.dof = dof

    def matrix(self, local: np.ndarray) -> sp.csr_matrix:
        data = np.bincount(self.position, weights=local.ravel(), minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=self.shape)


_PATTERNS: dict = {}


def _pattern(faces: np.ndarray, n_nodes: int) -> _Pattern:
    """The block pattern of a connectivity, computed once (a few kept)."""
    key = (n_nodes, faces.shape, hash(faces.tobytes()))
    if key not in _PATTERNS:
        if len(_PATTERNS) >= 8:
            _PATTERNS.clear()
        _PATTERNS[key] = _Pattern(faces, n_nodes)
    return _PATTERNS[key]


def viscous_blocks(area: np.ndarray, normal: np.ndarray, grads: np.ndarray, eta_s: float,
                   eta_b: float) -> np.ndarray:
    """Per-triangle 9x9 blocks (corner-major) of the second derivative of the dissipation.

    With ``G = sum_k v_k g_k^T`` and ``U = (P G + G^T P)/2``: ``|U|^2 = 1/2 sum_km [v_k^T P v_m
    (g_k . g_m) + (g_k . v_m)(g_m . v_k)]`` (the ``g_k`` lie in the plane), ``tr U = sum_k g_k . v_k``,
    so the (k, m) block of ``d^2/dv^2 A [eta_s |U|^2 + (eta_b - eta_s)/2 (tr U)^2]`` is
    ``A [eta_s (P (g_k . g_m) + g_m g_k^T) + (eta_b - eta_s) g_k g_m^T]``.
    """
    proj = np.eye(3)[None] - normal[:, :, None] * normal[:, None, :]          # (T, 3, 3)
    gg = grads @ grads.transpose(0, 2, 1)                                    # g_k . g_m
    outer = grads[:, :, :, None, None] * grads[:, None, None, :, :]          # [t,k,i,m,j] = g_ki g_mj
    # absurd viscosities (1e308) overflow here; the solver then refuses the matrix in one line
    with np.errstate(over="ignore", invalid="ignore"):
        blk = eta_s * (gg[:, :, None, :, None] * proj[:, None, :, None, :] + outer.transpose(0, 3, 2, 1, 4))
        blk += (eta_b - eta_s) * outer
        return area[:, None, None] * blk.reshape(-1, 9, 9)


def _normal_form(geometry: Geometry, physics: Physics, zeta: np.ndarray, implicit_dt: float,
                 terms: list[str]) -> tuple[np.ndarray | None, np.ndarray]:
    """``B^cd`` (N, 2, 2) of the dissipation ``1/2 B^cd d_c v_n d_d v_n`` (bending viscosity and
    the semi-implicit tension; None without either) and ``beta_0`` (N,) of ``1/2 beta_0 v_n^2``."""
    eff = physics.effects
    bform, beta0 = None, np.zeros(geometry.n_nodes)
    if "bending_viscosity" in eff and (physics.eta_bar > 0 or physics.eta_bar_b > 0):
        beta, beta0 = bending_tensors(geometry, physics.eta_bar, physics.eta_bar_b)
        bform = -beta
        terms.append("bending viscosity")
    if implicit_dt > 0.0 and "active_stress" in eff:
        # dt zeta |grad v_n|^2, zeta clipped at 0: positive semidefinite whatever dt
        imp = (implicit_dt * np.clip(zeta, 0.0, None))[:, None, None] * geometry.metric_inv
        bform = imp if bform is None else bform + imp
        terms.append("semi-implicit active tension")
    return bform, beta0


def _normal_blocks(geometry: Geometry, faces: np.ndarray, bform: np.ndarray, tnormal: np.ndarray,
                   grads: np.ndarray, area: np.ndarray) -> np.ndarray:
    """Per-triangle 9x9 blocks of ``int B^cd d_c v_n d_d v_n dA`` with ``v_n = n_k . v_k`` linear."""
    e = geometry.tangents
    bt = (e.transpose(0, 2, 1) @ bform @ e)[faces].mean(axis=1)             # B^cd e_c e_d, corner mean
    proj = np.eye(3)[None] - tnormal[:, :, None] * tnormal[:, None, :]
    bt = proj @ bt @ proj
    bt = 0.5 * (bt + bt.transpose(0, 2, 1))
    # the tensor lies in the triangle's plane (rank 2): PSD iff its trace and the product of its
    # in-plane eigenvalues are >= 0; elsewhere clip the negative eigenvalues
    tr = np.trace(bt, axis1=1, axis2=2)
    det2 = 0.5 * (tr ** 2 - np.sum(bt * bt, axis=(1, 2)))
    bad = (tr < 0.0) | (det2 < 0.0)
    if bad.any():
        w, vec = np.linalg.eigh(bt[bad])
        bt[bad] = np.einsum("tia,ta,tja->tij", vec, np.clip(w, 0.0, None), vec)
    nrm = geometry.normal
    gn = (grads.transpose(0, 2, 1)[:, :, :, None] * nrm[faces][:, None, :, :]).reshape(-1, 3, 9)  # grad v_n rows
    return area[:, None, None] * (gn.transpose(0, 2, 1) @ bt @ gn)


def _lumped_normal(geometry: Geometry, beta0: np.ndarray) -> sp.csr_matrix:
    """``sum_k A_k beta_0,k (n_k . v_k)^2`` as a (3N, 3N) block-diagonal matrix."""
    n, nrm = geometry.n_nodes, geometry.normal
    nn = (beta0 * geometry.area)[:, None, None] * nrm[:, :, None] * nrm[:, None, :]
    r = np.repeat(np.arange(n)[:, None] * 3 + np.arange(3)[None, :], 3, axis=1).reshape(n, 3, 3)
    return sp.csr_matrix((nn.ravel(), (r.ravel(), r.transpose(0, 2, 1).ravel())), shape=(3 * n, 3 * n))


def _constraint_rows(geometry: Geometry, physics: Physics, pressure_weights: str, terms: list[str]):
    """The gauge and volume rows (m, N, 3), the rows the multipliers push along (None: the same),
    and the names and the index of the pressure's multiplier."""
    rows = [gauge_rows(geometry, physics)]
    names = [f"momentum[{k}]" for k in range(6)]
    if not ("incompressibility" in physics.effects and physics.normal_balance):
        return np.concatenate(rows), None, names, None
    nrm = geometry.normal
    exact = np.einsum("nc,nc->n", nrm, geometry.volume_gradient)
    terms.append("pressure and volume conservation")
    names.append("volume")
    force_on = exact if pressure_weights == "exact" else geometry.area
    enforce = geometry.area if pressure_weights == "area" else exact
    cons = np.concatenate(rows + [(enforce[:, None] * nrm)[None]])
    force = None if pressure_weights != "petrov" else np.concatenate(rows + [(force_on[:, None] * nrm)[None]])
    return cons, force, names, 6


def assemble_p1(geometry: Geometry, physics: Physics, zeta: np.ndarray, faces: np.ndarray,
                implicit_dt: float = 0.0, pressure_weights: str = "petrov") -> EnergySystem:
    """The Rayleighian system of the effects in ``physics`` on the shape ``geometry`` (module
    docstring); ``implicit_dt > 0``: the semi-implicit tension of a step of that length."""
    if pressure_weights not in PRESSURE_WEIGHTS:
        raise SolverError(f"unknown pressure_weights {pressure_weights!r}: choose one of {', '.join(PRESSURE_WEIGHTS)}")
    zeta = check_inputs(physics, zeta, implicit_dt)
    eff = physics.effects
    n = geometry.n_nodes
    faces = np.asarray(faces)
    area, tnormal, grads = triangle_gradients(geometry.points, faces)
    eta_b = physics.eta_b if "bulk_viscosity" in eff else 0.0
    terms = ["shear viscosity"] + (["bulk viscosity"] if eta_b > 0 else [])
    pattern = _pattern(faces, n)
    local = viscous_blocks(area, tnormal, grads, physics.eta_s, eta_b)
    beta0 = np.zeros(n)
    if physics.normal_balance:
        bform, beta0 = _normal_form(geometry, physics, zeta, float(implicit_dt), terms)
        if bform is not None:
            local = local + _normal_blocks(geometry, faces, bform, tnormal, grads, area)
    kmat = pattern.matrix(local)
    if np.any(beta0):
        kmat = (kmat + _lumped_normal(geometry, beta0)).tocsr()
    f = np.zeros(3 * n)
    if "active_stress" in eff:
        terms.append("active tension")
        ft = -(area * zeta[faces].mean(axis=1))[:, None] * grads.reshape(-1, 9)   # -A_T zeta_T grad tr U
        f = np.bincount(pattern.dof.ravel(), weights=ft.ravel(), minlength=3 * n)
    cons, force, names, pidx = _constraint_rows(geometry, physics, pressure_weights, terms)
    basis = velocity_basis(geometry, physics)
    if basis.shape[1] != 3:          # tangential unknowns only (fixed_normal_velocity)
        bmat = sp.block_diag([basis[i].T for i in range(n)], format="csr")  # (3N, nb N)
        kmat = (bmat.T @ kmat @ bmat).tocsr()
        f = bmat.T @ f

    def on_unknowns(rows):
        return np.einsum("mnc,nbc->mnb", rows, basis).reshape(rows.shape[0], -1)

    return EnergySystem(stiffness=kmat, rhs=f, constraints=on_unknowns(cons), constraint_names=names,
                        basis=basis, pressure_index=pidx, pressure_sign=-1.0, terms=terms,
                        force_rows=None if force is None else on_unknowns(force))
