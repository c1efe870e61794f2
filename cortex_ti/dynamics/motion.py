r"""How the mesh moves (registry :data:`MESH_MOTIONS`, the scene key ``mesh.motion``).

The cortex moves with its velocity ``v``; the mesh's nodes move with a mesh velocity ``w`` whose
normal part is always ``v_n n`` (the surface is where the cortex is), and whose tangential part
is the motion's choice. What the mesh does not follow, the fields it carries are transported
by: the velocity relative to the mesh, ``v - w`` (:mod:`cortex_ti.surface.transport`).

``normal``      ``w = v_n n``: the paper's (Eq. 60), the default. The nodes keep their place on
                the surface; tangential flow moves material across them.
``lagrangian``  ``w = v``: the nodes are material points; nothing moves across them.
``ale``         ``w = v_n n + w_t`` with ``w_t`` the tangential mesh velocity that relaxes the
                triangles toward the shapes they had at t = 0 (a gradient flow of their
                conformal distortion, :func:`ale_velocity`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..surface.remesh import min_angles

__all__ = [
    "MESH_MOTIONS",
    "MeshMotion",
    "MotionContext",
    "register_motion",
    "ale_velocity",
    "conformal_distortion",
    "volume_gradient",
]


@dataclass(frozen=True)
class MeshMotion:
    """One way the mesh moves: ``velocity(v, normal, points, context) -> w`` (N, 3)."""

    name: str
    description: str
    velocity: Callable | None = None


@dataclass
class MotionContext:
    """What a mesh motion may need beyond the velocity: the connectivity, the triangles' shapes at
    t = 0 (``reference``), the local mesh size and the ALE relaxation time."""

    faces: np.ndarray
    reference: np.ndarray  # (N, 3) the nodes at t = 0
    ale_time: float = 0.05
    _dm_inv: np.ndarray | None = field(default=None, repr=False)

    @property
    def dm_inv(self) -> np.ndarray:
        """(T, 2, 2) inverse of each reference triangle's edge matrix in its own plane."""
        if self._dm_inv is None:
            x = self.reference[self.faces]
            e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
            u = e1 / np.linalg.norm(e1, axis=1)[:, None]
            n = np.cross(e1, e2)
            w = np.cross(n / np.linalg.norm(n, axis=1)[:, None], u)
            dm = np.stack(
                [np.stack([(u * e1).sum(1), (u * e2).sum(1)], 1), np.stack([(w * e1).sum(1), (w * e2).sum(1)], 1)], 1
            )
            self._dm_inv = np.linalg.inv(dm)
        return self._dm_inv


#: name -> :class:`MeshMotion`
MESH_MOTIONS: dict[str, MeshMotion] = {}


def register_motion(name: str, description: str):
    """Decorator adding a mesh velocity function to :data:`MESH_MOTIONS` under ``name``."""

    def deco(func):
        MESH_MOTIONS[name] = MeshMotion(name, description, func)
        return func

    return deco


@register_motion("normal", "the nodes move with the normal velocity v_n n (the paper's Eq. 60)")
def normal_velocity(velocity, normal, points=None, context=None):
    vn = np.einsum("nc,nc->n", velocity, normal)
    return vn[:, None] * normal


@register_motion("lagrangian", "the nodes move with the full velocity: material points")
def lagrangian_velocity(velocity, normal, points=None, context=None):
    return velocity


def conformal_distortion(points: np.ndarray, context: MotionContext, gradient: bool = False):
    r"""The conformal distortion of every triangle against its reference shape,
    ``E_T = |F|^2 / (2 J) - 1`` (0 for a similar triangle, > 0 otherwise; ``F`` the 3x2 map from the
    reference triangle, ``J = sqrt(det F^T F)`` its area ratio), and with ``gradient`` the
    gradient ``(N, 3)`` of ``sum_T E_T`` with respect to the nodes:
    ``dE/dF = (F - |F|^2/2 F C^{-1}) / J``, ``C = F^T F``, chained through ``F = D_s D_m^{-1}``.
    """
    faces = context.faces
    x = points[faces]
    ds = np.stack([x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]], axis=2)  # (T, 3, 2)
    f = ds @ context.dm_inv  # (T, 3, 2)
    c = np.transpose(f, (0, 2, 1)) @ f  # (T, 2, 2)
    i1 = c[:, 0, 0] + c[:, 1, 1]
    det = c[:, 0, 0] * c[:, 1, 1] - c[:, 0, 1] * c[:, 1, 0]
    j = np.sqrt(det)
    energy = i1 / (2.0 * j) - 1.0
    if not gradient:
        return energy
    # C^{-1} of the 2x2 C in closed form
    cinv = np.stack([np.stack([c[:, 1, 1], -c[:, 0, 1]], 1), np.stack([-c[:, 1, 0], c[:, 0, 0]], 1)], 1)
    cinv /= det[:, None, None]
    de_df = (f - 0.5 * i1[:, None, None] * (f @ cinv)) / j[:, None, None]
    de_ds = de_df @ np.transpose(context.dm_inv, (0, 2, 1))  # (T, 3, 2)
    n = points.shape[0]
    idx = np.concatenate([faces[:, 1], faces[:, 2], faces[:, 0]])
    w = np.concatenate([de_ds[:, :, 0], de_ds[:, :, 1], -(de_ds[:, :, 0] + de_ds[:, :, 1])])
    g = np.stack([np.bincount(idx, weights=w[:, k], minlength=n) for k in range(3)], axis=1)
    return energy, g


