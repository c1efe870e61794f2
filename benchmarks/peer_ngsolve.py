"""A peer on the t = 0 sphere problem: NGSolve's curved surface finite elements, error against wall time.

The first solve of a ring scene on the unit sphere, without bending viscosity, whose exact flow is
known (:func:`cortex_ti.truth.sphere_exact.sphere_flow`), solved by an established finite
element library (NGSolve, the ``peers`` extra: ``pip install -e '.[peers]'``) with its own
isoparametric surface elements, beside ``rayleigh_p1`` (``--ours``), at about equal velocity nodes.

The peer's recipe (what the lead needs to match it):

* **mesh**: Netgen's surface mesh of the unit sphere (CSG sphere, ``MESHSURFACE``), its ``maxh``
  searched so that the velocity nodes ``k^2 (V - 2) + 2`` of order ``k`` come close to the asked
  count; geometry curved to the velocity's order, ``mesh.Curve(k)`` (isoparametric);
* **velocity**: the full 3D surface velocity ``v`` (tangential and normal) in ``VectorH1`` of
  order ``k`` on the surface; velocity nodes = ndof / 3;
* **weak form**: the stationary point of the Rayleighian
  ``R[v] = int [eta_s |u~|^2 + eta_b/2 (tr u)^2] dA + int zeta tr u dA - P int v.n dA``,
  ``u = sym(P grad_G v P)`` (``grad_G v = Grad(v).Trace()``, ``P = I - n n`` with the normal of
  the curved element), ``u~ = u - tr(u) P / 2``; the volume constraint ``int v.n dA = 0`` and the
  six rigid motions (``int v dA = 0``, ``int x x v dA = 0``) each by an exact Lagrange multiplier
  (seven ``NumberSpace`` unknowns), no penalty; the pressure is minus the volume multiplier;
* **quadrature**: the bilinear form ``bonus_intorder=2`` above NGSolve's default (which under-integrates
  the curved cells: order 3 is then 1.6-1.8x less accurate at 10^4 nodes; a bonus of 4 gives the same
  digits as 2); the integrands ``Compile()``-d (3-5x faster assembly, same numbers);
* **active tension**: ``zeta`` of the scene's patterns, evaluated by
  ``cortex_ti.physics.patterns.evaluate_active_stress`` at every quadrature point of the
  curved cells (an ``IntegrationRuleSpaceSurface`` of order ``2 k + 6``, the load integrated on
  that same rule), so no interpolation of the pattern;
* **solve**: NGSolve's sparse LDL^T (``sparsecholesky``) of the symmetric saddle-point matrix,
  one thread (``SetNumThreads(1)``, OMP/OpenBLAS/MKL threads 1); wall time = curving + assembly
  + factorisation + solve, the fastest of ``--repeat`` (mesh generation and the error evaluation
  excluded);
* **error**: eps_rel (paper Eq. 58, ``cortex_ti.truth.analytic.error_measures``) at every
  velocity node (the Lagrange points of order ``k`` of each curved triangle, deduplicated: their
  count equals ndof / 3) and, second, at the mesh vertices only, and the L2 error over the curved
  surface; the exact flow (``cortex_ti.truth.sphere_exact.sphere_flow``, about the ring's axis)
  is evaluated at the point projected on the unit sphere.

Usage::

    python benchmarks/peer_ngsolve.py --orders 1 2 3 --nodes 642 2562 10242 --ours
    python benchmarks/peer_ngsolve.py --smoke

One table row per scene, method and node count.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

MISSING = "ngsolve is not installed (the peers extra: pip install -e '.[peers]')"


def _ngsolve():
    """NGSolve, quiet and on one thread, or None when the peers extra is not installed."""
    try:
        import netgen.meshing
        import ngsolve
    except ImportError:
        return None
    netgen.meshing.SetMessageImportance(0)
    ngsolve.ngsglobals.msg_level = 0
    ngsolve.SetNumThreads(1)
    return ngsolve


def velocity_nodes(vertices: int, order: int) -> int:
    """Velocity nodes of a continuous order-``order`` space on a closed triangulation of ``vertices``."""
    return order * order * (vertices - 2) + 2


def sphere_mesh(nodes: int, order: int, cache: dict | None = None):
    """Netgen's unit-sphere surface mesh whose order-``order`` velocity nodes are closest to ``nodes``."""
    ng = _ngsolve()
    from netgen.csg import CSGeometry, Pnt, Sphere
    from netgen.meshing import MeshingStep

    cache = {} if cache is None else cache
    geo = CSGeometry()
    geo.Add(Sphere(Pnt(0, 0, 0), 1.0))

    def make(h):
        if h not in cache:
            cache[h] = geo.GenerateMesh(maxh=h, perfstepsend=MeshingStep.MESHSURFACE)
        return cache[h]

    target = (nodes - 2) / order**2 + 2
    h, best = 0.3, None
    for _ in range(5):  # the vertices go as h^-2: a few secant steps
        m = make(round(h, 5))
        nv = len(m.Points())
        if best is None or abs(nv - target) < abs(best[1] - target):
            best = (round(h, 5), nv)
        if abs(nv - target) <= 0.02 * target:
            break
        h *= np.sqrt(nv / target)
    return ng.Mesh(make(best[0])), best[0]


