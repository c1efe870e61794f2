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

``--p2``: the discretisation that carries the rigidity in 3D instead, the mixed curvature vector on
the curved cells of formulation ``rayleigh_p2`` (:mod:`cortex_ti.surface.curved_bending`), measured by
what converges: (1) the energy of the sphere against 8 pi kappa, and the second variation of
``E_h - P0 V`` along ``r = 1 + eps Y_lm`` (central differences at eps = 0.01, 0.02, Richardson)
against ``K_l`` of :mod:`cortex_ti.truth.helfrich_sphere`, with the time of one energy and gradient;
(2) the linearised shape-mode rates of l = 2, 3, 4 (``cortex_ti.dynamics.mode_rates``, m = 0;
``--all-m``: every m of l = 2) against ``lambda_l = -M_l K_l``, kappa = eta_s = eta_b = 1, with and
without a uniform tension (then ``numerics.active_force: gradient``); (3) ``--steps T``: relaxation
runs from an ellipsoid to t = T with ``time.scheme: bdf2`` (its error control), normal and lagrangian
node motion, kappa = 1 and 0.01, and the step sizes it takes (or the stability guard's stop); (4)
``--accuracy T``: the same relaxation (first mesh of ``--nodes``) by ``bdf2`` at three tolerances
against explicit Heun at dt = 2e-5, the largest node difference at t = T; (5) ``--ratio``: how much
larger the frozen-geometry Hessian ``L M^-1 L`` can be than ``L D^-1 L`` (the semi-implicit
rigidity's factor); (6) ``--rest``: the icosphere's nodes on the unit sphere are not a discrete
equilibrium of ``E_h``: the velocity of the solve at dt = 0 and the transient of a run.

Usage::

    python benchmarks/bending_force_3d.py --nodes 642 2562 10242 40962 --fits quadratic quartic
    python benchmarks/bending_force_3d.py --p2 --nodes 162 642 2562 10242
    python benchmarks/bending_force_3d.py --p2 --nodes 162 642 2562 --degrees 2 --steps 0.01
    python benchmarks/bending_force_3d.py --p2 --nodes 162 --degrees 2 --accuracy 0.01

Cost: 40962 nodes with the quartic fit ~1 min; ``--p2`` to 10242 nodes a few minutes.
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


def _orders(errors: list[float]) -> str:
    e = np.abs(np.asarray(errors))
    return " ".join(f"{o:.2f}" for o in np.log2(e[:-1] / e[1:]))


def p2_energies(nodes: list[int]) -> None:
    import time

    from cortex_ti.physics.spherical import direction_angles, real_sph_harm
    from cortex_ti.surface.curved import p2_cells
    from cortex_ti.surface.curved_bending import bending_energy
    from cortex_ti.surface.mesh import icosphere
    from cortex_ti.truth.helfrich_sphere import base_pressure, stiffness

    print("(1) P2 mixed energy: relative errors (sphere: 8 pi kappa; Y_lm: K_l); seconds per energy + gradient")
    cases = [
        ("sphere", 0, 0, 0.0),
        ("Y20", 2, 0, 0.0),
        ("Y31", 3, 1, 0.0),
        ("Y42", 4, 2, 0.0),
        ("Y20 c0=0.5", 2, 0, 0.5),
    ]
    errors = {c[0]: [] for c in cases}
    for n in nodes:
        mesh = icosphere(n)
        cells, x0 = p2_cells(mesh.faces), mesh.points
        t0 = time.perf_counter()
        e = bending_energy(x0, cells, 1.0)
        seconds = time.perf_counter() - t0
        theta, phi = direction_angles(x0)
        line = f"N={n:6d} cells={len(cells):5d} time {seconds:.3f} s"
        for name, l, m, c0 in cases:
            if l == 0:
                err = e.energy / (8 * np.pi) - 1
            else:
                y = real_sph_harm(l, m, theta, phi)

                def second(eps, y=y, c0=c0, x0=x0, cells=cells):
                    en = [
                        bending_energy(x0 * (1 + s * eps * y)[:, None], cells, 1.0, c0, gradient=False)
                        for s in (1, 0, -1)
                    ]
                    return (en[0].energy + en[2].energy - 2 * en[1].energy) / eps**2 - 2 * base_pressure(
                        kappa=1.0, c0=c0
                    )

                fine, coarse = second(0.01), second(0.02)
                err = (fine + (fine - coarse) / 3) / stiffness(l, kappa=1.0, c0=c0) - 1
            errors[name].append(err)
            line += f" | {name} {err:.2e}"
        print(line, flush=True)
    if len(nodes) > 1:
        print("orders: " + "; ".join(f"{k}: {_orders(v)}" for k, v in errors.items()))


def _relaxation_scene(nodes: int, zeta0: float, over: list[str]):
    from cortex_ti.scene import load_scene, scene_from_dict

    sets = [f"mesh.nodes={nodes}", "numerics.formulation=rayleigh_p2", "numerics.fit=quartic", "solver.rtol=1e-12"]
    data = load_scene("furrow_p4_a1", [*sets, *over]).data
    data["effects"] = ["shear_viscosity", "bulk_viscosity", "normal_balance", "incompressibility", "shape_evolution"]
    data["effects"] += ["bending_rigidity"] + (["active_stress"] if zeta0 else [])
    data["active_stress"] = [{"type": "ring", "zeta0": zeta0, "amplitude": 0.0}] if zeta0 else []
    data["rigidity"] = {"bending": KAPPA, "spontaneous_curvature": 0.0}
    data["viscosity"] = {"shear": 1.0, "bulk": 1.0, "bending": 0.0, "bending_bulk": 0.0}
    return scene_from_dict(data)


def p2_rates(nodes: list[int], degrees: list[int], all_m: bool) -> None:
    import time

    from cortex_ti.dynamics.mode_rates import normal_mode_rate
    from cortex_ti.simulation import Simulation
    from cortex_ti.truth.helfrich_sphere import rate

    print(f"(2) linearised shape-mode rates, kappa = {KAPPA}, eta_s = eta_b = 1: rate (relative error)")
    for zeta0 in (0.0, 1.0):
        over = ["numerics.active_force=gradient"] if zeta0 else []
        errors = {l: [] for l in degrees}
        for n in nodes:
            t0 = time.perf_counter()
            sim = Simulation(_relaxation_scene(n, zeta0, over))
            line = f"zeta0={zeta0:g} N={n:6d}"
            for l in degrees:
                truth = rate(l, kappa=KAPPA, eta_s=1.0, eta_b=1.0, zeta0=zeta0)
                r = normal_mode_rate(sim, l)
                errors[l].append(r / truth - 1)
                line += f" | l={l}: {r:.4f} (truth {truth:g}, {r / truth - 1:+.2e})"
            if all_m:
                spread = [
                    normal_mode_rate(sim, 2, m) / rate(2, kappa=KAPPA, eta_s=1.0, eta_b=1.0, zeta0=zeta0) - 1
                    for m in range(-2, 3)
                ]
                line += " | l=2, m=-2..2: " + " ".join(f"{e:+.2e}" for e in spread)
            print(line + f" [{time.perf_counter() - t0:.1f} s]", flush=True)
        if len(nodes) > 1:
            print("orders: " + "; ".join(f"l={l}: {_orders(v)}" for l, v in errors.items()))


def p2_steps(nodes: list[int], t_end: float, kappas: tuple[float, ...] = (KAPPA, 0.01)) -> None:
    import tempfile
    import time
    from pathlib import Path

    from cortex_ti.errors import StabilityError
    from cortex_ti.io import Trajectory
    from cortex_ti.scene import scene_from_dict
    from cortex_ti.simulation import Simulation
    from cortex_ti.simulation.report import run_summary

    print(f"(3) relaxation from the ellipsoid diag(1.1, 1, 0.9), bdf2 at its default tolerance, to t = {t_end:g}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in nodes:
            for motion in ("normal", "lagrangian"):
                for kappa in kappas:
                    over = ["time.scheme=bdf2", "time.dt=1e-4", f"time.t_end={t_end}", f"time.save_every={t_end / 10}"]
                    data = _relaxation_scene(n, 0.0, [*over, f"mesh.motion={motion}"]).data
                    data["mesh"]["transform"] = [[1.1, 0, 0], [0, 1.0, 0], [0, 0, 0.9]]
                    data["rigidity"]["bending"] = kappa
                    sim = Simulation(scene_from_dict(data))
                    t0 = time.perf_counter()
                    head = f"N={n:5d} {motion:10s} kappa={kappa:g}:"
                    try:
                        out = sim.run(Path(tmp) / f"relax_{n}_{motion}_{kappa}.h5", progress=False)
                    except StabilityError as err:
                        print(f"{head} stopped by the guard: {str(err)[:150]}", flush=True)
                        continue
                    with Trajectory(out) as tr:
                        dts = tr.ds["dt"].values[1:]
                    wall = time.perf_counter() - t0
                    s = run_summary(sim)
                    steps = f"{s['steps']} steps ({s['rejected']} rejected), {wall:.0f} s"
                    print(f"{head} step at the frames " + " ".join(f"{d:.1e}" for d in dts) + f"; {steps}", flush=True)


def p2_accuracy(nodes: int, t_end: float, dt_ref: float, tols: list[float]) -> None:
    import tempfile
    import time
    from pathlib import Path

    from cortex_ti.io import Trajectory
    from cortex_ti.scene import scene_from_dict
    from cortex_ti.simulation import Simulation

    print(f"(4) bdf2, semi-implicit rigidity, against explicit Heun at dt = {dt_ref:g} (N = {nodes}, t = {t_end:g})")
    with tempfile.TemporaryDirectory() as tmp:

        def final(over, name):
            data = _relaxation_scene(nodes, 0.0, [f"time.t_end={t_end}", f"time.save_every={t_end}", *over]).data
            data["mesh"]["transform"] = [[1.1, 0, 0], [0, 1.0, 0], [0, 0, 0.9]]
            sim = Simulation(scene_from_dict(data))
            t0 = time.perf_counter()
            with Trajectory(sim.run(Path(tmp) / f"{name}.h5", progress=False)) as tr:
                x = tr.ds["points"].values[-1].copy()
            return x, sim.stats.steps, time.perf_counter() - t0

        ref, steps, wall = final(["time.scheme=heun", f"time.dt={dt_ref}"], "ref")
        print(f"reference: {steps} Heun steps, {wall:.0f} s")
        for tol in tols:
            x, steps, wall = final(["time.scheme=bdf2", "time.dt=1e-4", f"time.tol={tol}"], f"bdf2_{tol}")
            print(
                f"time.tol={tol:g}: {steps} steps, largest node difference {np.abs(x - ref).max():.2e} ({wall:.0f} s)"
            )


def p2_ratio(nodes: list[int]) -> None:
    import scipy.linalg as sla

    from cortex_ti.surface.curved import p2_cells
    from cortex_ti.surface.curved_bending import cell_matrices
    from cortex_ti.surface.mesh import icosphere

    print("(5) the semi-implicit rigidity's factor: largest generalised eigenvalue of (L M^-1 L, L D^-1 L)")
    for n in nodes:
        m = icosphere(n)
        mass, stiff = (a.toarray() for a in cell_matrices(m.points, p2_cells(m.faces)))
        d = np.diag(mass)
        hess, approx = stiff @ np.linalg.solve(mass, stiff), stiff @ (stiff / d[:, None])
        shift = 1e-9 * np.eye(n)  # both vanish on the constants
        print(f"N={n:6d}: {sla.eigh(hess + shift, approx + shift, eigvals_only=True).max():.3f}", flush=True)


def p2_rest(nodes: list[int], t_end: float = 0.01) -> None:
    import tempfile
    from pathlib import Path

    from cortex_ti.io import Trajectory
    from cortex_ti.simulation import Simulation

    print(f"(6) the icosphere at rest (no activity): the solve at dt = 0, then bdf2 to t = {t_end:g}")
    with tempfile.TemporaryDirectory() as tmp:
        for n in nodes:
            over = ["time.scheme=bdf2", "time.dt=1e-5", f"time.t_end={t_end}", f"time.save_every={t_end / 5}"]
            sim = Simulation(_relaxation_scene(n, 0.0, over))
            x = sim.mesh.points / np.linalg.norm(sim.mesh.points, axis=1)[:, None]
            system = sim.system(sim.shape_geometry(x))
            v, _, _ = sim.solver.solve(system, x)
            with Trajectory(sim.run(Path(tmp) / f"rest_{n}.h5", progress=False)) as tr:
                p, vel = tr.ds["points"].values, tr.ds["velocity"].values
            moved = np.abs(np.linalg.norm(p, axis=2) - 1).max(1)
            print(
                f"N={n:6d}: max |v| at dt = 0 {np.abs(system.velocity(v)).max():.2e}; in the run at the frames "
                + " ".join(f"{a:.1e}" for a in np.abs(vel).max((1, 2)))
                + "; max ||x| - 1| "
                + " ".join(f"{a:.1e}" for a in moved)
                + f"; {sim.stats.steps} steps",
                flush=True,
            )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="*", default=[642, 2562, 10242])
    p.add_argument("--p2", action="store_true", help="the P2 mixed energy of formulation rayleigh_p2 (docstring)")
    p.add_argument("--degrees", type=int, nargs="*", default=[2, 3, 4], help="--p2: the shape modes' degrees")
    p.add_argument("--all-m", action="store_true", help="--p2: every m of l = 2 too")
    p.add_argument("--steps", type=float, default=0.0, help="--p2: the relaxation run's end time (0: none)")
    p.add_argument(
        "--accuracy", type=float, default=0.0, help="--p2: bdf2 against explicit Heun to this time (0: none)"
    )
    p.add_argument("--fits", nargs="*", default=["quadratic", "quartic"])
    p.add_argument("--eps", type=float, nargs="*", default=[0.0, 0.2], help="amplitudes of the P2 shape")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:  # both parts, tiny
        p2_energies([42, 162])
        p2_rates([42, 162], [2], False)
        p2_steps([42], 2e-4, (KAPPA,))
        p2_accuracy(42, 2e-4, 1e-4, [1e-5])
        p2_ratio([42])
        args.nodes, args.fits, args.eps = [162, 642], ["quadratic"], [0.2]
    elif args.p2:
        print(_bench.header(), end="")
        p2_energies(args.nodes)
        p2_rates(args.nodes, args.degrees, args.all_m)
        if args.steps > 0:
            p2_steps(args.nodes, args.steps)
        if args.accuracy > 0:
            p2_accuracy(args.nodes[0], args.accuracy, 2e-5, [1e-5, 1e-6, 1e-7])
        if args.rest:
            p2_rest(args.nodes)
        if args.ratio:
            p2_ratio([n for n in args.nodes if n <= 2562])
        return 0
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
