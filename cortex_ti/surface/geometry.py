r"""Discrete differential geometry of the triangulated cortex (paper Secs. 3.1, 3.5).

Per node ``i`` (all Taichi kernels, one thread per node):

1. **Frame** (paper Eq. 30): ``n`` = angle-weighted mean of the incident face normals;
   ``e_xi`` = the edge to the first one-ring neighbour projected on the plane normal
   to ``n``; ``e_eta = n x e_xi``.
2. **Areas**: Meyer's mixed area ``A_i`` (sums to the mesh area exactly) and the
   gradient of the enclosed volume ``dV/dx_i`` (used for the discrete
   incompressibility constraint, see :mod:`cortex_ti.physics.terms.constraints`).
3. **Fit operator** (paper Sec. 3.5, the "inverse parabolic fit"): for the stencil
   nodes ``a`` (the one-ring, or the two-ring where the one-ring cannot determine a
   quadratic) with local coordinates ``(xi_a, eta_a)``, the least-squares fit

   .. math:: f(\xi,\eta) = f_i + A\xi + B\eta + \tfrac12 C\xi^2 + \tfrac12 D\eta^2 + E\xi\eta

   of any nodal field is linear in the differences ``f_a - f_i``:
   ``[A..E] = sum_a F[i, :, a] (f_a - f_i)``.  ``F`` is computed here, once per
   shape, from the 5x5 normal equations (Cholesky, in coordinates scaled by the
   mean stencil edge length so the matrix is well conditioned).  Its smallest
   scaled pivot is stored as ``fit_quality``: a value near zero means the stencil
   cannot determine a quadratic (rank deficiency) and the node is given the
   two-ring stencil instead (:func:`compute_geometry`). A node whose higher-order (quartic) fit
   stays rank deficient even on the widest stencil takes the quadratic terms alone there
   (:func:`~cortex_ti.surface.fits.quadratic_fallback`: second order at that node, logged), where a quadratic fit is
   still well posed; only a stencil that cannot see a quadratic either is a :class:`MeshError`.
4. **Surface patch**: the same operator applied to the heights ``h_a = (x_a - x_i) . n``
   gives the local Monge patch ``X(xi, eta) = x_i + xi e_xi + eta e_eta + h n``, whence the
   tangent vectors ``e_1 = e_xi + h_xi n``, ``e_2 = e_eta + h_eta n``, the metric
   ``g_ab``, the unit normal of the fitted patch ``n_f``, the curvature tensor
   ``C_ab = -n_f . d_a d_b X`` (positive on a sphere) and the Christoffel symbols
   ``Gamma^c_ab = g^cd e_d . d_a d_b X``.

Because the velocity (paper Eq. 18) is fitted with the *same* operator as the
position, a rigid rotation ``v = w x X`` has ``d_a v = w x e_a`` exactly and
produces no strain: the discrete operator keeps the rigid-body kernel exactly.
"""

from dataclasses import dataclass
from math import factorial

import numpy as np

from ..errors import MeshError
from ..runtime import f64_1, f64_2, f64_3, f64_4, i32_1, i32_2, kernel, ti
from .fits import StencilChooser, lowered, quadratic_fallback
from .topology import Topology

__all__ = ["FIT_TERMS", "FIT_QUALITY_MIN", "Geometry", "compute_geometry"]

#: The five fitted derivatives, in the order used by every array here:
#: d/dxi, d/deta, d2/dxi2, d2/deta2, d2/dxi deta (paper's A, B, C, D, E).
FIT_TERMS = ("A", "B", "C", "D", "E")
#: Below this scaled pivot the 5x5 fit is treated as rank deficient.
FIT_QUALITY_MIN = 1e-8


@ti.func
def _vec(x: ti.template(), i):
    return ti.Vector([x[i, 0], x[i, 1], x[i, 2]])


