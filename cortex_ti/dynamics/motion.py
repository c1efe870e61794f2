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

from dataclasses import dataclass
from typing import Callable

__all__ = ["MESH_MOTIONS", "MeshMotion", "register_motion"]


@dataclass(frozen=True)
class MeshMotion:
    """One way the mesh moves: ``velocity(v, normal, context) -> w`` (N, 3)."""

    name: str
    description: str
    velocity: Callable | None = None


#: name -> :class:`MeshMotion`
MESH_MOTIONS: dict[str, MeshMotion] = {}


def register_motion(name: str, description: str):
    """Decorator adding a mesh velocity function to :data:`MESH_MOTIONS` under ``name``."""
    def deco(func):
        MESH_MOTIONS[name] = MeshMotion(name, description, func)
        return func

    return deco


@register_motion("normal", "the nodes move with the normal velocity v_n n (the paper's Eq. 60)")
def normal_velocity(velocity, normal, context=None):
    vn = (velocity * normal).sum(axis=1)
    return vn[:, None] * normal


@register_motion("lagrangian", "the nodes move with the full velocity: material points")
def lagrangian_velocity(velocity, normal, context=None):
    return velocity