def lagrange_points(order: int) -> list[tuple[float, float]]:
    """The reference triangle's Lagrange points of ``order`` (the velocity nodes of one cell)."""
    return [(i / order, j / order) for i in range(order + 1) for j in range(order + 1 - i)]


def _build_and_solve(ng, mesh, order: int, eta_s: float, eta_b: float, pats, bonus: int):
    """Spaces, forms, assembly, factorisation and solve on the curved ``mesh``: the timed part."""
    from cortex_ti.physics.patterns import evaluate_active_stress

    bnd = mesh.Boundaries(".*")
    t1 = time.perf_counter()
    V = ng.VectorH1(mesh, order=order, definedon=bnd)
    X = ng.FESpace([V] + [ng.NumberSpace(mesh, definedon=bnd) for _ in range(7)])
    (v, p, *lam), (w, q, *mu) = X.TnT()
    n = ng.specialcf.normal(3)
    Pt = ng.Id(3) - ng.OuterProduct(n, n)
    pos = ng.CF((ng.x, ng.y, ng.z))

    def strain(u):  # sym(P grad_G u P); Grad(u).Trace() is already grad u P
        G = ng.Grad(u).Trace()
        return 0.5 * (Pt * G + G.trans * Pt)

    def dev(E):
        return E - 0.5 * ng.Trace(E) * Pt

    Ev, Ew = strain(v), strain(w)
    a = ng.BilinearForm(X, symmetric=True)
    dissipation = 2 * eta_s * ng.InnerProduct(dev(Ev), dev(Ew)) + eta_b * ng.Trace(Ev) * ng.Trace(Ew)
    constraints = p * ng.InnerProduct(w, n) + q * ng.InnerProduct(v, n)  # volume; p = -P
    rv, rw = ng.Cross(pos, v), ng.Cross(pos, w)
    for i in range(3):  # zero mean velocity and zero angular momentum
        constraints += lam[i] * w[i] + mu[i] * v[i] + lam[3 + i] * rw[i] + mu[3 + i] * rv[i]
    # Compile(): NGSolve's fused evaluation of the expression tree (3-5x faster assembly, same numbers)
    a += dissipation.Compile() * ng.ds(bonus_intorder=bonus)
    a += constraints.Compile() * ng.ds(bonus_intorder=bonus)
    # the scene's active tension at every quadrature point of the curved cells
    irs = ng.comp.IntegrationRuleSpaceSurface(mesh, order=2 * order + 6, definedon=bnd)
    rules = irs.GetIntegrationRules()
    qp = pos(mesh.MapToAllElements(rules[ng.TRIG], ng.BND))
    zeta = ng.GridFunction(irs)
    zeta.vec.FV().NumPy()[:] = evaluate_active_stress(qp, pats)
    f = ng.LinearForm(X)
    f += -zeta * ng.Trace(Ew) * ng.ds(intrules=rules)
    a.Assemble()
    f.Assemble()
    t2 = time.perf_counter()
    inv = a.mat.Inverse(inverse="sparsecholesky")
    t3 = time.perf_counter()
    sol = ng.GridFunction(X)
    sol.vec.data = inv * f.vec
    t4 = time.perf_counter()
    return sol, V, irs, rules, qp, dict(assembly=t2 - t1, factorisation=t3 - t2, solve=t4 - t3)


