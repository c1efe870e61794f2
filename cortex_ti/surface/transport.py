r"""Transport of nodal fields on a moving triangulated surface: finite volumes on the dual cells.

Every node ``i`` owns the barycentric dual cell (a third of each triangle around it, area
``A_i``); two neighbours ``a``, ``b`` of a triangle share the dual edge from the midpoint of
``ab`` to the triangle's centroid. A field is carried by the velocity relative to the mesh,
``u = v - w`` (``w`` the nodes' velocity, :mod:`cortex_ti.dynamics.motion`), through these dual
edges. Derivation and the truths the tests check: ``docs/derivations/transport.md``.

Two kinds of field:

* a **density** ``c`` (amount per area, e.g. myosin): its content ``m_i = c_i A_i`` changes only by
  the fluxes, ``dm_a/dt = -sum_b F_ab c_ab`` with ``F_ab = -F_ba``, so ``sum_i m_i`` is kept to
  round-off whatever the motion; the dilution by surface stretching is the change of ``A_i``
  itself (``c = m / A`` on the new shape);
* a **property** ``q`` (carried by the material without dilution, e.g. a prescribed tension):
  ``A_a dq_a/dt = -sum_b F_ab (q_ab - q_a)``, the conservative flux minus ``q_a`` times the
  divergence, so a uniform ``q`` stays uniform exactly.

``F_ab`` is the exact flux of the linearly interpolated ``u`` through the dual edge (its midpoint
rule is exact for a linear integrand). ``c_ab`` is the upwind node's value extrapolated with its
gradient to the midpoint of the edge ``ab`` and limited to lie between the upwind value and the
edge average ``(c_a + c_b)/2``: second order where the field is smooth (the extrapolation is the
average up to O(h^2)), first order at extrema, and never beyond the average towards the downwind
value. That bound is what makes the scheme stable: a face value ``c_ab = c_a + theta (c_b - c_a)``
(``a`` upwind) adds ``-F_ab (1/2 - theta) (c_b - c_a)^2`` to the energy ``(1/2) sum A q^2`` of a
property beyond the flow's own compression ``(1/2) sum A div_h(u) q^2``, so ``theta <= 1/2`` only
dissipates, whereas the downwind value (``theta = 1``, what a clip to ``[c_a, c_b]`` allows) is a
downwind difference with growing linearisations (docs/derivations/transport.md, "Energy").
Surface diffusion and
linear turnover are implicit in the step (:func:`implicit_diffusion_reaction`): the cotangent
Laplacian with the dual areas as lumped mass, so the diffusive time ``h^2/D`` never limits it.
Everything here is vectorised numpy on arrays (pure functions of points, faces and velocities).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .mesh import per_connectivity

__all__ = [
    "DENSITY",
    "PROPERTY",
    "dual_areas",
    "dual_area_rates",
    "triangle_gradients",
    "nodal_gradients",
    "dual_fluxes",
    "advective_rate",
    "cotan_laplacian",
    "implicit_diffusion_reaction",
]

#: the two kinds of transported field
DENSITY, PROPERTY = "density", "property"

# the dual edge of (a, b) in a triangle (a, b, c): from the midpoint of ab to the centroid; its
# midpoint has barycentric coordinates (5/12, 5/12, 1/6)
_W_ADJ, _W_OPP = 5.0 / 12.0, 1.0 / 6.0


def _cross(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``p x q`` over the last axis (broadcasting), without numpy.cross's overhead on small axes."""
    return np.stack(
        [
            p[..., 1] * q[..., 2] - p[..., 2] * q[..., 1],
            p[..., 2] * q[..., 0] - p[..., 0] * q[..., 2],
            p[..., 0] * q[..., 1] - p[..., 1] * q[..., 0],
        ],
        axis=-1,
    )


