"""The Taichi kernels of formulation ``rayleigh_p2``: the per-cell blocks and forces
(:func:`cortex_ti.physics.galerkin_p2.cell_blocks`, which has the derivation). A module of its own
so that importing the assembly starts no Taichi.

One thread per cell; scalar code with runtime loops (the syntax tree Taichi transforms on a
process's first call stays small), per-cell scratch in ndarrays.
"""

from ..runtime import f64_2, f64_3, f64_4, i32_2, kernel, ti


@ti.func
def _clipped(b: ti.template(), t, q, n):
    """The tangential tensor ``b[t, q]`` clipped to its positive semidefinite part (its restriction
    to the plane normal to ``n``, two eigenvalues, each clipped at 0)."""
    e = ti.Vector([1.0, 0.0, 0.0])
    if ti.abs(n[1]) < ti.abs(n[0]) and ti.abs(n[1]) <= ti.abs(n[2]):
        e = ti.Vector([0.0, 1.0, 0.0])
    elif ti.abs(n[2]) < ti.abs(n[0]) and ti.abs(n[2]) < ti.abs(n[1]):
        e = ti.Vector([0.0, 0.0, 1.0])
    t1 = n.cross(e).normalized()
    t2 = n.cross(t1)
    m = ti.Matrix.zero(ti.f64, 3, 3)
    for a, c in ti.ndrange(3, 3):
        m[a, c] = 0.5 * (b[t, q, a, c] + b[t, q, c, a])
    b11 = t1.dot(m @ t1)
    b12 = t1.dot(m @ t2)
    b22 = t2.dot(m @ t2)
    half = 0.5 * (b11 + b22)
    rad = ti.sqrt(0.25 * (b11 - b22) ** 2 + b12 * b12)
    l1 = ti.max(half + rad, 0.0)
    l2 = ti.max(half - rad, 0.0)
    # eigenvector of the larger eigenvalue in the (t1, t2) basis
    u = ti.Vector([b12, half + rad - b11])
    if u.norm() < 1e-300 * (1.0 + ti.abs(half) + rad) or u.norm() == 0.0:
        u = ti.Vector([1.0, 0.0]) if b11 >= b22 else ti.Vector([0.0, 1.0])
    u = u.normalized()
    w1 = u[0] * t1 + u[1] * t2
    w2 = -u[1] * t1 + u[0] * t2
    return l1 * w1.outer_product(w1) + l2 * w2.outer_product(w2)


@kernel
def cell_strain_kernel(
    weight: f64_2,
    grads: f64_4,
    qnormal: f64_3,
    qcurv: f64_4,
    normal: f64_2,
    cells: i32_2,
    shape: f64_2,
    shear: ti.f64,
    bulk: ti.f64,
    zeta: f64_2,
    form: f64_4,
    beta0: f64_2,
    strain: f64_4,
    weighted: f64_4,
    pair: f64_3,
    force: f64_2,
    area_rate: f64_2,
):
    """Per cell t what its (18, 18) block is made of (columns: node i, component c at r = 3 i + c):
    ``strain[t, r, q]`` (T, 18, Q, 7) the six components of ``U_ic = sym((P P_i e_c) g_i^T) + N_i n_ic C``
    and its trace at point q, ``weighted`` the same times ``w`` and the viscosities' weights
    (``2 eta_s`` on the diagonal components, ``4 eta_s`` on the three off-diagonal ones, ``eta_b - eta_s``
    on the trace), so that the viscous block is ``strain[t] . weighted[t]^T`` over (q, component);
    ``pair[t]`` (6, 6) the normal forms' ``sum_q w (g_i . B g_j + beta_0 N_i N_j)`` (B clipped to its
    positive semidefinite part; the nodal normals ``n_ic n_jd`` that multiply it do not depend on q);
    the force ``force[t] = -sum_q w zeta tr U_ic`` and the area's rate ``area_rate[t] = sum_q w tr U_ic``."""
    for t in range(cells.shape[0]):
        for r in range(18):
            force[t, r] = 0.0
            area_rate[t, r] = 0.0
        for i, j in ti.ndrange(6, 6):
            pair[t, i, j] = 0.0
        for q in range(shape.shape[0]):
            w = weight[t, q]
            n = ti.Vector([qnormal[t, q, 0], qnormal[t, q, 1], qnormal[t, q, 2]])
            for i in range(6):
                v = cells[t, i]
                ni = ti.Vector([normal[v, 0], normal[v, 1], normal[v, 2]])
                g = ti.Vector([grads[t, q, i, 0], grads[t, q, i, 1], grads[t, q, i, 2]])
                for c in range(3):
                    # a = P P_i e_c = P (e_c - n_ic n_i)
                    a = -ni[c] * ni
                    a[c] += 1.0
                    a -= a.dot(n) * n
                    s = shape[q, i] * ni[c]
                    r = 3 * i + c
                    u0 = a[0] * g[0] + s * qcurv[t, q, 0, 0]
                    u1 = a[1] * g[1] + s * qcurv[t, q, 1, 1]
                    u2 = a[2] * g[2] + s * qcurv[t, q, 2, 2]
                    u3 = 0.5 * (a[0] * g[1] + a[1] * g[0]) + s * qcurv[t, q, 0, 1]
                    u4 = 0.5 * (a[0] * g[2] + a[2] * g[0]) + s * qcurv[t, q, 0, 2]
                    u5 = 0.5 * (a[1] * g[2] + a[2] * g[1]) + s * qcurv[t, q, 1, 2]
                    tr = u0 + u1 + u2
                    strain[t, r, q, 0] = u0
                    strain[t, r, q, 1] = u1
                    strain[t, r, q, 2] = u2
                    strain[t, r, q, 3] = u3
                    strain[t, r, q, 4] = u4
                    strain[t, r, q, 5] = u5
                    strain[t, r, q, 6] = tr
                    weighted[t, r, q, 0] = 2.0 * shear * w * u0
                    weighted[t, r, q, 1] = 2.0 * shear * w * u1
                    weighted[t, r, q, 2] = 2.0 * shear * w * u2
                    weighted[t, r, q, 3] = 4.0 * shear * w * u3
                    weighted[t, r, q, 4] = 4.0 * shear * w * u4
                    weighted[t, r, q, 5] = 4.0 * shear * w * u5
                    weighted[t, r, q, 6] = (bulk - shear) * w * tr
                    force[t, r] -= w * zeta[t, q] * tr
                    area_rate[t, r] += w * tr
            bc = _clipped(form, t, q, n)
            for i, j in ti.ndrange(6, 6):
                gbg = 0.0
                for a in ti.static(range(3)):
                    for b in ti.static(range(3)):
                        gbg += grads[t, q, i, a] * bc[a, b] * grads[t, q, j, b]
                pair[t, i, j] += w * (gbg + beta0[t, q] * shape[q, i] * shape[q, j])


