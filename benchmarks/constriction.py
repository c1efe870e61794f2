"""Does a deep ring close the furrow or arrest it? The axisymmetric model without bending viscosity
(issue 18): rings zeta = 1 + amplitude exp(-sigma |theta - pi/2|^p) (sigma 10, ring-to-pole
tension ratio 1 + amplitude), run to t_end or until the neck reaches 0.1 R0, with the tension on
the normally moving points (the paper's) or carried by the material.

What it measures, and why each column is there:

- ``selfconv``: the neck radius against n, rtol and the parametrisation (``lagrangian``: the
  nodes are the normally moving points; ``arclength``: nodes equidistant in arc length carrying
  the label). The material stretch max/min |dX/du| says when the label map stops being resolved
  (the run's numbers after that are not converged, whatever they show).
- ``sweep``: for each p and amplitude, how the run ends: arrested (the neck's rate below 1e-4
  R0/t_a at t_end), closed (neck 0.1 R0), or unresolved (stretch > 100 first), in the arc-length
  parametrisation at two n, next to the lagrangian one.
- ``carried``: with the tension carried by the material, when and where the label map folds.
- ``adaptive``: the self-convergence of the adaptive points (``parametrization='adaptive'``:
  equidistributing curvature, the label's log-stretch rate and the tension's gradient) to the
  end points of issue 18 (t = 5 or a neck of 0.1 R0), in n (64 - 192) and rtol (1e-8 - 1e-12),
  with the spectral tail of the state as the a-posteriori resolution indicator, then the
  largest disagreement between the finest runs at each time.

Usage (one core; a few minutes on a shared machine, seconds with --smoke):

    python benchmarks/constriction.py [--smoke] [--p P ...] [section ...]

Sections: selfconv, sweep, carried, adaptive (default: all). Markdown tables on stdout, headed by the
machine, the date and the commit; docs/validation/constriction.md is written from it by
``python benchmarks/page.py constriction --title "..." -- constriction``.
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import argparse  # noqa: E402

import numpy as np  # noqa: E402
from _bench import run_sections  # noqa: E402  (benchmarks/_bench.py)

from cortex_ti.axisymmetric.evolve import STRETCH_LIMIT as STRETCH_MAX  # noqa: E402
from cortex_ti.axisymmetric.evolve import StepFailed, first_unresolved, simulate  # noqa: E402

#: eta_s = eta_b = 1, no bending viscosity (with it the model is ill-posed at a deep neck:
#: docs/validation/axisymmetric.md, benchmarks/axisym_deep_furrow.py)
NOBEND = dict(eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0)
SMOKE = False
P_VALUES = (2, 4, 8)


def ring(amplitude: float, p: int = 4, sigma: float = 10.0):
    """Paper Eq. 59 about z: zeta = 1 + amplitude exp(-sigma |theta - pi/2|^p)."""
    return lambda th: 1.0 + amplitude * np.exp(-sigma * np.abs(np.asarray(th, dtype=float) - np.pi / 2) ** p)


def evolve(
    amplitude, n, *, p=4, t_end=5.0, rtol=1e-10, tension="nodes", parametrization="auto", frames=20, max_steps=20000
):
    """The run (frames every 1/frames t_a), or the frames before an integrator failure (its
    ``stopped`` says so); a failure without frames returns the message."""
    times = np.linspace(0.0, t_end, int(round(t_end * frames)) + 1)
    try:
        return simulate(
            ring(amplitude, p),
            **NOBEND,
            t_end=t_end,
            save_times=times,
            n=n,
            rtol=rtol,
            interpolate=True,
            tension=tension,
            parametrization=parametrization,
            stop_neck=0.1,
            max_steps=max_steps,
        )
    except StepFailed as exc:
        return exc.result
    except ValueError as exc:
        return str(exc)


def neck(res) -> np.ndarray:
    """The neck radius per frame (the furrow radius before a neck forms)."""
    return np.where(np.isfinite(res.neck_radius), res.neck_radius, res.furrow_radius)


def unresolved(res) -> int | None:
    """The first frame whose material stretch exceeds STRETCH_MAX (or has folded), None if none."""
    return first_unresolved(res.stretch)


def outcome(res) -> str:
    """How a run ended: closed / unresolved / arrested / still closing / failed."""
    if isinstance(res, str):
        return f"failed: {res}"
    nk, j = neck(res), unresolved(res)
    if j is not None:
        return f"unresolved at t = {res.t[j]:.2f} (neck {nk[j]:.4f})"
    if res.stopped.startswith("neck"):
        return f"closed: neck 0.1 at t = {res.t[-1]:.4f}"
    if res.stopped != "t_end":
        return f"{res.stopped.split(':')[0]} at t = {res.t[-1]:.3f} (neck {nk[-1]:.4f})"
    rate = (nk[-1] - nk[-2]) / (res.t[-1] - res.t[-2])
    return f"{'arrested' if abs(rate) < 1e-4 else 'closing'}: neck {nk[-1]:.5f}, rate {rate:.1e}"


def selfconv():
    amps = (6.0,) if SMOKE else (6.0, 12.0, 20.0)
    t_end = 0.2 if SMOKE else 5.0
    print("## Self-convergence of the neck radius (tension on the nodes, no bending viscosity)\n")
    print(
        "Neck radius (R0) at t; t_u: the first frame whose material stretch max/min |dX/du| exceeds "
        f"{STRETCH_MAX:g} (the label map is no longer resolved); last column: how the run ended.\n"
    )
    checks = (0.1, 0.2) if SMOKE else (1.0, 2.0, 5.0)
    print("| amplitude | parametrisation | n | rtol | " + " | ".join(f"t={t:g}" for t in checks) + " | t_u | end |")
    print("|---:|---|---:|---:|" + "---:|" * len(checks) + "---:|---|")
    rows = [("lagrangian", n, 1e-10) for n in ((8, 12) if SMOKE else (48, 64, 96, 128))]
    rows += [("arclength", n, 1e-10) for n in ((8, 12) if SMOKE else (48, 64, 96, 128))]
    rows += [("arclength", 12 if SMOKE else 96, rt) for rt in (1e-8, 1e-12)]
    for amp in amps:
        for par, n, rt in rows:
            r = evolve(amp, n, t_end=t_end, rtol=rt, parametrization=par)
            if isinstance(r, str):
                print(f"| {amp:g} | {par} | {n} | {rt:g} | " + " | ".join("" for _ in checks) + f" | | {r} |")
                continue
            nk, j = neck(r), unresolved(r)
            cells = [f"{nk[r.index(t)]:.8f}" if t <= r.t[-1] + 1e-9 else "-" for t in checks]
            tu = "-" if j is None else f"{r.t[j]:.2f}"
            print(f"| {amp:g} | {par} | {n} | {rt:g} | " + " | ".join(cells) + f" | {tu} | {outcome(r)} |")
    print()


def sweep():
    ps = (4,) if SMOKE else P_VALUES
    amps = (6.0,) if SMOKE else (3.0, 4.0, 5.0, 6.0, 9.0, 12.0, 20.0, 40.0)
    t_end = 0.2 if SMOKE else 10.0
    ns = (8, 12) if SMOKE else (64, 96)
    print(f"## Arrest or closure: rings of ratio 1 + amplitude, to t = {t_end:g} (tension on the nodes)\n")
    print(
        f"Arc-length parametrisation at n = {ns[0]} and {ns[1]}; the lagrangian one at n = {ns[1]} (its "
        "neck loses its points: compare).\n"
    )
    print(f"| p | amplitude | ratio | arclength n={ns[0]} | arclength n={ns[1]} | lagrangian n={ns[1]} |")
    print("|---:|---:|---:|---|---|---|")
    for p in ps:
        for amp in amps:
            cells = [outcome(evolve(amp, n, p=p, t_end=t_end, parametrization="arclength")) for n in ns]
            cells.append(outcome(evolve(amp, ns[1], p=p, t_end=t_end, parametrization="lagrangian")))
            print(f"| {p} | {amp:g} | {1 + amp:g} | " + " | ".join(cells) + " |")
    print()


def carried():
    amps = (20.0,) if SMOKE else (6.0, 12.0, 20.0)
    t_end = 0.2 if SMOKE else 5.0
    print("## Tension carried by the material: where the label map folds\n")
    print(
        "The first unresolved frame (stretch > 100 or folded), the neck there, and the label, radius and "
        "height of the point where |dX/du| is smallest (the material piles up); last column: how the run ended.\n"
    )
    print("| amplitude | parametrisation | n | t_u | neck at t_u | pile-up label, r, z | end |")
    print("|---:|---|---:|---:|---:|---|---|")
    for amp in amps:
        for par, n in (
            (("lagrangian", 12), ("arclength", 12))
            if SMOKE
            else [(par, n) for par in ("lagrangian", "arclength") for n in (48, 96)]
        ):
            r = evolve(amp, n, t_end=t_end, tension="material", parametrization=par)
            if isinstance(r, str):
                print(f"| {amp:g} | {par} | {n} | | | | failed: {r} |")
                continue
            j = unresolved(r)
            k = len(r.t) - 1 if j is None else j
            s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(r.r[k]), np.diff(r.z[k])))])
            dsdu = np.gradient(s, r.u[k])
            m = int(np.argmin(dsdu))
            where = f"{r.u[k][m]:.3f}, {r.r[k][m]:.3f}, {r.z[k][m]:+.3f}"
            tu = "-" if j is None else f"{r.t[j]:.2f}"
            end = "t_end" if r.stopped == "t_end" else r.stopped.split(" (")[0][:90]
            print(f"| {amp:g} | {par} | {n} | {tu} | {neck(r)[k]:.4f} | {where} | {end} |")
    print()


def tail(res) -> float:
    """The a-posteriori resolution indicator: the largest over the frames of the largest of the
    last 8 spectral coefficients of r, z and (arc-length-type points) u - sigma, in R0 / rad."""
    sp, worst = res._spectral, 0.0
    for st in res._states:
        parts = [sp.coeffs("R", st["r"]), sp.coeffs("Z", st["z"])]
        if st.get("u") is not None:
            parts.append(sp.coeffs("O", st["u"] - sp.u))
        worst = max(worst, max(float(np.abs(c[-8:]).max()) for c in parts))
    return worst


def adaptive():
    amps = (12.0,) if SMOKE else (6.0, 12.0, 20.0)
    t_end = 0.2 if SMOKE else 5.0
    checks = (0.1, 0.2) if SMOKE else (0.5, 1.0, 1.15, 2.0, 2.25, 2.35, 5.0)
    ns = (8, 12) if SMOKE else (64, 96, 128, 192)
    nr = 12 if SMOKE else 128
    rows = [(n, 1e-10) for n in ns] + [(nr, rt) for rt in (1e-8, 1e-12)]
    print("## Adaptive points: self-convergence to t = 5 or a neck of 0.1 R0 (tension on the nodes)\n")
    print(
        "Neck radius (R0) at t (the furrow radius before a neck forms; '-': the run had stopped); t(0.1): "
        "when the neck reaches 0.1 R0; tail: the largest over the frames of the last 8 spectral coefficients "
        "of r, z, u; wall: integration time (s).\n"
    )
    head = " | ".join(f"t={t:g}" for t in checks)
    print(f"| amplitude | n | rtol | {head} | t(0.1) | tail | steps | wall |")
    print("|---:|---:|---:|" + "---:|" * len(checks) + "---:|---:|---:|---:|")
    spread = {}
    for amp in amps:
        runs = {}
        for n, rt in rows:
            r = evolve(amp, n, t_end=t_end, rtol=rt, parametrization="adaptive")
            if isinstance(r, str):
                print(f"| {amp:g} | {n} | {rt:g} | " + " | ".join("" for _ in checks) + f" | {r} | | | |")
                continue
            nk = neck(r)
            vals = {t: float(nk[r.index(t)]) for t in checks if t <= r.t[-1] + 1e-9 and abs(r.t[r.index(t)] - t) < 1e-9}
            tc = float(r.t[-1]) if r.stopped.startswith("neck") else None
            if r.stopped != "t_end" and tc is None:
                print(f"<!-- amplitude {amp:g}, n = {n}, rtol {rt:g}: {r.stopped} -->")
            runs[(n, rt)] = (vals, tc)
            cells = [f"{vals[t]:.9f}" if t in vals else "-" for t in checks]
            tcs = "-" if tc is None else f"{tc:.7f}"
            print(
                f"| {amp:g} | {n} | {rt:g} | " + " | ".join(cells) + f" | {tcs} | {tail(r):.0e} | {r.n_steps} | "
                f"{r.wall_time:.0f} |",
                flush=True,
            )
        spread[amp] = runs
    print()
    fine, coarse = (ns[-1], 1e-10), (ns[-2], 1e-10)
    print(
        f"Largest disagreement among n = {coarse[0]}, {fine[0]} (rtol 1e-10) and n = {nr} at rtol 1e-8, 1e-12 "
        "(neck radius at t, and the time of a neck of 0.1 R0), with the neck there:\n"
    )
    print("| amplitude | " + " | ".join(f"t={t:g}" for t in checks) + " | t(0.1) |")
    print("|---:|" + "---|" * (len(checks) + 1))
    for amp, runs in spread.items():
        group = [runs[k] for k in (coarse, fine, (nr, 1e-8), (nr, 1e-12)) if k in runs]
        cells = []
        for t in checks:
            v = [g[0][t] for g in group if t in g[0]]
            cells.append(f"{max(v) - min(v):.1e} (neck {v[-1]:.3f})" if len(v) == len(group) and v else "-")
        tc = [g[1] for g in group if g[1] is not None]
        cells.append(f"{max(tc) - min(tc):.1e}" if len(tc) == len(group) and tc else "-")
        print(f"| {amp:g} | " + " | ".join(cells) + " |")
    print()


SECTIONS = {"selfconv": selfconv, "sweep": sweep, "carried": carried, "adaptive": adaptive}


def main():
    global SMOKE, P_VALUES
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes and times: checks that the script runs")
    ap.add_argument("--p", type=int, nargs="+", default=list(P_VALUES), help="ring exponents of the sweep")
    ap.add_argument("sections", nargs="*", choices=[*SECTIONS, []], default=[])
    args = ap.parse_args()
    SMOKE = args.smoke
    P_VALUES = tuple(args.p)
    run_sections(SECTIONS, args.sections)


if __name__ == "__main__":
    main()
