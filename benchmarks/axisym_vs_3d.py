"""3D runs against the axisymmetric solution of the same scene: the command ``cortex-ti twin`` now
(:func:`cortex_ti.axisymmetric.compare.twin_report`, shipped with the package); this script runs it
and stays for the validation pages' commands and its smoke test.

For each 3D trajectory of an axisymmetric scene, the axisymmetric twin is solved (the scene stored
in the file, with its own bending viscosity, ~1 s) at the file's frame times, and compared:

* the radii: the largest |3D - axisymmetric| of pole and furrow radius over the frames, and at
  the last frame;
* the velocity profiles at t = 0.1, 1.5, 3: at every 3D node, v_n and |v_t| against the twin's
  at the same material point (the label theta0 = the node's polar angle on the initial sphere:
  both codes move their points with the normal velocity), largest and rms deviation.

With several files of one scene at different resolutions (``--convergence``), the error ratio per
refinement. Usage::

    cortex-ti run furrow_p4_a1 -o p4_2562.h5
    cortex-ti run furrow_p4_a1 -o p4_10242.h5 --set mesh.nodes=10242
    cortex-ti twin p4_2562.h5 p4_10242.h5 --convergence        # = python benchmarks/axisym_vs_3d.py ...

Expected cost: a few seconds per file (the 3D runs are the expensive part).
"""

import argparse
import sys

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trajectories", nargs="*")
    p.add_argument("--convergence", action="store_true", help="error ratios between the files (one scene, by N)")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:  # a tiny furrow past the first profile time
        args.trajectories = [str(_bench.tiny_run("furrow_p4_a1", t_end=0.12))]
    if not args.trajectories:
        p.error("give at least one trajectory")
    from cortex_ti.cli import main as cli

    return cli(["twin", *args.trajectories, *(["--convergence"] if args.convergence else [])])


if __name__ == "__main__":
    sys.exit(main())
