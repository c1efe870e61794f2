"""Question: What is the one growing mode (+0.32 / +0.36 on the furrow_p4_a1 shapes at t = 1 / 3) of the
linearised normal dynamics?

Answer: The model's free rigid translation: 98 % of its normal displacement on the furrow shapes (87 %
and 78 % on the shear_075 shapes) is the normal part U.n of a rigid translation along the pattern axis;
with the centroid gauge it is gone (+0.0148 at t = 1, 642 nodes). docs/validation/formulations.md.

What the one growing mode on the deformed shapes is: its share of rigid translation.

On the frames of a stored run, the rightmost eigenvalues of the linearised normal dynamics
(:func:`cortex_ti.dynamics.spectrum.normal_spectrum`, dense: up to 3000 nodes) and, for each
eigenvalue above 0.1 /t_a, the share of its normal displacement ``s`` (area-weighted squared
norm) that is the normal part ``U . n`` of a rigid translation ``U``, and the direction of ``U``.
A share near 1 means the mode moves the body as a whole while the nodes, which move normally
and carry their tension, slide along it: the free rigid translation (fixed by the constraint
of zero mean velocity) is what grows, not the shape. ``benchmarks/investigations/axisym_translation_mode.py``
measures the same mode with the axisymmetric solver, in both of its translation gauges.

Usage::

    python benchmarks/investigations/translation_mode.py RUN.h5 1 3        # a furrow_p4_a1 run: frames t = 1, 3
    python benchmarks/investigations/translation_mode.py RUN.h5 0.5 1.35   # a shear_075 run
    python benchmarks/investigations/translation_mode.py RUN.h5 1 3 --set translation=centroid   # the centroid held

Cost (one core): about 30 s per frame at 2562 nodes.
"""

from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np

from cortex_ti.dynamics.spectrum import normal_spectrum, translation_share
from cortex_ti.io.trajectory import Trajectory
from cortex_ti.scene import scene_from_dict
from cortex_ti.simulation.core import Simulation


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trajectory", nargs="?")
    p.add_argument("times", type=float, nargs="*")
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="change the run's scene, e.g. translation=centroid",
    )
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.trajectory, args.times = str(_bench.tiny_run("furrow_p4_a1", t_end=0.05)), [0.05]
    if args.trajectory is None or not args.times:
        p.error("give a trajectory and the times of its frames")
    with Trajectory(args.trajectory) as tr:
        scene, tt = scene_from_dict(copy.deepcopy(tr.scene.data), args.overrides), tr.ds["time"].values
        frames = [
            (float(tt[k]), tr.ds["points"].isel(time=k).values, tr.ds["active_stress"].isel(time=k).values)
            for k in (int(np.argmin(np.abs(tt - t))) for t in args.times)
        ]
    sim = Simulation(scene)
    s = scene.settings
    print(f"{s.name}, {len(frames[0][1])} nodes, {s.numerics.formulation}, translation {s.translation}")
    print("| t | rightmost Re lambda | growing mode | translation share | direction of U |")
    print("|---|---|---|---|---|")
    for t, x, zeta in frames:
        sim.zeta = np.asarray(zeta, dtype=float)
        sp = normal_spectrum(sim, x, modes=True)
        geo = sim.shape_geometry(x)
        growing = np.flatnonzero(sp.eigenvalues.real > 0.1)
        if not len(growing):
            print(f"| {t:g} | {', '.join(f'{v:+.4f}' for v in sp.eigenvalues.real[:3])} | none | | |")
        for j in growing:
            share, u = translation_share(np.real(sp.modes[:, j]), geo.normal, np.asarray(geo.area))
            print(
                f"| {t:g} | {', '.join(f'{v:+.4f}' for v in sp.eigenvalues.real[:3])} | "
                f"{sp.eigenvalues[j].real:+.4f} | {share:.3f} | {np.array2string(u, precision=3)} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
