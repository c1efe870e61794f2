"""The Taichi kernel of the fluids' direct summation (:mod:`.fluids_fast`, backend ``direct``): the
7-point single layer and its transpose applied without storing the matrix. A module of its own so
that importing the term registry starts no Taichi."""

from ..runtime import f64_2, kernel, ti


@ti.func
def _stokeslet_sum(at, points: f64_2, density: f64_2):
    """``sum_k G(at - points_k) density_k``, ``G(r) = I / |r| + r r^T / |r|^3``."""
    acc = ti.Vector([0.0, 0.0, 0.0])
    for k in range(points.shape[0]):
        r = at - ti.Vector([points[k, 0], points[k, 1], points[k, 2]])
        inv = 1.0 / ti.sqrt(r.dot(r))
        f = ti.Vector([density[k, 0], density[k, 1], density[k, 2]])
        acc += inv * f + (inv * inv * inv * r.dot(f)) * r
    return acc


@kernel
def stokeslet_sums(x: f64_2, y: f64_2, s: f64_2, g: f64_2, u: f64_2, t: f64_2):
    """``u_i = sum_q G(x_i - y_q) s_q`` at the nodes ``x`` (N, 3) and ``t_q = sum_i G(y_q - x_i) g_i``
    at the quadrature points ``y`` (Q, 3), ``G(r) = I / |r| + r r^T / |r|^3`` (no 1 / 8 pi); every pair
    is evaluated twice (once per loop: no atomic sums across threads)."""
    for i in range(x.shape[0]):
        acc = _stokeslet_sum(ti.Vector([x[i, 0], x[i, 1], x[i, 2]]), y, s)
        for c in ti.static(range(3)):
            u[i, c] = acc[c]
    for q in range(y.shape[0]):
        acc = _stokeslet_sum(ti.Vector([y[q, 0], y[q, 1], y[q, 2]]), x, g)
        for c in ti.static(range(3)):
            t[q, c] = acc[c]