@kernel
def _frames_kernel(x: f64_2, ring: i32_2, valence: i32_1, frame: f64_3, area: f64_1, volgrad: f64_2):
    for i in range(x.shape[0]):
        xi = _vec(x, i)
        nsum = ti.Vector([0.0, 0.0, 0.0])
        vg = ti.Vector([0.0, 0.0, 0.0])
        amix = 0.0
        k = valence[i]
        for j in range(k):
            xa = _vec(x, ring[i, j])
            xb = _vec(x, ring[i, (j + 1) % k])
            ea = xa - xi
            eb = xb - xi
            ab = xb - xa
            cr = ea.cross(eb)
            twice = cr.norm()
            dot_i = ea.dot(eb)
            nsum += ti.atan2(twice, dot_i) * cr / twice
            vg += xa.cross(xb) / 6.0
            # Meyer, Desbrun, Schroeder & Barr (2003), mixed area of one triangle
            dot_a = -ea.dot(ab)
            dot_b = eb.dot(ab)
            if dot_i < 0.0:
                amix += 0.25 * twice
            elif dot_a < 0.0 or dot_b < 0.0:
                amix += 0.125 * twice
            else:
                amix += (eb.norm_sqr() * dot_a + ea.norm_sqr() * dot_b) / (8.0 * twice)
        n = nsum.normalized()
        d0 = _vec(x, ring[i, 0]) - xi
        exi = (d0 - d0.dot(n) * n).normalized()
        eeta = n.cross(exi)
        for c in ti.static(range(3)):
            frame[i, 0, c] = exi[c]
            frame[i, 1, c] = eeta[c]
            frame[i, 2, c] = n[c]
            volgrad[i, c] = vg[c]
        area[i] = amix


@kernel
def _design_kernel(
    x: f64_2, stencil: i32_2, ssize: i32_1, frame: f64_3, powers: i32_2, inv_fact: f64_1, design: f64_3, scale: f64_1
):
    """design[i, j, t] = u^a w^b / (a! b!) for stencil node j, monomial t = (a, b), in
    coordinates (u, w) = (xi, eta) / scale_i; rows beyond the stencil stay zero."""
    for i in range(x.shape[0]):
        xi = _vec(x, i)
        exi = ti.Vector([frame[i, 0, 0], frame[i, 0, 1], frame[i, 0, 2]])
        eeta = ti.Vector([frame[i, 1, 0], frame[i, 1, 1], frame[i, 1, 2]])
        s = ssize[i]
        h = 0.0
        for j in range(s):
            h += (_vec(x, stencil[i, j]) - xi).norm()
        h /= s
        scale[i] = h
        for j in range(s):
            d = _vec(x, stencil[i, j]) - xi
            u = d.dot(exi) / h
            w = d.dot(eeta) / h
            for t in range(powers.shape[0]):
                design[i, j, t] = u ** powers[t, 0] * w ** powers[t, 1] * inv_fact[t]


@ti.func
def _normal_cholesky(design: ti.template(), s, chol: ti.template(), i):
    """Node i's normal matrix ``N = D^T D`` of its first ``s`` design rows, factorised in place in
    ``chol[i]`` (lower triangle); returns the quality ``min_a L_aa^2 / max_a N_aa`` (<= 0 where a pivot
    is not positive)."""
    p = design.shape[2]
    dmax = 0.0
    for a in range(p):
        for b in range(a + 1):
            acc = 0.0
            for j in range(s):
                acc += design[i, j, a] * design[i, j, b]
            chol[i, a, b] = acc
        dmax = ti.max(dmax, chol[i, a, a])
    pmin = 1e300
    ok = 1
    for a in range(p):
        if ok == 1:
            for b in range(a + 1):
                acc = chol[i, a, b]
                for k in range(b):
                    acc -= chol[i, a, k] * chol[i, b, k]
                if b < a:
                    chol[i, a, b] = acc / chol[i, b, b]
                elif acc > 0.0:
                    chol[i, a, a] = ti.sqrt(acc)
                    pmin = ti.min(pmin, acc)
                else:
                    pmin = acc
                    ok = 0
    return pmin / dmax


