"""Deprecated: the growing and the stiffest modes of a stored frame are the command
``cortex-ti modes`` now (:mod:`cortex_ti.simulation.modes`, shipped with the package); this wrapper
keeps the old command working for one release and says so on stderr. Usage::

    cortex-ti modes run.h5.partial --time 2.2
    cortex-ti modes run.h5 --time 2.5 2.6 --dt 1.3e-3 4.8e-3 --stiffest 2
    python benchmarks/remesh_mode.py --smoke        # a 162-node frame at t = 0.02

``--modes N`` of this script is ``--growing N`` of the command.
"""

from __future__ import annotations

import argparse
import sys

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trajectory", nargs="?")
    ap.add_argument("--time", type=float, nargs="+", default=None)
    ap.add_argument("--dt", type=float, nargs="+", default=None)
    ap.add_argument("--modes", type=int, default=4, help="growing modes shown (the command's --growing)")
    ap.add_argument("--stiffest", type=int, default=0)
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    print("remesh_mode.py is deprecated: use `cortex-ti modes` (--growing for --modes)", file=sys.stderr)
    if args.smoke:
        args.trajectory, args.stiffest = str(_bench.tiny_run("furrow_p4_a1", t_end=0.02)), 1
    if not args.trajectory:
        ap.error("give a trajectory")
    from cortex_ti.cli import main as cli

    command = ["modes", args.trajectory, "--growing", str(args.modes), "--stiffest", str(args.stiffest)]
    command += ["--time", *map(str, args.time)] if args.time else []
    command += ["--dt", *map(str, args.dt)] if args.dt else []
    return cli(command)


if __name__ == "__main__":
    raise SystemExit(main())
