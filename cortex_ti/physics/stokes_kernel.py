"""The Taichi kernel of the fluids' direct summation (:mod:`.fluids_fast`, backend ``direct``): the
7-point single layer and its transpose applied without storing the matrix. A module of its own so
that importing the term registry starts no Taichi."""

from ..runtime import f64_1, f64_2, i32_1, i32_2, kernel, ti


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


@kernel
def stokeslet_nodes(x: f64_2, s: f64_2, u: f64_2):
    """``u_i = sum_{j != i} G(x_i - x_j) s_j`` over the nodes ``x`` (N, 3): the lumped far field
    (:mod:`.fluids_fast`), every pair once per target, no self term."""
    for i in range(x.shape[0]):
        at = ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
        acc = ti.Vector([0.0, 0.0, 0.0])
        for k in range(x.shape[0]):
            r = at - ti.Vector([x[k, 0], x[k, 1], x[k, 2]])
            d2 = r.dot(r)
            if d2 > 0.0:
                inv = 1.0 / ti.sqrt(d2)
                f = ti.Vector([s[k, 0], s[k, 1], s[k, 2]])
                acc += inv * f + (inv * inv * inv * r.dot(f)) * r
        for c in ti.static(range(3)):
            u[i, c] = acc[c]


@ti.func
def _stokeslet(r):
    inv = 1.0 / ti.sqrt(r.dot(r))
    return inv * ti.Matrix.identity(ti.f64, 3) + (inv * inv * inv) * r.outer_product(r)


@ti.func
def _rule_blocks(at, p0, p1, p2, bary: ti.template(), w: ti.template()):
    """``sum_q w_q G(at - y_q) phi_k(y_q)`` on the triangle ``p0 p1 p2`` with the barycentric rule
    ``bary, w``: (3, 9), column ``3 k + b`` the corner ``k``'s column ``b``."""
    acc = ti.Matrix.zero(ti.f64, 3, 9)
    for q in range(bary.shape[0]):
        b0, b1, b2 = bary[q, 0], bary[q, 1], bary[q, 2]
        g = w[q] * _stokeslet(at - (b0 * p0 + b1 * p1 + b2 * p2))
        for a in ti.static(range(3)):
            for c in ti.static(range(3)):
                acc[a, c] += b0 * g[a, c]
                acc[a, 3 + c] += b1 * g[a, c]
                acc[a, 6 + c] += b2 * g[a, c]
    return acc


@kernel
def near_blocks(
    x: f64_2,
    faces: i32_2,
    pi: i32_1,
    pf: i32_1,
    kind: i32_1,
    b7: f64_2,
    w7: f64_1,
    bd: f64_2,
    wd: f64_1,
    bs: f64_2,
    ws: f64_1,
    slot: i32_2,
    out: f64_2,
):
    """The corrections of the lumped far field on the (node ``pi``, triangle ``pf``) pairs: the
    accurate ``int_T G(x_i - y) phi_k(y) dA`` (``kind`` 0-2: the node is that corner, the Duffy rule
    ``bd, wd`` collapsed there; 3: near, the split rule ``bs, ws``; 4: the 7-point rule ``b7, w7``)
    minus the lumped value ``G(x_i - x_k) |T| / 3`` (none for ``x_k = x_i``), added to the node
    pair's block ``out[slot[p, k]]`` (B, 9; row, column). No ``1 / 8 pi``."""
    for p in range(pi.shape[0]):
        i, f = pi[p], pf[p]
        kd = kind[p]
        rot = 0
        if kd < 3:
            rot = kd  # the rule's corner 0 is the triangle's corner kd
        at = ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
        j0, j1, j2 = faces[f, rot], faces[f, (rot + 1) % 3], faces[f, (rot + 2) % 3]
        p0 = ti.Vector([x[j0, 0], x[j0, 1], x[j0, 2]])
        p1 = ti.Vector([x[j1, 0], x[j1, 1], x[j1, 2]])
        p2 = ti.Vector([x[j2, 0], x[j2, 1], x[j2, 2]])
        area = 0.5 * (p1 - p0).cross(p2 - p0).norm()
        acc = ti.Matrix.zero(ti.f64, 3, 9)
        if kd < 3:
            acc = _rule_blocks(at, p0, p1, p2, bd, wd)
        elif kd == 3:
            acc = _rule_blocks(at, p0, p1, p2, bs, ws)
        else:
            acc = _rule_blocks(at, p0, p1, p2, b7, w7)
        acc *= area
        lump = area / 3.0
        if j0 != i:
            g = _stokeslet(at - p0)
            for a in ti.static(range(3)):
                for c in ti.static(range(3)):
                    acc[a, c] -= lump * g[a, c]
        if j1 != i:
            g = _stokeslet(at - p1)
            for a in ti.static(range(3)):
                for c in ti.static(range(3)):
                    acc[a, 3 + c] -= lump * g[a, c]
        if j2 != i:
            g = _stokeslet(at - p2)
            for a in ti.static(range(3)):
                for c in ti.static(range(3)):
                    acc[a, 6 + c] -= lump * g[a, c]
        for m in ti.static(range(3)):
            k = (m + rot) % 3  # the triangle's corner of the rule's corner m
            for a in ti.static(range(3)):
                for c in ti.static(range(3)):
                    out[slot[p, k], 3 * a + c] += acc[a, 3 * m + c]
