"""Issue 20's bars (1) and (4) from a store of the workflow study ``self_organisation``.

Reads ``results/aggregate/self_organisation.nc`` (``config/paper.yaml``: 642, 2562 and 10242 nodes)
and prints:

* the rates: per rate run (a seeded harmonic's slope of ``log`` over t = 3-6, bdf2 at the row's
  ``tol``) the run's rate, the spectrum tool's at the same resolution
  (``dynamics.spectrum.degree_jacobian``) and the closed form's, as the issue's relative error
  ``lambda / lambda_closed - 1`` and as ``|Delta lambda| / A`` (A = zeta0 gamma, the activity: the
  size of the terms whose difference the rate is, ``docs/derivations/myosin_rates_3d.md`` §3);
  the observed order ``log2(e_N / e_4N)`` between resolutions;
* the onsets ``A_c`` of each (l, k) of the runs: closed form, spectrum tool per resolution, and the
  relative shift ``A_c(N) / A_c - 1``;
* the ring: the furrow radius of the 3D runs against the axisymmetric twin at given times, its
  observed order, the time the deviation last leaves 2e-3 R0, and the 3D runs' departure from
  mirror symmetry about z = 0 (the twin's symmetry): per frame ``max_i |P x_i - x_m(i)|`` with
  ``P = diag(1, 1, -1)`` and ``m`` the mirror node of the icosphere (the nearest node of ``P x_i``
  at t = 0, exact there), and ``max_i |c_i - c_m(i)| / c0`` of the myosin, from the trajectories.

Usage::

    python benchmarks/self_organisation_bars.py STORE [--ring-trajectories 3D.h5 ...] [--compare LABEL=FILE ...]
    python benchmarks/self_organisation_bars.py --smoke
"""

from __future__ import annotations

import argparse
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

RING_TIMES = (0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 36.0)
BAR = 2e-3


def _order(e_coarse: float, e_fine: float) -> str:
    if not (np.isfinite(e_coarse) and np.isfinite(e_fine)) or e_fine == 0.0:
        return "-"
    return f"{np.log2(abs(e_coarse) / abs(e_fine)):.2f}"