@kernel
def _fit_kernel(design: f64_3, ssize: i32_1, chol: f64_3, fit: f64_3, quality: f64_1, qmin: float):
    """Per node the least-squares fit operator of the design rows ``D`` (stencil x monomials):
    the normal matrix ``N = D^T D``, its Cholesky factor ``L`` (in ``chol``, lower triangle), the
    quality ``min_a L_aa^2 / max_a N_aa`` (<= 0 where a pivot is not positive) and, where the
    quality exceeds ``qmin``, ``F = N^{-1} D^T`` by two triangular solves per stencil node
    (columns beyond the stencil, and rank-deficient nodes, stay zero)."""
    for i in range(design.shape[0]):
        p = design.shape[2]
        s = ssize[i]
        quality[i] = _normal_cholesky(design, s, chol, i)
        if quality[i] > qmin:
            for j in range(s):
                for a in range(p):  # L y = D[j]^T
                    acc = design[i, j, a]
                    for k in range(a):
                        acc -= chol[i, a, k] * fit[i, k, j]
                    fit[i, a, j] = acc / chol[i, a, a]
                for q in range(p):  # L^T f = y
                    a = p - 1 - q
                    acc = fit[i, a, j]
                    for k in range(a + 1, p):
                        acc -= chol[i, k, a] * fit[i, k, j]
                    fit[i, a, j] = acc / chol[i, a, a]


@kernel
def _height_coef_kernel(
    x: f64_2,
    stencil: i32_2,
    ssize: i32_1,
    frame: f64_3,
    design: f64_3,
    chol: f64_3,
    height: f64_2,
    coef: f64_2,
    quality: f64_1,
    qmin: float,
):
    """Per node the fitted coefficients ``N^{-1} D^T h`` of the stencil heights ``h_j = (x_j - x_i) . n``
    over its frame (the fit operator of :func:`_fit_kernel` applied to ``h``, without forming it: one
    right-hand side instead of one per stencil node), in the scaled coordinates of the design;
    rank-deficient nodes (quality at most ``qmin``) stay zero."""
    for i in range(design.shape[0]):
        p = design.shape[2]
        s = ssize[i]
        quality[i] = _normal_cholesky(design, s, chol, i)
        if quality[i] > qmin:
            xi = _vec(x, i)
            n = ti.Vector([frame[i, 2, 0], frame[i, 2, 1], frame[i, 2, 2]])
            for j in range(s):
                height[i, j] = (_vec(x, stencil[i, j]) - xi).dot(n)
            for a in range(p):  # L y = D^T h
                acc = 0.0
                for j in range(s):
                    acc += design[i, j, a] * height[i, j]
                for k in range(a):
                    acc -= chol[i, a, k] * coef[i, k]
                coef[i, a] = acc / chol[i, a, a]
            for q in range(p):  # L^T c = y
                a = p - 1 - q
                acc = coef[i, a]
                for k in range(a + 1, p):
                    acc -= chol[i, k, a] * coef[i, k]
                coef[i, a] = acc / chol[i, a, a]


@ti.func
def _patch_at(
    i,
    h,
    frame: ti.template(),
    tangents: ti.template(),
    nfit: ti.template(),
    metric: ti.template(),
    metric_inv: ti.template(),
    curv: ti.template(),
    gamma: ti.template(),
    hfit: ti.template(),
):
    """Node i's fitted Monge patch from its height's five fitted derivatives ``h`` (A..E)."""
    exi = ti.Vector([frame[i, 0, 0], frame[i, 0, 1], frame[i, 0, 2]])
    eeta = ti.Vector([frame[i, 1, 0], frame[i, 1, 1], frame[i, 1, 2]])
    n = ti.Vector([frame[i, 2, 0], frame[i, 2, 1], frame[i, 2, 2]])
    for k in ti.static(range(5)):
        hfit[i, k] = h[k]
    hx = h[0]
    hy = h[1]
    e1 = exi + hx * n
    e2 = eeta + hy * n
    w = 1.0 + hx * hx + hy * hy
    nf = (n - hx * exi - hy * eeta) / ti.sqrt(w)
    g = ti.Matrix([[1.0 + hx * hx, hx * hy], [hx * hy, 1.0 + hy * hy]])
    gi = ti.Matrix([[1.0 + hy * hy, -hx * hy], [-hx * hy, 1.0 + hx * hx]]) / w
    hab = ti.Matrix([[h[2], h[4]], [h[4], h[3]]])
    cab = -hab / ti.sqrt(w)
    hd = ti.Vector([hx, hy])
    for c in ti.static(range(3)):
        tangents[i, 0, c] = e1[c]
        tangents[i, 1, c] = e2[c]
        nfit[i, c] = nf[c]
    for a in ti.static(range(2)):
        for b in ti.static(range(2)):
            metric[i, a, b] = g[a, b]
            metric_inv[i, a, b] = gi[a, b]
            curv[i, a, b] = cab[a, b]
            for c in ti.static(range(2)):
                # Gamma^c_ab = g^cd e_d . X_ab, with X_ab = h_ab n and e_d . n = h_d
                gamma[i, c, a, b] = (gi[c, 0] * hd[0] + gi[c, 1] * hd[1]) * hab[a, b]


