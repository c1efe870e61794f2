"""What the one growing mode on the deformed shapes is: its share of rigid translation.

On the frames of a stored run, the rightmost eigenvalues of the linearised normal dynamics
(:func:`cortex_ti.dynamics.spectrum.normal_spectrum`, dense: up to 3000 nodes) and, for each
eigenvalue above 0.1 /t_a, the share of its normal displacement ``s`` (area-weighted squared
norm) that is the normal part ``U . n`` of a rigid translation ``U``, and the direction of ``U``.
A share near 1 means the mode moves the body as a whole while the nodes, which move normally
and carry their tension, slide along it: the free rigid translation (fixed by the constraint
of zero mean velocity) is what grows, not the shape. ``benchmarks/axisym_translation_mode.py``
measures the same mode with the axisymmetric solver, in both of its translation gauges.

Usage::

    python benchmarks/translation_mode.py RUN.h5 1 3        # a furrow_p4_a1 run: frames t = 1, 3
    python benchmarks/translation_mode.py RUN.h5 0.5 1.35   # a shear_075 run

Cost (one core): about 30 s per frame at 2562 nodes.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from cortex_ti.dynamics.spectrum import normal_spectrum
from cortex_ti.io.trajectory import Trajectory
from cortex_ti.simulation.core import Simulation


def translation_share(s: np.ndarray, normal: np.ndarray, area: np.ndarray) -> tuple[float, np.ndarray]:
    """Share of ``s`` (area-weighted) in the span of ``U . n`` and the unit direction of ``U``."""
    w = np.sqrt(area)
    u, *_ = np.linalg.lstsq(w[:, None] * normal, w * s, rcond=None)
    rest = w * s - (w[:, None] * normal) @ u
    return 1.0 - float(rest @ rest) / float(np.sum(area * s * s)), u / np.linalg.norm(u)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trajectory")
    p.add_argument("times", type=float, nargs="+")
    args = p.parse_args(argv)
    with Trajectory(args.trajectory) as tr:
        scene, tt = tr.scene, tr.ds["time"].values
        frames = [(float(tt[k]), tr.ds["points"].isel(time=k).values)
                  for k in (int(np.argmin(np.abs(tt - t))) for t in args.times)]
    sim = Simulation(scene)
    print(f"{scene.settings.name}, {len(frames[0][1])} nodes, {scene.settings.numerics.formulation}")
    print("| t | rightmost Re lambda | growing mode | translation share | direction of U |")
    print("|---|---|---|---|---|")
    for t, x in frames:
        sp = normal_spectrum(sim, x, modes=True)
        geo = sim.shape_geometry(x)
        for j in np.flatnonzero(sp.eigenvalues.real > 0.1):
            share, u = translation_share(np.real(sp.modes[:, j]), geo.normal, np.asarray(geo.area))
            print(f"| {t:g} | {', '.join(f'{v:+.4f}' for v in sp.eigenvalues.real[:3])} | "
                  f"{sp.eigenvalues[j].real:+.4f} | {share:.3f} | {np.array2string(u, precision=3)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