def rates(ds) -> None:
    from cortex_ti.studies import self_organisation as so

    table = so.rate_table(ds)
    print("## Rates of single harmonics\n")
    print(
        "| l | A | k | nodes | tol / dt_max | run | spectrum tool | closed form | run / closed - 1 | tool / closed - 1 "
        "| abs(run - closed) / A | abs(tool - closed) / A | run - tool |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    groups = {}
    for r in sorted(table, key=lambda r: (r.turnover != 0.2, r.degree, -r.activity, r.turnover, r.nodes)):
        closed = so.closed_rate(r.scene, r.degree, r.activity, r.turnover)
        tool = so.spectrum_rate(r.scene, r.nodes, r.degree, r.activity, r.turnover)
        step = "/".join(f"{float(ds[c].values[r.index]):.3g}" for c in ("tol", "dt_max") if c in ds.coords)
        print(
            f"| {r.degree} | {r.activity:g} | {r.turnover:g} | {r.nodes} | {step} | {r.rate:+.5f} | {tool:+.5f} "
            f"| {closed:+.5f} | {r.rate / closed - 1:+.2e} | {tool / closed - 1:+.2e} "
            f"| {abs(r.rate - closed) / r.activity:.2e} | {abs(tool - closed) / r.activity:.2e} "
            f"| {r.rate - tool:+.1e} |"
        )
        groups.setdefault((r.degree, r.activity, r.turnover), {})[r.nodes] = (r.rate - closed, tool - closed)
    multi = {g: v for g, v in groups.items() if len(v) > 1}
    if multi:
        print("\nObserved order log2(e_N / e_4N) of the error against the closed form (run; spectrum tool):\n")
        print("| l | A | k | orders, runs | orders, spectrum tool |")
        print("|---|---|---|---|---|")
        for (l, a, k), by in multi.items():
            ns = sorted(by)
            runs = ", ".join(f"{n1}->{n2}: {_order(by[n1][0], by[n2][0])}" for n1, n2 in zip(ns, ns[1:], strict=False))
            tools = ", ".join(f"{n1}->{n2}: {_order(by[n1][1], by[n2][1])}" for n1, n2 in zip(ns, ns[1:], strict=False))
            print(f"| {l} | {a:g} | {k:g} | {runs} | {tools} |")
    print("\nLargest errors per resolution over the rate runs (bar 1):\n")
    print(
        "| nodes | runs | max abs(run / closed - 1) | max abs(tool / closed - 1) | max abs(run - closed) / A "
        "| max abs(tool - closed) / A | max abs(run - tool) |"
    )
    print("|---|---|---|---|---|---|---|")
    for n in sorted({r.nodes for r in table}):
        rows = [r for r in table if r.nodes == n]
        cl = [so.closed_rate(r.scene, r.degree, r.activity, r.turnover) for r in rows]
        tl = [so.spectrum_rate(r.scene, r.nodes, r.degree, r.activity, r.turnover) for r in rows]
        rel_run = max(abs(r.rate / c - 1) for r, c in zip(rows, cl, strict=True))
        rel_tool = max(abs(t / c - 1) for t, c in zip(tl, cl, strict=True))
        abs_run = max(abs(r.rate - c) / r.activity for r, c in zip(rows, cl, strict=True))
        abs_tool = max(abs(t - c) / r.activity for r, t, c in zip(rows, tl, cl, strict=True))
        diff = max(abs(r.rate - t) for r, t in zip(rows, tl, strict=True))
        print(f"| {n} | {len(rows)} | {rel_run:.2e} | {rel_tool:.2e} | {abs_run:.2e} | {abs_tool:.2e} | {diff:.1e} |")


def onsets(ds) -> None:
    from cortex_ti.studies import self_organisation as so

    table = so.rate_table(ds)
    pairs = sorted({(r.scene, r.degree, r.turnover) for r in table})
    nodes = sorted({r.nodes for r in table})
    print("\n## Onsets\n")
    print(
        "| l | k | closed form A_c | "
        + " | ".join(f"tool {n} (shift)" for n in nodes)
        + " | runs: A (grew? closed form says) |"
    )
    print("|---|---|---|" + "---|" * len(nodes) + "---|")
    for scene, l, k in pairs:
        ac = float(so.closed_onset(scene, l, k)[0])
        cells = []
        for n in nodes:
            a = so.spectrum_onset(scene, n, l, k)
            cells.append(f"{a:.5f} ({a / ac - 1:+.1e})")
        runs = sorted(
            {
                (r.activity, r.rate > 0, r.activity > ac)
                for r in table
                if (r.scene, r.degree, r.turnover) == (scene, l, k)
            }
        )
        said = ", ".join(f"{a:g} ({'yes' if g else 'no'}; {'yes' if e else 'no'})" for a, g, e in runs)
        print(f"| {l} | {k:g} | {ac:.5f} | " + " | ".join(cells) + f" | {said} |")


def mirror(path: Path):
    """Frame times, nodes, and per frame the shape's and the myosin's departure from mirror symmetry
    about z = 0 (max over nodes), with the mirror map's own residual at t = 0."""
    import h5py
    from scipy.spatial import cKDTree

    flip = np.array([1.0, 1.0, -1.0])
    with h5py.File(path, "r") as f:
        t, x, c = f["time"][...], f["points"][...], f["myosin"][...]
    d0, m = cKDTree(x[0]).query(x[0] * flip)
    shape = np.array([np.linalg.norm(x[k] * flip - x[k][m], axis=1).max() for k in range(len(t))])
    myo = np.abs(c - c[:, m]).max(axis=1)
    return t, x.shape[1], shape, myo, float(d0.max())


def _first(t, v, level):
    above = np.flatnonzero(v > level)
    return f"{t[above[0]]:g}" if above.size else f"> {t[-1]:g}"


def furrow(path: Path):
    """Frame times and furrow radius of a trajectory (3D or axisymmetric)."""
    import h5py

    with h5py.File(path, "r") as f:
        return f["time"][...], f["furrow_radius"][...]


def compare(ds, runs) -> None:
    """Further runs of the ring (``LABEL=PATH``) against the store's twin, at the ring's times."""
    from cortex_ti.studies import self_organisation as so

    t = ds["time"].values
    for scene, (_, j) in so.ring_runs(ds).items():
        twin = ds["furrow_radius"].values[j]
        series, paths = {}, {}
        for item in runs:
            label, path = item.rsplit("=", 1)
            series[label], paths[label] = furrow(Path(path)), path
        print(f"\n## {scene}: further runs against the store's twin (furrow radius, R0)\n")
        print("| t | twin | " + " | ".join(f"{label} - twin" for label in series) + " |")
        print("|---|---|" + "---|" * len(series))
        for tq in RING_TIMES:
            k = int(np.argmin(np.abs(t - tq)))
            if abs(t[k] - tq) > 1e-6 or not np.isfinite(twin[k]):
                continue
            cells = []
            for tt, r in series.values():
                kk = int(np.argmin(np.abs(tt - tq)))
                cells.append(f"{r[kk] - twin[k]:+.2e}" if abs(tt[kk] - tq) < 1e-6 else "-")
            print(f"| {t[k]:g} | {twin[k]:.6f} | " + " | ".join(cells) + " |")
        ok = np.isfinite(twin)
        times = [tq for tq in RING_TIMES if tq >= 0.5 * t[ok][-1]]
        print("\nTheir lag behind the twin (t_a; the initial offset taken off, as in the lag table above):\n")
        print(
            "| run | "
            + " | ".join(f"t = {tq:g}" for tq in times)
            + f" | last t within {BAR:g} | mirror asymmetry > 1e-6 / 1e-4 / 2e-3 |"
        )
        print("|---|" + "---|" * (len(times) + 2))
        for label, (tt, r) in series.items():
            e = np.abs(r - np.interp(tt, t[ok], twin[ok]))
            inside = np.flatnonzero(e <= BAR)
            within = f"{tt[inside[-1]]:g}" if inside.size else "never within"
            try:
                ts, _, shape, _, _ = mirror(Path(paths[label]))
                sym = " / ".join(_first(ts, shape, v) for v in (1e-6, 1e-4, BAR))
            except (KeyError, ValueError):  # an axisymmetric file: no nodes to mirror
                sym = "-"
            cells = []
            for tq in times:
                kk = int(np.argmin(np.abs(tt - tq)))
                target = r[kk] - (r[0] - twin[ok][0])
                cells.append(f"{tq - float(np.interp(target, twin[ok][::-1], t[ok][::-1])):.3f}")
            print(f"| {label} | " + " | ".join(cells) + f" | {within} | {sym} |")


def lag(ds, scene: str, nodes, dev, twin) -> None:
    """How far behind the twin each 3D ring is in time, against what its linear rate's error makes.

    With the initial offset (the polyhedron's furrow radius) taken off, the lag ``s`` solves
    ``twin(t - s) = 3D(t) - offset`` on the twin's falling branch; a growth rate
    ``lambda (1 + eps)`` alone lags ``-eps t`` (``eps`` the spectrum tool's relative error of the
    scene's l = 2 rate at its activity and turnover)."""
    from cortex_ti.studies import self_organisation as so

    t = ds["time"].values
    ok = np.isfinite(twin)
    tt, tw = t[ok], twin[ok]
    start = tt[int(np.argmax(-np.diff(tw) > 0))] if tt.size > 2 else tt[0]
    falling = (tt >= start) & np.concatenate([[True], np.diff(tw) < 0])
    i0 = next(i for i in so.ring_runs(ds)[scene][0])
    act = so.activity(ds, i0)
    k = float(ds["turnover"].values[i0])
    closed = so.closed_rate(scene, 2, act, k)
    eps = {n: so.spectrum_rate(scene, n, 2, act, k) / closed - 1 for n in nodes}
    times = [tq for tq in RING_TIMES if tq >= 0.5 * tt[-1]]
    print("\nThe lag of the 3D ring behind the twin (t_a), measured and from its l = 2 rate's error alone:\n")
    print("| nodes | l = 2 rate / closed - 1 | " + " | ".join(f"t = {tq:g}: lag / -eps t" for tq in times) + " |")
    print("|---|---|" + "---|" * len(times))
    for n in nodes:
        cells = []
        for tq in times:
            kq = int(np.argmin(np.abs(t - tq)))
            target = twin[kq] + dev[n][kq] - dev[n][0]
            s = tq - float(np.interp(target, tw[falling][::-1], tt[falling][::-1]))
            cells.append(f"{s:.3f} / {-eps[n] * tq:.3f}")
        print(f"| {n} | {eps[n]:+.2e} | " + " | ".join(cells) + " |")


def ring(ds, trajectories) -> None:
    from cortex_ti.studies import self_organisation as so

    t = ds["time"].values
    for scene, (idx, j) in so.ring_runs(ds).items():
        twin = ds["furrow_radius"].values[j]
        idx = sorted(idx, key=lambda i: int(ds["nodes"].values[i]))
        nodes = [int(ds["nodes"].values[i]) for i in idx]
        dev = {n: ds["furrow_radius"].values[i] - twin for n, i in zip(nodes, idx, strict=True)}
        sym = {}
        for p in trajectories:
            tt, n, shape, myo, d0 = mirror(Path(p))
            sym[n] = (tt, shape, myo, d0)
        print(f"\n## {scene}: the furrow radius against the axisymmetric twin\n")
        head = ["t", "twin", *(f"{n} - twin" for n in nodes)]
        head += [f"order {a}->{b}" for a, b in zip(nodes, nodes[1:], strict=False)]
        head += [f"{n}: shape / myosin asymmetry" for n in sorted(sym)]
        print("| " + " | ".join(head) + " |")
        print("|" + "---|" * len(head))
        for tq in RING_TIMES:
            k = int(np.argmin(np.abs(t - tq)))
            if abs(t[k] - tq) > 1e-6 or not np.isfinite(twin[k]):
                continue
            cells = [f"{dev[n][k]:+.2e}" for n in nodes]
            cells += [_order(dev[a][k], dev[b][k]) for a, b in zip(nodes, nodes[1:], strict=False)]
            for n in sorted(sym):
                tt, shape, myo, _ = sym[n]
                kk = int(np.argmin(np.abs(tt - tq)))
                cells.append(f"{shape[kk]:.1e} / {myo[kk]:.1e}" if abs(tt[kk] - tq) < 1e-6 else "-")
            print(f"| {t[k]:g} | {twin[k]:.5f} | " + " | ".join(cells) + " |")
        print(
            f"\nWhen the deviation leaves {BAR:g} R0 for good (the last frame within it), and the first frame beyond:\n"
        )
        print("| nodes | abs deviation at t = 0 | last t within | first t beyond | t reached |")
        print("|---|---|---|---|---|")
        for n in nodes:
            ok = np.isfinite(dev[n])
            tt, e = t[ok], np.abs(dev[n][ok])
            inside = np.flatnonzero(e <= BAR)
            last = f"{tt[inside[-1]]:g}" if inside.size else "never within"
            print(f"| {n} | {e[0]:.2e} | {last} | {_first(tt, e, BAR)} | {tt[-1]:g} |")
        lag(ds, scene, nodes, dev, twin)
        if sym:
            print("\nThe 3D runs' departure from mirror symmetry (shape, R0): the first frame beyond each level\n")
            print("| nodes | mirror map at t = 0 | > 1e-8 | > 1e-6 | > 1e-4 | > 2e-3 | myosin > 1e-4 |")
            print("|---|---|---|---|---|---|---|")
            for n in sorted(sym):
                tt, shape, myo, d0 = sym[n]
                lv = " | ".join(_first(tt, shape, v) for v in (1e-8, 1e-6, 1e-4, BAR))
                print(f"| {n} | {d0:.1e} | {lv} | {_first(tt, myo, 1e-4)} |")


def _smoke_store(where: Path):
    from cortex_ti.io import write_dataset
    from cortex_ti.studies.stores import study_dataset

    base = {"seed": 1e-3, "myosin_gamma": 1.0, "turnover": 0.2, "t_end": 0.4}
    rows = [
        {"scene": "myosin_decay", "model": "3d", "degree": 2, "nodes": 162, "tol": 1e-6, **base},
        {"scene": "myosin_ring", "model": "3d", "degree": 2, "nodes": 162, "tol": 1e-6, **base},
        {"scene": "myosin_ring", "model": "axisymmetric", "degree": 2, "nodes": 162, "tol": 1e-6, **base},
    ]
    paths = [
        _bench.tiny_run("myosin_decay", 0.4, where=where, overrides=["time.tol=1e-6", "time.save_every=0.1"]),
        _bench.tiny_run("myosin_ring", 0.4, where=where, overrides=["time.save_every=0.1"]),
    ]
    import cortex_ti

    twin = ["mesh.nodes=162", "time.t_end=0.4", "model=axisymmetric", "time.save_every=0.1"]
    cortex_ti.run("myosin_ring", where / "twin.h5", overrides=twin)
    paths.append(where / "twin.h5")
    store = where / "store.nc"
    write_dataset(study_dataset("self_organisation", rows, paths), store)
    return store, [paths[1]]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("store", nargs="?", type=Path)
    ap.add_argument("--ring-trajectories", nargs="*", default=[], help="the 3D ring runs' trajectory.h5")
    ap.add_argument(
        "--compare", nargs="*", default=[], metavar="LABEL=PATH", help="further ring runs to set against the twin"
    )
    ap.add_argument("--ring-times", type=float, nargs="+", default=None, help="the times of the ring's tables")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    global RING_TIMES
    if args.ring_times:
        RING_TIMES = tuple(args.ring_times)
    where = None
    if args.smoke:
        where = _bench.folder()
        args.store, args.ring_trajectories = _smoke_store(where)
        args.compare = [f"again={args.ring_trajectories[0]}"]
        RING_TIMES = (0.0, 0.2, 0.4)
    if args.store is None:
        ap.error("give the store (results/aggregate/self_organisation.nc)")
    import xarray as xr

    ds = xr.load_dataset(args.store, engine="h5netcdf")
    rates(ds)
    onsets(ds)
    ring(ds, args.ring_trajectories)
    if args.compare:
        compare(ds, args.compare)
    if where is not None:
        import shutil

        shutil.rmtree(where, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
