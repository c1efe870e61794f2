"""Where and when a stored run's smallest triangle angle falls (``cortex-ti angles``).

The smallest angle per frame (:func:`cortex_ti.surface.remesh.min_angles`, on each frame's own mesh,
so a remeshed run's too), and at the worst frame how many triangles are below a threshold and the
worst ones: their smallest angle there and at t = 0, their polar angle on the initial mesh about the
pattern axis z (where on the body they started), and the mean tension of their corners. A remeshed
run's triangles change from mesh to mesh: its rows give the worst frame's triangles only.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import CortexError

__all__ = ["angle_report"]


def angle_report(trajectory: str | os.PathLike, below: float = 30.0, worst: int = 4) -> str:
    """The report (Markdown) of ``trajectory`` (a finished run or its ``.partial``): the smallest
    angle per frame, then at the worst frame the triangles below ``below`` degrees and the ``worst``
    smallest. Bad input raises :class:`~cortex_ti.errors.CortexError`."""
    if not (np.isfinite(below) and 0.0 < below < 60.0):
        raise CortexError(f"--below must be an angle in degrees between 0 and 60, got {below:g}")
    if worst < 0:
        raise CortexError(f"--worst must be >= 0, got {worst}")
    if not os.path.exists(trajectory):
        raise CortexError(f"trajectory file '{trajectory}' does not exist")
    from ..surface.remesh import min_angles
    from .trajectory import Trajectory

    tr = Trajectory(trajectory)
    t = np.asarray(tr.times, dtype=float)
    meshes = [tr.mesh(k) for k in range(len(t))]
    per = [min_angles(pts, tri) for pts, tri in meshes]
    out = [
        "| t | " + " | ".join(f"{x:.3g}" for x in t) + " |",
        "|---|" + "---|" * len(t),
        "| smallest angle (deg) | " + " | ".join(f"{a.min():.1f}" for a in per) + " |",
    ]
    k = int(np.argmin([a.min() for a in per]))
    pts, tri = meshes[k]
    one_mesh = not tr.remeshed
    x0 = meshes[0][0]
    if one_mesh:
        c0 = x0[tri].mean(1) - x0.mean(0)
        polar = np.degrees(np.arccos(np.clip(c0[:, 2] / np.linalg.norm(c0, axis=1), -1.0, 1.0)))
    bad = np.flatnonzero(per[k] < below)
    where = (
        f", initial polar angles {polar[bad].min():.0f} to {polar[bad].max():.0f} deg" if bad.size and one_mesh else ""
    )
    out += ["", f"At t = {t[k]:.3g}: {bad.size} of {tri.shape[0]} triangles below {below:g} deg{where}", ""]
    if worst:
        out += ["| triangle | angle (deg) | at t = 0 | initial polar angle (deg) | tension |", "|---|---|---|---|---|"]
        zeta = tr.nodal("active_stress", k)
        for w in np.argsort(per[k])[:worst]:
            then = f"{per[0][w]:.1f}" if one_mesh else "-"
            start = f"{polar[w]:.0f}" if one_mesh else "-"
            out.append(f"| {w} | {per[k][w]:.1f} | {then} | {start} | {zeta[tri[w]].mean():.2f} |")
    return "\n".join(out)