@kernel
def _patch_kernel(
    x: f64_2,
    stencil: i32_2,
    ssize: i32_1,
    frame: f64_3,
    fit: f64_3,
    height: f64_2,
    from_fit: ti.template(),
    tangents: f64_3,
    nfit: f64_2,
    metric: f64_3,
    metric_inv: f64_3,
    curv: f64_3,
    gamma: f64_4,
    hfit: f64_2,
):
    """The fitted Monge patch X = x_i + xi e_xi + eta e_eta + h(xi, eta) n of every node, its height's
    five fitted derivatives the fit operator ``fit`` applied to the stencil heights (``from_fit``), or
    ``height`` (N, 5) as given."""
    for i in range(x.shape[0]):
        h = ti.Vector([0.0, 0.0, 0.0, 0.0, 0.0])
        if ti.static(from_fit):
            xi = _vec(x, i)
            n = ti.Vector([frame[i, 2, 0], frame[i, 2, 1], frame[i, 2, 2]])
            for j in range(ssize[i]):
                hj = (_vec(x, stencil[i, j]) - xi).dot(n)
                for k in ti.static(range(5)):
                    h[k] += fit[i, k, j] * hj
        else:
            for k in ti.static(range(5)):
                h[k] = height[i, k]
        _patch_at(i, h, frame, tangents, nfit, metric, metric_inv, curv, gamma, hfit)


@kernel
def _fit_scalar_kernel(f: f64_1, stencil: i32_2, ssize: i32_1, fit: f64_3, out: f64_2):
    for i in range(f.shape[0]):
        for k in ti.static(range(5)):
            acc = 0.0
            for j in range(ssize[i]):
                acc += fit[i, k, j] * (f[stencil[i, j]] - f[i])
            out[i, k] = acc


