"""The per-triangle blocks of the flat-triangle (P1) Rayleighian that formulations and terms share:
the dissipation of the in-plane viscosities (:func:`viscous_blocks`), the normal-gradient form
``int B^cd d_c v_n d_d v_n dA`` (:func:`normal_blocks`) and the force of that form centred on a rate
(:func:`normal_form_force`). Terms declare and formulations integrate: a term that needs one of these
imports it from here, never from a formulation's module (:mod:`cortex_ti.physics.galerkin`, which
imports the terms). Importing this module starts no Taichi; each function imports its kernel
(:mod:`.galerkin_kernel`) when first called."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from ..surface.geometry import Geometry

__all__ = ["normal_blocks", "normal_form_force", "viscous_blocks"]


def viscous_blocks(area: np.ndarray, normal: np.ndarray, grads: np.ndarray, eta_s: float, eta_b: float) -> np.ndarray:
    """Per-triangle 9x9 blocks (corner-major) of the second derivative of the dissipation.

    With ``G = sum_k v_k g_k^T`` and ``U = (P G + G^T P)/2``: ``|U|^2 = 1/2 sum_km [v_k^T P v_m
    (g_k . g_m) + (g_k . v_m)(g_m . v_k)]`` (the ``g_k`` lie in the plane), ``tr U = sum_k g_k . v_k``,
    so the (k, m) block of ``d^2/dv^2 A [eta_s |U|^2 + (eta_b - eta_s)/2 (tr U)^2]`` is
    ``A [eta_s (P (g_k . g_m) + g_m g_k^T) + (eta_b - eta_s) g_k g_m^T]``, written by one Taichi
    kernel (:mod:`.galerkin_kernel`).
    """
    from .galerkin_kernel import viscous_blocks_kernel  # starts Taichi

    out = np.empty((len(area), 9, 9))
    # absurd viscosities (1e308) overflow to inf here; the solver then refuses the matrix in one line
    viscous_blocks_kernel(
        np.ascontiguousarray(area, dtype=float),
        np.ascontiguousarray(normal, dtype=float),
        np.ascontiguousarray(grads, dtype=float),
        float(eta_s),
        float(eta_b),
        out,
    )
    return out


def _triangle_form(geometry: Geometry, faces: np.ndarray, bform: np.ndarray, tnormal: np.ndarray) -> np.ndarray:
    """``B^cd e_c e_d`` per triangle (T, 3, 3): the corner mean, projected on the triangle, clipped
    to its positive semidefinite part (one Taichi kernel, :mod:`.galerkin_kernel`)."""
    from .galerkin_kernel import triangle_form_kernel  # starts Taichi

    out = np.empty((len(faces), 3, 3))
    triangle_form_kernel(
        np.ascontiguousarray(faces, dtype=np.int32),
        np.ascontiguousarray(geometry.tangents, dtype=float),
        np.ascontiguousarray(bform, dtype=float),
        np.ascontiguousarray(tnormal, dtype=float),
        out,
    )
    return out


def normal_blocks(
    geometry: Geometry, faces: np.ndarray, bform: np.ndarray, tnormal: np.ndarray, grads: np.ndarray, area: np.ndarray
) -> np.ndarray:
    """Per-triangle 9x9 blocks of ``int B^cd d_c v_n d_d v_n dA`` with ``v_n = n_k . v_k`` linear."""
    from .galerkin_kernel import normal_blocks_kernel  # starts Taichi

    bt = _triangle_form(geometry, faces, bform, tnormal)
    out = np.empty((len(area), 9, 9))
    normal_blocks_kernel(
        np.ascontiguousarray(area, dtype=float),
        np.ascontiguousarray(geometry.normal[faces], dtype=float),
        np.ascontiguousarray(grads, dtype=float),
        np.ascontiguousarray(bt, dtype=float),
        out,
    )
    return out


def normal_form_force(
    geometry: Geometry,
    faces: np.ndarray,
    bform: np.ndarray,
    tnormal: np.ndarray,
    grads: np.ndarray,
    area: np.ndarray,
    rate: np.ndarray,
) -> np.ndarray:
    """(T, 9): the blocks of :func:`normal_blocks` applied to the nodal vectors ``rate`` (N, 3),
    without forming them: the force of ``1/2 int B^cd d_c (v_n - r_n) d_d (v_n - r_n) dA`` that
    moves its minimum from ``v_n = 0`` to ``v_n = r_n``."""
    from .galerkin_kernel import normal_force_kernel  # starts Taichi

    out = np.empty((len(faces), 9))
    normal_force_kernel(
        np.ascontiguousarray(area, dtype=float),
        np.ascontiguousarray(geometry.normal[faces], dtype=float),
        np.ascontiguousarray(grads, dtype=float),
        _triangle_form(geometry, faces, bform, tnormal),
        np.ascontiguousarray(np.asarray(rate, dtype=float)[faces]),
        out,
    )
    return out
