"""Question: How much does the time step (``time.tol``, ``time.dt_max``) change a measured myosin growth
rate?

Answer: At 2562 nodes the l = 1 rate is 0.67995 at the default tol 1.6e-5 (-1.7e-2 from the spectrum
tool's 0.69691) and 0.69614 at tol 1e-7 (-7.7e-4, the fit window's remainder); l = 3 at tol 1e-7
approaches the tool's -0.28367 as dt_max goes 0.2 -> 0.025 (-2.3e-3 -> -1.1e-4). So rate runs take tol
1e-7. docs/validation/self_organisation.md (measured at c66c200).

What the time step does to a measured myosin growth rate: one seeded harmonic at several ``time.tol``.

Runs ``myosin_decay`` seeded with ``1e-3 Y_l0`` (the study ``self_organisation``'s rate runs) at the
given linear-law slope, to t = 6, once per tolerance (``default``: the scene's, ``bdf2``'s mesh-scaled
default), in this process, and prints per run the steps and the slope of ``log |c_l|`` over the second
half of the frames (``cortex_ti.analysis.harmonics``), with the closed form and the spectrum tool at
the same resolution (``cortex_ti.studies.self_organisation``).

Usage::

    python benchmarks/investigations/myosin_rate_tol.py  # l = 1, gamma = 1, 2562 nodes; default, 4e-6, 1e-7
    python benchmarks/investigations/myosin_rate_tol.py --degree 2 --tols default 1e-7
    python benchmarks/investigations/myosin_rate_tol.py --smoke  # 162 nodes, to t = 1 (seconds)
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--degree", type=int, default=1)
    ap.add_argument("--gamma", type=float, default=1.0)
    ap.add_argument("--nodes", type=int, default=2562)
    ap.add_argument("--tols", nargs="+", default=["default", "4e-6", "1e-7"])
    ap.add_argument(
        "--dt-max",
        nargs="+",
        default=["default"],
        help="time.dt_max values (each with every tol; default: the scene's)",
    )
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    t_end = 1.0 if args.smoke else 6.0
    if args.smoke:
        args.nodes, args.tols = 162, ["default", "1e-6"]

    import h5py

    from cortex_ti.analysis.harmonics import degree_amplitudes, growth_rate
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation.core import Simulation
    from cortex_ti.studies.self_organisation import closed_rate, spectrum_rate

    l, where = args.degree, _bench.folder()
    closed = closed_rate("myosin_decay", l, args.gamma, 0.2)
    tool = float("nan") if args.smoke else spectrum_rate("myosin_decay", args.nodes, l, args.gamma, 0.2)
    head = f"myosin_decay, l = {l}, gamma = {args.gamma}, {args.nodes} nodes"
    print(f"{head}: closed form {closed:.5f}, spectrum tool {tool:.5f}")
    print("| time.tol | time.dt_max | steps | rate | rate / spectrum tool - 1 | rate - spectrum tool |")
    print("|---|---|---|---|---|---|")
    for tol, dt_max in ((a, b) for b in args.dt_max for a in args.tols):
        sets = [
            f"mesh.nodes={args.nodes}",
            f"fields.myosin.initial.0.terms.0.l={l}",
            "fields.myosin.initial.0.terms.0.coeff=1e-3",
            f"fields.myosin.tension.gamma={args.gamma}",
            f"time.t_end={t_end}",
        ] + ([] if tol == "default" else [f"time.tol={tol}"])
        sets += [] if dt_max == "default" else [f"time.dt_max={dt_max}"]
        sim = Simulation(load_scene("myosin_decay", sets))
        path = sim.run(Path(where) / f"tol_{tol}_{dt_max}.h5", progress=False)
        with h5py.File(path, "r") as f:
            t, tri = f["time"][...], f["triangles"][...]
            amp = np.array([degree_amplitudes(f["points"][k], tri, f["myosin"][k], l + 1)[l] for k in range(len(t))])
        late = t >= 0.5 * t[-1]
        rate = growth_rate(t[late], amp[late])
        steps = sim.summary()["steps"]
        used = sim.settings.time
        print(
            f"| {used.tol:.3g} ({tol}) | {used.dt_max:g} | {steps} | {rate:.5f} | {rate / tool - 1:+.1e} "
            f"| {rate - tool:+.1e} |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