@dataclass
class Geometry:
    """Everything the force balance needs to know about the current shape.

    Arrays are per node (first axis ``N``); indices ``a, b, c`` run over the two
    surface coordinates ``(xi, eta)`` of the node's local frame.
    """

    points: np.ndarray  # (N, 3)
    frame: np.ndarray  # (N, 3, 3) rows e_xi, e_eta, and the angle-weighted normal (fit coordinates)
    area: np.ndarray  # (N,) Meyer mixed area
    volume_gradient: np.ndarray  # (N, 3) dV/dx_i of the enclosed volume
    stencil: np.ndarray  # (N, S) int32 fit stencil, padded with -1
    stencil_size: np.ndarray  # (N,) int32
    fit: np.ndarray | None  # (N, 5, S) fit operator F (None: computed without, compute_geometry)
    fit_quality: np.ndarray  # (N,) smallest scaled Cholesky pivot of the fit
    tangents: np.ndarray  # (N, 2, 3) e_1, e_2 of the fitted patch
    normal_fit: np.ndarray  # (N, 3) unit normal of the fitted patch
    metric: np.ndarray  # (N, 2, 2) g_ab
    metric_inv: np.ndarray  # (N, 2, 2) g^ab
    curvature: np.ndarray  # (N, 2, 2) C_ab (covariant)
    christoffel: np.ndarray  # (N, 2, 2, 2) Gamma^c_ab stored as [c, a, b]
    height_fit: np.ndarray  # (N, 5) fitted derivatives of the height over the tangent plane
    fit_residual: np.ndarray | None = None  # (N, S, S) I - D F: what the local fit leaves unexplained
    ring: np.ndarray | None = None  # (N, max valence) one-ring, padded with -1
    #: (N, P) every fitted coefficient of the height over the node's (e_xi, e_eta) plane, Taylor-normalised
    #: (``h = sum_t c_t xi^a eta^b / (a! b!)``, ``(a, b) = fit_powers[t]``): the whole local patch, whose
    #: first five are ``height_fit``; the curved cells (:mod:`cortex_ti.surface.curved`) evaluate it
    height_poly: np.ndarray | None = None
    fit_powers: np.ndarray | None = None  # (P, 2) int
    _edge: np.ndarray | None = None

    @property
    def n_nodes(self) -> int:
        return self.points.shape[0]

    @property
    def normal(self) -> np.ndarray:
        """The node's unit normal: the normal of its fitted patch ``(N, 3)``.

        This is *the* normal of the physics: ``v_n = v . n`` in the bending term and the
        volume constraint, the direction of advection (Eq. 60), the frame in which
        ``v_n = 0`` is imposed. The angle-weighted normal (``frame[:, 2]``, paper Sec. 3.1)
        only defines the local coordinates of the fit; it is first-order accurate on
        irregular meshes, the fitted normal to the order of the fit.
        """
        return self.normal_fit

    @property
    def edge_length(self) -> np.ndarray:
        """Mean length of the edges at each node ``(N,)`` (the local mesh size h)."""
        if self._edge is None:
            ring = self.ring
            d = np.linalg.norm(self.points[np.maximum(ring, 0)] - self.points[:, None, :], axis=2)
            self._edge = np.where(ring >= 0, d, 0.0).sum(1) / (ring >= 0).sum(1)
        return self._edge

    def tangent_frame(self) -> np.ndarray:
        """Orthonormal tangent vectors ``(N, 2, 3)`` perpendicular to the fitted normal.

        The angle-weighted normal is only first-order accurate on irregular meshes;
        the normal of the fitted patch is accurate to the order of the fit, so
        constraints on the normal velocity use this frame.
        """
        nf = self.normal
        t1 = self.frame[:, 0, :] - np.einsum("nc,nc->n", self.frame[:, 0, :], nf)[:, None] * nf
        t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
        return np.ascontiguousarray(np.stack([t1, np.cross(nf, t1)], axis=1))

    @property
    def mean_curvature(self) -> np.ndarray:
        """Trace ``C = g^ab C_ab`` (2/R on a sphere of radius R)."""
        return np.einsum("nab,nab->n", self.metric_inv, self.curvature)

    @property
    def gaussian_curvature(self) -> np.ndarray:
        return np.linalg.det(self.curvature) / np.linalg.det(self.metric)

    def fit_scalar(self, values: np.ndarray) -> np.ndarray:
        """Fitted derivatives ``(N, 5)`` of a nodal scalar field (order :data:`FIT_TERMS`)."""
        if self.fit is None:
            raise ValueError("this geometry was computed without its fit operators (compute_geometry(operators=False))")
        out = np.zeros((self.n_nodes, 5))
        _fit_scalar_kernel(
            np.ascontiguousarray(values, dtype=np.float64), self.stencil, self.stencil_size, self.fit, out
        )
        return out

    def fit_vector(self, values: np.ndarray) -> np.ndarray:
        """Fitted derivatives ``(N, 5, 3)`` of a nodal vector field."""
        return np.stack([self.fit_scalar(values[:, c]) for c in range(values.shape[1])], axis=-1)