def peer_solve(
    scene_name: str,
    nodes: int,
    order: int,
    cache: dict | None = None,
    geometry_order: int = 0,
    bonus: int = 2,
    repeat: int = 1,
    overrides=(),
) -> dict:
    """Solve the t = 0 problem of ``scene_name`` (bending viscosity off) with NGSolve at order ``order``,
    the geometry curved to ``geometry_order`` (0: the same order, isoparametric), the forms integrated
    ``bonus`` orders above NGSolve's default; the fastest of ``repeat`` solves is timed."""
    from cortex_ti.physics.patterns import evaluate_active_stress
    from cortex_ti.scene import load_scene
    from cortex_ti.truth.analytic import error_measures
    from cortex_ti.truth.sphere_exact import sphere_flow

    ng = _ngsolve()
    s = load_scene(scene_name, list(overrides)).settings
    pats, eta_s, eta_b = list(s.patterns), s.viscosity.shear, s.viscosity.bulk
    mesh, maxh = sphere_mesh(nodes, order, cache)
    t0 = time.perf_counter()
    geometry_order = geometry_order or order
    mesh.Curve(geometry_order)
    parts = {"curve": time.perf_counter() - t0}
    best = None
    for _ in range(max(1, repeat)):
        sol, V, irs, rules, qp, times = _build_and_solve(ng, mesh, order, eta_s, eta_b, pats, bonus)
        if best is None or sum(times.values()) < sum(best.values()):
            best = times
    parts.update(best)
    pos = ng.CF((ng.x, ng.y, ng.z))

    vel = sol.components[0]
    # every velocity node: the Lagrange points of each curved cell, shared ones once
    ir = ng.IntegrationRule(points=lagrange_points(order), weights=[0.0] * len(lagrange_points(order)))
    mips = mesh.MapToAllElements(ir, ng.BND)
    xq, vq = pos(mips), vel(mips)
    _, first = np.unique(np.round(xq, 9), axis=0, return_index=True)
    xq, vq = xq[first], vq[first]
    corners = mesh.MapToAllElements(ng.IntegrationRule(points=lagrange_points(1), weights=[0.0] * 3), ng.BND)
    xv, vv = pos(corners), vel(corners)
    _, first = np.unique(np.round(xv, 9), axis=0, return_index=True)
    xv, vv = xv[first], vv[first]
    vqp = vel(mesh.MapToAllElements(rules[ng.TRIG], ng.BND))  # at the quadrature points, for the L2 error
    on_sphere = np.vstack([xq, xv, qp])
    on_sphere /= np.linalg.norm(on_sphere, axis=1)[:, None]
    exact, p_exact, _ = sphere_flow(
        lambda y: evaluate_active_stress(y, pats),
        on_sphere,
        eta_s=eta_s,
        eta_b=eta_b,
        axis=s.pattern_axis,  # the ring's axis: the axisymmetric expansion (checked by sphere_flow)
        lmax="auto",
        tol=1e-6,
    )
    ndof_v = V.ndof // 3
    err2 = ng.GridFunction(irs)
    err2.vec.FV().NumPy()[:] = np.sum((vqp - exact[len(xq) + len(xv) :]) ** 2, axis=1)
    area = ng.Integrate(ng.CF(1.0) * ng.ds(intrules=rules), mesh)
    l2 = np.sqrt(ng.Integrate(err2 * ng.ds(intrules=rules), mesh) / area)
    return dict(
        scene=scene_name,
        method=f"NGSolve P{order}" + (f" (geometry {geometry_order})" if geometry_order != order else ""),
        order=order,
        maxh=maxh,
        vertices=mesh.nv,
        nodes=ndof_v,
        nodes_found=len(xq),
        vertices_found=len(xv),
        eps_rel=error_measures(vq, exact[: len(xq)])[1],
        eps_rel_vertices=error_measures(vv, exact[len(xq) : len(xq) + len(xv)])[1],
        eps_l2=float(l2 / np.max(np.linalg.norm(exact[: len(xq)], axis=1))),
        pressure=-float(sol.components[1].vec[0]),
        pressure_exact=float(p_exact),
        seconds=sum(parts.values()),
        seconds_parts=parts,
    )