def dual_areas(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Barycentric dual-cell areas ``(N,)``: a third of the area of every triangle at the node."""
    x = points[faces]
    area = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
    return np.bincount(faces.ravel(), weights=np.repeat(area / 3.0, 3), minlength=points.shape[0])


def dual_area_rates(points: np.ndarray, faces: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``dA_i/dt`` (N,) of the barycentric dual areas when the nodes move with ``w`` (N, 3): a third
    of each triangle's ``dA_T/dt = n_T . (dot e_1 x e_2 + e_1 x dot e_2) / 2`` (exact, no differencing).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> rate = dual_area_rates(m.points, m.faces, m.points)      # a uniform dilation x -> (1 + t) x
    >>> bool(np.allclose(rate, 2.0 * dual_areas(m.points, m.faces), rtol=1e-13))
    True
    """
    x, v = points[faces], w[faces]
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    cr = _cross(e1, e2)
    n = cr / np.linalg.norm(cr, axis=1)[:, None]
    d = _cross(v[:, 1] - v[:, 0], e2) + _cross(e1, v[:, 2] - v[:, 0])
    rate = 0.5 * np.einsum("tc,tc->t", n, d)
    return np.bincount(faces.ravel(), weights=np.repeat(rate / 3.0, 3), minlength=points.shape[0])


def triangle_gradients(points: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Areas ``(T,)``, unit normals ``(T, 3)`` and the in-plane gradients ``(T, 3, 3)`` (corner, xyz)
    of the three barycentric functions of the flat triangles."""
    x = points[faces]
    cr = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    twice = np.linalg.norm(cr, axis=1)
    n = cr / twice[:, None]
    grads = np.empty((faces.shape[0], 3, 3))
    for k in range(3):
        a, b = x[:, (k + 1) % 3], x[:, (k + 2) % 3]
        grads[:, k] = np.cross(n, b - a) / twice[:, None]
    return 0.5 * twice, n, grads


def nodal_gradients(values: np.ndarray, points: np.ndarray, faces: np.ndarray, tri=None) -> np.ndarray:
    """Gradient ``(N, 3)`` of a nodal field: the area-weighted mean of the (constant) gradients of
    its linear interpolant on the triangles around each node."""
    area, _, grads = tri if tri is not None else triangle_gradients(points, faces)
    n = points.shape[0]
    gt = np.einsum("tk,tkc->tc", values[faces], grads) * area[:, None]
    idx = faces.ravel()
    wsum = np.bincount(idx, weights=np.repeat(area, 3), minlength=n)
    out = np.stack([np.bincount(idx, weights=np.repeat(gt[:, c], 3), minlength=n) for c in range(3)], axis=1)
    return out / wsum[:, None]


def dual_fluxes(points: np.ndarray, faces: np.ndarray, u: np.ndarray, tri=None) -> tuple[np.ndarray, np.ndarray]:
    """The flux of the linear velocity ``u`` (N, 3) through each dual edge: ``(T, 3)``, entry ``k``
    from corner ``k`` to corner ``k+1`` (mod 3) of each triangle, and the dual edges' midpoints
    ``(T, 3, 3)``."""
    x = points[faces]
    _, n, _ = tri if tri is not None else triangle_gradients(points, faces)
    a, b, c = [0, 1, 2], [1, 2, 0], [2, 0, 1]  # edge k joins corners k and k+1
    xa, xb = x[:, a], x[:, b]
    seg = x.mean(axis=1)[:, None, :] - 0.5 * (xa + xb)  # (T, 3, 3) midpoint -> centroid
    nu = _cross(seg, n[:, None, :])  # |seg| times a unit normal in the plane
    sign = np.sign((nu * (xb - xa)).sum(axis=2))
    uf = u[faces]
    umid = _W_ADJ * (uf[:, a] + uf[:, b]) + _W_OPP * uf[:, c]
    flux = sign * (nu * umid).sum(axis=2)
    mids = _W_ADJ * (xa + xb) + _W_OPP * x[:, c]
    return flux, mids


def _face_values(
    values: np.ndarray, grad: np.ndarray, points: np.ndarray, faces: np.ndarray, flux: np.ndarray, mids: np.ndarray
) -> np.ndarray:
    """Upwind values at the dual edges: the upwind node's value extrapolated with its gradient to the
    midpoint of the edge, limited to lie between the upwind value and the edge average (``mids``: the
    dual edges' midpoints, unused: the edge midpoint's value is the average for a linear field, so
    the bound clips only at O(h^2), where the dual edge's midpoint would clip at O(h))."""
    a, b = faces, faces[:, [1, 2, 0]]
    up = np.where(flux >= 0.0, a, b)
    dn = np.where(flux >= 0.0, b, a)
    rec = values[up] + 0.5 * np.einsum("tkc,tkc->tk", grad[up], points[dn] - points[up])
    vu = values[up]
    mid = 0.5 * (values[a] + values[b])
    return np.clip(rec, np.minimum(vu, mid), np.maximum(vu, mid))


def advective_rate(
    values: np.ndarray, kind: str, points: np.ndarray, faces: np.ndarray, u: np.ndarray, tri=None
) -> np.ndarray:
    """The rate of the stored quantity of a field carried by the velocity relative to the mesh ``u``:
    ``dm_i/dt`` (``m = c A``) for a :data:`DENSITY`, ``dq_i/dt`` for a :data:`PROPERTY` (module docstring).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> spin = np.cross([0.0, 0.0, 1.0], m.points)      # a rigid rotation about z
    >>> c = 1.0 + m.points[:, 0]
    >>> bool(abs(advective_rate(c, DENSITY, m.points, m.faces, spin).sum()) < 1e-14)   # conservative
    True
    >>> bool(np.abs(advective_rate(np.ones(162), PROPERTY, m.points, m.faces, spin)).max() < 1e-14)
    True
    """
    tri = tri if tri is not None else triangle_gradients(points, faces)
    flux, mids = dual_fluxes(points, faces, u, tri)
    grad = nodal_gradients(values, points, faces, tri)
    face = _face_values(values, grad, points, faces, flux, mids)
    n = points.shape[0]
    a, b = faces, np.roll(faces, -1, axis=1)  # (T, 3): the two ends of each dual edge
    carried = flux * face
    if kind == PROPERTY:
        out_a, out_b = -(carried - flux * values[a]), carried - flux * values[b]
    else:
        out_a, out_b = -carried, carried
    out = np.bincount(
        np.concatenate([a.ravel(), b.ravel()]), weights=np.concatenate([out_a.ravel(), out_b.ravel()]), minlength=n
    )
    if kind == PROPERTY:
        out /= dual_areas(points, faces)
    return out


def cotan_laplacian(points: np.ndarray, faces: np.ndarray) -> sp.csr_matrix:
    """The symmetric positive semidefinite stiffness ``K`` (N, N) of ``int grad f . grad g dA`` for
    linear ``f``, ``g`` on the flat triangles (the cotangent formula); its rows sum to zero."""
    area, _, grads = triangle_gradients(points, faces)
    local = area[:, None, None] * np.einsum("tkc,tmc->tkm", grads, grads)
    rows = np.repeat(faces, 3, axis=1).ravel()
    cols = np.tile(faces, (1, 3)).ravel()
    n = points.shape[0]
    return sp.csr_matrix((local.ravel(), (rows, cols)), shape=(n, n))


def implicit_diffusion_reaction(
    stored: np.ndarray,
    kind: str,
    points: np.ndarray,
    faces: np.ndarray,
    dt: float,
    diffusion: float = 0.0,
    rate: float = 0.0,
    target: float = 0.0,
) -> np.ndarray:
    """The nodal values on the shape ``points`` after the implicit part of a step ``dt``: surface
    diffusion ``D Lap c`` and linear turnover ``-k (c - c_target)``, backward Euler in the dual cells,

    ``(M + dt D K + dt k M) c = m + dt k c_target M 1``, ``M = diag(A)`` the dual areas,

    with ``m`` the stored content (``c A`` of a density after the explicit part of the step, or
    ``q A`` of a property). Without diffusion and turnover it is ``m / A`` (a density) or ``m`` as
    given (a property's stored quantity is its value).
    """
    if diffusion == 0.0 and rate == 0.0 and kind != DENSITY:
        return stored
    area = dual_areas(points, faces)
    content = stored if kind == DENSITY else stored * area
    if diffusion == 0.0 and rate == 0.0:
        return content / area
    lhs = sp.diags(area * (1.0 + dt * rate)) + (dt * diffusion) * cotan_laplacian(points, faces)
    rhs = content + dt * rate * target * area
    factor = _diffusion_factor(faces, points.shape[0])
    factor.factorize(lhs.tocsr())
    return factor.solve(rhs)


_FACTORS: dict = {}


def _diffusion_factor(faces: np.ndarray, n: int):
    """The sparse factorisation of the implicit diffusion's matrices on one mesh (symmetric positive
    definite, the mesh's pattern every step): the solver's default backend, which keeps its symbolic
    analysis from step to step (PARDISO at 2562 nodes: 1.4 ms a step against SuperLU's 8.9 ms, which
    orders the matrix anew each time). A few meshes are kept (a remeshing run moves on)."""
    from ..solve.factorizations import choose_factorization

    return per_connectivity(_FACTORS, faces, n, choose_factorization("auto"), keep=4)
