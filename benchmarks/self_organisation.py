"""The myosin scenes of issue 20 run to their end: wall time, and what each one shows against its truth.

* ``myosin_decay`` (subcritical): the rate of the seeded l = 2 over the second half of the run
  against the closed form and the spectrum tool at the same resolution;
* ``myosin_ring`` (supercritical l = 2, mirror-symmetric seed): the furrow radius against the
  axisymmetric twin (``--set model=axisymmetric``, also timed);
* ``myosin_noise`` (random noise, 3D only): the amplitude of every degree l <= 6 of the myosin
  (:func:`cortex_ti.analysis.harmonics.degree_amplitudes`) over time, the rate of each in two
  windows against the closed form and the spectrum tool, which degree grows first, and the end state
  (myosin extremes, the cap's half-angle at half maximum, the centroid's displacement);
* ``myosin_cued_ring`` (the paper's ring as a cue plus transported myosin): the radii beside
  ``furrow_p4_a1`` (also run).

Each scene runs as a user runs it, ``python -m cortex_ti run SCENE -o FILE`` (start-up included),
one after the other, with one thread.

Usage::

    python benchmarks/self_organisation.py [--nodes 2562] [--scenes myosin_decay ...] [--keep DIR]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("myosin_decay", "myosin_ring", "myosin_noise", "myosin_cued_ring")


def run(scene: str, out: Path, sets=(), in_process: bool = False) -> dict:
    """``cortex-ti run`` in a process of its own: its wall time and its summary (``in_process``, the
    smoke mode: :func:`cortex_ti.run` here, one start-up for all)."""
    if in_process:
        import cortex_ti

        t0 = time.perf_counter()
        ds = cortex_ti.run(scene, out, overrides=list(sets), force=True)  # as --force below
        return {"wall": time.perf_counter() - t0, "t_reached": float(ds["time"].values[-1]), "steps": ds.sizes["time"]}
    env = {**os.environ, "CORTEX_TI_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    cmd = [sys.executable, "-m", "cortex_ti", "run", scene, "-o", str(out), "--force", "--summary", str(out) + ".json"]
    for s in sets:
        cmd += ["--set", s]
    t0 = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if res.returncode != 0:
        raise SystemExit(f"{scene} failed: {res.stderr[-2000:]}")
    return {"wall": wall, **json.loads(Path(str(out) + ".json").read_text())}


def amplitudes(path: Path, lmax: int = 6):
    """Frame times and the amplitude of every degree of the myosin per frame."""
    from cortex_ti.analysis.harmonics import degree_amplitudes
    from cortex_ti.io.trajectory import Trajectory

    with Trajectory(path, lazy=True) as tr:
        return tr.times, np.array(
            [degree_amplitudes(*tr.mesh(k), tr.nodal("myosin", k), lmax) for k in range(len(tr.times))]
        )


def fit(t, a, lo, hi) -> float:
    from cortex_ti.analysis.harmonics import growth_rate

    sel = (t >= lo - 1e-9) & (t <= hi + 1e-9)
    return growth_rate(t[sel], a[sel]) if sel.sum() >= 3 else float("nan")


def radii(path: Path, times):
    from cortex_ti.io.trajectory import Trajectory

    with Trajectory(path, lazy=True) as tr:
        ks = [tr.frame_at(t) for t in times]
        return [(float(tr.times[k]), float(tr.ds["furrow_radius"][k]), float(tr.ds["pole_radius"][k])) for k in ks]


def noise_end_state(path: Path) -> dict:
    """The myosin's extremes, the cap's direction and half-angle at half maximum (from the area
    centroid), and the centroid's displacement along the cap's direction."""
    from cortex_ti.analysis.diagnostics import area_centroid
    from cortex_ti.analysis.harmonics import harmonic_coefficients
    from cortex_ti.io.trajectory import Trajectory

    with Trajectory(path, lazy=True) as tr:
        k = len(tr.times) - 1
        p, f = tr.mesh(k)
        c = tr.nodal("myosin", k)
        centre = area_centroid(p, f)
        a1 = harmonic_coefficients(p, f, c, 1)[1]  # m = -1, 0, 1: y, z, x
        d = np.array([a1[2], a1[0], a1[1]])
        d /= np.linalg.norm(d)
        u = p - centre
        u /= np.linalg.norm(u, axis=1)[:, None]
        hi = c > 0.5 * (c.max() + c.mean())
        angle = float(np.degrees(np.arccos(np.clip(u[hi] @ d, -1, 1))).max())
        shift = centre - area_centroid(*tr.mesh(0))
        return {
            "t": float(tr.times[k]),
            "c_max": float(c.max()),
            "c_min": float(c.min()),
            "cap_angle": angle,
            "shift": float(np.linalg.norm(shift)),
            "shift_along_cap": float(shift @ d),
            "furrow": float(tr.ds["furrow_radius"][k]),
        }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nodes", type=int, default=2562)
    ap.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES)
    ap.add_argument("--keep", type=Path, default=None, help="keep the trajectories in this folder")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    sets = [f"mesh.nodes={args.nodes}"]
    if args.smoke:
        # three frames a run (two scenes save every 0.01): enough for every table and fit below
        args.nodes, sets = 162, ["mesh.nodes=162", "time.t_end=0.1", "time.save_every=0.05"]
    where = _bench.folder() if args.smoke or args.keep is None else args.keep
    where.mkdir(parents=True, exist_ok=True)
    from cortex_ti.studies import self_organisation as so

    files, rows = {}, []
    for scene in args.scenes:
        files[scene] = where / f"{scene}.h5"
        s = run(scene, files[scene], sets, args.smoke)
        rows.append((scene, s))
    extra = []
    if "myosin_ring" in args.scenes:
        files["twin"] = where / "myosin_ring_axisymmetric.h5"
        extra.append(
            (
                "myosin_ring, model: axisymmetric",
                run("myosin_ring", files["twin"], [*sets, "model=axisymmetric"], args.smoke),
            )
        )
    if "myosin_cued_ring" in args.scenes:
        files["furrow"] = where / "furrow_p4_a1.h5"
        extra.append(("furrow_p4_a1 (beside the cued ring)", run("furrow_p4_a1", files["furrow"], sets, args.smoke)))

    print(f"## Wall time at {args.nodes} nodes (one thread, start-up included)\n")
    print("| scene | t reached | steps | rejected | wall (s) |")
    print("|---|---|---|---|---|")
    for scene, s in rows + extra:
        reached = s.get("t_reached", float("nan"))
        print(f"| {scene} | {reached:g} | {s.get('steps')} | {s.get('rejected', '')} | {s['wall']:.1f} |")

    # the uniform state's rates at the scenes' parameters (D = 0.05, k = 0.2, A = zeta0 gamma)
    if "myosin_decay" in args.scenes:
        t, a = amplitudes(files["myosin_decay"])
        lo = 0.5 * t[-1]
        rate = fit(t, a[:, 2], lo, t[-1])
        exact, spec = (
            so.closed_rate("myosin_decay", 2, 0.25, 0.2),
            so.spectrum_rate("myosin_decay", args.nodes, 2, 0.25, 0.2),
        )
        print("\n## myosin_decay: the seeded l = 2 decays\n")
        print(f"Amplitude of l = 2: {a[0, 2]:.3e} at t = 0, {a[-1, 2]:.3e} at t = {t[-1]:g}.\n")
        print(
            "| run (slope of log, t >= t_end / 2) | spectrum tool | closed form | run - spectrum | run / closed - 1 |"
        )
        print("|---|---|---|---|---|")
        print(f"| {rate:+.5f} | {spec:+.5f} | {exact:+.5f} | {rate - spec:+.1e} | {rate / exact - 1:+.2e} |")

    if "myosin_ring" in args.scenes:
        print("\n## myosin_ring: the furrow radius against the axisymmetric twin\n")
        r3, rt = radii(files["myosin_ring"], np.arange(0.0, 37.0, 4.0)), radii(files["twin"], np.arange(0.0, 37.0, 4.0))
        print("| t | twin | 3D | 3D - twin |")
        print("|---|---|---|---|")
        for (t3, f3, _), (tt, ft, _) in zip(r3, rt, strict=True):
            if abs(t3 - tt) < 1e-9:
                print(f"| {t3:g} | {ft:.5f} | {f3:.5f} | {f3 - ft:+.2e} |")

    if "myosin_noise" in args.scenes:
        t, a = amplitudes(files["myosin_noise"])
        print("\n## myosin_noise: which degree grows first\n")
        print("Amplitude sqrt(sum_m c_lm^2) of each degree of the myosin (directions from the area centroid):\n")
        print("| t | " + " | ".join(f"l = {l}" for l in range(1, a.shape[1])) + " |")
        print("|---|" + "---|" * (a.shape[1] - 1))
        for tq in np.arange(0.0, t[-1] + 1e-9, max(1.0, round(t[-1] / 12))):
            k = int(np.argmin(np.abs(t - tq)))
            print(f"| {t[k]:g} | " + " | ".join(f"{v:.2e}" for v in a[k, 1:]) + " |")
        windows = [(1.0, 4.0), (4.0, 7.0)] if t[-1] >= 7.0 else [(0.0, t[-1])]
        print("\nRates (slope of log amplitude) in two windows, against the closed form and the spectrum tool:\n")
        print(
            "| l | " + " | ".join(f"run, t = {lo:g}-{hi:g}" for lo, hi in windows) + " | spectrum tool | closed form |"
        )
        print("|---|" + "---|" * (len(windows) + 2))
        closed = {}
        for l in range(1, a.shape[1]):
            closed[l] = so.closed_rate("myosin_noise", l, 1.0, 0.2)
            spec = so.spectrum_rate("myosin_noise", args.nodes, l, 1.0, 0.2) if l <= 4 else float("nan")
            cells = " | ".join(f"{fit(t, a[:, l], lo, hi):+.4f}" for lo, hi in windows)
            print(f"| {l} | {cells} | {spec:+.4f} | {closed[l]:+.4f} |")
        lo, hi = windows[0]
        grown = {l: fit(t, a[:, l], lo, hi) for l in closed}
        print(
            f"\nFastest in the run (t = {lo:g}-{hi:g}): l = {max(grown, key=grown.get)}; the closed form's fastest: "
            f"l = {max(closed, key=closed.get)}."
        )
        e = noise_end_state(files["myosin_noise"])
        print(
            f"\nEnd state at t = {e['t']:g}: myosin {e['c_min']:.3f} to {e['c_max']:.3f} (c0 = 1), in one cap of "
            f"half-angle {e['cap_angle']:.0f} deg at half maximum; the area centroid moved {e['shift']:.3f} R0, "
            f"{e['shift_along_cap']:+.3f} R0 along the cap's direction; furrow radius {e['furrow']:.4f}."
        )

    if "myosin_cued_ring" in args.scenes:
        print("\n## myosin_cued_ring beside furrow_p4_a1\n")
        print("| t | furrow_p4_a1 furrow / pole | myosin_cued_ring furrow / pole |")
        print("|---|---|---|")
        ts = [0.5, 1.0, 2.0, 3.0]
        for (_, f0, p0), (t1, f1, p1) in zip(
            radii(files["furrow"], ts), radii(files["myosin_cued_ring"], ts), strict=True
        ):
            print(f"| {t1:g} | {f0:.4f} / {p0:.4f} | {f1:.4f} / {p1:.4f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