def uniform_solve(nodes: int, order: int, geometry_order: int, bonus: int = 2) -> dict:
    """A uniform tension 1 on the unit sphere (``eta_s = eta_b = 1``): the exact flow is zero and ``P = 2``,
    so the largest discrete velocity is the spurious flow of the discrete Laplace law (the tension's
    force ``int div_G w dA`` against the pressure's ``int w.n dA`` on the curved cells)."""
    ng = _ngsolve()
    mesh, _ = sphere_mesh(nodes, order, {})
    mesh.Curve(geometry_order)
    pats = [{"type": "harmonics", "terms": [{"l": 0, "m": 0, "coeff": float(np.sqrt(4 * np.pi))}]}]
    sol, V, _, rules, qp, _ = _build_and_solve(ng, mesh, order, 1.0, 1.0, pats, bonus)
    mips = mesh.MapToAllElements(rules[ng.TRIG], ng.BND)
    normal = ng.specialcf.normal(3)(mips)
    radius = np.linalg.norm(qp, axis=1)
    return dict(
        method=f"NGSolve P{order}" + (f" (geometry {geometry_order})" if geometry_order != order else ""),
        nodes=V.ndof // 3,
        max_v=float(np.max(np.linalg.norm(sol.components[0](mips), axis=1))),
        pressure=-float(sol.components[1].vec[0]),
        radius_error=float(np.max(np.abs(radius - 1.0))),
        normal_error=float(np.max(np.linalg.norm(normal - qp / radius[:, None], axis=1))),
    )


def _uniform_table(args) -> None:
    print(
        "\nUniform tension 1 on the unit sphere (exact flow zero, P = 2): the largest velocity at the quadrature "
        "points (the spurious flow of the discrete Laplace law, in units of zeta R / eta) and the geometry's "
        "largest errors there (| |x| - 1 | and |n_h - x / |x||); in brackets the order in h from the row above.\n"
    )
    print("| method | velocity nodes | max abs v | P | radius error | normal error |")
    print("|---|---|---|---|---|---|")
    for order in args.orders:
        for b in args.geometry_bonus:
            prev = None
            for n in args.nodes:
                r = uniform_solve(n, order, order + b, args.quadrature_bonus)
                rate = ""
                if prev is not None:
                    q = 2 * np.log(prev["max_v"] / r["max_v"]) / np.log(r["nodes"] / prev["nodes"])
                    rate = f" ({q:.1f})"
                print(
                    f"| {r['method']} | {r['nodes']} | {r['max_v']:.2e}{rate} | {r['pressure']:.6f} "
                    f"| {r['radius_error']:.1e} | {r['normal_error']:.1e} |",
                    flush=True,
                )
                prev = r


#: our formulations in the table (``--ours``) and the fit each runs with
OURS = {"rayleigh_p1": "quadratic", "rayleigh_p2": "quartic"}


def ours(scene_name: str, nodes: int, repeat: int = 1, overrides=(), formulation: str = "rayleigh_p1") -> dict:
    """One of our formulations on the same problem (benchmarks/t0_accuracy.py: its first solve, geometry +
    assembly + solve, timed), the fastest of ``repeat``; every node of ours is a velocity node."""
    from _bench import t0_error

    runs = [
        t0_error(scene_name, nodes, OURS[formulation], formulation, bending=False, overrides=overrides)
        for _ in range(max(1, repeat))
    ]
    r = min(runs, key=lambda x: x["seconds"])
    order = 2 if formulation == "rayleigh_p2" else 1
    return dict(r, method=formulation, eps_rel_vertices=r["eps_rel"], eps_l2=float("nan"), order=order)


def recipe() -> str:
    """The recipe of the module's docstring, for the page."""
    doc = __doc__.split("The peer's recipe (what the lead needs to match it):")[1].split("Usage::")[0]
    return "The peer's recipe:\n\n" + doc.strip() + "\n"


