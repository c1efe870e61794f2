"""The furrow in fluid (``furrow_in_fluid``, issue 36) in the axisymmetric model and in 3D: the
axisymmetric run's convergence in its meridian points ``n``, and the 3D run against it (its
axisymmetric twin) at several node counts, with the observed order.

Both models run the scene as it is (to its ``time.t_end``, one thread); the axisymmetric one with
``--set model=axisymmetric --set axisymmetric.n=<n>``. Reported: the furrow radius at t = 1, 2, 3, its
difference from the finest ``n`` (the axisymmetric model's self-convergence) and the 3D run's
difference from the finest axisymmetric run, with the order ``log2(e_N / e_4N) / 1`` per quadrupling of
the nodes (``h`` halves: a second-order method gives 2), and each run's CPU seconds.

``--dir``: where the trajectories are written (``ax<n>.h5``, ``d3_<N>.h5``); a file already there is
read, not rerun (so the 2562-node run can be made once, apart).

Usage::

    OMP_NUM_THREADS=1 python benchmarks/fluids_axisymmetric.py --n 8 12 16 24 --nodes 162 642 2562 --dir /tmp/fa
    python benchmarks/fluids_axisymmetric.py --smoke
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import _bench  # benchmarks/_bench.py: what the scripts share

TIMES = (1.0, 2.0, 3.0)


def run(path: Path, overrides: list[str]) -> float | None:
    """Run furrow_in_fluid with ``overrides`` into ``path`` unless it is there; its CPU seconds (None: reused)."""
    if path.exists():
        return None
    import cortex_ti as ct

    t0 = time.process_time()
    ct.run("furrow_in_fluid", output=path, overrides=overrides, threads=1)
    return time.process_time() - t0


def furrow(path: Path, times) -> list[float]:
    """The furrow radius at the frames nearest ``times`` (NaN past the last frame)."""
    import h5py

    with h5py.File(path, "r") as f:
        t, fr = f["time"][:], f["furrow_radius"][:]
    return [_bench.at(t, fr, s) for s in times]


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, nargs="+", default=[8, 12, 16, 24], help="axisymmetric meridian points")
    p.add_argument("--nodes", type=int, nargs="+", default=[162, 642], help="3D node counts")
    p.add_argument("--dir", type=Path, default=None, help="where the trajectories go (default: a temporary folder)")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    times, extra = TIMES, []
    if args.smoke:
        args.n, args.nodes, times, extra = [8], [162], (0.01,), ["time.t_end=0.01"]
    where = args.dir or _bench.folder()
    where.mkdir(parents=True, exist_ok=True)
    print(_bench.header(sys.argv if argv is None else ["fluids_axisymmetric.py", *argv]))
    ax = {}
    print("\n| axisymmetric n | " + " | ".join(f"R_f(t={s:g})" for s in times) + " | CPU s |")
    print("|---" * (len(times) + 2) + "|")
    for n in args.n:
        path = where / f"ax{n}.h5"
        cpu = run(path, ["model=axisymmetric", f"axisymmetric.n={n}", *extra])
        ax[n] = furrow(path, times)
        cell = "reused" if cpu is None else f"{cpu:.1f}"
        print(f"| {n} | " + " | ".join(f"{v:.9f}" for v in ax[n]) + f" | {cell} |")
    ref = ax[max(args.n)]
    print(f"\nself-convergence: |R_f(n) - R_f({max(args.n)})|")
    for n in sorted(args.n)[:-1]:
        print(f"  n = {n}: " + ", ".join(f"{abs(a - b):.2e}" for a, b in zip(ax[n], ref)))
    print(f"\n| 3D nodes | " + " | ".join(f"e(t={s:g})" for s in times) + " | order | CPU s |")
    print("|---" * (len(times) + 3) + "|")
    prev = None
    for nodes in args.nodes:
        path = where / f"d3_{nodes}.h5"
        cpu = run(path, [f"mesh.nodes={nodes}", *extra])
        err = [abs(a - b) for a, b in zip(furrow(path, times), ref)]
        order = "" if prev is None else f"{math.log2(prev[-1] / err[-1]):.2f}"
        cell = "reused" if cpu is None else f"{cpu:.1f}"
        print(f"| {nodes} | " + " | ".join(f"{e:.3e}" for e in err) + f" | {order} | {cell} |")
        prev = err


if __name__ == "__main__":
    main()
