"""Accuracy at t = 0 against the exact flow on the sphere, per formulation: the ring and fold scenes.

The first solve of each scene on its undeformed sphere (effects without ``shape_evolution``;
with ``--no-bending`` also without the bending viscosity) is compared with the exact flow for
the scene's own pattern and viscosities (:func:`cortex_ti.truth.sphere_exact.sphere_flow`,
degree by degree, independent of the 3D code): eps_rel (paper Eq. 58), the normal velocity at
the pole against the exact one, and the pressure. Without bending viscosity the exact flow of a
ring is ``v = -(R / 2 eta_b)(zeta - zeta_bar) n`` (docs/method/conventions.md).

Usage::

    python benchmarks/t0_accuracy.py --no-bending --nodes 642 2562 10242 --fits quadratic quartic
    python benchmarks/t0_accuracy.py --scenes fold_narrow fold_broad --nodes 642 2562

One table row per scene, fit and formulation, one column per node count (ratio to the previous
count in brackets).
"""

from __future__ import annotations

import argparse
import json
import sys

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
from _bench import t0_error


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenes", nargs="+", default=["furrow_p8_a1", "furrow_p4_a3"])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    p.add_argument("--fits", nargs="+", default=["quadratic"])
    p.add_argument("--formulations", nargs="+", default=["paper", "rayleigh_p1"])
    p.add_argument("--no-bending", action="store_true", help="switch the bending viscosity off (closed-form truth)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", default=None, help="append one JSON record per solve to this file")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.scenes, args.nodes = ["furrow_p8_a1"], [162]
    from cortex_ti import runtime

    runtime.init(threads=args.threads)
    bending = not args.no_bending
    print(f"bending viscosity {'on (the scenes own)' if bending else 'off'}; eps_rel (ratio), [pole v_n / exact]\n")
    print("| scene | fit | formulation | " + " | ".join(f"N = {n}" for n in args.nodes) + " |")
    print("|---|---|---|" + "---|" * len(args.nodes))
    for scene in args.scenes:
        for fit in args.fits:
            for form in args.formulations:
                cells, prev = [], None
                for n in args.nodes:
                    r = t0_error(scene, n, fit, form, bending, args.overrides)
                    ratio = "" if prev is None else f" ({prev / r['eps_rel']:.1f})"
                    prev = r["eps_rel"]
                    cells.append(f"{r['eps_rel']:.3g}{ratio} [{r['pole_vn']:+.3f} / {r['pole_exact']:+.3f}]")
                    if args.json:
                        with open(args.json, "a") as fh:
                            fh.write(json.dumps(r) + "\n")
                print(f"| {scene} | {fit} | {form} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
