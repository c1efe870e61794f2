"""Issue 35's bars for a run that divides (``division.neck_radius``), read from its trajectory.

From a trajectory file (``--file``, e.g. of ``cortex-ti run cytokinesis``) or a run made here
(``--scene`` with ``--set``): the frames' body count; the daughters' volumes at the first two-body
frame and at the last against the initial volume, and against each other; the recorded cut
(:func:`cortex_ti.io.trajectory.read_divisions`: its time, neck and the sides' volumes); the total of
every stored density (``sum_i c_i A_i``, barycentric dual areas; on the curved cells of ``rayleigh_p2``
``sum_i c_i int N_i dA``) at every frame, its largest relative
change across the cut (the last one-body frame to the first two-body frame) and over the run; each
daughter's roundness at the last frame (the largest ``|r - mean r| / mean r`` of its nodes' distances
from its area centroid); the smallest triangle angle over all frames (of the curved cells' corner
triangles on ``rayleigh_p2``: those the remeshing keeps above its angle); the run's time.

Usage::

    cortex-ti run cytokinesis -o c.h5 --threads 1 && python benchmarks/division.py --file c.h5
    python benchmarks/division.py --scene cytokinesis --set mesh.nodes=642 --set division.neck_radius=0.15
    python benchmarks/division.py --smoke       # the 642-node dumbbell, cut at its first step (to t = 0.0012)
    python benchmarks/division.py --dumbbell    # the same followed until its daughters are round (t = 1.6)
    python benchmarks/division.py --twin c642.h5 c2562.h5 [--twin-n 64 96]

``--twin`` (with ``--set`` for the axisymmetric model's keys) compares the neck of one or more 3D
runs of a scene (remeshed runs too: the neck is a measure of the shape, not of the nodes) with the
axisymmetric model of the same scene (``model=axisymmetric``, the bending forms of the 3D
formulation, at the meridian points ``--twin-n``, the scene's by default; it runs to a neck of
``division.neck_radius`` by ``time.stop_neck``): the neck radius at the frames both have, from the
first frame with a neck in both to the cut, largest deviation; the cut time (the neck reaching
``division.neck_radius``) of each and its relative difference. The axisymmetric frames are the 3D
run's (the same ``time.save_every``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np


def bars(path: Path) -> dict:
    """The measurements of the module docstring for the trajectory ``path``."""
    from cortex_ti.io.trajectory import Trajectory, frame_mesh, read_divisions
    from cortex_ti.physics.formulations import FORMULATIONS
    from cortex_ti.scene.yamltext import load_yaml
    from cortex_ti.surface.curved_remesh import corner_mesh, curved_masses
    from cortex_ti.surface.measures import min_angles
    from cortex_ti.surface.transport import dual_areas

    ds = Trajectory(path).ds
    # rayleigh_p2: the curved cells' measures (read from the stored text: a scene an older run wrote may
    # no longer pass today's rules)
    numerics = load_yaml(ds.attrs["scene"]).get("numerics") or {}
    curved = FORMULATIONS[numerics.get("formulation", "rayleigh_p1")].curved
    n = ds["n_bodies"].values
    vol = ds["body_volume"].values
    v0 = vol[0, 0]
    out = {"frames": len(n), "t_end": float(ds["time"].values[-1]), "n_bodies": f"{int(n[0])} -> {int(n[-1])}"}
    densities = [v for v in ds.data_vars if v.startswith("field_") or v == "myosin"]
    totals, smallest = {d: [] for d in densities}, np.inf
    for k in range(len(n)):
        p, f = frame_mesh(ds, k)
        # the angles of the triangles remeshed (the curved cells' corner triangles), a density's weights
        smallest = min(smallest, float(min_angles(*(corner_mesh(p, f) if curved else (p, f))).min()))
        a = curved_masses(p, f) if curved else dual_areas(p, f)
        for d in densities:
            totals[d].append(float(ds[d].values[k][: len(p)] @ a))
    out["smallest angle (deg)"] = smallest
    cut = read_divisions(path)
    if cut:
        c = cut[0]
        out["cut: t, neck"] = (c["division_time"], c["division_neck"])
        out["cut: sides' volumes / volume before - 1"] = sum(c["division_volumes"]) / c["division_volume"] - 1.0
    two = np.flatnonzero(n == 2)
    if two.size:
        k = int(two[0])
        for label, j in (("first two-body frame", k), ("last frame", len(n) - 1)):
            out[f"{label}: V0 + V1 - V(0), relative"] = (vol[j, 0] + vol[j, 1]) / v0 - 1.0
            out[f"{label}: abs(V0 - V1) / (V0 + V1)"] = abs(vol[j, 0] - vol[j, 1]) / (vol[j, 0] + vol[j, 1])
        for d in densities:
            m = np.array(totals[d])
            out[f"{d}: total across the cut, relative change"] = m[k] / m[k - 1] - 1.0
            out[f"{d}: total over the run, largest relative change"] = float(np.max(np.abs(m / m[0] - 1.0)))
        for b, (rb, vb) in enumerate(roundness(ds, len(n) - 1)):
            out[f"daughter {b}: roundness max abs(r / mean r - 1), volume"] = (rb, vb)
    return out


def roundness(ds, k: int) -> list[tuple[float, float]]:
    """``(roundness, volume)`` of each body of frame ``k`` (module docstring)."""
    from cortex_ti.io.trajectory import frame_mesh
    from cortex_ti.surface.division import body_roundness

    return body_roundness(*frame_mesh(ds, k))


def rounding(path: Path) -> str:
    """A table of the daughters' roundness against time (every two-body frame)."""
    from cortex_ti.io.trajectory import Trajectory

    ds = Trajectory(path).ds
    rows = ["| t | daughter 0: roundness | daughter 1: roundness | V0 | V1 |", "|---|---|---|---|---|"]
    for k in np.flatnonzero(ds["n_bodies"].values == 2):
        (r0, _), (r1, _) = roundness(ds, int(k))
        v0, v1 = ds["body_volume"].values[k][:2]  # the run's (on rayleigh_p2 the curved cells')
        rows.append(f"| {float(ds['time'].values[k]):.4g} | {r0:.4f} | {r1:.4f} | {v0:.6f} | {v1:.6f} |")
    return "\n".join(rows)


