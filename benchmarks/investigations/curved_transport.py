"""Question: Which part of the myosin transport makes the rates on ``rayleigh_p2`` miss 1 %, and does
the quadratic Galerkin transport on the curved cells remove it?

Answer: the dilution measured by the flat dual cells' area change: the exact sphere flow of a tension
``eps Y_l0`` through the flat transport dilutes at -1.7e-3 / -5.7e-3 / -1.2e-2 of the exact rate at
2562 nodes (l = 1, 2, 3), at second order; the flat cotangent Laplacian with its lumped dual areas
adds 0 / -1.4e-3 / -3.6e-3 of l (l + 1). On the curved cells (consistent mass, the curved area
change, the P2 stiffness) they are -6.9e-6 / -4.7e-5 / -1.4e-4 and +6.1e-6 / +1.1e-5 / +4.2e-5, at
order 4, when projected in the cells' mass (in the dual areas they read at order 2). A row-sum
lumped mass on the quadratic cells is off by +240 to +720 %. Table and command:
docs/derivations/curved_transport.md (measured at 7beb8d9, 2026-12-07).

Each candidate separately, against closed forms on the unit sphere (no solve of the flow: the exact
sphere flow, :func:`cortex_ti.truth.sphere_exact.sphere_flow`, of the tension ``1 + eps Y_l0`` with
eta_s = eta_b = 1, whose dilution rate ``-div v`` is ``eps Y_l0`` exactly):

* ``dilution``: ``-div v`` of the exact flow through the transport (the velocity relative to the
  mesh carried, the rest by the mesh's normal motion), projected on ``Y_l0``, relative to 1: the flat
  dual cells (``advective_rate`` and ``dual_area_rates`` over the dual areas) and the curved cells
  (``M^-1 (r - dM/dt 1)``);
* ``laplacian``: ``M^-1 K Y_l0`` projected on ``Y_l0`` relative to ``l (l + 1)``: flat (cotangent
  stiffness, lumped dual areas) and curved (P2 stiffness and consistent mass), and the two mixes
  (flat stiffness with the curved mass is not defined: the corner functions' mass is not a dual area);
* the projection is the dual-area one the rate benchmark uses (``proj``) and the curved mass's
  (``projM``, for the curved rows).

Usage::

    python benchmarks/investigations/curved_transport.py --nodes 162 642 2562 10242
    python benchmarks/investigations/curved_transport.py --smoke
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np  # noqa: E402


def probe(nodes: int, l: int, eps: float = 1e-3) -> dict:
    import scipy.sparse.linalg as spla

    from cortex_ti.surface.curved_transport import (
        cell_quadrature,
        curved_advective_rate,
        curved_mass,
        curved_mass_rate,
        curved_stiffness,
    )
    from cortex_ti.surface.mesh import icosphere
    from cortex_ti.surface.transport import DENSITY, advective_rate, cotan_laplacian, dual_area_rates, dual_areas
    from cortex_ti.truth.sphere_exact import real_sph_harm, sphere_flow

    m = icosphere(nodes)
    pts, faces = m.points, m.faces
    nrm = pts / np.linalg.norm(pts, axis=1)[:, None]
    Y = real_sph_harm(l, 0, pts)
    v, _, _ = sphere_flow(
        lambda p: 1.0 + eps * real_sph_harm(l, 0, p), pts, eta_s=1.0, eta_b=1.0, lmax=8, axis=[0, 0, 1]
    )
    w = np.einsum("nc,nc->n", v, nrm)[:, None] * nrm
    one = np.ones(len(pts))
    area = dual_areas(pts, faces)
    quad = cell_quadrature(pts, faces)
    M = curved_mass(pts, faces, quad).tocsc()
    solveM = spla.factorized(M)

    def proj(f):
        return float((f * Y * area).sum() / (Y * Y * area).sum())

    def projM(f):
        return float(Y @ (M @ f) / (Y @ (M @ Y)))

    flat = (advective_rate(one, DENSITY, pts, faces, v - w) - dual_area_rates(pts, faces, w)) / area
    curved = solveM(curved_advective_rate(one, pts, faces, v - w, quad) - curved_mass_rate(pts, faces, w, quad) @ one)
    lam = l * (l + 1)
    lap_flat = cotan_laplacian(pts, faces) @ Y / area
    K2 = curved_stiffness(pts, faces, quad)
    lap_curved = solveM(K2 @ Y)
    return {
        "dilution flat": proj(flat) / eps - 1,
        "dilution curved": proj(curved) / eps - 1,
        "dilution curved, projM": projM(curved) / eps - 1,
        "laplacian flat": proj(lap_flat) / lam - 1,
        "laplacian curved": proj(lap_curved) / lam - 1,
        "laplacian curved, projM": projM(lap_curved) / lam - 1,
        "laplacian curved K, lumped row-sum mass": proj((K2 @ Y) / np.asarray(M.sum(axis=1)).ravel()) / lam - 1,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[162, 642, 2562])
    ap.add_argument("--degrees", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    if args.smoke:
        args.nodes, args.degrees = [162], [2]
    print(_bench.header())
    res = {(n, l): probe(n, l) for n in args.nodes for l in args.degrees}
    names = list(next(iter(res.values())))
    print("Relative error of each candidate against its closed form (dilution: 1 per unit eps; Laplacian: l(l+1)):\n")
    print("| candidate | l | " + " | ".join(str(n) for n in args.nodes) + " | orders |")
    print("|---|---|" + "---|" * (len(args.nodes) + 1))
    for name in names:
        for l in args.degrees:
            e = [res[n, l][name] for n in args.nodes]
            orders = " ".join(f"{np.log2(abs(a / b)):.2f}" for a, b in zip(e, e[1:], strict=False))
            print(f"| {name} | {l} | " + " | ".join(f"{x:+.2e}" for x in e) + f" | {orders} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