def _row(r: dict, prev: dict | None) -> str:
    parts = r.get("seconds_parts")
    split = " / ".join(f"{v * 1e3:.0f}" for v in parts.values()) if parts else ""
    order = ""
    if prev is not None and prev["nodes"] < r["nodes"]:  # e ~ h^q and nodes ~ h^-2
        order = f" ({2 * np.log(prev['eps_rel'] / r['eps_rel']) / np.log(r['nodes'] / prev['nodes']):.1f})"
    return (
        f"| {r['scene']} | {r['method']} | {r['nodes']} | {r['eps_rel']:.3g}{order} | {r['eps_rel_vertices']:.3g} "
        f"| {'n/a' if np.isnan(r['eps_l2']) else format(r['eps_l2'], '.3g')} "
        f"| {r['seconds']:.3f} | {split} |"
    )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", nargs="+", default=["furrow_p8_a1", "furrow_p4_a3"])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562, 10242], help="velocity nodes asked for")
    p.add_argument("--orders", type=int, nargs="+", default=[1, 2, 3], choices=[1, 2, 3, 4])
    p.add_argument(
        "--geometry-bonus",
        type=int,
        nargs="+",
        default=[0],
        metavar="B",
        help="also curve the geometry to order k + B (0: isoparametric, the default; 1: the normal one order higher)",
    )
    p.add_argument(
        "--quadrature-bonus",
        type=int,
        default=2,
        help="integrate the forms this many orders above NGSolve's default (2: converged, 4 gives the same digits)",
    )
    p.add_argument("--repeat", type=int, default=3, help="time the fastest of this many solves")
    p.add_argument("--ours", action="store_true", help="also rayleigh_p1 and rayleigh_p2 at the same node counts")
    p.add_argument(
        "--uniform",
        action="store_true",
        help="also a uniform tension (exact flow zero): the spurious flow of the discrete Laplace law per order",
    )
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="scene overrides (e.g. another active_stress), for both methods",
    )
    p.add_argument("--json", default=None, help="append one JSON record per solve to this file")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    ng = _ngsolve()
    if ng is None:
        if args.smoke:
            print(f"peer_ngsolve: skipped: {MISSING}")
            return 0
        print(f"cortex-ti: error: {MISSING}", file=sys.stderr)
        return 2
    if args.smoke:
        args.scenes, args.nodes, args.orders, args.repeat = ["furrow_p8_a1"], [162], [1, 2], 1
        args.ours = args.uniform = True
        args.json = None
    if args.ours:
        from cortex_ti import runtime

        runtime.init(threads=1)
        for form in OURS:  # Taichi compiles its kernels once, outside the timed solves
            ours(args.scenes[0], 162, formulation=form)
    print(
        f"NGSolve {ng.__version__} (`sparsecholesky`), one thread; the forms integrated "
        f"{args.quadrature_bonus} orders above NGSolve's default; bending viscosity off. eps_rel (paper Eq. 58) "
        "at every velocity node, and at the vertices only; L2 / max: the L2 error over the surface (rms per "
        "area) over max |v_exact|. Wall time: the fastest of "
        f"{args.repeat} solves, curving + assembly + factorisation + solve for the peer (each in ms in the "
        "last column), geometry + assembly + solve for `rayleigh_p1` (its first solve, Taichi's kernels "
        "compiled before). `NGSolve Pk (geometry m)`: velocity of order k on a geometry curved to order m. "
        "In brackets: the order in h of eps_rel from the row above (nodes ~ h^-2).\n"
    )
    print(recipe())
    print(
        "| scene | method | velocity nodes | eps_rel (nodes) | eps_rel (vertices) | L2 / max | wall s "
        "| curve / assemble / factor / solve ms |"
    )
    print("|---|---|---|---|---|---|---|---|")
    cache: dict = {}
    prev = None
    for scene in args.scenes:
        rows = [(order, b, n) for order in args.orders for b in args.geometry_bonus for n in args.nodes]
        if args.ours:
            rows = [(0, form, n) for form in OURS for n in args.nodes] + rows
        for order, b, n in rows:
            if order == 0:
                r = ours(scene, n, args.repeat, args.overrides, formulation=b)
            else:
                key = cache.setdefault((order, b), {})
                r = peer_solve(scene, n, order, key, order + b, args.quadrature_bonus, args.repeat, args.overrides)
            same = prev is not None and (prev["scene"], prev["method"]) == (r["scene"], r["method"])
            print(_row(r, prev if same else None), flush=True)
            prev = r
            if args.json:
                with open(args.json, "a") as fh:
                    fh.write(json.dumps(r) + "\n")
    if args.uniform:
        _uniform_table(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
