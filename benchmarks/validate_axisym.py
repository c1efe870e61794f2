"""Compare a furrow_p8_a1 trajectory with the axisymmetric reference (paper Fig. 5).

Prints the largest deviation of pole and furrow radius over all frames on the
reference's 0.01 t_a grid, and of the normal and tangential speed profiles v_n(z),
|v_t|(z) at t = 0, 0.1, 1.5, 3, plus the volume drift.

Usage::

    cortex-ti run furrow_p8_a1 -o results/furrow_p8_a1.h5
    python benchmarks/validate_axisym.py results/furrow_p8_a1.h5

Expected cost: a few seconds (the run itself is the expensive part).
"""

import argparse
import sys

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

from cortex_ti.analysis.reference import (
    PROFILE_TIMES,
    profile_deviation,
    radii_deviation,
)
from cortex_ti.io import Trajectory


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trajectory", nargs="?")
    p.add_argument("--reference", default=None, help="folder of the axisymmetric reference CSV files")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:  # the reference's problem, 162 nodes, past its first profile time
        args.trajectory = str(_bench.tiny_run("furrow_p8_a1", t_end=0.12))
    if args.trajectory is None:
        p.error("give a furrow_p8_a1 trajectory")
    with Trajectory(args.trajectory, lazy=True) as tr:
        ds = tr.ds
        t = ds["time"].values
        dev = radii_deviation(t, ds["pole_radius"].values, ds["furrow_radius"].values, args.reference)
        vol = ds["volume"].values
        print(f"{args.trajectory}: {len(t)} frames to t = {t[-1]:.3f}")
        print(
            f"radii: largest deviation from the reference over {dev['frames']} frames: "
            f"pole {dev['pole']:.2e} R0 (t = {dev['t_pole']:.2f}), furrow {dev['furrow']:.2e} R0 (t = "
            f"{dev['t_furrow']:.2f})"
        )
        print(f"volume drift: {np.abs(vol / vol[0] - 1).max():.2e} (relative, largest over frames)")
        print("| t | max dev v_n | rms dev v_n | max dev abs v_t | rms dev abs v_t | (scale v_n, abs v_t) |")
        print("|---|---|---|---|---|---|")
        for tp in PROFILE_TIMES:
            k = int(np.argmin(np.abs(t - tp)))
            if abs(t[k] - tp) > 1e-6:
                continue
            pts = ds["points"].isel(time=k).values
            vel = ds["velocity"].isel(time=k).values
            normals = tr.normals(k)  # the solver's
            d = profile_deviation(pts, vel, normals, tp, args.reference)
            print(
                f"| {tp:.1f} | {d['vn_max']:.2e} | {d['vn_rms']:.2e} | {d['vt_max']:.2e} | {d['vt_rms']:.2e} | "
                f"{d['vn_scale']:.3f}, {d['vt_scale']:.3f} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
