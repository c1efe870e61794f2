"""The Taichi kernels of the per-triangle blocks of formulation ``rayleigh_p1``
(:func:`cortex_ti.physics.galerkin.viscous_blocks` and :func:`~cortex_ti.physics.galerkin.normal_blocks`,
which have the derivations). A module of its own so that importing the assembly starts no Taichi.

Only the innermost loops are unrolled (``ti.static``): unrolled whole, a kernel's syntax tree is
what Taichi transforms on every process's first call, even when the compiled kernel comes from its
offline cache (about a second each, against a tenth of one)."""

from ..runtime import f64_1, f64_2, f64_3, i32_2, kernel, ti


@kernel
def viscous_blocks_kernel(area: f64_1, normal: f64_2, grads: f64_3, eta_s: ti.f64, eta_b: ti.f64, out: f64_3):
    """``out[t, 3k+i, 3m+j] = A_t [eta_s (P_ij (g_k . g_m) + g_mi g_kj) + (eta_b - eta_s) g_ki g_mj]``."""
    for t in range(area.shape[0]):
        for k, m in ti.ndrange(3, 3):
            gkm = grads[t, k, 0] * grads[t, m, 0] + grads[t, k, 1] * grads[t, m, 1] + grads[t, k, 2] * grads[t, m, 2]
            for i, j in ti.static(ti.ndrange(3, 3)):
                pij = (1.0 if i == j else 0.0) - normal[t, i] * normal[t, j]
                out[t, 3 * k + i, 3 * m + j] = area[t] * (
                    eta_s * (pij * gkm + grads[t, m, i] * grads[t, k, j])
                    + (eta_b - eta_s) * grads[t, k, i] * grads[t, m, j]
                )


@kernel
def normal_blocks_kernel(area: f64_1, corner_normals: f64_3, grads: f64_3, form: f64_3, out: f64_3):
    """``out[t, 3k+i, 3m+j] = A_t (g_k . B_t g_m) n_ki n_mj``: the blocks of ``int B^cd d_c v_n d_d v_n dA``
    with ``v_n = sum_k n_k . v_k psi_k`` (``corner_normals[t, k]`` the normal of corner k)."""
    for t in range(area.shape[0]):
        for k, m in ti.ndrange(3, 3):
            q = 0.0
            for c, d in ti.ndrange(3, 3):
                q += grads[t, k, c] * form[t, c, d] * grads[t, m, d]
            for i, j in ti.static(ti.ndrange(3, 3)):
                out[t, 3 * k + i, 3 * m + j] = area[t] * q * corner_normals[t, k, i] * corner_normals[t, m, j]


@kernel
def triangle_form_kernel(faces: i32_2, tangents: f64_3, form: f64_3, tnormal: f64_2, out: f64_3):
    """``out[t] = B_t``: the corner mean of ``B^cd e_c e_d`` (``tangents[v, c]`` = e_c, ``form[v]`` = B^cd
    at node v), projected on the triangle ``P B P`` (``P = I - n n^T``), symmetrised, and clipped to its
    positive semidefinite part: it lies in the plane, so its two in-plane eigenvalues (of its 2x2
    restriction to an orthonormal in-plane basis a, b) are clipped at 0 when the trace or the
    determinant of that restriction is negative."""
    for t in range(faces.shape[0]):
        m = ti.Matrix.zero(ti.f64, 3, 3)
        for k in range(3):
            v = faces[t, k]
            for i, j in ti.static(ti.ndrange(3, 3)):
                s = 0.0
                for c, d in ti.static(ti.ndrange(2, 2)):
                    s += tangents[v, c, i] * form[v, c, d] * tangents[v, d, j]
                m[i, j] += s / 3.0
        n = ti.Vector([tnormal[t, 0], tnormal[t, 1], tnormal[t, 2]])
        p = ti.Matrix.identity(ti.f64, 3) - n.outer_product(n)
        b = p @ m @ p
        b = 0.5 * (b + b.transpose())
        tr = b.trace()
        det2 = 0.5 * (tr * tr - (b * b).sum())
        if tr < 0.0 or det2 < 0.0:
            axis = 0  # the axis least aligned with n gives the in-plane basis
            if ti.abs(n[1]) < ti.abs(n[axis]):
                axis = 1
            if ti.abs(n[2]) < ti.abs(n[axis]):
                axis = 2
            e = ti.Vector([0.0, 0.0, 0.0])
            if axis == 0:
                e[0] = 1.0
            elif axis == 1:
                e[1] = 1.0
            else:
                e[2] = 1.0
            a = n.cross(e).normalized()
            c = n.cross(a)
            baa, bcc, bac = a.dot(b @ a), c.dot(b @ c), a.dot(b @ c)
            half = 0.5 * (baa + bcc)
            r = ti.sqrt(0.25 * (baa - bcc) ** 2 + bac * bac)
            theta = 0.5 * ti.atan2(2.0 * bac, baa - bcc)
            u = ti.cos(theta) * a + ti.sin(theta) * c  # eigenvector of half + r
            w = -ti.sin(theta) * a + ti.cos(theta) * c  # of half - r
            b = ti.max(half + r, 0.0) * u.outer_product(u) + ti.max(half - r, 0.0) * w.outer_product(w)
        for i, j in ti.static(ti.ndrange(3, 3)):
            out[t, i, j] = b[i, j]


@kernel
def normal_force_kernel(area: f64_1, corner_normals: f64_3, grads: f64_3, form: f64_3, rate: f64_3, out: f64_2):
    """``out[t, 3k+i] = A_t (g_k . B_t grad r_n) n_ki`` with ``grad r_n = sum_k g_k (n_k . r_k)``: the
    blocks of :func:`normal_blocks_kernel` applied to the corners' vectors ``rate[t, k]``."""
    for t in range(area.shape[0]):
        gr = ti.Vector([0.0, 0.0, 0.0])
        for k in range(3):
            rn = 0.0
            for i in ti.static(range(3)):
                rn += corner_normals[t, k, i] * rate[t, k, i]
            for c in ti.static(range(3)):
                gr[c] += grads[t, k, c] * rn
        w = ti.Vector([0.0, 0.0, 0.0])
        for c, d in ti.static(ti.ndrange(3, 3)):
            w[c] += form[t, c, d] * gr[d]
        for k in range(3):
            q = 0.0
            for c in ti.static(range(3)):
                q += grads[t, k, c] * w[c]
            for i in ti.static(range(3)):
                out[t, 3 * k + i] = area[t] * q * corner_normals[t, k, i]
