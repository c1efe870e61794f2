"""What a transported field costs a step: furrow_p4_a1 with the tension glued to normally moving
nodes (the paper's), carried by the material (normal motion, ALE) and on material nodes
(lagrangian), wall time per step and per stage, the smallest triangle angle and the volume drift
at the end, and the furrow radius.

    python benchmarks/transport_cost.py                 # 2562 nodes to t = 0.5
    python benchmarks/transport_cost.py --smoke         # 162 nodes, a few steps
    python benchmarks/transport_cost.py --write docs/validation/transport.md
    python benchmarks/transport_cost.py --formulation rayleigh_p2   # the myosin on the curved cells

The table carries the date, the commit and the machine (the timings are whole-step wall times on
a machine that may be shared: compare the columns of one table, not tables of two machines).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np
import xarray as xr

#: a myosin field on top of the ring (its tension a tenth of the ring's base, the rates of myosin_ring)
MYOSIN = (
    "fields.myosin={c0: 1.0, diffusion: 0.05, turnover: 0.2, tension: {law: linear, zeta0: 0.1, gamma: 1.0}, "
    "initial: [{type: harmonics, terms: [{l: 2, m: 0, coeff: 0.05}]}]}"
)
#: every variant steps as the table says (Euler at dt = 5e-3): the same steps, so the same solves
STEPPING = ["time.scheme=euler", "time.dt=5e-3"]
VARIANTS = {
    "glued (paper)": [],
    "material, normal motion": ["tension_transport=material"],
    "material, ale": ["tension_transport=material", "mesh.motion=ale"],
    "lagrangian": ["mesh.motion=lagrangian"],
    "myosin field, normal motion": ["tension_transport=material", MYOSIN],
    "myosin field, ale": ["tension_transport=material", "mesh.motion=ale", MYOSIN],
}


def measure(nodes: int, t_end: float, scene: str = "furrow_p4_a1", repeat: int = 1, numerics: tuple = ()) -> list[dict]:
    """Per variant, the fastest of ``repeat`` runs (wall and CPU time per step: on a shared machine
    the CPU time of this single-threaded process is the steadier of the two)."""
    import time

    from cortex_ti.scene import load_scene
    from cortex_ti.simulation.core import Simulation

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        # warm-up: the kernels are compiled (and the factorisation backend loaded) before any is timed
        warm = [f"mesh.nodes={nodes}", "time.t_end=0.01", *STEPPING, *numerics, *VARIANTS["myosin field, ale"]]
        Simulation(load_scene(scene, warm)).run(Path(tmp) / "warm.h5", progress=False)
        for label, sets in VARIANTS.items():
            best = None
            for _ in range(repeat):
                over = [f"mesh.nodes={nodes}", f"time.t_end={t_end}", *STEPPING, *numerics, *sets]
                sim = Simulation(load_scene(scene, over))
                cpu = time.process_time()
                out = sim.run(Path(tmp) / "run.h5", progress=False, force=True)  # one file, run after run
                cpu = time.process_time() - cpu
                if best is None or sim.stats.wall < best[0].stats.wall:
                    best = (sim, best[1] if best is not None and best[1] < cpu else cpu)
                else:
                    best = (best[0], min(best[1], cpu))
            sim, cpu = best
            st = sim.stats
            ds = xr.load_dataset(out, engine="h5netcdf")
            per = {k: 1e3 * v / max(st.steps, 1) for k, v in sim.seconds.items()}
            rows.append(
                {
                    "variant": label,
                    "steps": st.steps,
                    "ms_per_step": 1e3 * st.wall / max(st.steps, 1),
                    "cpu_ms_per_step": 1e3 * cpu / max(st.steps, 1),
                    **{f"ms_{k}": v for k, v in per.items()},
                    "furrow_radius": float(ds.furrow_radius[-1]),
                    "min_angle_deg": float(ds.min_angle_deg.min()),
                    "volume_drift": float(abs(ds.volume[-1] / ds.volume[0] - 1)),
                }
            )
    base, cpu_base = rows[0]["ms_per_step"], rows[0]["cpu_ms_per_step"]
    for r in rows:
        r["ratio"] = r["ms_per_step"] / base
        r["cpu_ratio"] = r["cpu_ms_per_step"] / cpu_base
    return rows


def table(rows: list[dict], nodes: int, t_end: float, repeat: int = 1, formulation: str = "rayleigh_p1") -> str:
    head = (
        f"{_bench.header()}\nfurrow_p4_a1 on {formulation}, {nodes} nodes, to t = {t_end:g} (Euler, dt 5e-3, "
        "semi-implicit tension); "
        f"the fastest of {repeat} run(s) per variant, wall and CPU time of this process per step\n\n"
    )
    cols = [
        "variant",
        "steps",
        "ms_per_step",
        "ratio",
        "cpu_ms_per_step",
        "cpu_ratio",
        "ms_geometry",
        "ms_assembly",
        "ms_solve",
        "ms_transport",
        "furrow_radius",
        "min_angle_deg",
        "volume_drift",
    ]
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        cells = []
        for c in cols:
            v = r.get(c, 0.0)
            cells.append(v if isinstance(v, str) else (f"{v:d}" if isinstance(v, int) else f"{v:.4g}"))
        lines.append("| " + " | ".join(cells) + " |")
    return head + "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--nodes", type=int, default=2562)
    ap.add_argument("--t-end", type=float, default=0.5)
    ap.add_argument("--smoke", action="store_true", help="162 nodes, t_end 0.02: checks that it runs")
    ap.add_argument("--write", type=Path, help="write the markdown table to this file")
    ap.add_argument("--repeat", type=int, default=1, help="runs per variant; the fastest is kept")
    ap.add_argument("--formulation", default="rayleigh_p1", help="numerics.formulation (rayleigh_p2: quartic fit)")
    args = ap.parse_args(argv)
    nodes, t_end = (162, 0.02) if args.smoke else (args.nodes, args.t_end)
    numerics = (f"numerics.formulation={args.formulation}",)
    if args.formulation == "rayleigh_p2":
        numerics += ("numerics.fit=quartic",)
    rows = measure(nodes, t_end, repeat=args.repeat, numerics=numerics)
    text = table(rows, nodes, t_end, args.repeat, args.formulation)
    print(text)
    if args.write:
        args.write.parent.mkdir(parents=True, exist_ok=True)
        args.write.write_text(
            "# What a transported field costs\n\nGenerated by `python benchmarks/transport_cost.py "
            f"--nodes {nodes} --t-end {t_end:g} --repeat {args.repeat} --write {args.write}`.\n\n" + text
        )
    assert np.isfinite([r["ms_per_step"] for r in rows]).all()


if __name__ == "__main__":
    main()