def _neck(ds) -> tuple[np.ndarray, np.ndarray]:
    """(times, neck) of a trajectory's one-body frames with a neck (the frames before the cut)."""
    t, r = ds["time"].values, ds["neck_radius"].values
    one = ds["n_bodies"].values == 1 if "n_bodies" in ds else np.ones(t.size, bool)
    ok = one & np.isfinite(r)
    return t[ok], r[ok]


def _cut_time(path: Path, ds, neck: float) -> float:
    """When the neck reached ``neck``: the recorded cut of a 3D run, else (the axisymmetric file ends at
    its cut) the last frame if its neck is there."""
    from cortex_ti.io.trajectory import read_divisions

    cut = read_divisions(path)
    if cut:
        return float(cut[0]["division_time"])
    t, r = _neck(ds)
    return float(t[-1]) if r.size and r[-1] <= neck * (1 + 1e-6) else float("nan")


def twin(paths: list[Path], ns: list[int | None], sets=()) -> str:
    """The ``--twin`` table (module docstring)."""
    from cortex_ti.api import run as ct_run
    from cortex_ti.io.trajectory import Trajectory
    from cortex_ti.scene import scene_from_dict, scene_from_yaml

    runs = [(p, Trajectory(p).ds) for p in paths]
    scene = scene_from_yaml(runs[0][1].attrs["scene"])
    neck_cut = float(scene.data["division"]["neck_radius"])
    twins = {}
    data = dict(scene.data, model="axisymmetric")
    # the axisymmetric model runs to a neck of the cut's radius (time.stop_neck: division.neck_radius
    # does not take a myosin field there); what acts on the 3D cut and its daughters is not its to take
    data.pop("division")
    data["time"] = dict(data["time"], stop_neck=neck_cut)
    data["mesh"] = {k: v for k, v in data["mesh"].items() if k != "remesh"}  # 3D's remeshing
    for n in ns:
        over = [*([f"axisymmetric.n={n}"] if n else []), *sets]
        c0 = time.process_time()
        out = _bench.folder() / f"ax{n}.h5"
        ct_run(scene_from_dict(data), out, overrides=over, force=True)
        ax = Trajectory(out).ds
        twins[n or scene.data["axisymmetric"]["n"]] = (_neck(ax), _cut_time(out, ax, neck_cut))
        print(f"<!-- the axisymmetric twin, n = {n or 'scene'}: {time.process_time() - c0:.0f} CPU s -->")
    rows = [
        "| run | nodes (start / remeshing budget) | twin n | neck: largest abs deviation (at t, neck) "
        "| cut t (3D, twin) | cut t rel. diff |"
    ]
    rows.append("|---|---|---|---|---|---|")
    for path, ds in runs:
        mesh = scene_from_yaml(ds.attrs["scene"]).data["mesh"]
        nodes = f"{mesh['nodes']} / {(mesh.get('remesh') or {}).get('nodes') or mesh['nodes']}"
        t3, r3 = _neck(ds)
        cut3 = _cut_time(path, ds, neck_cut)
        for n, ((ta, ra), cuta) in twins.items():
            common, i3, ia = np.intersect1d(np.round(t3, 9), np.round(ta, 9), return_indices=True)
            if not common.size:
                rows.append(f"| {path.name} | {nodes} | {n} | no common frame | {cut3:.4f}, {cuta:.4f} | |")
                continue
            d = np.abs(r3[i3] - ra[ia])
            k = int(np.argmax(d))
            rows.append(
                f"| {path.name} | {nodes} | {n} | {d[k]:.2e} (t = {common[k]:.3g}, "
                f"{ra[ia][k]:.4f}) | {cut3:.4f}, {cuta:.4f} | {cut3 / cuta - 1:+.2e} |"
            )
    return "\n".join(rows)


