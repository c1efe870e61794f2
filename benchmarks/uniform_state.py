"""Is the uniform state steady? A uniform myosin field on the unit icosphere (issue 20).

Two measurements, each printed as a Markdown table (``docs/derivations/uniform_state.md`` says
what they test):

* ``t0``: the flow of a uniform tension (zeta = 1, rayleigh_p1, the paper's bending viscosity) on
  the icosphere at t = 0, max |v| split into its normal and tangential parts, and the flows driven
  separately by the tangential part of the nodal active force and by the normal residual
  (active force plus pressure); linear, so the two add up to the flow. Per ``numerics.active_force``.
* ``axisym``: what the balanced force costs a paper scene: furrow_p4_a1 run to t = 3 with each
  force and compared with its axisymmetric twin (``cortex_ti.axisymmetric.compare``, as
  ``benchmarks/axisym_vs_3d.py`` does): radii and velocity profiles.
* ``run``: a uniform, subcritical myosin field (c = c0 = 1, linear law zeta0 = gamma = 1,
  D = 0.05, k = 1; the l = 1 mode decays at -0.1, ``analysis.myosin_stability``) run to t_end with
  each mesh motion: max_i |c_i - <c>| / <c> (<c> the area-weighted mean) over time, its value at
  the end, and max |v| at the end.

    python benchmarks/uniform_state.py t0 --nodes 162 642 2562
    python benchmarks/uniform_state.py run --run-nodes 162 642 --t-end 20
    python benchmarks/uniform_state.py run --run-nodes 642 --motions lagrangian --forces balanced \
        --set numerics.formulation=rayleigh_p2 --set numerics.fit=quartic     # <c> on the curved cells
    python benchmarks/uniform_state.py axisym --axisym-nodes 642
    python benchmarks/uniform_state.py --smoke
    python benchmarks/page.py uniform_state --title "The uniform state" -- uniform_state all \
        --nodes 162 642 2562 --run-nodes 162 642 --final-nodes 2562
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import _bench  # noqa: E402  (benchmarks/_bench.py)

FORCES = ("gradient", "balanced")
MOTIONS = ("normal", "lagrangian", "ale")
#: the uniform myosin scene (furrow_p4_a1's viscosities, the ring removed)
MYOSIN = [
    "active_stress=[]",
    "fields.myosin.c0=1.0",
    "fields.myosin.diffusion=0.05",
    "fields.myosin.turnover=1.0",
    "fields.myosin.tension.zeta0=1.0",
    "fields.myosin.tension.gamma=1.0",
]


def _scene(nodes: int, extra=()):
    from cortex_ti.scene import load_scene

    return load_scene("furrow_p4_a1", [f"mesh.nodes={nodes}", *MYOSIN, *extra])


def _split(v: np.ndarray, normal: np.ndarray) -> tuple[float, float, float]:
    vn = np.einsum("nc,nc->n", v, normal)
    vt = v - vn[:, None] * normal
    return float(np.linalg.norm(v, axis=1).max()), float(np.abs(vn).max()), float(np.linalg.norm(vt, axis=1).max())


def t0_rows(nodes_list, forces=FORCES) -> list[dict]:
    """The t = 0 flow of the uniform tension and the flows of the two parts of the force."""
    from cortex_ti.simulation import Simulation

    rows = []
    for force in forces:
        for nodes in nodes_list:
            sim = Simulation(_scene(nodes, [f"numerics.active_force={force}"]))
            x = sim.mesh.points
            geo = sim.shape_geometry(x)
            system = sim.system(geo)
            n = geo.normal
            u, p, _ = sim.solver.solve(system, x)
            v = system.velocity(u)
            f = system.rhs.reshape(-1, 3)
            fn = np.einsum("nc,nc->n", f, n)
            ft = f - fn[:, None] * n
            # the pressure force is along A_k n_k: the normal residual is fn + P A_k
            resid_n = fn + p * geo.area
            parts = {}
            for name, rhs in (("tangential", ft), ("normal", fn[:, None] * n)):
                vv = system.velocity(sim.solver.solve(dataclasses.replace(system, rhs=rhs.ravel()), x)[0])
                parts[name] = float(np.linalg.norm(vv, axis=1).max())
            vmax, vn, vt = _split(v, n)
            rows.append(
                {
                    "active_force": force,
                    "nodes": nodes,
                    "h": float(geo.edge_length.mean()),
                    "max|v|": vmax,
                    "max|v_n|": vn,
                    "max|v_t|": vt,
                    "max|f_t|/A": float((np.linalg.norm(ft, axis=1) / geo.area).max()),
                    "max|f_n+PA|/A": float(np.abs(resid_n / geo.area).max()),
                    "v(f_t)": parts["tangential"],
                    "v(f_n)": parts["normal"],
                    "P-2": float(p - 2.0),
                }
            )
    return rows


def run_rows(
    nodes_list,
    t_end: float,
    motions=MOTIONS,
    forces=FORCES,
    dt: float = 0.01,
    where=None,
    scheme: str = "euler",
    sets=(),
) -> list[dict]:
    """Uniform myosin to ``t_end`` with each mesh motion: its deviation from uniform over time
    (``scheme``: ``time.scheme``; ``dt`` its step, bdf2's first step; ``sets`` further scene
    overrides, e.g. ``numerics.formulation=rayleigh_p2``)."""
    import xarray as xr

    from cortex_ti.dynamics.state import State
    from cortex_ti.simulation.core import Simulation

    rows = []
    with tempfile.TemporaryDirectory(dir=where) as tmp:
        for force in forces:
            for nodes in nodes_list:
                for motion in motions:
                    over = [
                        *sets,
                        f"numerics.active_force={force}",
                        f"mesh.motion={motion}",
                        f"time.t_end={t_end}",
                        f"time.dt={dt}",
                        f"time.scheme={scheme}",
                        f"time.save_every={max(dt, t_end / 200):g}",
                    ]
                    sim = Simulation(_scene(nodes, over))
                    ds = xr.load_dataset(sim.run(Path(tmp) / "run.h5", progress=False, force=True), engine="h5netcdf")
                    faces, cells = sim.mesh.faces, sim.transport["myosin"].cells
                    dev = []
                    for k in range(ds.sizes["time"]):
                        c = ds.myosin.values[k]
                        # <c> on the run's cells: flat dual areas, or int c_h dA / A on the curved cells
                        st = State(ds.points.values[k], {"myosin": c, "one": np.ones_like(c)}, faces)
                        mean = st.total("myosin", cells) / st.total("one", cells)
                        dev.append(float(np.abs(c - mean).max() / mean))
                    v = ds.velocity.values[-1]
                    rows.append(
                        {
                            "active_force": force,
                            "formulation": sim.settings.numerics.formulation,
                            "nodes": nodes,
                            "motion": motion,
                            "scheme": scheme,
                            "tol": f"{sim.settings.time.tol:.2g}" if scheme == "bdf2" else "-",
                            "steps": sim.summary()["steps"],
                            "t_end": float(ds.time.values[-1]),
                            "max dev": max(dev),
                            "dev(t_end)": dev[-1],
                            "t of max": float(ds.time.values[int(np.argmax(dev))]),
                            "max|v|(t_end)": float(np.linalg.norm(v, axis=1).max()),
                        }
                    )
    return rows


def axisym_rows(nodes_list, t_end: float = 3.0, forces=FORCES, where=None) -> list[dict]:
    """furrow_p4_a1 with each active force against its axisymmetric twin."""
    from cortex_ti.axisymmetric.compare import compare
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation.core import Simulation

    rows = []
    with tempfile.TemporaryDirectory(dir=where) as tmp:
        for nodes in nodes_list:
            for force in forces:
                sets = [f"mesh.nodes={nodes}", f"numerics.active_force={force}", f"time.t_end={t_end}"]
                path = Simulation(load_scene("furrow_p4_a1", sets)).run(Path(tmp) / f"{force}.h5", progress=False)
                r = compare(str(path))
                row = {
                    "active_force": force,
                    "nodes": nodes,
                    "max dev pole": r["pole_radius"][0],
                    "max dev furrow": r["furrow_radius"][0],
                    "dev pole (t_end)": r["pole_radius"][2],
                    "dev furrow (t_end)": r["furrow_radius"][2],
                }
                for key in sorted(k for k in r if k.startswith("profile_")):
                    t = key.split("_", 1)[1]
                    row[f"v_n max/rms (t={t})"] = f"{r[key][0]:.2e} / {r[key][1]:.2e}"
                    row[f"abs v_t max/rms (t={t})"] = f"{r[key][2]:.2e} / {r[key][3]:.2e}"
                rows.append(row)
    return rows


def table(rows: list[dict]) -> str:
    cols = list(rows[0])
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = [v if isinstance(v, str) else (str(v) if isinstance(v, int) else f"{v:.3g}") for v in r.values()]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out) + "\n"


def orders(rows: list[dict], key: str, by=("active_force",)) -> str:
    """Observed orders in h of ``key`` between successive meshes."""
    lines = []
    groups = {}
    for r in rows:
        groups.setdefault(tuple(r.get(b) for b in by), []).append(r)
    for g, rs in groups.items():
        rs = sorted(rs, key=lambda r: r["nodes"])
        for a, b in zip(rs, rs[1:], strict=False):
            h = {r["nodes"]: 1.0 / np.sqrt(r["nodes"]) for r in (a, b)}
            p = np.log(a[key] / b[key]) / np.log(h[a["nodes"]] / h[b["nodes"]]) if b[key] > 0 else float("inf")
            lines.append(f"- {', '.join(map(str, g))}: {key} {a['nodes']} -> {b['nodes']} nodes: order {p:.2f}")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("what", nargs="?", choices=("t0", "run", "axisym", "all"), default="all")
    ap.add_argument("--axisym-nodes", type=int, nargs="+", default=[642])
    ap.add_argument("--axisym-t-end", type=float, default=3.0)
    ap.add_argument("--nodes", type=int, nargs="+", default=None)
    ap.add_argument("--run-nodes", type=int, nargs="+", default=[162, 642])
    ap.add_argument("--final-nodes", type=int, nargs="*", default=[], help="further meshes run with normal motion only")
    ap.add_argument("--t-end", type=float, default=20.0)
    ap.add_argument("--dt", type=float, default=0.01)
    ap.add_argument("--schemes", nargs="+", default=["euler"], help="time.scheme of the runs (bdf2: dt its first step)")
    ap.add_argument("--motions", nargs="+", default=list(MOTIONS), choices=MOTIONS)
    ap.add_argument("--forces", nargs="+", default=list(FORCES), choices=FORCES)
    ap.add_argument(
        "--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="scene overrides (run)"
    )
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    where = None
    if args.smoke:
        args.what, args.nodes, args.run_nodes, args.t_end, args.dt = "all", [162], [162], 0.05, 0.01
        args.axisym_nodes, args.axisym_t_end = [162], 0.12
        where = _bench.folder()
    if args.what in ("t0", "all"):
        rows = t0_rows(args.nodes or [162, 642, 2562], args.forces)
        print("## The flow of a uniform tension at t = 0\n")
        print(
            "zeta = 1 on the unit icosphere, rayleigh_p1 with the paper's bending viscosity, pressure on the "
            "Meyer areas (petrov). max|v| and its normal and tangential parts (the fitted normals); the "
            "nodal active force's tangential part per node area (max|f_t|/A) and the normal residual with "
            "the pressure (max|f_n+PA|/A); the flows each drives alone (v(f_t), v(f_n): the solve is linear "
            "and the pressure's force is along A_k n_k, so they add up to the flow); P - 2 the pressure's "
            "error. The bending viscosity adds no force at t = 0.\n"
        )
        print(table(rows))
        print(orders(rows, "max|v_t|"))
        print(orders(rows, "max|f_t|/A"))
    if args.what in ("run", "all"):
        rows = []
        for scheme in args.schemes:
            rows += run_rows(args.run_nodes, args.t_end, args.motions, args.forces, args.dt, where, scheme, args.sets)
            if args.final_nodes:
                rows += run_rows(
                    args.final_nodes, args.t_end, ["normal"], args.forces, args.dt, where, scheme, args.sets
                )
        rows.sort(key=lambda r: (r["active_force"] != "gradient", r["scheme"], r["motion"], r["nodes"]))
        print(f"## Uniform myosin to t = {args.t_end:g}\n")
        print(
            "c = c0 = 1 with D = 0.05, k = 1, linear law zeta0 = gamma = 1 (subcritical: the slowest mode, "
            "l = 1, decays at -0.1), furrow_p4_a1's viscosities; Euler at dt = "
            f"{args.dt:g}, bdf2 at its default tolerance from a first step {args.dt:g}; the semi-implicit "
            "tension. max dev: the largest max_i |c_i - <c>| / <c> over "
            "the frames (every t_end/200), dev(t_end) at the end, t of max when it peaked; max|v| at the end.\n"
        )
        print(table(rows))
        print(orders(rows, "max dev", by=("active_force", "scheme", "motion")))
    if args.what in ("axisym", "all"):
        rows = axisym_rows(args.axisym_nodes, args.axisym_t_end, args.forces, where)
        print(
            "## What the balanced force costs a paper scene: furrow_p4_a1 against its twin to "
            f"t = {args.axisym_t_end:g}\n"
        )
        print(
            "Largest |3D - axisymmetric| of the pole and furrow radii over the frames and at the end, and "
            "of v_n and |v_t| at the nodes (max / rms) at the profile times (benchmarks/axisym_vs_3d.py).\n"
        )
        print(table(rows))
    if where is not None:
        import shutil

        shutil.rmtree(where, ignore_errors=True)


if __name__ == "__main__":
    main()
