"""The Taichi kernels of the per-triangle blocks of formulation ``rayleigh_p1``
(:func:`cortex_ti.physics.p1_blocks.viscous_blocks` and :func:`~cortex_ti.physics.p1_blocks.normal_blocks`,
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
    """``out[t] = B_t``: the corner mean ``M`` of ``B^cd e_c e_d`` (``tangents[v, c]`` = e_c, ``form[v]`` =
    B^cd at node v), projected on the triangle and symmetrised, ``P sym(M) P`` with ``P = I - n n^T``,
    and clipped to its positive semidefinite part: it lies in the plane, so its two in-plane
    eigenvalues (of its restriction to an orthonormal in-plane basis a, c) are clipped at 0 when its
    trace or the determinant of that restriction is negative. Scalar code with runtime loops: the
    syntax tree Taichi transforms on a process's first call stays small."""
    for t in range(faces.shape[0]):
        for i, j in ti.ndrange(3, 3):
            s = 0.0
            for k, c, d in ti.ndrange(3, 2, 2):
                v = faces[t, k]
                s += tangents[v, c, i] * form[v, c, d] * tangents[v, d, j]
            out[t, i, j] = s / 3.0
        # P sym(M) P = sym(M) - n s^T - s n^T + (n.M n) n n^T with s = sym(M) n
        n0, n1, n2 = tnormal[t, 0], tnormal[t, 1], tnormal[t, 2]
        s0 = 0.5 * (out[t, 0, 0] * n0 + out[t, 0, 1] * n1 + out[t, 0, 2] * n2)
        s0 += 0.5 * (out[t, 0, 0] * n0 + out[t, 1, 0] * n1 + out[t, 2, 0] * n2)
        s1 = 0.5 * (out[t, 1, 0] * n0 + out[t, 1, 1] * n1 + out[t, 1, 2] * n2)
        s1 += 0.5 * (out[t, 0, 1] * n0 + out[t, 1, 1] * n1 + out[t, 2, 1] * n2)
        s2 = 0.5 * (out[t, 2, 0] * n0 + out[t, 2, 1] * n1 + out[t, 2, 2] * n2)
        s2 += 0.5 * (out[t, 0, 2] * n0 + out[t, 1, 2] * n1 + out[t, 2, 2] * n2)
        nmn = n0 * s0 + n1 * s1 + n2 * s2
        for i in range(3):
            for j in range(i, 3):
                ni, nj = tnormal[t, i], tnormal[t, j]
                si = s0 if i == 0 else (s1 if i == 1 else s2)
                sj = s0 if j == 0 else (s1 if j == 1 else s2)
                value = 0.5 * (out[t, i, j] + out[t, j, i]) - ni * sj - si * nj + nmn * ni * nj
                out[t, i, j] = value
                out[t, j, i] = value
        tr = out[t, 0, 0] + out[t, 1, 1] + out[t, 2, 2]
        sq = 0.0
        for i, j in ti.ndrange(3, 3):
            sq += out[t, i, j] * out[t, i, j]
        if tr < 0.0 or 0.5 * (tr * tr - sq) < 0.0:
            # a = n x e / |n x e| with e the axis least aligned with n, c = n x a
            a0, a1, a2 = 0.0, n2, -n1
            if ti.abs(n1) < ti.abs(n0) and ti.abs(n1) <= ti.abs(n2):
                a0, a1, a2 = -n2, 0.0, n0
            elif ti.abs(n2) < ti.abs(n0) and ti.abs(n2) < ti.abs(n1):
                a0, a1, a2 = n1, -n0, 0.0
            na = ti.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
            a0, a1, a2 = a0 / na, a1 / na, a2 / na
            c0, c1, c2 = n1 * a2 - n2 * a1, n2 * a0 - n0 * a2, n0 * a1 - n1 * a0
            baa, bcc, bac = 0.0, 0.0, 0.0
            for i, j in ti.ndrange(3, 3):
                ai = a0 if i == 0 else (a1 if i == 1 else a2)
                aj = a0 if j == 0 else (a1 if j == 1 else a2)
                ci = c0 if i == 0 else (c1 if i == 1 else c2)
                cj = c0 if j == 0 else (c1 if j == 1 else c2)
                baa += ai * out[t, i, j] * aj
                bcc += ci * out[t, i, j] * cj
                bac += ai * out[t, i, j] * cj
            half = 0.5 * (baa + bcc)
            r = ti.sqrt(0.25 * (baa - bcc) ** 2 + bac * bac)
            theta = 0.5 * ti.atan2(2.0 * bac, baa - bcc)
            cs, sn = ti.cos(theta), ti.sin(theta)
            lu, lw = ti.max(half + r, 0.0), ti.max(half - r, 0.0)  # along u = cs a + sn c, w = -sn a + cs c
            for i, j in ti.ndrange(3, 3):
                ai = a0 if i == 0 else (a1 if i == 1 else a2)
                aj = a0 if j == 0 else (a1 if j == 1 else a2)
                ci = c0 if i == 0 else (c1 if i == 1 else c2)
                cj = c0 if j == 0 else (c1 if j == 1 else c2)
                ui, uj, wi, wj = cs * ai + sn * ci, cs * aj + sn * cj, cs * ci - sn * ai, cs * cj - sn * aj
                out[t, i, j] = lu * ui * uj + lw * wi * wj


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
