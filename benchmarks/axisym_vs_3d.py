"""3D runs against the axisymmetric solution of the same scene (the same model, model: axisymmetric).

For each 3D trajectory of an axisymmetric scene, the axisymmetric twin is solved here (the
scene stored in the file, with its own bending viscosity, ~1 s) at the file's frame times, and
compared:

* the radii: the largest |3D - axisymmetric| of pole and furrow radius over the frames, and at
  the last frame;
* the velocity profiles at t = 0.1, 1.5, 3: at every 3D node, v_n and |v_t| against the twin's
  at the same material point (the label theta0 = the node's polar angle on the initial sphere:
  both codes move their points with the normal velocity), largest and rms deviation.

With several files of one scene at different resolutions (``--convergence``), the error ratio per
refinement. Usage::

    cortex-ti run furrow_p4_a1 -o p4_2562.h5
    cortex-ti run furrow_p4_a1 -o p4_10242.h5 --set mesh.nodes=10242
    python benchmarks/axisym_vs_3d.py p4_2562.h5 p4_10242.h5 --convergence

Expected cost: a few seconds per file (the 3D runs are the expensive part).
"""

import argparse
import sys

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares

from cortex_ti.axisymmetric.compare import PROFILE_TIMES, compare


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
    rows = [compare(path) for path in args.trajectories]
    print(
        "| scene | N | t_end | max dev. pole (t) | max dev. furrow (t) | dev. at t_end: pole, furrow | "
        "3D at t_end: pole, furrow | axisymmetric: pole, furrow |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        (pm, pt, pe), (fm, ft, fe) = r["pole_radius"], r["furrow_radius"]
        print(
            f"| {r['scene']} | {r['nodes']} | {r['t_end']:g} | {pm:.2e} ({pt:.2f}) | {fm:.2e} ({ft:.2f}) | "
            f"{pe:.2e}, {fe:.2e} | {r['final'][0]:.6f}, {r['final'][1]:.6f} | {r['final'][2]:.6f}, "
            f"{r['final'][3]:.6f} |"
        )
    print("\n| scene | N | t | max / rms dev. v_n | max / rms dev. abs v_t | scale v_n, abs v_t |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        for t in PROFILE_TIMES:
            if f"profile_{t:g}" in r:
                a, b, c, d, sn, st = r[f"profile_{t:g}"]
                print(
                    f"| {r['scene']} | {r['nodes']} | {t:g} | {a:.1e} / {b:.1e} | {c:.1e} / {d:.1e} | "
                    f"{sn:.3f}, {st:.3f} |"
                )
    if args.convergence and len(rows) > 1:
        rows.sort(key=lambda r: r["nodes"])
        print("\n| N | max radius error | ratio to the next coarser | error at t_end | ratio |")
        print("|---|---|---|---|---|")
        prev = None
        for r in rows:
            e = max(r["pole_radius"][0], r["furrow_radius"][0])
            ee = max(r["pole_radius"][2], r["furrow_radius"][2])
            ratio = "" if prev is None else f"{prev[0] / e:.2f}"
            ratio_e = "" if prev is None else f"{prev[1] / ee:.2f}"
            print(f"| {r['nodes']} | {e:.2e} | {ratio} | {ee:.2e} | {ratio_e} |")
            prev = (e, ee)
    return 0


if __name__ == "__main__":
    sys.exit(main())
