"""The Taichi kernel of the per-triangle viscous blocks of formulation ``rayleigh_p1``
(:func:`cortex_ti.physics.galerkin.viscous_blocks`, which has the derivation). A module of its own
so that importing the assembly starts no Taichi."""

from ..runtime import f64_1, f64_2, f64_3, kernel, ti


@kernel
def viscous_blocks_kernel(area: f64_1, normal: f64_2, grads: f64_3, eta_s: ti.f64, eta_b: ti.f64, out: f64_3):
    """``out[t, 3k+i, 3m+j] = A_t [eta_s (P_ij (g_k . g_m) + g_mi g_kj) + (eta_b - eta_s) g_ki g_mj]``."""
    for t in range(area.shape[0]):
        a = area[t]
        for k in ti.static(range(3)):
            for m in ti.static(range(3)):
                gkm = 0.0
                for c in ti.static(range(3)):
                    gkm += grads[t, k, c] * grads[t, m, c]
                for i in ti.static(range(3)):
                    for j in ti.static(range(3)):
                        pij = (1.0 if i == j else 0.0) - normal[t, i] * normal[t, j]
                        out[t, 3 * k + i, 3 * m + j] = a * (
                            eta_s * (pij * gkm + grads[t, m, i] * grads[t, k, j])
                            + (eta_b - eta_s) * grads[t, k, i] * grads[t, m, j]
                        )


@kernel
def normal_blocks_kernel(area: f64_1, corner_normals: f64_3, grads: f64_3, form: f64_3, out: f64_3):
    """``out[t, 3k+i, 3m+j] = A_t (g_k . B_t g_m) n_ki n_mj``: the blocks of ``int B^cd d_c v_n d_d v_n dA``
    with ``v_n = sum_k n_k . v_k psi_k`` (``corner_normals[t, k]`` the normal of corner k)."""
    for t in range(area.shape[0]):
        a = area[t]
        for k in ti.static(range(3)):
            for m in ti.static(range(3)):
                q = 0.0
                for c in ti.static(range(3)):
                    for d in ti.static(range(3)):
                        q += grads[t, k, c] * form[t, c, d] * grads[t, m, d]
                for i in ti.static(range(3)):
                    for j in ti.static(range(3)):
                        out[t, 3 * k + i, 3 * m + j] = a * q * corner_normals[t, k, i] * corner_normals[t, m, j]
