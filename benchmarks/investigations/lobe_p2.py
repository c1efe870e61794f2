"""Question: Does bending rigidity hold the up-down lobe mode of the deep furrow down in 3D, on the curved
cells of ``rayleigh_p2``, so that ``cytokinesis`` ends in two equal daughters (issue 35)?

Answer: no. The lobe mode (one lobe swelling, the other emptying through the neck) grows at every
rigidity: at 642 nodes the spectrum tool's fastest mode on the amplitude-12 furrow with kappa = 0.01 is
odd under z -> -z and axisymmetric (shares 0.98-1.00 and 0.99), +4.13 / t_a at t = 0.5 and +4.55 at
t = 0.8 (neck 0.50; the axisymmetric linearisation: +4.79); the next modes are even, non-axisymmetric
and slow (+0.77, +0.93). At 2562 nodes with kappa = 0.1 (``cytokinesis_rigid``) the volume split at
the ring's plane grows from 7.4e-4 to 7.5e-2 between t = 1.4 and 2.4 (4.6 / t_a; axisymmetric: 4.7 -
5.0 at those necks) and the cut comes at a split of 0.145 (rayleigh_p1 without rigidity: 0.748; a
ring of ratio 31 with kappa = 0.1, which closes sooner: 4.0e-3). The
rigidity removes the fast late growth of the rigidity-free neck (37 / t_a at a neck of 0.1 -> 5.1), so
the amplification from a neck of 0.5 to 0.1 falls from e^17.9 to e^7.0; equal daughters to 1e-3 would
need a seed below ~1e-6 at a neck of 0.5, and one remeshing of 2562 nodes leaves ~1e-5. Physical: the
mode is the two-bubble (Laplace pressure) instability of two lobes joined by a neck under one tension,
which bending does not resist. Remeshing one half and reflecting it (``mesh.remesh.mirror``) seeds ~1e-6
instead of ~1e-4, and the strong ring's daughters then differ by 2.4e-4. Measured on 2026-12-07
(docs/validation/division.md, "Bending rigidity against the lobe mode").

Two parts:

* ``split FILE``: at every ``--every``-th frame, the neck (``neck_radius``: radius, height from the
  area centroid) and the curved cells' volumes on the two sides of the ring's plane (the ring's
  height: the mean height of the tension above its base, weighted by the nodes' dual areas) and of
  the neck's plane, ``|V0 - V1| / V`` (the neck's plane is ill-defined while the neck is wide: it
  jumps with the remeshing; the ring's follows the material);
* ``spectrum FILE --t T --set ...``: the normal spectrum (:func:`cortex_ti.dynamics.spectrum.normal_spectrum`,
  dense) of the frame nearest ``T`` of a run of ``constriction_p4`` with the overrides ``--set``:
  the six fastest modes with their share even under z -> -z (about the area centroid; 0: odd) and
  their axisymmetric share (1 - the variance within bands of height over the whole).

Usage::

    python benchmarks/investigations/lobe_p2.py split cr.h5 --every 4
    python benchmarks/investigations/lobe_p2.py spectrum k01.h5 --t 0.8 --p2-rigid --set mesh.nodes=642 \\
        --set active_stress.0.amplitude=12
    python benchmarks/investigations/lobe_p2.py --smoke

(``--p2-rigid``: the overrides of :data:`P2_RIGID`, rayleigh_p2 with rigidity 0.01 and the gradient
active force; ``--set numerics.active_force=balanced`` after it for the default force.)
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import _bench  # noqa: E402

AXIS = np.array([0.0, 0.0, 1.0])
P2_RIGID = [
    "numerics.formulation=rayleigh_p2",
    "numerics.fit=quartic",
    "numerics.active_force=gradient",
    "effects=[active_stress, shear_viscosity, bulk_viscosity, normal_balance, incompressibility, "
    "shape_evolution, bending_rigidity]",
    "rigidity.bending=0.01",
]


def split(path: Path, every: int) -> None:
    from cortex_ti.analysis.sections import neck_radius
    from cortex_ti.io.trajectory import Trajectory, frame_mesh
    from cortex_ti.surface.curved_division import curved_side_volumes
    from cortex_ti.surface.measures import area_centroid
    from cortex_ti.surface.transport import dual_areas

    ds = Trajectory(path).ds
    t = ds["time"].values
    n_bodies = ds["n_bodies"].values if "n_bodies" in ds else np.ones(len(t))
    print("| t | nodes | neck | neck height | ring height | split at the ring's plane | at the neck's plane |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    for k in sorted({*range(0, len(t), every), len(t) - 1}):
        if n_bodies[k] > 1:
            continue
        p, f = frame_mesh(ds, k)
        c = area_centroid(p, f)
        zeta = np.asarray(ds["active_stress"].values[k][: len(p)], dtype=float)
        w = np.clip(zeta - zeta.min(), 0.0, None) * dual_areas(p, f)
        ring = float(w @ (p @ AXIS) / w.sum()) if w.sum() > 0 else float(c @ AXIS)
        lo, hi = curved_side_volumes(p, f, ring * AXIS, AXIS)
        r, h = neck_radius(p, f, axis=AXIS)
        neck = "-"
        if np.isfinite(r):
            a, b = curved_side_volumes(p, f, c + h * AXIS, AXIS)
            neck = f"{abs(a - b) / (a + b):.2e}"
        print(
            f"| {t[k]:.3f} | {len(p)} | {r:.4f} | {h:+.4f} | {ring - c @ AXIS:+.4f} | "
            f"{abs(lo - hi) / (lo + hi):.2e} | {neck} |"
        )
    print()


def spectrum(path: Path, t_at: float, sets: list[str]) -> None:
    from scipy.spatial import cKDTree

    from cortex_ti.dynamics.spectrum import normal_spectrum
    from cortex_ti.io.trajectory import Trajectory, frame_mesh
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation.core import Simulation
    from cortex_ti.surface.measures import area_centroid

    ds = Trajectory(path).ds
    k = int(np.argmin(np.abs(ds["time"].values - t_at)))
    p, f = frame_mesh(ds, k)
    sim = Simulation(load_scene("constriction_p4", sets))
    sim.use_mesh(p, f)
    sim.zeta = np.asarray(ds["active_stress"].values[k][: len(p)], dtype=float)
    c0 = time.process_time()
    spec = normal_spectrum(sim, p, 0.0, modes=True)
    print(
        f"t = {ds['time'].values[k]:.3f}, {len(p)} nodes, {time.process_time() - c0:.1f} CPU s, leak {spec.leak:.1e}\n"
    )
    c = area_centroid(p, f)
    z = (p - c) @ AXIS
    mirror = p - 2.0 * np.outer(z, AXIS)
    _, partner = cKDTree(p).query(mirror)  # the node nearest each node's mirror image
    bands = np.digitize(z, np.linspace(z.min(), z.max(), 16))
    print("| rate (1/t_a) | even share | axisymmetric share |")
    print("|---:|---:|---:|")
    for i in range(6):
        s = spec.modes[:, i].real
        s = s / np.linalg.norm(s)
        even = np.linalg.norm(s + s[partner]) / (np.linalg.norm(s - s[partner]) + np.linalg.norm(s + s[partner]))
        within = sum(((s[bands == b] - s[bands == b].mean()) ** 2).sum() for b in np.unique(bands))
        w = spec.eigenvalues[i]
        print(f"| {w.real:+.3f}{w.imag:+.3f}i | {even:.2f} | {1.0 - within:.2f} |")
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("part", nargs="?", choices=["split", "spectrum"])
    ap.add_argument("file", nargs="?", type=Path)
    ap.add_argument("--every", type=int, default=2)
    ap.add_argument("--t", type=float, default=0.0)
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    ap.add_argument("--p2-rigid", action="store_true", help="the overrides P2_RIGID before the --set ones")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    a = ap.parse_args()
    print(_bench.header())
    if a.smoke:
        sets = [*P2_RIGID, "mesh.remesh.min_angle=null", "active_stress.0.amplitude=12", "time.stop_neck=null"]
        path = _bench.tiny_run("constriction_p4", 0.02, 162, overrides=[*sets, "time.save_every=0.01"])
        split(path, 1)
        spectrum(path, 0.02, ["mesh.nodes=162", *sets])
        return
    if a.part == "split":
        split(a.file, a.every)
    elif a.part == "spectrum":
        spectrum(a.file, a.t, [*(P2_RIGID if a.p2_rigid else []), *a.sets])
    else:
        ap.error("give a part (split or spectrum) and a file, or --smoke")


if __name__ == "__main__":
    main()
