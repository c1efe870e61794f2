"""Where and when a run's smallest triangle angle falls: the command ``cortex-ti angles`` now
(:func:`cortex_ti.io.angles.angle_report`, shipped with the package); this script runs it and stays
for the validation pages' commands and its smoke test.

The smallest angle per frame, and at the worst frame the worst triangles (their polar angle on the
initial mesh about the pattern axis z, their angle at t = 0, the tension on them) and how many
triangles are below ``--below`` degrees. Usage::

    cortex-ti run shear_075 --set tension_transport=material --set mesh.motion=ale \\
        --set time.save_every=0.25 -o sh.h5
    cortex-ti angles sh.h5              # = python benchmarks/worst_triangles.py sh.h5

Cost: seconds.
"""

from __future__ import annotations

import argparse
import sys

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trajectory", nargs="?")
    p.add_argument("--below", type=float, default=30.0)
    p.add_argument("--worst", type=int, default=4)
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.trajectory = str(_bench.tiny_run("shear_075", t_end=0.02))
    if not args.trajectory:
        p.error("give a trajectory")
    from cortex_ti.cli import main as cli

    return cli(["angles", args.trajectory, "--below", str(args.below), "--worst", str(args.worst)])


if __name__ == "__main__":
    sys.exit(main())