def _solve_fits(design: np.ndarray, ssize: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares fit operators ``(N, P, S)`` and their quality (smallest scaled pivot).

    One Taichi kernel (:func:`_fit_kernel`, a Cholesky factorisation per node) instead of NumPy's
    batched ``einsum`` + ``cholesky`` + ``solve``: the same operators to 1e-15 (quadratic) and 5e-14
    (quartic, relative), and the whole of :func:`compute_geometry` at 2562 nodes in 3.2 instead of
    5.8 ms of CPU (quadratic), 21 instead of 34 ms (quartic) (docs/validation/speed.md).
    Rank-deficient nodes (quality at most :data:`FIT_QUALITY_MIN`) get a zero operator; the
    caller widens their stencil and fits them again (that operator is never used).
    """
    n, _, p = design.shape
    fit = np.zeros((n, p, design.shape[1]))
    quality = np.zeros(n)
    _fit_kernel(design, ssize, np.zeros((n, p, p)), fit, quality, FIT_QUALITY_MIN)
    return fit, quality


def compute_geometry(
    points: np.ndarray,
    topo: Topology,
    stencils: StencilChooser | None = None,
    residual: bool = False,
    operators: bool = True,
) -> Geometry:
    """Frames, areas, fit operators and the fitted surface patch of every node
    (and, with ``residual``, the fit-residual operators ``I - D F``).

    ``operators=False``: the fitted patch only (normal, curvature, ``height_poly``: what the curved
    cells of ``rayleigh_p2`` read), its coefficients solved for directly from the heights instead of
    through the fit operator (one right-hand side per node instead of one per stencil node); ``fit``
    is then None (:meth:`Geometry.fit_scalar` refuses) and the patch agrees with the operator's to
    rounding."""
    x = np.ascontiguousarray(points, dtype=np.float64)
    n = x.shape[0]
    if not np.all(np.isfinite(x)):
        bad = np.flatnonzero(~np.isfinite(x).all(axis=1))
        raise MeshError(f"{bad.size} node positions are not finite (first: node {bad[0]})")
    if x.ndim != 2 or x.shape[1] != 3 or n != len(topo.valence):
        # the kernels would read past the arrays (a segmentation fault) on another mesh's connectivity
        raise MeshError(f"{x.shape} node positions for a mesh of {len(topo.valence)} nodes")
    stencils = stencils or StencilChooser(topo)
    operators = operators or residual
    scheme = stencils.scheme
    powers = scheme.powers
    inv_fact = 1.0 / np.array([factorial(a) * factorial(b) for a, b in powers], dtype=np.float64)
    frame = np.zeros((n, 3, 3))
    area = np.zeros(n)
    volgrad = np.zeros((n, 3))
    _frames_kernel(x, topo.ring, topo.valence, frame, area, volgrad)
    while True:
        stencil, ssize = stencils.arrays()
        # the patch-only path's design is a work array (the operators' is kept in the fit residual)
        shape = (n, stencil.shape[1], scheme.n_terms)
        design = np.zeros(shape) if operators else _work("design", shape)
        scale = np.zeros(n)
        _design_kernel(x, stencil, ssize, frame, powers, inv_fact, design, scale)
        if operators:
            fit_full, quality = _solve_fits(design, ssize)
        else:
            coef, quality = np.zeros((n, scheme.n_terms)), np.zeros(n)
            chol = _work("chol", (n, scheme.n_terms, scheme.n_terms))
            height = _work("height", (n, stencil.shape[1]))
            _height_coef_kernel(x, stencil, ssize, frame, design, chol, height, coef, quality, FIT_QUALITY_MIN)
        bad = np.flatnonzero(~(quality > FIT_QUALITY_MIN))
        if bad.size == 0:
            break
        if not stencils.widen(bad):
            low = None
            if scheme.n_terms > len(FIT_TERMS):
                low = quadratic_fallback(design, ssize, bad, _stencil_distances(x, stencil, ssize), FIT_QUALITY_MIN)
            if low is not None:
                lowered(scheme.name, bad, quality)
                quality[bad] = low[1]
                if operators:
                    fit_full[bad] = low[0]
                else:
                    coef[bad] = np.einsum("nps,ns->np", low[0], _stencil_heights(x, stencil, ssize, frame)[bad])
                break
            raise MeshError(
                f"the {scheme.name} fit is rank deficient at {bad.size} node(s) even on the widest stencil "
                f"(first: node {bad[0]}, scaled pivot {quality[bad[0]]:.2e}): the mesh is too distorted there"
            )
    arrays = dict(
        tangents=np.zeros((n, 2, 3)),
        normal_fit=np.zeros((n, 3)),
        metric=np.zeros((n, 2, 2)),
        metric_inv=np.zeros((n, 2, 2)),
        curvature=np.zeros((n, 2, 2)),
        christoffel=np.zeros((n, 2, 2, 2)),
        height_fit=np.zeros((n, 5)),
    )
    if operators:
        degree = powers[:5].sum(axis=1)
        fit = np.ascontiguousarray(fit_full[:, :5, :] / scale[:, None, None] ** degree[None, :, None])
        _patch_kernel(x, stencil, ssize, frame, fit, np.zeros((0, 5)), True, *arrays.values())
        height_poly = _height_poly(x, stencil, ssize, frame, fit_full, scale, powers)
    else:
        fit = None
        height_poly = coef / scale[:, None] ** powers.sum(axis=1)[None, :]
        heights = np.ascontiguousarray(height_poly[:, :5])
        _patch_kernel(x, stencil, ssize, frame, np.zeros((0, 5, 0)), heights, False, *arrays.values())
    return Geometry(
        height_poly=height_poly,
        fit_powers=powers,
        points=x,
        frame=frame,
        area=area,
        volume_gradient=volgrad,
        stencil=stencil,
        stencil_size=ssize,
        fit=fit,
        fit_quality=quality,
        ring=topo.ring,
        fit_residual=_fit_residual(design, fit_full, ssize) if residual else None,
        **arrays,
    )


def _stencil_offsets(x, stencil, ssize) -> tuple[np.ndarray, np.ndarray]:
    """(N, S, 3): each stencil node's offset from the node, and (N, S) which slots are not padding."""
    valid = np.arange(stencil.shape[1])[None, :] < ssize[:, None]
    return x[np.where(valid, stencil, 0)] - x[:, None, :], valid


def _stencil_distances(x, stencil, ssize) -> np.ndarray:
    """(N, S): each stencil node's distance from the node (padded slots infinite)."""
    d, valid = _stencil_offsets(x, stencil, ssize)
    return np.where(valid, np.linalg.norm(d, axis=2), np.inf)


def _stencil_heights(x, stencil, ssize, frame) -> np.ndarray:
    """(N, S): each stencil node's height over the node's tangent plane (padded slots zero)."""
    d, valid = _stencil_offsets(x, stencil, ssize)
    return np.where(valid, np.einsum("nsc,nc->ns", d, frame[:, 2]), 0.0)


_WORK: dict = {}


def _work(name: str, shape: tuple) -> np.ndarray:
    """A work array of the patch-only fit (:func:`compute_geometry` with ``operators=False``), kept
    between calls of the same shape, not zeroed: its kernels write every entry they read (the first
    ``ssize`` stencil rows of the design and the heights, the lower triangle of the Cholesky factor).
    Zeroing fresh ones (57 MB at 10242 nodes) cost ~4 ms a solve there."""
    buf = _WORK.get(name)
    if buf is None or buf.shape != shape:
        buf = _WORK[name] = np.empty(shape)
    return buf


def _height_poly(x, stencil, ssize, frame, fit_full, scale, powers) -> np.ndarray:
    """(N, P): the fit operator applied to the stencil heights over each node's tangent plane, in
    unscaled coordinates (all the fitted coefficients, not only the five of ``height_fit``)."""
    h = _stencil_heights(x, stencil, ssize, frame)
    degree = powers.sum(axis=1)
    return np.einsum("nps,ns->np", fit_full, h) / scale[:, None] ** degree[None, :]


def _fit_residual(design: np.ndarray, fit_full: np.ndarray, ssize: np.ndarray) -> np.ndarray:
    """Per node the operator ``I - D F`` on the stencil differences ``f_a - f_i``: the part of
    the nodal values the local Taylor polynomial does not reproduce (zero for any polynomial
    of the scheme's degree; padded slots are zero)."""
    n, smax, _ = design.shape
    res = np.einsum("ij,n->nij", np.eye(smax), np.ones(n)) - np.einsum("nsk,nkt->nst", design, fit_full)
    pad = np.arange(smax)[None, :] >= ssize[:, None]
    res[pad] = 0.0
    res.transpose(0, 2, 1)[pad] = 0.0
    return res
