"""3D trajectories against the axisymmetric solution of their own scene (the same model).

For a 3D trajectory of an axisymmetric scene, :func:`compare` solves the scene again with the
axisymmetric model at the file's frame times (~1 s) and measures the radii and the velocity
profiles at the same points (the label theta0 = a node's polar angle on the initial sphere: both
codes move their points with the normal velocity, whatever carries the tension).
:func:`twin_report` is ``cortex-ti twin``: those measurements of one or more files as Markdown tables.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import CortexError
from ..io.trajectory import Trajectory
from ..physics.formulations import FORMULATIONS
from ..scene import scene_from_dict
from .evolve import simulate
from .fluids import axisymmetric_fluids
from .run import AxisymmetricRun, evolution_options, viscosities

__all__ = ["PROFILE_TIMES", "twin_of", "compare", "node_radii", "pole_and_equator", "twin_report"]

PROFILE_TIMES = (0.1, 1.5, 3.0)


def twin_of(tr: Trajectory):
    """The axisymmetric solution of the trajectory's scene at its frame times, with the bending
    viscosity's normal force in the form the trajectory's formulation discretises
    (:attr:`~cortex_ti.physics.formulations.Formulation.bending_form`)."""
    form = FORMULATIONS[tr.settings.numerics.formulation].bending_form
    data = dict(tr.scene.data, model="axisymmetric")
    data["axisymmetric"] = dict(data.get("axisymmetric") or {}, bending_form=form)
    run = AxisymmetricRun(scene_from_dict(data))
    s = run.settings
    return simulate(
        run.zeta,
        **viscosities(s),
        radius=s.mesh.radius,
        t_end=float(tr.times[-1]),
        save_times=tr.times,
        n=s.axisymmetric.n,
        rtol=s.axisymmetric.rtol,
        interpolate=True,
        fluids=axisymmetric_fluids(s.fluid),
        **dict(evolution_options(s), stop_neck=None, stop_ill_posed=False),
    )


def pole_and_equator(x0: np.ndarray) -> tuple[int, np.ndarray]:
    """The pole node (largest z at t = 0) and the nodes on the initial equator (z = 0 to round-off) of
    the initial points ``x0``: the nodes :func:`node_radii` measures."""
    eq = np.flatnonzero(np.abs(x0[:, 2]) < 1e-12 * max(1.0, float(np.abs(x0).max())))
    return int(np.argmax(x0[:, 2])), eq


def node_radii(pole: np.ndarray, equator: np.ndarray, res) -> tuple[float, float]:
    """The radii at the nodes against the twin ``res``, largest deviation over the frames: the pole
    node's height (``pole``, (F, 3) over the frames) and the mean radius of the equator's nodes
    (``equator``, (F, k, 3); nan if k = 0), the nodes of :func:`pole_and_equator`. Nodes lie on both
    formulations' surfaces, so unlike the section radii (a flat section of ``rayleigh_p1`` is O(h^2)
    inside its sphere) this measures flat and curved cells alike."""
    ep = float(np.abs(pole[:, 2] - res.pole_radius).max())
    if equator.shape[1] == 0:
        return ep, float("nan")
    return ep, float(np.abs(np.hypot(equator[..., 0], equator[..., 1]).mean(axis=1) - res.furrow_radius).max())


def compare(path: str, times=PROFILE_TIMES) -> dict:
    """Radii (largest deviation over the frames, its time, the deviation at the last frame; and at
    the nodes, ``node_radii``: :func:`node_radii`) and
    velocity profiles at ``times`` (largest / rms deviation of v_n and |v_t| at the nodes, and
    their scales) of a 3D trajectory against its axisymmetric twin."""
    tr = Trajectory(path, lazy=True)
    res = twin_of(tr)
    ds = tr.ds
    out = {"path": path, "nodes": int(ds.sizes["node"]), "scene": tr.settings.name, "t_end": float(tr.times[-1])}
    for name in ("pole_radius", "furrow_radius"):
        d = np.abs(ds[name].values - getattr(res, name))
        out[name] = (float(d.max()), float(tr.times[np.argmax(d)]), float(d[-1]))
    x0 = ds["points"].isel(time=0).values
    pole, eq = pole_and_equator(x0)
    at = ds["points"].isel(node=[pole, *eq.tolist()]).values  # the frames of these nodes only
    out["node_radii"] = node_radii(at[:, 0], at[:, 1:], res)
    labels = np.arccos(np.clip(x0[:, 2] / np.linalg.norm(x0, axis=1), -1.0, 1.0))
    for t in times:
        if t > tr.times[-1] + 1e-9:
            continue
        k = tr.frame_at(t)
        v, n = ds["velocity"].isel(time=k).values, tr.normals(k)
        vn = np.einsum("nc,nc->n", v, n)
        vt = np.linalg.norm(v - vn[:, None] * n, axis=1)
        e = res.evaluate(k, labels, coordinate="sigma" if res.params["parametrization"] == "lagrangian" else "label")
        dvn, dvt = vn - e["v_n"], vt - np.abs(e["v_s"])
        out[f"profile_{t:g}"] = (
            float(np.abs(dvn).max()),
            float(np.sqrt(np.mean(dvn**2))),
            float(np.abs(dvt).max()),
            float(np.sqrt(np.mean(dvt**2))),
            float(np.abs(e["v_n"]).max()),
            float(np.abs(e["v_s"]).max()),
        )
    out["twin_wall_s"] = res.wall_time
    out["final"] = (
        float(ds["pole_radius"].values[-1]),
        float(ds["furrow_radius"].values[-1]),
        float(res.pole_radius[-1]),
        float(res.furrow_radius[-1]),
    )
    tr.close()
    return out


def _checked(path) -> str:
    """The scene's name of a file ``compare`` can measure; one line for one it cannot: missing, not a
    3D run, or remeshed."""
    if not os.path.exists(path):
        raise CortexError(f"trajectory file '{path}' does not exist")
    tr = Trajectory(path, lazy=True)
    try:
        if tr.settings.model == "axisymmetric" or "node" not in tr.ds.sizes or "velocity" not in tr.ds:
            raise CortexError(f"'{path}' is not a 3D run (its twin is what the axisymmetric model computes)")
        if "mesh_id" in tr.ds:
            raise CortexError(
                f"'{path}' was remeshed: its nodes do not keep their labels, so it has no twin to compare"
            )
    finally:
        tr.close()


def twin_report(paths, convergence: bool = False) -> str:
    """``cortex-ti twin``: Markdown tables of :func:`compare` for the 3D trajectories ``paths``
    (radii over the frames, velocity profiles at :data:`PROFILE_TIMES`), and with ``convergence``
    the error ratios between them (one scene at several node counts). Bad input raises
    :class:`~cortex_ti.errors.CortexError` before any solve."""
    paths = [str(p) for p in paths]
    for path in paths:
        _checked(path)
    rows = [compare(path) for path in paths]
    if convergence and len({r["scene"] for r in rows}) > 1:
        raise CortexError(
            "--convergence compares runs of one scene at several node counts; these are of several scenes"
        )
    out = [
        "| scene | N | t_end | max dev. pole (t) | max dev. furrow (t) | dev. at t_end: pole, furrow | "
        "3D at t_end: pole, furrow | axisymmetric: pole, furrow |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        (pm, pt, pe), (fm, ft, fe) = r["pole_radius"], r["furrow_radius"]
        out.append(
            f"| {r['scene']} | {r['nodes']} | {r['t_end']:g} | {pm:.2e} ({pt:.2f}) | {fm:.2e} ({ft:.2f}) | "
            f"{pe:.2e}, {fe:.2e} | {r['final'][0]:.6f}, {r['final'][1]:.6f} | {r['final'][2]:.6f}, "
            f"{r['final'][3]:.6f} |"
        )
    out += ["", "| scene | N | t | max / rms dev. v_n | max / rms dev. abs v_t | scale v_n, abs v_t |"]
    out.append("|---|---|---|---|---|---|")
    for r in rows:
        for t in PROFILE_TIMES:
            if f"profile_{t:g}" in r:
                a, b, c, d, sn, st = r[f"profile_{t:g}"]
                out.append(
                    f"| {r['scene']} | {r['nodes']} | {t:g} | {a:.1e} / {b:.1e} | {c:.1e} / {d:.1e} | "
                    f"{sn:.3f}, {st:.3f} |"
                )
    if convergence and len(rows) > 1:
        rows.sort(key=lambda r: r["nodes"])
        out += [
            "",
            "| N | max radius error | ratio to the next coarser | error at t_end | ratio |",
            "|---|---|---|---|---|",
        ]
        prev = None
        for r in rows:
            e = max(r["pole_radius"][0], r["furrow_radius"][0])
            ee = max(r["pole_radius"][2], r["furrow_radius"][2])
            ratio = "" if prev is None else f"{prev[0] / e:.2f}"
            ratio_e = "" if prev is None else f"{prev[1] / ee:.2f}"
            out.append(f"| {r['nodes']} | {e:.2e} | {ratio} | {ee:.2e} | {ratio_e} |")
            prev = (e, ee)
    return "\n".join(out)
