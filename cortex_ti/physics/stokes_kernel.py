"""The Taichi kernels of the matrix-free fluids (:mod:`.fluids_fast`): the far field's direct sums
(backend ``direct``) and the near corrections' quadrature (both backends). A module of its own so
that importing the term registry starts no Taichi."""

from ..runtime import f64_1, f64_2, i32_1, i32_2, kernel, ti

#: targets per pass of the inner loop (register blocking: measured 2.3 ns a pair against 4.1 with one
#: target, 3.8 with 6 or 8; 2562 targets, 5120 sources, one thread)
_BLOCK = 4


@kernel
def stokeslet_sums(x: f64_2, y: f64_2, s: f64_2, u: f64_2):
    """``u_i = sum_k G(x_i - y_k) s_k`` at the targets ``x`` (N, 3) over the sources ``y`` (M, 3),
    ``G(r) = I / |r| + r r^T / |r|^3`` (no 1 / 8 pi), a source on a target skipped (``r = 0``)."""
    n = x.shape[0]
    for blk in range((n + _BLOCK - 1) // _BLOCK):
        at = ti.Matrix.zero(ti.f64, _BLOCK, 3)
        acc = ti.Matrix.zero(ti.f64, _BLOCK, 3)
        for j in ti.static(range(_BLOCK)):
            i = ti.min(_BLOCK * blk + j, n - 1)
            for c in ti.static(range(3)):
                at[j, c] = x[i, c]
        for k in range(y.shape[0]):
            p0, p1, p2 = y[k, 0], y[k, 1], y[k, 2]
            f0, f1, f2 = s[k, 0], s[k, 1], s[k, 2]
            for j in ti.static(range(_BLOCK)):
                r0, r1, r2 = at[j, 0] - p0, at[j, 1] - p1, at[j, 2] - p2
                d2 = r0 * r0 + r1 * r1 + r2 * r2
                inv = ti.select(d2 > 0.0, 1.0 / ti.sqrt(d2), 0.0)
                q = inv * inv * inv * (r0 * f0 + r1 * f1 + r2 * f2)
                acc[j, 0] += inv * f0 + q * r0
                acc[j, 1] += inv * f1 + q * r1
                acc[j, 2] += inv * f2 + q * r2
        for j in ti.static(range(_BLOCK)):
            if _BLOCK * blk + j < n:
                for c in ti.static(range(3)):
                    u[_BLOCK * blk + j, c] = acc[j, c]


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
    centroid: ti.f64,
    out: f64_2,
):
    """The corrections of the far field on the (node ``pi``, triangle ``pf``) pairs: the accurate
    ``int_T G(x_i - y) phi_k(y) dA`` (``kind`` 0-2: the node is that corner, the Duffy rule ``bd, wd``
    collapsed there; 3: near, the split rule ``bs, ws``; 4: the 7-point rule ``b7, w7``) minus the far
    field's value ``((1 - centroid) G(x_i - x_k) + centroid G(x_i - c_T)) |T| / 3`` (``c_T`` the
    centroid; the first term none for ``x_k = x_i``), added to the node pair's block
    ``out[slot[p, k]]`` (B, 9; row, column). No ``1 / 8 pi``."""
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
        lump = (1.0 - centroid) * area / 3.0
        gc = (centroid * area / 3.0) * _stokeslet(at - (p0 + p1 + p2) / 3.0)
        for m in ti.static(range(3)):
            for a in ti.static(range(3)):
                for c in ti.static(range(3)):
                    acc[a, 3 * m + c] -= gc[a, c]
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


