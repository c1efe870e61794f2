"""The axisymmetric model measured: resolution and tolerance study, the external reference,
speed, stiffness with and without bending viscosity, non-symmetric patterns, integrators.

Usage (one core; a few minutes for all sections; the tables of docs/validation/axisymmetric_truth.md come from it):

    python benchmarks/axisymmetric_convergence.py [section ...]

Sections: convergence, reference, speed, stiffness, nobend, asym, integrators (default: all).
``--smoke``: the ``speed`` section (or the sections named) on tiny runs (n <= 16, t <= 0.1), in
seconds, to check the script runs; its numbers mean nothing.
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import sys  # noqa: E402
import time  # noqa: E402

import _bench  # noqa: E402  (benchmarks/_bench.py)
import numpy as np  # noqa: E402

from cortex_ti.analysis.reference import DEFAULT_DIR  # noqa: E402
from cortex_ti.axisymmetric import balance, dynamics, evolve  # noqa: E402
from cortex_ti.axisymmetric.run import axisymmetric_tension, viscosities  # noqa: E402
from cortex_ti.scene import load_scene  # noqa: E402


class ax:  # the solver's names, as this script uses them
    SCENES = ("furrow_p8_a1", "furrow_p4_a1", "furrow_p4_a3")
    simulate = staticmethod(evolve.simulate)
    Dynamics = dynamics.Dynamics
    _Physics = balance._Physics
    _System = balance.ForceBalance

    @staticmethod
    def scene_tension(name):
        settings = load_scene(name, ["model=axisymmetric"]).settings
        return axisymmetric_tension(settings), viscosities(settings)


REF = str(DEFAULT_DIR) + "/"
DEFAULT_N, DEFAULT_RTOL = 48, 1e-10
SCENES = list(ax.SCENES)


#: --smoke: every run of a section at n <= 16, rtol >= 1e-6, to t <= 0.1 (seconds; numbers mean nothing)
SMOKE = "--smoke" in sys.argv


def run(name, n=DEFAULT_N, rtol=DEFAULT_RTOL, bend=True, **kw):
    if SMOKE:
        n, rtol = min(n, 16), max(rtol, 1e-6)
        kw["t_end"] = min(kw.get("t_end", 0.1), 0.1)
        if "save_times" in kw:
            kw["save_times"] = [t for t in kw["save_times"] if t <= kw["t_end"]]
    z, v = ax.scene_tension(name)
    if not bend:
        v["eta_bar"] = v["eta_bar_b"] = 0.0
    kw.setdefault("t_end", 3.0)
    return ax.simulate(z, **v, n=n, rtol=rtol, **kw)


def convergence():
    print("## Convergence of the radii at t = 3 (symmetric, lagrangian)\n")
    truth = {}
    for name in SCENES:
        t0 = time.perf_counter()
        r = run(name, n=128, rtol=1e-12)
        truth[name] = (r.pole_radius[-1], r.furrow_radius[-1])
        print(
            f"truth {name}: n=128 rtol=1e-12: pole {truth[name][0]:.12f} furrow {truth[name][1]:.12f} "
            f"({time.perf_counter() - t0:.1f} s)"
        )
    print("\n### vs n (rtol = 1e-10); deviation from the n=128, rtol=1e-12 run\n")
    print("| scene | n | pole(3) | furrow(3) | dev pole | dev furrow |")
    print("|---|---|---|---|---|---|")
    for name in SCENES:
        for n in (16, 24, 32, 48, 64, 96):
            r = run(name, n=n, rtol=1e-10)
            print(
                f"| {name} | {n} | {r.pole_radius[-1]:.10f} | {r.furrow_radius[-1]:.10f} | "
                f"{r.pole_radius[-1] - truth[name][0]:+.1e} | {r.furrow_radius[-1] - truth[name][1]:+.1e} |"
            )
    print("\n### vs rtol (n = 48, atol = rtol); deviation from the n=128, rtol=1e-12 run\n")
    print("| scene | rtol | steps | dev pole | dev furrow | wall s |")
    print("|---|---|---|---|---|---|")
    for name in SCENES:
        for rtol in (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12):
            r = run(name, n=48, rtol=rtol)
            print(
                f"| {name} | {rtol:.0e} | {r.n_steps} | {r.pole_radius[-1] - truth[name][0]:+.1e} | "
                f"{r.furrow_radius[-1] - truth[name][1]:+.1e} | {r.wall_time:.2f} |"
            )
    print("\n### default (n=48, rtol=1e-10) vs doubled n and halved tolerance (n=96, rtol=5e-11), all saved times\n")
    print("| scene | max over t in [0,3] of abs change pole | furrow | volume drift (default) | max stretch |")
    print("|---|---|---|---|---|")
    ts = np.linspace(0, 3, 31)
    for name in SCENES:
        a = run(name, save_times=ts)
        b = run(name, n=96, rtol=5e-11, save_times=ts)
        print(
            f"| {name} | {np.abs(a.pole_radius - b.pole_radius).max():.1e} | "
            f"{np.abs(a.furrow_radius - b.furrow_radius).max():.1e} | {np.abs(a.volume - a.volume[0]).max():.1e} | "
            f"{a.stretch.max():.3f} |"
        )
    print("\n### values at t = 3 (default settings)\n")
    print("| scene | bending | pole radius | furrow radius | area | P |")
    print("|---|---|---|---|---|---|")
    for name in SCENES:
        r = run(name)
        print(
            f"| {name} | on | {r.pole_radius[-1]:.7f} | {r.furrow_radius[-1]:.7f} | {r.area[-1]:.7f} | {r.P[-1]:.7f} |"
        )
    for name in SCENES:
        r = run(name, bend=False)
        print(
            f"| {name} | off | {r.pole_radius[-1]:.7f} | {r.furrow_radius[-1]:.7f} | {r.area[-1]:.7f} | {r.P[-1]:.7f} |"
        )
    print()


def _ref_interp_z(res, i, zq):
    uu = np.linspace(0, np.pi, 4001)
    e = res.evaluate(i, uu)
    u = np.interp(zq, e["z"][::-1], uu[::-1])
    for _ in range(8):
        f = res.evaluate(i, u)
        zu = res._spectral.evaluate("Z", res._states[i]["z"], u, 1)
        ok = np.abs(zu) > 1e-3
        u = np.clip(u - np.where(ok, (f["z"] - zq) / np.where(ok, zu, 1.0), 0.0), 0, np.pi)
    return u


def _ref_interp_s(res, i, s_ref, s_ref_total):
    uu = np.linspace(0, np.pi, 20001)
    sp, st = res._spectral, res._states[i]
    h = np.hypot(sp.evaluate("R", st["r"], uu, 1), sp.evaluate("Z", st["z"], uu, 1))
    s_north = np.concatenate([[0], np.cumsum(0.5 * (h[1:] + h[:-1]) * np.diff(uu))])
    Ltot = s_north[-1]
    s_south = Ltot - s_north
    return np.interp(s_ref / s_ref_total * Ltot, s_south[::-1], uu[::-1]), Ltot


def reference():
    print("## External reference (p = 8, zeta_hat = 1, no bending viscosity)\n")
    d = np.loadtxt(REF + "caseA_p8_zh1_radii_vs_time.csv", delimiter=",", skiprows=1, usecols=(0, 1, 2))
    d3 = d[d[:, 0] <= 3.0 + 1e-9]
    ts = np.unique(np.concatenate([d[:, 0], [0.0, 0.1, 1.5, 3.0, 5.0]]))
    for label, kw in (("no bending (as the reference)", dict(bend=False)), ("with the scene's bending viscosity", {})):
        res = run("furrow_p8_a1", t_end=5.0, save_times=ts, interpolate=True, **kw)
        idx = np.searchsorted(res.t, d3[:, 0])
        dp, df = res.pole_radius[idx] - d3[:, 1], res.furrow_radius[idx] - d3[:, 2]
        print(f"**{label}** (n=48, rtol=1e-10, dense output at the reference's times; wall {res.wall_time:.2f} s)\n")
        print(
            f"- max |pole - ref| for t <= 3: {np.abs(dp).max():.2e} (at t = {d3[np.argmax(np.abs(dp)), 0]:.3f}); "
            f"max |furrow - ref|: {np.abs(df).max():.2e} (at t = {d3[np.argmax(np.abs(df)), 0]:.3f})"
        )
        j3 = res.index(3.0)
        j5 = res.index(5.0)
        print(
            f"- t = 3: pole {res.pole_radius[j3]:.7f} (ref 1.134339), furrow {res.furrow_radius[j3]:.7f} "
            f"(ref 0.927040); "
            f"t = 5: pole {res.pole_radius[j5]:.7f} (ref 1.134599), furrow {res.furrow_radius[j5]:.7f} (ref 0.926899)\n"
        )
        print("| t | pole | ref | diff | furrow | ref | diff |")
        print("|---|---|---|---|---|---|---|")
        for tt in (0.01, 0.05, 0.1, 0.27, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0):
            j = np.argmin(np.abs(d3[:, 0] - tt))
            print(
                f"| {d3[j, 0]:.3f} | {res.pole_radius[idx[j]]:.7f} | {d3[j, 1]:.7f} | {dp[j]:+.1e} | "
                f"{res.furrow_radius[idx[j]]:.7f} | {d3[j, 2]:.7f} | {df[j]:+.1e} |"
            )
        print()
        if kw.get("bend", True):  # profiles only for the no-bending run (as the reference)
            continue
        print(
            "Velocity profiles (max abs deviation; v_n outward, |v_t|, and the signed v_t (reference: "
            "south -> north)):\n"
        )
        print(
            "| t | v_n by z | abs v_t by z | signed v_t by z | v_n by z, caps excl. | abs v_t by z, caps "
            "excl. | v_n by arc length | abs v_t by arc length | max abs v_t |"
        )
        print("|---|---|---|---|---|---|---|---|---|")
        for tt in (0.0, 0.1, 1.5, 3.0):
            ref = np.loadtxt(REF + f"caseA_p8_zh1_velocity_t{tt}.csv", delimiter=",", skiprows=1)
            i = res.index(tt)
            f = res.evaluate(i, _ref_interp_z(res, i, ref[:, 0]))
            m = np.abs(ref[:, 0]) < 0.98 * np.abs(ref[:, 0]).max()
            dvn, dvt, dvs = f["v_n"] - ref[:, 5], np.abs(f["v_s"]) - ref[:, 3], -f["v_s"] - ref[:, 4]
            u_s, _ = _ref_interp_s(res, i, ref[:, 2], ref[-1, 2])
            g = res.evaluate(i, u_s)
            print(
                f"| {tt} | {np.abs(dvn).max():.1e} | {np.abs(dvt).max():.1e} | {np.abs(dvs).max():.1e} | "
                f"{np.abs(dvn[m]).max():.1e} | {np.abs(dvt[m]).max():.1e} | {np.abs(g['v_n'] - ref[:, 5]).max():.1e} | "
                f"{np.abs(np.abs(g['v_s']) - ref[:, 3]).max():.1e} | {ref[:, 3].max():.3f} |"
            )
        print(
            "\n(caps excl.: |z| < 0.98 z_pole; at t = 0 the reference itself deviates from the exact sphere "
            "solution by 2e-3, README.)\n"
        )
        # exact sphere solution at t = 0 for our run
        zbar = 1.6454788578586
        print(
            f"- our t = 0 flow vs the exact sphere solution: max |v_n + (zeta - zeta_bar)/2| = "
            f"{np.abs(res.v_n[0] + 0.5 * (res.zeta[0] - zbar)).max():.1e}, max |v_s| = {np.abs(res.v_s[0]).max():.1e}\n"
        )


def speed():
    print("## Speed at the defaults (n = 48 half-meridian points, rtol = atol = 1e-10, Radau, t_end = 3)\n")
    print("| scene | bending | wall s (min of 3) | all 3 | steps | RHS solves | Jacobians | LU |")
    print("|---|---|---|---|---|---|---|---|")
    for bend in (True, False):
        for name in SCENES:
            walls = []
            for _ in range(3):
                r = run(name, bend=bend)
                walls.append(r.wall_time)
            print(
                f"| {name} | {'on' if bend else 'off'} | {min(walls):.2f} | {', '.join(f'{w:.2f}' for w in walls)} | "
                f"{r.n_steps} | {r.n_rhs} | {r.n_jac} | {r.n_lu} |"
            )
    print("\nOther settings (furrow_p4_a3, bending on):\n")
    print("| n | rtol | symmetric | parametrization | wall s | steps |")
    print("|---|---|---|---|---|---|")
    for n, rtol, sym, par in (
        (32, 1e-9, True, "lagrangian"),
        (48, 1e-10, True, "arclength"),
        (96, 1e-10, False, "lagrangian"),
        (96, 1e-10, False, "arclength"),
        (96, 5e-11, True, "lagrangian"),
    ):
        r = run("furrow_p4_a3", n=n, rtol=rtol, symmetric=sym, parametrization=par)
        print(f"| {n} | {rtol:.0e} | {sym} | {par} | {r.wall_time:.2f} | {r.n_steps} |")
    print()


def stiffness():
    print("## Stiffness: eigenvalues of the Jacobian d(dX/dt)/dX of the node dynamics\n")
    print("| scene | bending | n | min Re (t=0) | max Re (t=0) | min Re (t=3) | max Re (t=3) |")
    print("|---|---|---|---|---|---|---|")
    for name in ("furrow_p8_a1", "furrow_p4_a3"):
        for bend in (True, False):
            z, v = ax.scene_tension(name)
            if not bend:
                v["eta_bar"] = v["eta_bar_b"] = 0.0
            for n in (24, 48, 96):
                r = ax.simulate(z, **v, t_end=3.0, n=n, rtol=1e-9, save_times=[0.0, 3.0])
                sp = r._spectral
                dyn = ax.Dynamics(
                    sp, ax._System(sp, ax._Physics(1.0, 1.0, v["eta_bar"], v["eta_bar_b"])), z, "lagrangian"
                )
                row = []
                for i in (0, 1):
                    y = np.concatenate([r._states[i]["r"], r._states[i]["z"]])
                    ev = np.linalg.eigvals(dyn.jac(0.0, y))
                    row += [f"{ev.real.min():.3g}", f"{ev.real.max():.3g}"]
                print(f"| {name} | {'on' if bend else 'off'} | {n} | " + " | ".join(row) + " |")
    print()


def nobend():
    print("## furrow_p4_a3 without bending viscosity\n")
    print("| n | rtol | pole(3) | furrow(3) | steps | RHS | wall s | max stretch |")
    print("|---|---|---|---|---|---|---|---|")
    for n, rtol in ((24, 1e-10), (32, 1e-10), (48, 1e-10), (64, 1e-10), (96, 1e-10), (48, 1e-12)):
        r = run("furrow_p4_a3", n=n, rtol=rtol, bend=False)
        print(
            f"| {n} | {rtol:.0e} | {r.pole_radius[-1]:.10f} | {r.furrow_radius[-1]:.10f} | {r.n_steps} | {r.n_rhs} | "
            f"{r.wall_time:.2f} | {r.stretch.max():.3f} |"
        )
    print()


def asym():
    print(
        "## A non-symmetric pattern (full meridian): zeta = 1 + 2 exp(-10 |theta - 1.2|^4), "
        "eta_bar = 1e-4, eta_bar_b = 3.5e-3\n"
    )
    zf = lambda t: 1.0 + 2.0 * np.exp(-10 * np.abs(t - 1.2) ** 4)  # noqa: E731
    print(
        "| gauge | parametrization | n | pole(1) | furrow(1) | pole(3) | furrow(3) | z_centroid(3) | max "
        "stretch | wall s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for gauge in ("velocity", "centroid"):
        for par, n in (("arclength", 48), ("arclength", 96), ("lagrangian", 96)):
            try:
                r = ax.simulate(
                    zf,
                    eta_s=1.0,
                    eta_b=1.0,
                    eta_bar=1e-4,
                    eta_bar_b=3.5e-3,
                    t_end=3.0,
                    n=n,
                    rtol=1e-10,
                    gauge=gauge,
                    parametrization=par,
                    save_times=[0, 1, 3],
                )
                print(
                    f"| {gauge} | {par} | {n} | {r.pole_radius[1]:.9f} | {r.furrow_radius[1]:.9f} | "
                    f"{r.pole_radius[2]:.9f} | "
                    f"{r.furrow_radius[2]:.9f} | {r.z_centroid[2]:+.4f} | {r.stretch.max():.2f} | {r.wall_time:.1f} |"
                )
            except ValueError as err:
                print(f"| {gauge} | {par} | {n} | failed: {err} | | | | | | |")
    print()


def integrators():
    print("## Saving by dense output vs stopping at each save time; BDF vs Radau (furrow_p4_a3, n = 48)\n")
    ts = np.linspace(0, 3, 301)
    a = run("furrow_p4_a3", save_times=ts, interpolate=True)
    b = run("furrow_p4_a3", save_times=ts, interpolate=False)
    c = run("furrow_p4_a3", save_times=ts[::30], method="BDF")
    print(
        f"- 301 save times, dense output vs exact stops: max |d pole| "
        f"{np.abs(a.pole_radius - b.pole_radius).max():.1e}, "
        f"max |d furrow| {np.abs(a.furrow_radius - b.furrow_radius).max():.1e} "
        f"(steps {a.n_steps} vs {b.n_steps}, wall {a.wall_time:.2f} vs {b.wall_time:.2f} s)"
    )
    print(
        f"- BDF (rtol 1e-10) vs Radau at t = 0, 0.3, ..., 3: max |d pole| "
        f"{np.abs(c.pole_radius - b.pole_radius[::30]).max():.1e}, "
        f"max |d furrow| {np.abs(c.furrow_radius - b.furrow_radius[::30]).max():.1e} (BDF steps "
        f"{c.n_steps}, wall {c.wall_time:.2f} s)\n"
    )


SECTIONS = dict(
    convergence=convergence,
    reference=reference,
    speed=speed,
    stiffness=stiffness,
    nobend=nobend,
    asym=asym,
    integrators=integrators,
)

if __name__ == "__main__":
    names = [a for a in sys.argv[1:] if a != "--smoke"] or (["speed"] if SMOKE else list(SECTIONS))
    print(_bench.header())
    for nm in names:
        SECTIONS[nm]()
        sys.stdout.flush()
