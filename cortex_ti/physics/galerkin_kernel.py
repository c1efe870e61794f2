"""The Taichi kernels of the per-triangle blocks of formulation ``rayleigh_p1``
(:func:`cortex_ti.physics.galerkin.viscous_blocks` and :func:`~cortex_ti.physics.galerkin.normal_blocks`,
which have the derivations). A module of its own so that importing the assembly starts no Taichi.

Only the innermost loops are unrolled (``ti.static``): unrolled whole, a kernel's syntax tree is
what Taichi transforms on every process's first call, even when the compiled kernel comes from its
offline cache (about a second each, against a tenth of one)."""

from ..runtime import f64_1, f64_2, f64_3, kernel, ti


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
