"""Deep furrows in the axisymmetric model: where and why the model stops, the neck radius over
time for rings of amplitude 6, 12 and 20 (p = 4) with the tension on the nodes or carried by the
material, self-convergence in n and rtol, and the paper's furrows with a carried tension.

Usage (one core; about 15-30 minutes for everything on a shared machine, seconds with --smoke):

    python benchmarks/axisym_deep_furrow.py [--smoke] [section ...]

Sections: failure, limit, necks, selfconv, furrows (default: all). Markdown tables on stdout,
headed by the machine, the date and the commit; docs/validation/axisymmetric.md quotes them.
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from _bench import run_sections  # noqa: E402  (benchmarks/_bench.py)

from cortex_ti.axisymmetric.evolve import simulate  # noqa: E402
from cortex_ti.axisymmetric.run import axisymmetric_tension, viscosities  # noqa: E402
from cortex_ti.scene import load_scene  # noqa: E402

#: the paper's furrow_p4_a3 viscosities (eta_s = eta_b = 1, eta_bar = 1e-4, eta_bar_b = 3.5e-3)
BEND = dict(eta_s=1.0, eta_b=1.0, eta_bar=1e-4, eta_bar_b=3.5e-3)
NOBEND = dict(eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0)
SMOKE = False


def ring(amplitude: float, p: int = 4, sigma: float = 10.0):
    """Paper Eq. 59 about z: zeta = 1 + amplitude exp(-sigma |theta - pi/2|^p)."""
    return lambda th: 1.0 + amplitude * np.exp(-sigma * np.abs(np.asarray(th, dtype=float) - np.pi / 2) ** p)


def evolve(amplitude, tension, n, *, visc=BEND, rtol=1e-10, t_end=5.0, times=None, stop_neck=0.1, **kw):
    times = np.linspace(0.0, t_end, max(2, int(round(t_end * 4)) + 1)) if times is None else times
    try:
        return simulate(
            ring(amplitude),
            **visc,
            t_end=t_end,
            save_times=times,
            n=n,
            rtol=rtol,
            interpolate=True,
            tension=tension,
            stop_neck=stop_neck,
            **kw,
        )
    except ValueError as exc:
        return str(exc)


def failure():
    print("## The amplitude-6 ring (nodes): the integrator's failure time against the model's limit\n")
    print(
        "Unguarded (`stop_ill_posed=False`): the time the integrator fails; guarded: the time the bending "
        "margin `min(2 eta_bar k_i + (eta_bar_b - eta_bar) C)` reaches 0, and the neck there.\n"
    )
    print("| n | unguarded: integrator | guarded: stop time | neck at stop (R0) | wall (s) |")
    print("|---:|---|---:|---:|---:|")
    for n in (12,) if SMOKE else (16, 24, 32, 48, 64):
        t0 = time.perf_counter()
        free = evolve(6.0, "nodes", n, t_end=0.2 if SMOKE else 2.0, stop_ill_posed=False, rtol=1e-8)
        guarded = evolve(6.0, "nodes", n, t_end=0.2 if SMOKE else 2.0, rtol=1e-10)
        fail = free if isinstance(free, str) else f"reached t = {free.t[-1]:g}"
        stop = (
            f"{guarded.t[-1]:.6f} | {guarded.neck_radius[-1]:.6f}" if guarded.stopped != "t_end" else "not reached | -"
        )
        print(f"| {n} | {fail.split(':')[0]} | {stop} | {time.perf_counter() - t0:.1f} |")
    print()


def limit():
    print("## Where each ring stops (bending viscosity on, t_end 5, stop_neck 0.1)\n")
    print("| amplitude | tension | stopped (finer n) | t | neck (R0) | neck coarse - fine | t coarse - fine |")
    print("|---:|---|---|---:|---:|---:|---:|")
    for amp in (6.0,) if SMOKE else (3.0, 6.0, 12.0, 20.0):
        for tension in ("nodes", "material"):
            t_end = 0.2 if SMOKE else 5.0
            a, b = (
                evolve(amp, tension, n, t_end=t_end, rtol=1e-6 if SMOKE else 1e-10)
                for n in ((8, 12) if SMOKE else (32, 48))
            )
            if isinstance(b, str) or isinstance(a, str):
                print(f"| {amp:g} | {tension} | failed: {b if isinstance(b, str) else a} | | | | |")
                continue
            why = b.stopped.split(" ")[0] if b.stopped != "t_end" else "t_end"
            print(
                f"| {amp:g} | {tension} | {why} | {b.t[-1]:.6f} | {b.neck_radius[-1]:.6f} | "
                f"{a.neck_radius[-1] - b.neck_radius[-1]:.1e} | {a.t[-1] - b.t[-1]:.1e} |"
            )
    print()


def necks():
    print("## Neck radius (R0) over time; '-' after the run stopped (see the stop column)\n")
    times = np.array([0.0, 0.1, 0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 5.0])
    if SMOKE:
        times = times[times <= 0.1]
    head = " | ".join(f"t={t:g}" for t in times)
    print(f"| amplitude | tension | viscosity | {head} | stop | max n=32 vs 48 |")
    print("|---:|---|---|" + "---:|" * len(times) + "---|---:|")
    for amp in (6.0,) if SMOKE else (6.0, 12.0, 20.0):
        for visc_name, visc in (("bending", BEND), ("none", NOBEND)):
            for tension in ("nodes", "material"):
                runs = [
                    evolve(amp, tension, n, visc=visc, t_end=times[-1], times=times, rtol=1e-6 if SMOKE else 1e-10)
                    for n in ((8, 12) if SMOKE else (32, 48))
                ]
                if any(isinstance(r, str) for r in runs):
                    msg = next(r for r in runs if isinstance(r, str))
                    print(
                        f"| {amp:g} | {tension} | {visc_name} | "
                        + " | ".join("" for _ in times)
                        + f" | failed: {msg} | |"
                    )
                    continue
                a, b = runs
                cells = []
                for t in times:
                    i = np.nonzero(np.isclose(b.t, t))[0]
                    if i.size:
                        v = b.neck_radius[i[0]] if np.isfinite(b.neck_radius[i[0]]) else b.furrow_radius[i[0]]
                        cells.append(f"{v:.4f}")
                    else:
                        cells.append("-")
                m = min(len(a.t), len(b.t))
                diff = float(np.max(np.abs(a.furrow_radius[:m] - b.furrow_radius[:m])))
                stop = "t_end" if b.stopped == "t_end" else b.stopped.split(":")[0]
                print(f"| {amp:g} | {tension} | {visc_name} | " + " | ".join(cells) + f" | {stop} | {diff:.1e} |")
    print("\n(Before a neck forms the furrow radius, r at the equator, is shown.)\n")


def selfconv():
    amp = 6.0 if SMOKE else 12.0
    ref_n = 12 if SMOKE else 64
    for tension in ("nodes", "material"):
        probe = evolve(amp, tension, 8 if SMOKE else 32, t_end=0.1 if SMOKE else 5.0, rtol=1e-6 if SMOKE else 1e-10)
        t_c = round(0.9 * float(probe.t[-1]), 2)
        times = np.array([0.0, t_c])
        ref = evolve(amp, tension, ref_n, rtol=1e-8 if SMOKE else 1e-12, t_end=t_c, times=times)
        print(
            f"## Self-convergence: amplitude {amp:g}, tension on the {tension}, radii at t = {t_c:g} "
            f"(0.9 x the model's limit) against n = {ref_n}, rtol 1e-12\n"
        )
        print(f"reference: furrow {ref.furrow_radius[-1]:.12f} R0, pole {ref.pole_radius[-1]:.12f} R0\n")
        print("| n | rtol | max abs difference of (furrow, pole) radii (R0) | wall (s) |")
        print("|---:|---:|---:|---:|")
        rows = [(n, 1e-12) for n in ((8,) if SMOKE else (16, 24, 32, 48))]
        rows += [(ref_n, rt) for rt in ((1e-6,) if SMOKE else (1e-6, 1e-8, 1e-10))]
        for n, rt in rows:
            r = evolve(amp, tension, n, rtol=rt, t_end=t_c, times=times)
            d = max(abs(r.furrow_radius[-1] - ref.furrow_radius[-1]), abs(r.pole_radius[-1] - ref.pole_radius[-1]))
            print(f"| {n} | {rt:g} | {d:.2e} | {r.wall_time:.1f} |")
        print()


def furrows():
    print("## The paper's furrows (bending on), tension on the nodes against carried by the material\n")
    print("Furrow radius (R0) at t; the smallest over the run and when; how the run ended (n = 48, rtol 1e-10).\n")
    times = np.array([0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
    t_end = 0.1 if SMOKE else 3.0
    times = times[times <= t_end]
    fine = np.linspace(0.0, t_end, int(t_end * 40) + 1)
    print("| scene | tension | " + " | ".join(f"t={t:g}" for t in times) + " | min (t) | ended | max v_s at end |")
    print("|---|---|" + "---:|" * len(times) + "---:|---|---:|")
    for name in ("furrow_p4_a3",) if SMOKE else ("furrow_p8_a1", "furrow_p4_a1", "furrow_p4_a3"):
        s = load_scene(name, ["model=axisymmetric"]).settings
        for tension in ("nodes", "material"):
            r = simulate(
                axisymmetric_tension(s),
                **viscosities(s),
                t_end=t_end,
                save_times=fine,
                n=12 if SMOKE else 48,
                rtol=1e-6 if SMOKE else 1e-10,
                interpolate=True,
                tension=tension,
            )
            cells = [
                f"{r.furrow_radius[np.argmin(np.abs(r.t - t))]:.5f}" if t <= r.t[-1] + 1e-9 else "-" for t in times
            ]
            j = int(np.argmin(r.furrow_radius))
            ended = "t_end" if r.stopped == "t_end" else r.stopped.split(":")[0]
            print(
                f"| {name} | {tension} | "
                + " | ".join(cells)
                + f" | {r.furrow_radius[j]:.5f} ({r.t[j]:.3g}) | {ended} | {np.abs(r.v_s[-1]).max():.3f} |"
            )
    print()


SECTIONS = {"failure": failure, "limit": limit, "necks": necks, "selfconv": selfconv, "furrows": furrows}


def main():
    global SMOKE
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes and times: checks that the script runs")
    ap.add_argument("sections", nargs="*", choices=[*SECTIONS, []], default=[])
    args = ap.parse_args()
    SMOKE = args.smoke
    run_sections(SECTIONS, args.sections)


if __name__ == "__main__":
    main()
