r"""Spherical-harmonic content of a nodal field on a closed, star-shaped surface, and growth rates.

A field ``f`` at the nodes (the myosin density of a frame, say) is expanded in the real
orthonormal harmonics ``Y_lm`` (:func:`cortex_ti.physics.spherical.real_sph_harm`) of the
directions ``u_i`` of the nodes seen from the surface's area centroid (so a cell that moves does
not mix its degrees): the coefficients ``a_lm`` minimise ``sum_i w_i (f_i - sum a_lm Y_lm(u_i))^2``
with the barycentric dual areas ``w_i`` scaled to a total ``4 pi`` (by the normal equations). A
field that is a combination of the harmonics up to ``lmax`` is reproduced exactly (to round-off)
on any mesh; otherwise ``a_lm`` tends to ``oint f Y_lm dOmega`` on a sphere at the quadrature's
second order. The amplitude of degree l is ``|a_l| = sqrt(sum_m a_lm^2)``, invariant under rotations.

>>> from cortex_ti.physics.spherical import real_sph_harms_at
>>> from cortex_ti.surface.mesh import icosphere
>>> m = icosphere(642)
>>> f = 1.0 + 0.02 * real_sph_harms_at(2, m.points)[:, 6]
>>> degree_amplitudes(m.points, m.faces, f, lmax=3).round(6) + 0.0
array([3.544908, 0.      , 0.02    , 0.      ])
>>> round(growth_rate([0.0, 1.0, 2.0], [1.0, np.e**0.5, np.e]), 12)
0.5
"""

from __future__ import annotations

import math

import numpy as np

from ..physics.spherical import real_sph_harms_at

__all__ = ["harmonic_coefficients", "degree_amplitudes", "growth_rate"]


def _weights(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Barycentric dual areas scaled to a total of ``4 pi`` (the sphere's solid angle)."""
    x = points[faces]
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    w = np.bincount(faces.ravel(), weights=np.repeat(area / 3.0, 3), minlength=points.shape[0])
    return w * (4.0 * math.pi / w.sum()), area


def harmonic_coefficients(points, faces, values, lmax: int) -> dict[int, np.ndarray]:
    """``{l: a_l}``, ``a_l[m + l] = a_lm`` for ``m = -l..l``, of the nodal ``values`` (module docstring).

    Needs more nodes than the ``(lmax + 1)^2`` harmonics.

    >>> from cortex_ti.physics.spherical import real_sph_harms_at
    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> harmonic_coefficients(m.points, m.faces, real_sph_harms_at(1, m.points)[:, 1], 1)[1].round(12) + 0.0
    array([1., 0., 0.])
    """
    pts = np.asarray(points, dtype=float)
    faces = np.asarray(faces)
    f = np.asarray(values, dtype=float)
    lmax = int(lmax)
    if lmax < 0 or (lmax + 1) ** 2 >= pts.shape[0]:
        raise ValueError(f"lmax must be >= 0 with (lmax + 1)^2 below the {pts.shape[0]} nodes, got {lmax}")
    if f.shape != (pts.shape[0],):
        raise ValueError(f"values must have one number per node ({pts.shape[0]}), got shape {f.shape}")
    w, area = _weights(pts, faces)
    # the area centroid of the surface (of its triangles)
    centre = (area[:, None] * pts[faces].mean(axis=1)).sum(0) / area.sum()
    u = pts - centre
    Y = real_sph_harms_at(lmax, u)
    # the normal equations: the weighted harmonics are orthonormal up to the quadrature's O(h^2), so
    # their Gram matrix is close to the identity and as well conditioned (an SVD costs 10x more)
    Ys = Y * np.sqrt(w)[:, None]
    a = np.linalg.solve(Ys.T @ Ys, Ys.T @ (f * np.sqrt(w)))
    return {l: a[l * l : (l + 1) ** 2] for l in range(lmax + 1)}


def degree_amplitudes(points, faces, values, lmax: int) -> np.ndarray:
    """``(lmax + 1,)``: the amplitude ``sqrt(sum_m a_lm^2)`` of every degree (module docstring)."""
    return np.array([np.linalg.norm(a) for a in harmonic_coefficients(points, faces, values, lmax).values()])


def growth_rate(times, amplitudes) -> float:
    """The rate ``d log|a| / dt`` of a least-squares line through ``log|a|`` against ``t`` (the
    frames given: pick the window where one mode dominates)."""
    t = np.asarray(times, dtype=float)
    a = np.abs(np.asarray(amplitudes, dtype=float))
    if t.size < 2 or t.shape != a.shape or not np.all(a > 0):
        raise ValueError("growth_rate needs at least two frames with nonzero amplitudes")
    return float(np.polyfit(t, np.log(a), 1)[0])
