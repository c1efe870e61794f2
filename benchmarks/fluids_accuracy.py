"""The cortex between two Stokes fluids of equal viscosity (issue 36, first step) against the exact
truths of :mod:`cortex_ti.truth.fluid_sphere` (Lamb's solution with surface viscosities), on the
icosphere at several node counts; formulation ``rayleigh_p1`` plus the fluids' dissipation
(:mod:`cortex_ti.physics.fluids`, single layer of :mod:`cortex_ti.physics.stokes_bie`).

Cases (cortex eta_s = eta_b = 1, no bending viscosity; ``mu = mu_in = mu_out``):

* ``Y10``, ``Y20``: the t = 0 flow of the active tension ``zeta = P_l(z)`` on the unit sphere,
  against ``zeta (alpha_l grad_s P_l + beta_l P_l n)`` (``flow_coefficients``): max error / max |v|;
* ``furrow``: the same for furrow_p8_a1's ring, expanded in Legendre polynomials (degree 80);
* ``sediment``: the centroid velocity under a body force ``e_z`` on the cytoplasm, relative error
  against ``sedimentation_velocity`` (Boussinesq-Scriven);
* ``relax2``: the normal speed of the shape ``r = 1 + eps P_2(z)`` (eps = 1e-3) under the uniform
  tension 1, its ``P_2`` coefficient / eps against ``relaxation_rate(2)``: relative error;
* ``faxen``: mean surface velocity and surface rotation (normalised by the mesh's own moment of
  the node areas) in the shear ``u = G y e_x`` (G = 1) against ``faxen``: the larger absolute error;
* ``strain`` (with ``faxen``): the whole surface velocity in that shear against the rotation plus
  ``strain_response``'s degree-2 flow: max error / max of the degree-2 part.

Usage::

    python benchmarks/fluids_accuracy.py --nodes 162 642 2562 --mu 0.1 1 10
    python benchmarks/fluids_accuracy.py --nodes 642 2562 --mu 1 --lam 0.1 10 --solver direct
    python benchmarks/fluids_accuracy.py --operator --nodes 162 642 2562
    python benchmarks/fluids_accuracy.py --smoke
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import _bench  # benchmarks/_bench.py: what the scripts share
import numpy as np

NO_BENDING = [
    "viscosity.bending=0",
    "viscosity.bending_bulk=0",
    "effects=[active_stress,shear_viscosity,bulk_viscosity,normal_balance,incompressibility]",
]


def cortex(nodes: int):
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    return Simulation(
        load_scene("furrow_p8_a1", [f"mesh.nodes={nodes}", "numerics.formulation=rayleigh_p1", *NO_BENDING])
    )


def legendre_flow(coeffs, x, alpha_beta):
    """``sum_l c_l (alpha_l grad_s P_l + beta_l P_l n)`` on the unit sphere at the points x."""
    from numpy.polynomial import legendre as L

    n = x / np.linalg.norm(x, axis=1)[:, None]
    z = n[:, 2]
    v = np.zeros_like(n)
    tang = np.array([0.0, 0.0, 1.0])[None] - z[:, None] * n  # grad_s z
    for l, c in enumerate(coeffs):
        if l == 0 or c == 0.0:
            continue
        e = np.zeros(l + 1)
        e[l] = 1.0
        p, dp = L.legval(z, e), L.legval(z, L.legder(e))
        al, be = alpha_beta(l)
        v += c * (al * dp[:, None] * tang + be * p[:, None] * n)
    return v


def legendre_coefficients(func, lmax: int):
    """Legendre coefficients of an axisymmetric field ``func(z)`` by Gauss quadrature."""
    from numpy.polynomial import legendre as L

    z, w = L.leggauss(2 * lmax + 2)
    f = func(z)
    out = []
    for l in range(lmax + 1):
        e = np.zeros(l + 1)
        e[l] = 1.0
        out.append((2 * l + 1) / 2.0 * float(np.sum(w * f * L.legval(z, e))))
    return np.array(out)


def build_operator(solver: str, x, faces, normal, *, mu_in: float, mu_out: float):
    """The fluids on the shape ``x``: the dense path's :class:`FluidOperator` or the matrix-free
    ``direct`` operator (:func:`~cortex_ti.physics.fluids_fast.fmm_fluid`)."""
    if solver == "dense":
        from cortex_ti.physics.fluids import fluid_operator

        return fluid_operator(x, faces, normal, mu_in=mu_in, mu_out=mu_out)
    from cortex_ti.physics.fluids_fast import fmm_fluid

    return fmm_fluid(x, faces, normal, mu_in=mu_in, mu_out=mu_out, backend=solver)


def solve_fluids(system, fl, far=None, node_force=None, rtol: float = 1e-10):
    """``(velocity (N, 3), pressure, multipliers)`` of ``system`` with the fluids ``fl``: the dense
    bordered solve, or the coupled GMRES (to ``rtol``, the discretisation's error alone) with the
    gauge rows dropped as the dense solve drops them."""
    import dataclasses

    from cortex_ti.physics.fluids import FluidOperator, solve_with_fluids
    from cortex_ti.solve.fluid_krylov import FluidKrylov

    if isinstance(fl, FluidOperator):
        return solve_with_fluids(system, fl, far=far, node_force=node_force)
    keep = [k for k, name in enumerate(system.constraint_names) if not name.startswith("momentum")]
    names = [system.constraint_names[k] for k in keep]
    pidx = None if system.pressure_index is None else names.index(system.constraint_names[system.pressure_index])
    rhs = system.rhs if node_force is None else system.rhs + np.asarray(node_force, float).ravel()
    reduced = dataclasses.replace(
        system,
        rhs=rhs,
        constraints=system.constraints[keep],
        constraint_names=names,
        pressure_index=pidx,
        force_rows=None if system.force_rows is None else system.force_rows[keep],
    )
    fl.far = None if far is None else np.asarray(far, float).ravel()
    v, pressure, lam, _ = FluidKrylov(rtol=rtol, max_iterations=2000).solve(reduced, fl)
    fl.far = None
    return v.reshape(-1, 3), pressure, lam


def measure(nodes: int, mus, cases, lams=(1.0,), solver: str = "dense") -> list[dict]:
    from cortex_ti.physics.fluids import body_force_nodes, shear_flow
    from cortex_ti.physics.patterns import evaluate_active_stress
    from cortex_ti.truth import fluid_sphere as fs

    sim = cortex(nodes)
    x0 = sim.mesh.points
    faces = sim.mesh.faces
    shell = dict(eta_s=1.0, eta_b=1.0)
    rows = []
    geo0 = sim.shape_geometry(x0)
    pats = list(sim.settings.patterns)
    z_ring = legendre_coefficients(
        lambda z: evaluate_active_stress(np.stack([np.sqrt(1 - z**2), 0 * z, z], 1), pats), 80
    )
    for mu, lam in [(m, q) for q in lams for m in mus]:
        mi = lam * mu
        t0 = time.perf_counter()
        fl = build_operator(solver, x0, faces, geo0.normal, mu_in=mi, mu_out=mu)
        build = time.perf_counter() - t0

        def ab(l, mu=mu, mi=mi):
            return fs.flow_coefficients(l, mu_in=mi, mu_out=mu, **shell)

        def flow(zeta, exact, name, mu=mu, lam=lam, fl=fl, build=build):
            t1 = time.perf_counter()
            v, _, _ = solve_fluids(sim.system(geo0, zeta=zeta), fl)
            err = float(np.abs(v - exact).max() / np.abs(exact).max())
            rows.append(
                dict(case=name, nodes=nodes, mu=mu, lam=lam, error=err, build_s=build, solve_s=time.perf_counter() - t1)
            )

        z = x0[:, 2] / np.linalg.norm(x0, axis=1)
        if "Y10" in cases:
            flow(z.copy(), legendre_flow([0.0, 1.0], x0, ab), "Y10")
        if "Y20" in cases:
            flow(1.5 * z**2 - 0.5, legendre_flow([0.0, 0.0, 1.0], x0, ab), "Y20")
        if "furrow" in cases:
            flow(evaluate_active_stress(x0, pats), legendre_flow(z_ring, x0, ab), "furrow")
        if "sediment" in cases:
            t1 = time.perf_counter()
            force = body_force_nodes(x0, faces, [0.0, 0.0, 1.0])
            v, _, _ = solve_fluids(sim.system(geo0, zeta=np.zeros(len(x0))), fl, node_force=force)
            vn = np.einsum("nc,nc->n", v, geo0.normal)
            c = (geo0.area[:, None] * x0).sum(0) / geo0.area.sum()
            vol = float((geo0.area * np.einsum("nc,nc->n", x0 - c, geo0.normal)).sum() / 3.0)
            u = (geo0.area * (x0[:, 2] - c[2]) * vn).sum() / vol
            exact = fs.sedimentation_velocity(1.0, mu_in=mi, mu_out=mu, **shell)
            rows.append(
                dict(
                    case="sediment",
                    nodes=nodes,
                    mu=mu,
                    lam=lam,
                    error=float(abs(u / exact - 1.0)),
                    build_s=build,
                    solve_s=time.perf_counter() - t1,
                    value=float(u),
                    exact=exact,
                )
            )
        if "faxen" in cases:
            t1 = time.perf_counter()
            v, _, _ = solve_fluids(sim.system(geo0, zeta=np.zeros(len(x0))), fl, far=shear_flow(x0, 1.0))
            a = geo0.area
            mean = (a[:, None] * v).sum(0) / a.sum()
            # the rotation normalised by the mesh's own moment (exact for a rigid rotation on any mesh;
            # the continuum's 3 / (8 pi R^4) oint x cross v dA is the same on the sphere)
            r = x0 - (a[:, None] * x0).sum(0) / a.sum()
            inertia = np.einsum(
                "n,nab->ab", a, np.einsum("nc,nc->n", r, r)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :]
            )
            rot = np.linalg.solve(inertia, (a[:, None] * np.cross(r, v)).sum(0))
            u_c, w_c = fs.faxen([[0, 1.0, 0], [0, 0, 0], [0, 0, 0]])
            err = max(np.abs(mean - u_c).max(), np.abs(rot - w_c).max())
            # the strain's degree-2 response: v = w_c x x + a q n + b grad_s q, q = n . E n = x y
            n0 = x0 / np.linalg.norm(x0, axis=1)[:, None]
            e = np.array([[0, 0.5, 0], [0.5, 0, 0], [0, 0, 0.0]])
            q = np.einsum("na,ab,nb->n", n0, e, n0)
            sa, sb = fs.strain_response(mu_in=mi, mu_out=mu, **shell)
            strain = sa * q[:, None] * n0 + sb * 2.0 * (n0 @ e - q[:, None] * n0)
            exact = np.cross(w_c, x0) + strain
            strain_err = float(np.abs(v - exact).max() / np.abs(strain).max())
            rows.append(dict(case="strain", nodes=nodes, mu=mu, lam=lam, error=strain_err, build_s=build, solve_s=0.0))
            rows.append(
                dict(
                    case="faxen",
                    nodes=nodes,
                    mu=mu,
                    lam=lam,
                    error=float(err),
                    build_s=build,
                    solve_s=time.perf_counter() - t1,
                    rotation_z=float(rot[2]),
                )
            )
        if "relax2" in cases:
            t1 = time.perf_counter()
            eps = 1e-3
            n0 = x0 / np.linalg.norm(x0, axis=1)[:, None]
            p2 = 1.5 * n0[:, 2] ** 2 - 0.5
            x = n0 * (1.0 + eps * p2)[:, None]
            geo = sim.shape_geometry(x)
            fl2 = build_operator(solver, x, faces, geo.normal, mu_in=mi, mu_out=mu)
            v, _, _ = solve_fluids(sim.system(geo, zeta=np.ones(len(x))), fl2)
            vn = np.einsum("nc,nc->n", v, geo.normal)
            a = geo.area
            rate = float((a * vn * p2).sum() / (a * p2 * p2).sum() / eps)
            exact = fs.relaxation_rate(2, tension=1.0, mu_in=mi, mu_out=mu, **shell)
            rows.append(
                dict(
                    case="relax2",
                    nodes=nodes,
                    mu=mu,
                    lam=lam,
                    error=float(abs(rate / exact - 1.0)),
                    build_s=build,
                    solve_s=time.perf_counter() - t1,
                    value=rate,
                    exact=exact,
                )
            )
    return rows


def operator_report(nodes_list) -> None:
    """The operator alone on the unit icosphere: rigid motions and a pressure through the single
    layer (against Stokes), the quadrature against a much finer one, the build times, and the
    smallest eigenvalue of the fluids' dissipation for several viscosity ratios."""
    from cortex_ti.physics.fluids import fluid_operator
    from cortex_ti.physics.stokes_bie import double_layer_matrix, single_layer_matrix
    from cortex_ti.surface.mesh import icosphere

    print(
        f"{'nodes':>6s} {'translate':>10s} {'rotate':>10s} {'pressure':>10s} {'quadrature':>10s}"
        f" {'single s':>9s} {'double s':>9s}"
    )
    for nodes in nodes_list:
        m = icosphere(nodes)
        x = m.points
        t0 = time.perf_counter()
        c = single_layer_matrix(x, m.faces)
        t1 = time.perf_counter()
        double_layer_matrix(x, m.faces)
        t2 = time.perf_counter()
        tr = np.abs((c @ np.tile([0.0, 0.0, 1.0], nodes)).reshape(-1, 3) - [0, 0, 2.0 / 3.0]).max()
        w = np.array([0.0, 0.0, 1.0])
        rot = np.abs((c @ (3.0 * np.cross(w, x)).ravel()).reshape(-1, 3) - np.cross(w, x)).max()
        pr = np.abs(c @ x.ravel()).max()
        quad = float("nan")
        if nodes <= 642:
            fine = single_layer_matrix(x, m.faces, duffy_points=16, near_levels=3, near=5.0)
            quad = np.abs(c - fine).max() / np.abs(fine).max()
        print(f"{nodes:6d} {tr:10.2e} {rot:10.2e} {pr:10.2e} {quad:10.2e} {t1 - t0:9.1f} {t2 - t1:9.1f}")
        if nodes <= 642:
            from cortex_ti.physics.fluids_double import DoubleLayer

            u = np.stack([x[:, 2] ** 2, x[:, 0] * x[:, 1], np.sin(2.0 * x[:, 0])], 1).ravel()
            ref = double_layer_matrix(x, m.faces) @ u
            diff = np.abs(DoubleLayer(x, m.faces).apply(u) - ref).max() / np.abs(ref).max()
            print(f"       double layer matrix-free against dense (u = (z^2, xy, sin 2x)): {diff:.2e}")
            n = x / np.linalg.norm(x, axis=1)[:, None]
            for lam in (0.0, 0.1, 10.0, 100.0):
                fl = fluid_operator(x, m.faces, n, mu_in=lam, mu_out=1.0)
                print(f"       mu_in / mu_out = {lam:g}: smallest eigenvalue of D {fl.min_eigenvalue:.2e}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[162, 642, 2562])
    ap.add_argument("--mu", type=float, nargs="+", default=[0.1, 1.0, 10.0])
    ap.add_argument("--lam", type=float, nargs="+", default=[1.0], help="viscosity ratios mu_in / mu_out")
    ap.add_argument("--cases", nargs="+", default=["Y10", "Y20", "furrow", "sediment", "relax2", "faxen", "strain"])
    ap.add_argument("--json", help="write the rows to this file")
    ap.add_argument("--solver", default="dense", choices=["dense", "direct"], help="the fluids' solve")
    ap.add_argument("--operator", action="store_true", help="only the operator's own checks (operator_report)")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    if args.smoke:
        args.nodes, args.mu, args.json = [42], [1.0], None
    if args.operator or args.smoke:
        operator_report(args.nodes)
        if args.operator:
            return 0
    rows = []
    for nodes in args.nodes:
        rows += measure(nodes, args.mu, args.cases, args.lam, args.solver)
    print(f"{'case':9s} {'mu':>6s} {'lam':>6s} " + " ".join(f"{n:>17d}" for n in args.nodes))
    cases = [c for c in args.cases if c != "strain"] + (["strain"] if "faxen" in args.cases else [])
    for case, mu, lam in [(c, m, q) for c in cases for q in args.lam for m in args.mu]:
        if True:
            errs = [
                r["error"]
                for n in args.nodes
                for r in rows
                if r["case"] == case and r["mu"] == mu and r["lam"] == lam and r["nodes"] == n
            ]
            cells = [
                f"{e:9.2e}" + (f" ({errs[k - 1] / e:4.1f}x)" if k and e > 0 else " " * 8) for k, e in enumerate(errs)
            ]
            print(f"{case:9s} {mu:6.3g} {lam:6.3g} " + " ".join(cells))
    builds = {r["nodes"]: r["build_s"] for r in rows}
    print("operator build [s]: " + ", ".join(f"{n}: {b:.1f}" for n, b in builds.items()))
    if args.json:
        from cortex_ti import provenance

        with open(args.json, "w") as fh:
            json.dump({"provenance": provenance(), "command": sys.argv, "rows": rows}, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    sys.exit(main())