#: the stiffest rate of the ALE mesh velocity is at most ``ALE_STIFFNESS / (tau sin^2 a)``, ``a`` the
#: smallest angle of the reference triangles and ``tau = mesh.ale_time``: its linearisation (finite
#: differences of :func:`ale_velocity` at zero material flow) has its most negative eigenvalue at
#: -2.16 / tau on the 162-node icosphere (a = 54.4 deg; -2.23 / tau at 642 nodes), -2.50, -3.90,
#: -5.37 and -10.3 / tau on it sheared by 0.35, 0.75, 1.0 and 1.5 (a = 42.8, 33.6, 28.4, 17.8 deg),
#: -2.78 and -4.59 / tau at 642 nodes sheared by 0.35 and 0.75: independent of the mesh size (the
#: mobility h^2 / n_i), growing as the triangles distort (tests/dynamics/test_ale_step.py)
ALE_STIFFNESS = 1.5
#: the fraction of the stability limit a step may use
ALE_STEP_FRACTION = 0.9


def ale_stiffest_rate(context: MotionContext) -> float:
    """An upper estimate of the stiffest decay rate of the ALE mesh velocity about its reference
    triangles (:data:`ALE_STIFFNESS`)."""
    smallest = math.sin(math.radians(float(min_angles(context.reference, context.faces).min())))
    return ALE_STIFFNESS / (context.ale_time * smallest**2)


def ale_step_limit(explicit_interval: float, context: MotionContext) -> float:
    """The largest step with which a scheme whose stability interval on the negative real axis is
    ``explicit_interval`` (:attr:`cortex_ti.dynamics.schemes.Scheme.explicit_interval`) keeps the
    ALE mesh velocity about ``context``'s reference triangles stable (with a 10 % margin)."""
    return ALE_STEP_FRACTION * explicit_interval / ale_stiffest_rate(context)


@register_motion(
    "ale",
    "v_n n plus a tangential mesh velocity relaxing the triangles toward their initial "
    "shapes (relaxation time mesh.ale_time)",
)
def ale_velocity(velocity, normal, points, context: MotionContext):
    r"""``w = v_n n + w_t`` with ``w_t = -(h_i^2 / (tau n_i)) P_i dE/dx_i``: the tangential gradient
    flow of the triangles' conformal distortion (:func:`conformal_distortion`) with mobility
    ``h_i^2 / n_i`` (``h_i`` the mean edge length at node i, ``n_i`` its number of triangles), so
    that a distortion relaxes in about ``tau = mesh.ale_time`` whatever the mesh size. The
    distortion is measured against the triangles at t = 0: an undistorted mesh does not move
    tangentially, and a shape change that keeps the triangles similar (a uniform dilation) needs no
    mesh motion."""
    faces = context.faces
    _, g = conformal_distortion(points, context, gradient=True)
    x = points[faces]
    edges = np.linalg.norm(x - x[:, [1, 2, 0]], axis=2)  # (T, 3)
    count = np.bincount(faces.ravel(), minlength=points.shape[0]).astype(float)
    hsum = np.bincount(faces.ravel(), weights=(edges + edges[:, [2, 0, 1]]).ravel() / 2.0, minlength=points.shape[0])
    h = hsum / count
    g = g - np.einsum("nc,nc->n", g, normal)[:, None] * normal
    wt = -(h * h / (context.ale_time * count))[:, None] * g
    # volume-neutral: the solver keeps sum_k (n_k . dV/dx_k) v_n,k = 0, so the tangential motion
    # must not change the triangulated volume either: remove its component along P dV/dx
    vg = volume_gradient(points, faces)
    pg = vg - np.einsum("nc,nc->n", vg, normal)[:, None] * normal
    norm = float(np.sum(pg * pg))
    if norm > 0.0:
        wt = wt - (float(np.sum(vg * wt)) / norm) * pg
    return normal_velocity(velocity, normal) + wt


def volume_gradient(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``dV/dx_k`` (N, 3) of the triangulated volume ``V = sum_T x_a . (x_b x x_c) / 6``."""
    x = points[faces]
    n = points.shape[0]
    part = np.concatenate([np.cross(x[:, (k + 1) % 3], x[:, (k + 2) % 3]) for k in range(3)]) / 6.0
    idx = np.concatenate([faces[:, k] for k in range(3)])
    return np.stack([np.bincount(idx, weights=part[:, c], minlength=n) for c in range(3)], axis=1)