@kernel
def centred_force_kernel(
    weight: f64_2,
    grads: f64_4,
    qnormal: f64_3,
    normal: f64_2,
    cells: i32_2,
    shape: f64_2,
    form: f64_4,
    beta0: f64_2,
    centre: f64_2,
    force: f64_2,
):
    """``force[t]`` (18,): the blocks of the normal form ``(B, beta_0)`` (B clipped) applied to the nodal
    vectors ``centre``: ``sum_q w [(g_i . B grad r_n) + beta_0 N_i r_n] n_ic``, ``r_n = sum_j N_j n_j . r_j``."""
    for t in range(cells.shape[0]):
        for r in range(18):
            force[t, r] = 0.0
        for q in range(shape.shape[0]):
            w = weight[t, q]
            n = ti.Vector([qnormal[t, q, 0], qnormal[t, q, 1], qnormal[t, q, 2]])
            rn = 0.0
            gr = ti.Vector([0.0, 0.0, 0.0])
            for j in range(6):
                v = cells[t, j]
                s = normal[v, 0] * centre[v, 0] + normal[v, 1] * centre[v, 1] + normal[v, 2] * centre[v, 2]
                rn += shape[q, j] * s
                gr += s * ti.Vector([grads[t, q, j, 0], grads[t, q, j, 1], grads[t, q, j, 2]])
            bc = _clipped(form, t, q, n)
            bgr = bc @ gr
            for i in range(6):
                v = cells[t, i]
                gi = ti.Vector([grads[t, q, i, 0], grads[t, q, i, 1], grads[t, q, i, 2]])
                val = w * (gi.dot(bgr) + beta0[t, q] * shape[q, i] * rn)
                for c in range(3):
                    force[t, 3 * i + c] += val * normal[v, c]


@kernel
def finish_blocks_kernel(blocks: f64_3, pair: f64_3, normal: f64_2, cells: i32_2):
    """In place, per cell: the viscous block ``blocks[t]`` made exactly symmetric (the mean of it and its
    transpose), plus the normal forms ``pair[t, i, j] n_ic n_jd``."""
    for t in range(blocks.shape[0]):
        for r in range(18):
            i, c = r // 3, r % 3
            nic = normal[cells[t, i], c]
            for s in range(r, 18):
                j, d = s // 3, s % 3
                k = 0.5 * (blocks[t, r, s] + blocks[t, s, r]) + pair[t, i, j] * nic * normal[cells[t, j], d]
                blocks[t, r, s] = k
                blocks[t, s, r] = k
