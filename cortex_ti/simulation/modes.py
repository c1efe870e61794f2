"""The growing and the stiffest modes of a stored frame (``cortex-ti modes``), on that frame's own
mesh (a remeshed run's too).

The eigenvalues of the linearised normal dynamics (:func:`cortex_ti.dynamics.spectrum.normal_spectrum`,
dense) of largest real part and of most negative real part, and for each: how localised it is
(effective nodes: the inverse participation ratio of its area-weighted square), where its largest
entry is, the shortest edge there, whether it alternates in sign between neighbouring nodes (a
mesh-scale mode) or not (a smooth one), and the smaller principal value of the state's surface
stress there (tension plus viscous, :func:`cortex_ti.analysis.diagnostics.surface_stress`): without
bending resistance a compressed cortex wrinkles at the mesh scale, so a growing mode on a few nodes
where it is negative is that (docs/validation/remesh_constriction.md, "The mode after a remeshing").

With the semi-implicit tension the linearisation depends on the step (it is in the matrix): the
steps to take it at are given (default: the frame's own). A growing mode (Re lambda > 0) grows at
any time step: the step is not the cause. A stiff one (Re lambda < 0) bounds the step of the
extrapolated BDF2 at ``4/3 / |lambda|`` (:attr:`cortex_ti.dynamics.schemes.BDF2.explicit_interval`).

The run's guard names this command when a run stops on a mode that grows at any step
(:mod:`cortex_ti.dynamics.guard`).
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import CortexError

__all__ = ["DENSE_NODES", "frame_modes"]

#: the largest frame whose modes are computed (all eigenvectors of a dense Jacobian: N^2 memory, N^3 time)
DENSE_NODES = 3000


def _describe(pts, tri, w, v, j, area, hmin, explicit, stress) -> str:
    """One table row: the eigenvalue, the step limit, and the mode's size, place, edge, sign flips and
    the smaller principal stress of the state at its largest entry (``stress``: per node, the least
    over its triangles)."""
    s = np.real(v[:, j])
    p = s * s * area / np.sum(s * s * area)
    top = int(np.argmax(p))
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    big = np.abs(s) > 0.1 * np.abs(s).max()
    pair = big[edges[:, 0]] & big[edges[:, 1]]
    flips = float(np.mean(np.sign(s[edges[pair, 0]]) != np.sign(s[edges[pair, 1]]))) if pair.any() else 0.0
    limit = f"{explicit / abs(w[j]):.3g}" if w[j].real < 0 else "-"
    return (
        f"| {w[j].real:.4g}{w[j].imag:+.2g}i | {limit} | {1.0 / np.sum(p * p):.0f} | "
        f"z = {pts[top, 2]:.3f}, r = {np.hypot(pts[top, 0], pts[top, 1]):.3f} | {hmin[top]:.4f} | "
        f"{100 * flips:.0f} % | {stress[top]:.3g} |"
    )


def _check(times, dts, growing: int, stiffest: int) -> None:
    if growing < 0 or stiffest < 0 or growing + stiffest == 0:
        raise CortexError(f"--growing and --stiffest must be >= 0 and not both 0, got {growing} and {stiffest}")
    bad = [dt for dt in dts or () if not (np.isfinite(dt) and dt >= 0)]
    if bad:
        raise CortexError(f"--dt must be finite and >= 0, got {bad[0]:g}")
    bad = [t for t in times or () if not np.isfinite(t)]
    if bad:
        raise CortexError(f"--time must be finite, got {bad[0]:g}")


def frame_modes(
    trajectory: str | os.PathLike,
    times=None,
    dts=None,
    growing: int = 4,
    stiffest: int = 0,
) -> str:
    """The report (Markdown: one heading line and one table per frame and step) of the ``growing``
    modes of largest real part and the ``stiffest`` of most negative real part, at the frames of
    ``trajectory`` (a finished run or its ``.partial``) nearest ``times`` (default: the last), each
    linearised at every step of ``dts`` (default: the frame's own). Bad input raises
    :class:`~cortex_ti.errors.CortexError` before anything is solved."""
    _check(times, dts, growing, stiffest)
    from ..analysis.diagnostics import surface_stress
    from ..dynamics.schemes import BDF2
    from ..dynamics.spectrum import normal_spectrum
    from ..dynamics.state import State
    from ..io.trajectory import Trajectory
    from ..surface.remesh import min_angles
    from ..surface.transport import dual_areas
    from . import Simulation
    from .run import frame_fields

    if not os.path.exists(trajectory):
        raise CortexError(f"trajectory file '{trajectory}' does not exist")
    tr = Trajectory(trajectory)
    if tr.scene.settings.fluid is not None:
        raise CortexError(
            f"'{trajectory}' is a run with the effect 'fluids': the modes of its frames are not implemented (the "
            "linearisation has no shape derivative of the fluids' operator, and their dense solve keeps no "
            "factorisation to linearise with)"
        )
    t_all = np.asarray(tr.times, dtype=float)
    if times:
        half = 0.5 * float(np.max(np.diff(t_all))) if len(t_all) > 1 else 0.0
        outside = [t for t in times if t < t_all[0] - half or t > t_all[-1] + half]
        if outside:
            raise CortexError(
                f"--time {outside[0]:g} is outside '{trajectory}': its frames are at t = {t_all[0]:g} to {t_all[-1]:g}"
            )
    frames = [len(t_all) - 1] if not times else [tr.frame_at(t) for t in times]
    out = []
    for k in frames:
        pts, tri = tr.mesh(k)
        if len(pts) > DENSE_NODES:
            raise CortexError(
                f"frame {k} of '{trajectory}' has {len(pts)} nodes: the modes of a frame are computed densely, "
                f"for up to {DENSE_NODES} nodes"
            )
        edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
        length = np.linalg.norm(pts[edges[:, 0]] - pts[edges[:, 1]], axis=1)
        hmin = np.full(len(pts), np.inf)
        np.minimum.at(hmin, edges[:, 0], length)
        np.minimum.at(hmin, edges[:, 1], length)
        area = dual_areas(pts, tri)
        own = float(tr.ds["dt"].values[k]) if "dt" in tr.ds else 0.0
        for dt in dts or [own]:
            sim = Simulation(tr.scene)
            sim.use_mesh(pts, tri)
            # the fields the frame's nodes carried (a myosin density too), so the tension is the frame's
            stored = {spec.var: tr.nodal(spec.var, k) for spec in sim.fields if spec.var in tr.ds}
            where = f"{trajectory} at frame {k}"
            sim.state0 = State(pts, frame_fields(sim, stored, tr.nodal("active_stress", k), where), tri)
            sp = normal_spectrum(sim, pts, dt=dt, modes=True, dense=True)
            w, v = np.asarray(sp.eigenvalues), np.asarray(sp.modes)
            phys = sim.physics
            principal = surface_stress(pts, tri, sim.solve(pts, dt=dt).velocity, sim.zeta, phys.eta_s, phys.eta_b)
            stress = np.full(len(pts), np.inf)
            for c in range(3):
                np.minimum.at(stress, tri[:, c], principal[:, 0])
            out.append(
                f"# t = {float(t_all[k]):.4g}: {len(pts)} nodes, edges {length.min():.4f} - {length.max():.4f} R0, "
                f"smallest angle {min_angles(pts, tri).min():.1f} deg; linearised at dt = {dt:g}; surface stress "
                f"(tension + viscous) compressive on {int(np.sum(principal[:, 0] < 0))} of {len(tri)} triangles "
                f"(smallest principal value {principal[:, 0].min():.3g})\n"
            )
            out.append(
                "| lambda (1/t_a) | BDF2 step limit | effective nodes | where (z, r of its largest entry) | "
                "shortest edge there | sign changes between neighbours | smaller principal stress there |"
            )
            out.append("|---|---|---|---|---|---|---|")
            shown = list(range(min(growing, len(w))))
            shown += [j for j in range(len(w) - 1, len(w) - 1 - stiffest, -1) if j not in shown]
            out += [_describe(pts, tri, w, v, j, area, hmin, BDF2.explicit_interval, stress) for j in shown]
            out.append("")
    return "\n".join(out)
