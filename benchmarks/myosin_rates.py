"""Growth and decay rates of single harmonics of the uniform myosin cortex in 3D, against the closed
form (issue 20's bar: l = 1, 2, 3, sub- and supercritical, within 1 %), converging with N.

The uniform myosin sphere (D = 0.05, k = 0.2, linear law, zeta0 = 1; no bending viscosity,
eta_s = eta_b = 1, the mean-velocity gauge) is linearised with the rates of
:func:`cortex_ti.dynamics.spectrum.state_rates` (normal speed and myosin rate at every node; a
direct solve per evaluation, as :func:`~cortex_ti.dynamics.spectrum.state_jacobian`), but only
along the degree-l harmonics: ``J v`` by central differences for the ``2 (2l + 1)`` vectors ``v``
(normal displacement ``Y_lm``, myosin ``Y_lm``), projected back on the same harmonics with the
dual areas (on ``rayleigh_p2``: with the curved cells' mass, the density's own inner product,
docs/derivations/curved_transport.md). The rates of degree l are the eigenvalues of that ``2 (2l + 1)`` square matrix
(a Galerkin projection of the state spectrum); ``--full`` checks them against every eigenvalue
of the whole dense Jacobian (``state_spectrum``'s), feasible to 642 nodes. On the icosphere the
degree-1 and degree-2 harmonics are irreducible under its symmetry group, so their modes mix only
with degrees >= 4 (resp. 5), which moves the eigenvalues at second order in the mixing.

The Jacobian is affine in the law's slope ``gamma``: at the uniform state the tension is ``zeta0``
whatever ``gamma``, so only the myosin columns change, and at ``gamma = 0`` they are diffusion and
turnover alone, ``[0; -D M^-1 K - k I]`` (the uniform state is steady: no flow). So one set of
derivatives at ``gamma = 1`` gives every ``gamma`` (``--check``: against a second set at 0.5).

Reported per mesh, ``gamma``, degree and branch: the closed form
(:func:`cortex_ti.analysis.myosin_stability.growth_rates`), the 3D rate (mean over m; the spread
over m), the relative error, the observed order between consecutive meshes (``log2`` of the
error ratio, h halving) and Richardson's second-order extrapolation of the two finest.

Usage::

    python benchmarks/myosin_rates.py --nodes 162 642 2562 10242 --gammas 1 0.5 0.25 [--full] [--check] [--split]
    python benchmarks/myosin_rates.py --nodes 642 2562 --formulation rayleigh_p2

Cost (one core): 4 (2l + 1) solves per degree, 60 for l = 1..3: 10242 nodes about a minute.
"""

from __future__ import annotations

import argparse
import sys
import time

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

D, K, ZETA0 = 0.05, 0.2, 1.0
EFFECTS = [
    "active_stress",
    "shear_viscosity",
    "bulk_viscosity",
    "normal_balance",
    "incompressibility",
    "shape_evolution",
]


#: extra ``numerics`` of the scene (``--formulation``)
NUMERICS: dict = {}


def myosin_sphere(nodes: int, gamma: float = 1.0):
    from cortex_ti.scene import scene_from_dict
    from cortex_ti.simulation import Simulation

    data = {
        "name": "myosin_sphere",
        "mesh": {"nodes": nodes},
        "fields": {
            "myosin": {
                "c0": 1.0,
                "diffusion": D,
                "turnover": K,
                "tension": {"law": "linear", "zeta0": ZETA0, "gamma": gamma},
            }
        },
        "active_stress": [],
        "effects": EFFECTS,
    }
    if NUMERICS:
        data["numerics"] = dict(NUMERICS)
    return Simulation(scene_from_dict(data))


def projected(sim, l: int):
    """The state Jacobian (``gamma`` of the scene) projected on the degree-l harmonics
    (:func:`cortex_ti.dynamics.spectrum.degree_jacobian`)."""
    from cortex_ti.dynamics.spectrum import degree_jacobian

    return degree_jacobian(sim, l)


def full_jacobian(sim):
    from cortex_ti.dynamics.spectrum import state_jacobian

    jac = state_jacobian(sim)
    assert jac.names == ("normal", "myosin"), jac.names
    return jac.matrix


def gamma0_columns(points, faces, curved: bool = False) -> np.ndarray:
    """The myosin columns of the whole Jacobian at gamma = 0: no flow; diffusion and turnover only
    (``curved``: the curved cells' ``-D M^-1 K``)."""
    from cortex_ti.surface.curved_transport import curved_mass, curved_stiffness
    from cortex_ti.surface.transport import cotan_laplacian, dual_areas

    n = len(points)
    cols = np.zeros((2 * n, n))
    if curved:
        lap = np.linalg.solve(curved_mass(points, faces).toarray(), curved_stiffness(points, faces).toarray())
        cols[n:] = -D * lap - K * np.eye(n)
        return cols
    area = dual_areas(points, faces)
    cols[n:] = -D * cotan_laplacian(points, faces).toarray() / area[:, None] - K * np.eye(n)
    return cols


