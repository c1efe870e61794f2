"""The Taichi kernel of the viscous weights of formulation ``paper`` (:mod:`.viscous`, which
has the derivation). A module of its own so that importing the term registry starts no Taichi."""

from ...runtime import f64_2, f64_3, f64_4, kernel, ti


@ti.func
def _second(a: ti.template(), b: ti.template()):
    """Index of d_a d_b among the fitted derivatives (C, D, E = 2, 3, 4)."""
    return ti.static(2 if a == b == 0 else 3 if a == b == 1 else 4)


@ti.func
def _load2(arr: ti.template(), i):
    return ti.Matrix([[arr[i, 0, 0], arr[i, 0, 1]], [arr[i, 1, 0], arr[i, 1, 1]]])


@ti.func
def _add(W: ti.template(), i, r, k: ti.template(), v):
    for c in ti.static(range(3)):
        W[i, r, k, c] += v[c]


@kernel
def viscous_kernel(
    tangents: f64_3,
    nfit: f64_2,
    metric_inv: f64_3,
    curv: f64_3,
    gamma: f64_4,
    eta_s: ti.f64,
    eta_b: ti.f64,
    with_normal: ti.i32,
    W: f64_4,
):
    for i in range(tangents.shape[0]):
        es = [ti.Vector([tangents[i, a, 0], tangents[i, a, 1], tangents[i, a, 2]]) for a in ti.static(range(2))]
        n = ti.Vector([nfit[i, 0], nfit[i, 1], nfit[i, 2]])
        gi = _load2(metric_inv, i)
        cab = _load2(curv, i)
        for b in ti.static(range(2)):
            for a in ti.static(range(2)):
                for c in ti.static(range(2)):
                    for d in ti.static(range(2)):
                        t = eta_s * (2.0 * gi[a, c] * gi[b, d] - gi[a, b] * gi[c, d]) + eta_b * gi[a, b] * gi[c, d]
                        ec = es[c]
                        ed = es[d]
                        # 1/2 (H_ac . e_d + H_ad . e_c)
                        _add(W, i, b, _second(a, c), 0.5 * t * ed)
                        _add(W, i, b, _second(a, d), 0.5 * t * ec)
                        for m in ti.static(range(2)):
                            _add(W, i, b, m, -0.5 * t * (gamma[i, m, a, c] * ed + gamma[i, m, a, d] * ec))
                        # -1/2 C_ad V_c . n - 1/2 C_ac V_d . n
                        _add(W, i, b, c, -0.5 * t * cab[a, d] * n)
                        _add(W, i, b, d, -0.5 * t * cab[a, c] * n)
        if with_normal:
            cup = gi @ cab @ gi
            ctr = (gi * cab).sum()
            for c in ti.static(range(2)):
                for d in ti.static(range(2)):
                    s = eta_s * (2.0 * cup[c, d] - ctr * gi[c, d]) + eta_b * ctr * gi[c, d]
                    ec = es[c]
                    ed = es[d]
                    _add(W, i, 2, c, 0.5 * s * ed)
                    _add(W, i, 2, d, 0.5 * s * ec)