@kernel
def stresslet_sums(x: f64_2, y: f64_2, m: f64_2, q: f64_2, u: f64_2):
    """``u_i = sum_k r (r . m_k)(r . q_k) / |r|^5``, ``r = y_k - x_i``, at the targets ``x`` (N, 3) over
    the sources ``y`` (M, 3) with the normal weights ``m`` and the densities ``q`` (M, 3): the double
    layer's raw far field (:mod:`.fluids_double`; no ``3 / 4 pi``), a source on a target skipped."""
    n = x.shape[0]
    for blk in range((n + _BLOCK - 1) // _BLOCK):
        at = ti.Matrix.zero(ti.f64, _BLOCK, 3)
        acc = ti.Matrix.zero(ti.f64, _BLOCK, 3)
        for j in ti.static(range(_BLOCK)):
            i = ti.min(_BLOCK * blk + j, n - 1)
            for c in ti.static(range(3)):
                at[j, c] = x[i, c]
        for k in range(y.shape[0]):
            p0, p1, p2 = y[k, 0], y[k, 1], y[k, 2]
            m0, m1, m2 = m[k, 0], m[k, 1], m[k, 2]
            q0, q1, q2 = q[k, 0], q[k, 1], q[k, 2]
            for j in ti.static(range(_BLOCK)):
                r0, r1, r2 = p0 - at[j, 0], p1 - at[j, 1], p2 - at[j, 2]
                d2 = r0 * r0 + r1 * r1 + r2 * r2
                inv = ti.select(d2 > 0.0, 1.0 / ti.sqrt(d2), 0.0)
                inv2 = inv * inv
                s = inv2 * inv2 * inv * (r0 * m0 + r1 * m1 + r2 * m2) * (r0 * q0 + r1 * q1 + r2 * q2)
                acc[j, 0] += s * r0
                acc[j, 1] += s * r1
                acc[j, 2] += s * r2
        for j in ti.static(range(_BLOCK)):
            if _BLOCK * blk + j < n:
                for c in ti.static(range(3)):
                    u[_BLOCK * blk + j, c] = acc[j, c]


@ti.func
def _stresslet(r, nrm):
    """``r r^T (r . n) / |r|^5`` (the double layer's raw kernel, ``r = y - x``)."""
    d2 = r.dot(r)
    return r.outer_product(r) * (r.dot(nrm) / (d2 * d2 * ti.sqrt(d2)))


@kernel
def near_double_blocks(
    x: f64_2,
    faces: i32_2,
    pi: i32_1,
    pf: i32_1,
    kind: i32_1,
    b7: f64_2,
    w7: f64_1,
    bs: f64_2,
    ws: f64_1,
    slot: i32_2,
    out: f64_2,
):
    """The double layer's corrections (:mod:`.fluids_double`) on the pairs of ``near_blocks``: the
    accurate ``int_T k(y) phi_k(y) dA`` (``k`` the raw stresslet with ``n_T``; ``kind`` 3: the split
    rule, 4: the 7-point rule; 0-2, the node's own triangle, give zero on a flat triangle, ``(y - x) .
    n_T = 0``, accurately and lumped: skipped) minus the far rule's ``|T| (k(x_k) / 12 + k(c_T) / 4)``,
    added to ``out[slot[p, k]]`` (B, 9). No ``3 / 4 pi``."""
    for p in range(pi.shape[0]):
        if kind[p] >= 3:
            i, f = pi[p], pf[p]
            at = ti.Vector([x[i, 0], x[i, 1], x[i, 2]])
            j0, j1, j2 = faces[f, 0], faces[f, 1], faces[f, 2]
            p0 = ti.Vector([x[j0, 0], x[j0, 1], x[j0, 2]])
            p1 = ti.Vector([x[j1, 0], x[j1, 1], x[j1, 2]])
            p2 = ti.Vector([x[j2, 0], x[j2, 1], x[j2, 2]])
            nrm = (p1 - p0).cross(p2 - p0)
            area = 0.5 * nrm.norm()
            nrm /= 2.0 * area
            acc = ti.Matrix.zero(ti.f64, 3, 9)
            if kind[p] == 3:
                for q in range(bs.shape[0]):
                    b0, b1, b2 = bs[q, 0], bs[q, 1], bs[q, 2]
                    g = ws[q] * _stresslet(b0 * p0 + b1 * p1 + b2 * p2 - at, nrm)
                    for a in ti.static(range(3)):
                        for c in ti.static(range(3)):
                            acc[a, c] += b0 * g[a, c]
                            acc[a, 3 + c] += b1 * g[a, c]
                            acc[a, 6 + c] += b2 * g[a, c]
            else:
                for q in range(b7.shape[0]):
                    b0, b1, b2 = b7[q, 0], b7[q, 1], b7[q, 2]
                    g = w7[q] * _stresslet(b0 * p0 + b1 * p1 + b2 * p2 - at, nrm)
                    for a in ti.static(range(3)):
                        for c in ti.static(range(3)):
                            acc[a, c] += b0 * g[a, c]
                            acc[a, 3 + c] += b1 * g[a, c]
                            acc[a, 6 + c] += b2 * g[a, c]
            acc *= area
            gc = (area / 4.0) * _stresslet((p0 + p1 + p2) / 3.0 - at, nrm)
            g0 = (area / 12.0) * _stresslet(p0 - at, nrm)
            g1 = (area / 12.0) * _stresslet(p1 - at, nrm)
            g2 = (area / 12.0) * _stresslet(p2 - at, nrm)
            for a in ti.static(range(3)):
                for c in ti.static(range(3)):
                    out[slot[p, 0], 3 * a + c] += acc[a, c] - gc[a, c] - g0[a, c]
                    out[slot[p, 1], 3 * a + c] += acc[a, 3 + c] - gc[a, c] - g1[a, c]
                    out[slot[p, 2], 3 * a + c] += acc[a, 6 + c] - gc[a, c] - g2[a, c]
