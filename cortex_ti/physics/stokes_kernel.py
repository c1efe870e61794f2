"""The Taichi kernel of the fluids' direct summation (:mod:`.fluids_fast`, backend ``direct``): the
7-point single layer and its transpose applied without storing the matrix. A module of its own so
that importing the term registry starts no Taichi."""

from ..runtime import f64_2, kernel, ti


@kernel
def stokeslet_sums(x: f64_2, y: f64_2, s: f64_2, g: f64_2, u: f64_2, t: f64_2):
    """``u_i = sum_q G(x_i - y_q) s_q`` at the nodes ``x`` (N, 3) and ``t_q = sum_i G(y_q - x_i) g_i``
    at the quadrature points ``y`` (Q, 3), ``G(r) = I / |r| + r r^T / |r|^3`` (no 1 / 8 pi); every pair
    is evaluated twice (once per loop: no atomic sums across threads)."""
    for i in range(x.shape[0]):
        xi = ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
        acc = ti.Vector([0.0, 0.0, 0.0])
        for q in range(y.shape[0]):
            r = xi - ti.Vector([y[q, 0], y[q, 1], y[q, 2]])
            inv = 1.0 / ti.sqrt(r.dot(r))
            sq = ti.Vector([s[q, 0], s[q, 1], s[q, 2]])
            acc += inv * sq + (inv * inv * inv * r.dot(sq)) * r
        for c in ti.static(range(3)):
            u[i, c] = acc[c]
    for q in range(y.shape[0]):
        yq = ti.Vector([y[q, 0], y[q, 1], y[q, 2]])
        acc = ti.Vector([0.0, 0.0, 0.0])
        for i in range(x.shape[0]):
            r = yq - ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
            inv = 1.0 / ti.sqrt(r.dot(r))
            gi = ti.Vector([g[i, 0], g[i, 1], g[i, 2]])
            acc += inv * gi + (inv * inv * inv * r.dot(gi)) * r
        for c in ti.static(range(3)):
            t[q, c] = acc[c]