def smoke(t_end: float = 0.0012, save_every: float = 0.0002) -> Path:
    """The dumbbell of tests/dumbbell_tools.py under a uniform tension, cut at its first step, followed
    to ``t_end`` (1.6: until its daughters are round)."""
    import meshio

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
    from tests.dumbbell_tools import dumbbell

    where = _bench.folder()
    p, f = dumbbell(642, neck=0.25)
    meshio.write(where / "db.obj", meshio.Mesh(p, [("triangle", f)]))
    sets = [f"mesh.file={where / 'db.obj'}", "mesh.nodes=null", "active_stress.0.amplitude=0"]
    sets += ["division.neck_radius=0.27", "time.stop_neck=null", f"time.save_every={save_every}", f"time.t_end={t_end}"]
    sets += ["division.implicit_tension_weight=2"]  # docs/derivations/implicit_tension_weight.md
    return run("constriction_p4", sets, where)


def run(scene: str, sets: list[str], where: Path) -> Path:
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation.core import Simulation

    t0, c0 = time.perf_counter(), time.process_time()
    path = Simulation(load_scene(scene, sets)).run(where / f"{scene}.h5", progress=False, force=True)
    print(f"<!-- the run: {time.perf_counter() - t0:.0f} s wall, {time.process_time() - c0:.0f} s CPU -->")
    return path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--file", type=Path, help="a trajectory of a run with division.neck_radius")
    ap.add_argument("--scene", default="cytokinesis")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    ap.add_argument("--smoke", action="store_true", help="a tiny case: the dumbbell cut at its first step")
    ap.add_argument("--dumbbell", action="store_true", help="the smoke's dumbbell until its daughters are round")
    ap.add_argument("--rounding", action="store_true", help="also the daughters' roundness at every two-body frame")
    ap.add_argument(
        "--twin", type=Path, nargs="+", help="3D runs of one scene: their neck against the axisymmetric model's"
    )
    ap.add_argument(
        "--twin-n", type=int, nargs="+", default=[None], help="the twin's meridian points (default: the scene's)"
    )
    a = ap.parse_args()
    print(_bench.header())
    if a.twin:
        print(twin(a.twin, a.twin_n, a.sets))
        return
    if a.file:
        path = a.file
    elif a.smoke or a.dumbbell:
        path = smoke(1.6, 0.2) if a.dumbbell else smoke()
    else:
        path = run(a.scene, a.sets, _bench.folder())
    print("| measured | value |\n|---|---|")
    for k, v in bars(path).items():
        print(f"| {k} | {v if isinstance(v, str) else np.round(v, 12).tolist()} |")
    if a.rounding or a.dumbbell:
        print()
        print(rounding(path))


if __name__ == "__main__":
    main()
