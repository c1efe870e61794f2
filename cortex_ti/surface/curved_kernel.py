"""The Taichi kernel of the curved cells' quadrature data (:func:`cortex_ti.surface.curved.curved_surface`).
A module of its own so that importing the curved cells starts no Taichi. One thread per cell,
scalar code with runtime loops (a small syntax tree for Taichi to transform on a first call)."""

from ..runtime import f64_1, f64_2, f64_3, f64_4, i32_2, kernel, ti


@kernel
def curved_quadrature_kernel(
    nodes: f64_2,
    normal: f64_2,
    curvature: f64_3,
    cells: i32_2,
    shape: f64_2,
    dshape: f64_3,
    rule: f64_1,
    weight: f64_2,
    qpoint: f64_3,
    cell_normal: f64_3,
    qnormal: f64_3,
    qcurv: f64_4,
    grads: f64_4,
):
    """Per cell t and quadrature point q: the area weight (rule weight times the area element, 0 where
    the cell is degenerate or its normal turns against the interpolated smooth normal: the caller
    refuses it), the position, the cell's unit normal, the smooth normal and curvature interpolated
    from the nodes (the curvature projected on the smooth tangent plane), and the shape functions'
    gradients along the cell projected on the smooth tangent plane."""
    for t in range(cells.shape[0]):
        for q in range(shape.shape[0]):
            x = ti.Vector([0.0, 0.0, 0.0])
            a1 = ti.Vector([0.0, 0.0, 0.0])
            a2 = ti.Vector([0.0, 0.0, 0.0])
            ns = ti.Vector([0.0, 0.0, 0.0])
            for i in range(6):
                v = cells[t, i]
                p = ti.Vector([nodes[v, 0], nodes[v, 1], nodes[v, 2]])
                nv = ti.Vector([normal[v, 0], normal[v, 1], normal[v, 2]])
                x += shape[q, i] * p
                a1 += dshape[q, i, 0] * p
                a2 += dshape[q, i, 1] * p
                ns += shape[q, i] * nv
            cr = a1.cross(a2)
            jac = cr.norm()
            n = ns.normalized()
            nc = cr / ti.max(jac, 1e-300)
            ok = jac > 0.0 and nc.dot(n) > 0.0
            weight[t, q] = rule[q] * jac if ok else 0.0
            g11, g12, g22 = a1.dot(a1), a1.dot(a2), a2.dot(a2)
            det = g11 * g22 - g12 * g12
            det = det if det > 0.0 else 1.0
            for c in ti.static(range(3)):
                qpoint[t, q, c] = x[c]
                cell_normal[t, q, c] = nc[c]
                qnormal[t, q, c] = n[c]
            for i in range(6):
                d1, d2 = dshape[q, i, 0], dshape[q, i, 1]
                # g^ab d_b N a_a with g^-1 = [[g22, -g12], [-g12, g11]] / det
                c1 = (g22 * d1 - g12 * d2) / det
                c2 = (g11 * d2 - g12 * d1) / det
                g = c1 * a1 + c2 * a2
                g -= g.dot(n) * n
                for c in ti.static(range(3)):
                    grads[t, q, i, c] = g[c]
            # the interpolated curvature, symmetrised and projected: P sym(M) P
            m = ti.Matrix.zero(ti.f64, 3, 3)
            for i in range(6):
                v = cells[t, i]
                for a, b in ti.ndrange(3, 3):
                    m[a, b] += 0.5 * shape[q, i] * (curvature[v, a, b] + curvature[v, b, a])
            proj = ti.Matrix.identity(ti.f64, 3) - n.outer_product(n)
            pm = proj @ m @ proj
            for a, b in ti.ndrange(3, 3):
                qcurv[t, q, a, b] = pm[a, b]
