"""Convergence of candidate 3D Helfrich bending forces on flat triangles with fitted curvature,
against the exact first variation on the analytic shape (docs/validation/bending_rigidity.md).

Shape: the icosphere's nodes pushed along their rays to ``|X| = 1 + eps P2(cos theta)`` (``eps = 0``:
the unit sphere). Energy ``kappa/2 oint (C - c0)^2 dA`` with ``kappa = 1``, ``c0 = 0.5``. The exact
normal force density ``kappa [Lap C + (C - c0) C~ - (C - c0)^2 C/2]`` at each node comes from the
axisymmetric spectral evaluation at n = 64 (``cortex_ti.axisymmetric.rigidity``, exact to ~1e-13 on
this shape: its first-variation test). The candidates, all with ``C``, ``C~`` from the node's fitted
curvature tensor (``--fits``):

* ``fit-Laplacian``: ``Lap C`` by fitting the nodal ``C`` again (the paper formulation's
  ``g^ab nabla_a nabla_b`` on fitted derivatives): a strong, pointwise form;
* ``P1 weak consistent``: ``int f w dA = -kappa int grad C . grad w dA + int g w dA`` with
  piecewise-linear ``C`` and ``w`` on the flat triangles, the consistent mass matrix inverted;
* ``P1 weak lumped``: the same with the lumped mass (the cotangent Laplacian of ``C``).

Printed per mesh: mean edge h, the area-weighted L2 and the max error over nodes, and the orders
between successive meshes.

Usage::

    python benchmarks/bending_force_3d.py --nodes 642 2562 10242 40962 --fits quadratic quartic

Cost: 40962 nodes with the quartic fit ~1 min.
"""

from __future__ import annotations

import argparse
import sys

import _bench  # benchmarks/_bench.py: what the scripts share
import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

KAPPA, C0 = 1.0, 0.5


def _p2(x):
    return 0.5 * (3.0 * x * x - 1.0)


def exact_force(eps: float, theta: np.ndarray) -> np.ndarray:
    from cortex_ti.axisymmetric.rigidity import helfrich_force
    from cortex_ti.axisymmetric.spectral import Spectral, geometry

    sp = Spectral(64, True)
    f = 1.0 + eps * _p2(np.cos(sp.u))
    g = geometry(sp, np.sin(sp.u) * f, np.cos(sp.u) * f)
    return sp.evaluate("E", helfrich_force(sp, g, KAPPA, C0), theta)


def p1_matrices(points: np.ndarray, faces: np.ndarray):
    """Cotangent stiffness ``K`` (int grad phi_i . grad phi_j) and consistent mass ``M`` on flat triangles."""
    n = len(points)
    rows, cols, vals = [], [], []
    for k in range(3):
        i, j, m = faces[:, k], faces[:, (k + 1) % 3], faces[:, (k + 2) % 3]
        a, b = points[i] - points[m], points[j] - points[m]
        cot = np.einsum("ij,ij->i", a, b) / np.linalg.norm(np.cross(a, b), axis=1)
        rows += [i, j, i, j]
        cols += [j, i, i, j]
        vals += [-0.5 * cot, -0.5 * cot, 0.5 * cot, 0.5 * cot]
    area = 0.5 * np.linalg.norm(
        np.cross(points[faces[:, 1]] - points[faces[:, 0]], points[faces[:, 2]] - points[faces[:, 0]]), axis=1
    )
    mr, mc, mv = [], [], []
    for a in range(3):
        for b in range(3):
            mr.append(faces[:, a])
            mc.append(faces[:, b])
            mv.append(area * (2.0 if a == b else 1.0) / 12.0)
    K = sps.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    M = sps.csr_matrix((np.concatenate(mv), (np.concatenate(mr), np.concatenate(mc))), shape=(n, n))
    return K, M


def measure(nodes: int, eps: float, fit: str) -> tuple[float, dict]:
    from cortex_ti.physics.terms.bending import curvature_invariants, hessian_weights
    from cortex_ti.surface.fits import StencilChooser
    from cortex_ti.surface.geometry import compute_geometry
    from cortex_ti.surface.mesh import Mesh, icosphere
    from cortex_ti.surface.topology import build_topology

    m = icosphere(nodes)
    d = m.points / np.linalg.norm(m.points, axis=1, keepdims=True)
    theta = np.arccos(np.clip(d[:, 2], -1.0, 1.0))
    pts = d * (1.0 + eps * _p2(d[:, 2]))[:, None]
    topo = build_topology(Mesh(pts, m.faces))
    geo = compute_geometry(pts, topo, StencilChooser(topo, fit))
    _, _, C, Ct, _ = curvature_invariants(geo)
    g = (C - C0) * Ct - 0.5 * (C - C0) ** 2 * C
    exact = exact_force(eps, theta)
    lap = np.einsum("nk,nk->n", hessian_weights(geo, geo.metric_inv), geo.fit_scalar(C))
    K, M = p1_matrices(pts, m.faces)
    lumped = np.asarray(M.sum(1)).ravel()
    forces = {
        "fit-Laplacian": KAPPA * (lap + g),
        "P1 weak consistent": KAPPA * (-spla.spsolve(M.tocsc(), K @ C) + g),
        "P1 weak lumped": KAPPA * (-(K @ C) / lumped + g),
    }
    out = {}
    for name, f in forces.items():
        e = f - exact
        out[name] = (float(np.sqrt((e * e * lumped).sum() / lumped.sum())), float(np.abs(e).max()))
    return float(geo.edge_length.mean()), out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="*", default=[642, 2562, 10242])
    p.add_argument("--fits", nargs="*", default=["quadratic", "quartic"])
    p.add_argument("--eps", type=float, nargs="*", default=[0.0, 0.2], help="amplitudes of the P2 shape")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.fits, args.eps = [162, 642], ["quadratic"], [0.2]
    print(f"kappa = {KAPPA}, c0 = {C0}; errors of the normal force density against the exact first variation")
    for fit in args.fits:
        for eps in args.eps:
            scale = np.abs(exact_force(eps, np.linspace(0.0, np.pi, 2001))).max()
            print(f"{fit} fit, eps = {eps:g}: the exact force's largest value |f| = {scale:.3g}")
            prev = None
            for nodes in args.nodes:
                h, out = measure(nodes, eps, fit)
                line = f"{fit:9s} eps={eps:g} N={nodes:6d} h={h:.4f}"
                for name, (l2, mx) in out.items():
                    line += f" | {name}: L2 {l2:.2e} max {mx:.2e}"
                    if prev is not None:
                        rate = np.log(prev[0] / h)
                        o2, om = np.log(prev[1][name][0] / l2) / rate, np.log(prev[1][name][1] / mx) / rate
                        line += f" (orders {o2:.2f}, {om:.2f})"
                print(line, flush=True)
                prev = (h, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
