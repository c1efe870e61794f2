"""3D trajectories against the axisymmetric solution of their own scene (the same model).

For a 3D trajectory of an axisymmetric scene, :func:`compare` solves the scene again with the
axisymmetric model at the file's frame times (~1 s) and measures the radii and the velocity
profiles at the same points (the label theta0 = a node's polar angle on the initial sphere: both
codes move their points with the normal velocity, whatever carries the tension).
"""

from __future__ import annotations

import numpy as np

from ..io.trajectory import Trajectory
from ..scene import scene_from_dict
from .evolve import simulate
from .run import AxisymmetricRun, evolution_options, viscosities

__all__ = ["PROFILE_TIMES", "twin_of", "compare"]

PROFILE_TIMES = (0.1, 1.5, 3.0)


def twin_of(tr: Trajectory):
    """The axisymmetric solution of the trajectory's scene at its frame times."""
    run = AxisymmetricRun(scene_from_dict(dict(tr.scene.data, model="axisymmetric")))
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
        **dict(evolution_options(s), stop_neck=None, stop_ill_posed=False),
    )


def compare(path: str, times=PROFILE_TIMES) -> dict:
    """Radii (largest deviation over the frames, its time, the deviation at the last frame) and
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