def at_gamma(J1: np.ndarray, C0: np.ndarray, gamma: float) -> np.ndarray:
    n = J1.shape[0] // 2
    J = J1.copy()
    J[:, n:] = C0 + gamma * (J1[:, n:] - C0)
    return J


def branches(G: np.ndarray, exact) -> list:
    """The eigenvalues of the projected matrix, grouped into the closed form's branches: for each
    exact rate the ``2l + 1`` nearest (mean, spread)."""
    ev = np.linalg.eigvals(G)
    m = G.shape[0] // 2
    out = []
    for rate in exact:
        near = ev[np.argsort(np.abs(ev - rate))][:m].real
        out.append((float(near.mean()), float(np.ptp(near))))
    return out


def dilution_split(nodes: int, l: int, eps: float = 1e-3) -> tuple:
    """Where the error of the myosin's response sits, for a tension perturbation ``eps Y_l0``: the
    dilution rate ``-div v`` (per unit ``eps``, projected on ``Y_l0``; exact ``A X_l / D_l`` = 1
    here) from the 3D flow and the transport's operators, from the exact sphere flow
    (:func:`cortex_ti.truth.sphere_exact.sphere_flow`) and the same operators, and the 3D
    normal velocity's amplitude against the exact one. Without bending viscosity and with eta_s =
    eta_b the flow of an l >= 2 tension is normal, so the operator is the dual cells' area rate. On the
    curved cells (``rayleigh_p2``): ``M^-1 (r - dM/dt c)`` and the projections in the mass ``M``."""
    from cortex_ti.dynamics.state import State
    from cortex_ti.surface.transport import DENSITY, advective_rate, dual_area_rates, dual_areas
    from cortex_ti.truth.sphere_exact import real_sph_harm, sphere_flow

    sim = myosin_sphere(nodes)
    pts, faces = sim.mesh.points, sim.mesh.faces
    area = dual_areas(pts, faces)
    Y = real_sph_harm(l, 0, pts)
    c = 1.0 + eps * Y
    ev = sim.evaluate(State(pts, {"myosin": c}, sim.state0.faces))
    vex, _, _ = sphere_flow(
        lambda p: 1.0 + eps * real_sph_harm(l, 0, p), pts, eta_s=1.0, eta_b=1.0, lmax=8, axis=[0, 0, 1]
    )
    nrm = ev.normal
    if sim.transport["myosin"].curved_density:
        from scipy.sparse.linalg import spsolve

        from cortex_ti.surface.curved_transport import curved_advective_rate, curved_mass, curved_mass_rate

        mass = curved_mass(pts, faces)

        def dilution(v):
            w = np.einsum("nc,nc->n", v, nrm)[:, None] * nrm
            rate = curved_advective_rate(c, pts, faces, v - w) - curved_mass_rate(pts, faces, w) @ c
            return spsolve(mass.tocsc(), rate)

        def proj(f):
            return float(Y @ (mass @ f) / (Y @ (mass @ Y)) / eps)
    else:

        def dilution(v):
            w = np.einsum("nc,nc->n", v, nrm)[:, None] * nrm
            return (advective_rate(c, DENSITY, pts, faces, v - w) - c * dual_area_rates(pts, faces, w)) / area

        def proj(f):
            return float((f * Y * area).sum() / (Y * Y * area).sum() / eps)

    vn3, vnx = (proj(np.einsum("nc,nc->n", v, nrm)) for v in (ev.velocity, vex))
    return proj(dilution(ev.velocity)), proj(dilution(vex)), vn3 / vnx - 1.0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[162, 642])
    ap.add_argument("--gammas", type=float, nargs="+", default=[1.0, 0.5, 0.25])
    ap.add_argument("--degrees", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--check", action="store_true", help="check the affine gamma law with derivatives at 0.5")
    ap.add_argument("--full", action="store_true", help="also the whole dense Jacobian's eigenvalues (<= 642 nodes)")
    ap.add_argument("--split", action="store_true", help="where the error sits: the dilution of the flow (exact flow)")
    ap.add_argument("--formulation", default=None, help="numerics.formulation (rayleigh_p2: with the quartic fit)")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    if args.formulation:
        NUMERICS["formulation"] = args.formulation
        if args.formulation == "rayleigh_p2":
            NUMERICS["fit"] = "quartic"
    if args.smoke:
        args.nodes, args.gammas, args.degrees, args.check, args.full, args.split = [162], [1.0], [2], False, False, True
    from cortex_ti.analysis import myosin_stability as ms

    found, rows, notes = {}, [], []
    for nodes in args.nodes:
        sim = myosin_sphere(nodes)
        t0 = time.perf_counter()
        proj = {l: projected(sim, l) for l in args.degrees}
        print(f"{nodes} nodes: projections {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
        if args.check:
            half = myosin_sphere(nodes, 0.5)
            dev = max(
                np.abs(proj[l].at(0.5 * ZETA0) - projected(half, l).matrix).max() / np.abs(proj[l].matrix).max()
                for l in args.degrees
            )
            notes.append(
                f"{nodes} nodes: the affine law in gamma, max |G(0.5) - G0 - 0.5 (G1 - G0)| / max |G| = {dev:.1e}"
            )
        full = None
        if args.full and nodes <= 642:
            t0 = time.perf_counter()
            curved = sim.transport["myosin"].curved_density
            full = (full_jacobian(sim), gamma0_columns(sim.mesh.points, sim.mesh.faces, curved))
            print(f"{nodes} nodes: whole Jacobian {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
        for gamma in args.gammas:
            every = None if full is None else np.linalg.eigvals(at_gamma(*full, gamma))
            for l in args.degrees:
                exact = [
                    r for r in ms.growth_rates(l, ZETA0, gamma, D, K, decimals=None) if not (l == 1 and abs(r) < 1e-14)
                ]
                got = branches(proj[l].at(gamma * ZETA0), exact)
                for branch, (rate, (mean, spread)) in enumerate(zip(exact, got, strict=True)):
                    found[nodes, gamma, l, branch] = mean
                    gap = float("nan") if every is None else float(np.min(np.abs(every - mean)))
                    rows.append((nodes, gamma, l, branch, float(np.real(rate)), mean, spread, gap))
    print("Rates of degree l (branch 0: the larger); ``whole J`` = distance to the nearest eigenvalue of the")
    print("whole dense Jacobian (``--full``).\n")
    print("| nodes | gamma | l | branch | closed form | 3D | spread over m | rel. error | whole J |")
    print("|---|---|---|---|---|---|---|---|---|")
    for nodes, gamma, l, branch, exact, mean, spread, gap in rows:
        err = (mean - exact) / abs(exact)
        print(
            f"| {nodes} | {gamma:g} | {l} | {branch} | {exact:+.6f} | {mean:+.6f} | {spread:.1e} | {err:+.2e} "
            f"| {gap:.1e} |"
        )
    if args.split:
        print("\nThe myosin's dilution rate per unit tension perturbation eps Y_l0 (exact 1), and the 3D normal")
        print("velocity's amplitude against the exact sphere flow's:\n")
        print("| nodes | l | 3D flow, 3D operators | exact flow, 3D operators | v_n amplitude 3D / exact - 1 |")
        print("|---|---|---|---|---|")
        for nodes in args.nodes:
            for l in args.degrees:
                a, b, v = dilution_split(nodes, l)
                print(f"| {nodes} | {l} | {a:.5f} ({a - 1:+.2e}) | {b:.5f} ({b - 1:+.2e}) | {v:+.2e} |")
    if notes:
        print("\n" + "\n".join(f"- {x}" for x in notes))
    if len(args.nodes) > 1:
        print("\nObserved order log2(e_coarse / e_fine) between consecutive meshes, and Richardson's")
        print("(4 r_fine - r_coarse) / 3 from the two finest, its relative error:\n")
        pairs = list(zip(args.nodes, args.nodes[1:], strict=False))
        print("| gamma | l | branch | " + " | ".join(f"{a}->{b}" for a, b in pairs) + " | Richardson | rel. error |")
        print("|---|---|---|" + "---|" * (len(pairs) + 2))
        for gamma in args.gammas:
            for l in args.degrees:
                exact = [
                    r for r in ms.growth_rates(l, ZETA0, gamma, D, K, decimals=None) if not (l == 1 and abs(r) < 1e-14)
                ]
                for branch, rate in enumerate(exact):
                    r = [found[n, gamma, l, branch] for n in args.nodes]
                    e = [x - np.real(rate) for x in r]
                    orders = [np.log2(abs(a / b)) if b != 0 else float("nan") for a, b in zip(e, e[1:], strict=False)]
                    rich = (4 * r[-1] - r[-2]) / 3
                    rel = (rich - np.real(rate)) / abs(rate)
                    cells = " | ".join(f"{o:.2f}" for o in orders)
                    print(f"| {gamma:g} | {l} | {branch} | {cells} | {rich:+.6f} | {rel:+.1e} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
