"""What an axisymmetric run says about frames it did not converge (the methods of
:class:`RunChecks`, mixed into :class:`cortex_ti.axisymmetric.run.AxisymmetricRun`, on its ``settings``):
each is one warning line from the first such frame, in the run's own log."""

from __future__ import annotations

import logging

import numpy as np

log = logging.getLogger("cortex_ti.axisymmetric.run")  # the run's log: what it says is said of the run


class RunChecks:
    """Warnings about a finished simulation's result ``res`` (needs ``self.settings``)."""

    def _warn_compressed(self, res) -> None:
        """One line when the cortex turns compressive without bending resistance: its short waves
        then grow the faster the shorter, so the frames after it stop converging in n
        (docs/validation/constriction.md, "Where the model ends")."""
        bad = np.flatnonzero(np.asarray(res.min_stress) < 0.0)
        if bad.size and not (self.settings.has("bending_viscosity") or self.settings.has("bending_rigidity")):
            k = int(bad[0])
            log.warning(
                "%s (axisymmetric): from t = %.4g (neck %.4g R0) the cortex is compressed (smallest principal "
                "stress %.3g): without bending resistance its short waves grow, and the frames after it are "
                "not converged in axisymmetric.n",
                self.settings.name,
                res.t[k],
                res.neck_radius[k] if np.isfinite(res.neck_radius[k]) else res.furrow_radius[k],
                res.min_stress[k],
            )

    def _warn_negative_myosin(self, res) -> None:
        """One line when the myosin density goes negative anywhere: the continuum keeps it >= 0 (carried,
        diluted, diffused and turned over toward c0 > 0), so a negative value past round-off (1e-6 of
        its largest) is the meridian points failing to resolve its profile (a ring that gathers it
        faster than it diffuses: the points' spectral interpolant rings), and the frames from there
        on are not converged in axisymmetric.n: the shape too where the myosin makes tension (its law's
        zeta0 not 0), the myosin alone where it does not (a tracer: ``cytokinesis_rigid``'s)."""
        if res.c is None:
            return
        c = np.asarray(res.c, dtype=float).reshape(len(res.t), -1)
        low, high = c.min(axis=1), np.abs(c).max(axis=1)
        bad = np.flatnonzero(low < -1e-6 * high)
        if bad.size:
            k = int(bad[0])
            tracer = float(self.settings.field("myosin")["tension"]["zeta0"]) == 0.0
            log.warning(
                "%s (axisymmetric): from t = %.4g the myosin density is negative (smallest %.3g, largest %.3g): "
                "its profile is not resolved by axisymmetric.n = %d points (%s), and %s after it are not "
                "converged; raise axisymmetric.n or take axisymmetric.points: adaptive",
                self.settings.name,
                res.t[k],
                low[k],
                high[k],
                self.settings.axisymmetric.n,
                self.settings.axisymmetric.points,
                "its values (not the shape: its tension law's zeta0 is 0)" if tracer else "the frames",
            )
