"""Where and when a run's smallest triangle angle falls: the smallest angle per frame, and at the
worst frame the worst triangles (their polar angle on the initial mesh about the pattern axis z,
their angle at t = 0, the tension on them) and how many triangles are below ``--below`` degrees.

Usage::

    cortex-ti run shear_075 --set tension_transport=material --set mesh.motion=ale \\
        --set time.save_every=0.25 -o sh.h5
    python benchmarks/worst_triangles.py sh.h5

Cost: seconds.
"""

from __future__ import annotations

import argparse
import sys

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np
import xarray as xr


def smallest_angles(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The smallest interior angle of every triangle (degrees)."""
    p = points[faces]
    out = []
    for k in range(3):
        a, b = p[:, (k + 1) % 3] - p[:, k], p[:, (k + 2) % 3] - p[:, k]
        cos = (a * b).sum(1) / np.linalg.norm(a, axis=1) / np.linalg.norm(b, axis=1)
        out.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
    return np.min(out, axis=0)


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
    ds = xr.load_dataset(args.trajectory, engine="h5netcdf")
    faces = ds.triangles.values
    t = ds.time.values
    per = [smallest_angles(ds.points.values[k], faces) for k in range(len(t))]
    print("| t | " + " | ".join(f"{x:.3g}" for x in t) + " |")
    print("|---|" + "---|" * len(t))
    print("| smallest angle (deg) | " + " | ".join(f"{a.min():.1f}" for a in per) + " |")
    k = int(np.argmin([a.min() for a in per]))
    c0 = ds.points.values[0][faces].mean(1) - ds.points.values[0].mean(0)
    polar = np.degrees(np.arccos(c0[:, 2] / np.linalg.norm(c0, axis=1)))
    bad = np.flatnonzero(per[k] < args.below)
    print(
        f"\nAt t = {t[k]:.3g}: {bad.size} of {faces.shape[0]} triangles below {args.below:g} deg"
        + (f", initial polar angles {polar[bad].min():.0f} to {polar[bad].max():.0f} deg" if bad.size else "")
        + "\n"
    )
    print("| triangle | angle (deg) | at t = 0 | initial polar angle (deg) | tension |")
    print("|---|---|---|---|---|")
    for w in np.argsort(per[k])[: args.worst]:
        zeta = ds.active_stress.values[k][faces[w]].mean()
        print(f"| {w} | {per[k][w]:.1f} | {per[0][w]:.1f} | {polar[w]:.0f} | {zeta:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
