"""The growing and the stiffest modes of a stored frame (``cortex-ti modes``), on that frame's own
mesh (a remeshed run's too).

The eigenvalues of the linearised normal dynamics (:func:`cortex_ti.dynamics.spectrum.normal_spectrum`)
of largest real part and of most negative real part, and for each: how localised it is
(effective nodes: the inverse participation ratio of its area-weighted square), where its largest
entry is, the shortest edge there, whether it alternates in sign between neighbouring nodes (a
mesh-scale mode) or not (a smooth one), and the smaller principal value of the state's surface
stress there (tension plus viscous, :func:`cortex_ti.analysis.diagnostics.surface_stress`): without
bending resistance a compressed cortex wrinkles at the mesh scale, so a growing mode on a few nodes
where it is negative is that (docs/validation/remesh_constriction.md, "The mode after a remeshing").

Up to :data:`DENSE_NODES` nodes all eigenvalues are computed densely (LAPACK); a larger frame, or
any with ``sparse``, by ARPACK on the matrix-free Jacobian (one back-substitution per product):
``which='LR'`` for the growing modes and ``'SR'`` for the stiffest, each to the relative residual
:data:`ARPACK_TOL` (an eigenvalue is then within about ``kappa * ARPACK_TOL * |lambda|`` of the
Jacobian's, ``kappa`` its condition number; docs/derivations/modes_arpack.md). A frame of several
bodies (after a division) is linearised body by body, each with its own volume constraint and gauge
(:class:`cortex_ti.dynamics.spectrum.BodyJacobians`).

With the semi-implicit tension the linearisation depends on the step (it is in the matrix): the
steps to take it at are given (default: the frame's own). A growing mode (Re lambda > 0) grows at
any time step: the step is not the cause. A stiff one (Re lambda < 0) bounds the step of the run's
explicit extrapolation at ``c / |lambda|``, ``c`` the run's scheme's
:attr:`~cortex_ti.dynamics.schemes.Scheme.explicit_interval` (4/3 for bdf2, 20/21 for bdf3, 2 for euler).

The run's guard names this command when a run stops on a mode that grows at any step
(:mod:`cortex_ti.dynamics.guard`).
"""

from __future__ import annotations

import os

import numpy as np
from scipy.sparse.linalg import ArpackNoConvergence

from ..errors import CortexError

__all__ = ["ARPACK_TOL", "DENSE_NODES", "frame_modes"]

#: the largest frame whose modes are computed densely (all eigenvectors: N^2 memory, N^3 time); ARPACK above
DENSE_NODES = 3000

#: ARPACK's relative residual of a converged eigenpair, ``|J x - lambda x| <= tol |lambda|`` (x of norm 1)
ARPACK_TOL = 1e-8


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


def _spectrum(normal_spectrum, sim, pts, dt, growing, stiffest, arpack):
    """The eigenvalues (largest real part first) and modes: all of them densely, or by ARPACK the
    ``growing`` of largest real part and, after them, the ``stiffest`` of smallest real part."""
    if not arpack:
        sp = normal_spectrum(sim, pts, dt=dt, modes=True, dense=True)
        return np.asarray(sp.eigenvalues), np.asarray(sp.modes), "dense"
    from ..dynamics.spectrum import normal_jacobian

    jac = normal_jacobian(sim, pts, dt)  # once for both ends
    parts = []
    for count, which in ((growing, "LR"), (stiffest, "SR")):
        if count:
            # a few more than shown: ARPACK converges the wanted end of the spectrum better with room
            try:
                sp = normal_spectrum(
                    sim, pts, dt=dt, k=count + 4, dense=False, modes=True, which=which, tol=ARPACK_TOL, jacobian=jac
                )
            except ArpackNoConvergence as err:
                raise CortexError(
                    f"ARPACK (which='{which}') did not converge to {count + 4} eigenvalues of this {len(pts)}-node "
                    f"frame: {len(err.eigenvalues)} converged (fewer --growing/--stiffest, or a frame of <= "
                    f"{DENSE_NODES} nodes densely)"
                ) from None
            w, v = np.asarray(sp.eigenvalues), np.asarray(sp.modes)
            keep = slice(0, count) if which == "LR" else slice(len(w) - count, len(w))
            parts.append((w[keep], v[:, keep]))
    w = np.concatenate([p[0] for p in parts])
    v = np.concatenate([p[1] for p in parts], axis=1)
    return w, v, f"ARPACK, relative residual {ARPACK_TOL:g}"


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
    sparse: bool = False,
) -> str:
    """The report (Markdown: one heading line and one table per frame and step) of the ``growing``
        modes of largest real part and the ``stiffest`` of most negative real part, at the frames of
        ``trajectory`` (a finished run or its ``.partial``) nearest ``times`` (default: the last), each
        linearised at every step of ``dts`` (default: the frame's own); by ARPACK above :data:`DENSE_NODES`
    nodes or with ``sparse``, densely otherwise. Bad input raises
        :class:`~cortex_ti.errors.CortexError` before anything is solved."""
    _check(times, dts, growing, stiffest)
    from ..analysis.diagnostics import surface_stress
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
    scheme = tr.scene.settings.time.scheme
    interval = tr.scene.settings.time.scheme_class.explicit_interval
    out = []
    for k in frames:
        pts, tri = tr.mesh(k)
        arpack = sparse or len(pts) > DENSE_NODES
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
            w, v, how = _spectrum(normal_spectrum, sim, pts, dt, growing, stiffest, arpack)
            phys = sim.physics
            principal = surface_stress(pts, tri, sim.solve(pts, dt=dt).velocity, sim.zeta, phys.eta_s, phys.eta_b)
            stress = np.full(len(pts), np.inf)
            for c in range(3):
                np.minimum.at(stress, tri[:, c], principal[:, 0])
            out.append(
                f"# t = {float(t_all[k]):.4g}: {len(pts)} nodes, edges {length.min():.4f} - {length.max():.4f} R0, "
                f"smallest angle {min_angles(pts, tri).min():.1f} deg; linearised at dt = {dt:g} ({how}); "
                f"surface stress (tension + viscous) compressive on {int(np.sum(principal[:, 0] < 0))} of {len(tri)} "
                f"triangles (smallest principal value {principal[:, 0].min():.3g})\n"
            )
            out.append(
                f"| lambda (1/t_a) | {scheme} step limit | effective nodes | where (z, r of its largest entry) | "
                "shortest edge there | sign changes between neighbours | smaller principal stress there |"
            )
            out.append("|---|---|---|---|---|---|---|")
            shown = list(range(min(growing, len(w))))
            shown += [j for j in range(len(w) - 1, len(w) - 1 - stiffest, -1) if j not in shown]
            out += [_describe(pts, tri, w, v, j, area, hmin, interval, stress) for j in shown]
            out.append("")
    return "\n".join(out)
