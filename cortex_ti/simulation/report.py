"""How a run ended and what it cost: :class:`RunReport`, :data:`STOP_REASONS`, :func:`run_summary`.

A run (:func:`cortex_ti.simulation.run.run_scene`) returns its :class:`RunReport`; one that raises
carries it on the exception (``exc.run_report``), and :meth:`Simulation.run
<cortex_ti.simulation.core.Simulation.run>` keeps it as ``sim.report`` either way.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..dynamics.integrate import RunStats
from ..errors import MeshError, SceneError, SolverError, StabilityError
from ..io.files import OutputError

if TYPE_CHECKING:  # pragma: no cover
    from .core import Simulation

__all__ = ["STOP_REASONS", "EXIT_CODES", "RunReport", "stop_reason", "run_summary"]

#: Why a run ended (the summary's ``stopped``): the value, and what it means.
STOP_REASONS = {
    "static": "a static scene: solved once",
    "t_end": "reached time.t_end",
    "steady": "max |v_n| fell below time.steady_tol",
    "neck": "the neck radius fell to time.stop_neck (the axisymmetric model: or to axisymmetric.stop_neck)",
    "interrupted": "SIGINT (Ctrl-C) or SIGTERM: the frames so far are kept for --resume",
    "guard": "the stability guard stopped it (dynamics.guard)",
    "solver": "a solve failed",
    "io": "writing a file failed (full disk, I/O error)",
    "input": "the input was refused (the scene, its mesh, a pattern, an option): most before the run started",
    "error": "another error",
}

#: Exit status of ``cortex-ti`` by how it ended.
EXIT_CODES = {
    "ok": 0,
    "error": 2,  # bad input, a failed solve, the guard, a file that cannot be written: one line
    "internal": 1,  # a bug: the traceback is kept
    "SIGINT": 130,  # 128 + 2, as a shell reports Ctrl-C
    "SIGTERM": 143,  # 128 + 15
}


def stop_reason(exc: BaseException | None) -> str:
    """The :data:`STOP_REASONS` value of a run that raised ``exc``."""
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted"
    if isinstance(exc, StabilityError):
        return "guard"
    if isinstance(exc, SolverError):
        return "solver"
    if isinstance(exc, (OutputError, OSError)):
        return "io"
    if isinstance(exc, (SceneError, MeshError)):
        return "input"
    return "error"


@dataclass
class RunReport:
    """What a run did: the file it wrote (or the partial file it kept) and, for a dynamic run, its
    steps and solves; ``stopped`` one of :data:`STOP_REASONS`."""

    path: Path
    stats: RunStats | None = None  # None for a static run
    stopped: str = "static"
    solved: int = 1  # solves of a static run (0 if it failed before its solve)

    @property
    def solves(self) -> int:
        return self.solved if self.stats is None else self.stats.solves


def run_summary(sim: Simulation) -> dict:
    """What ``sim``'s last run took (steps, solves, time per stage), and how it was set up."""
    s = sim.settings
    report = sim.report
    st = sim.stats
    solves = report.solves if report is not None else 0
    stopped = report.stopped if report is not None else "static"
    out = {
        "scene": s.name,
        "model": s.model,
        "n_nodes": sim.mesh.n_nodes,
        "fit": s.numerics.fit,
        "solver_backend": s.solver_name,
        "effects": sorted(s.effects),
        "steps": st.steps if st is not None else 0,
        "rejected": st.rejected if st is not None else 0,
        "solves": solves,
        "t_reached": st.t if st is not None else 0.0,
        "stopped": stopped,
        "implicit_tension": s.time.implicit_tension,
        "formulation": s.numerics.formulation,
        "fit_residual_weight": s.numerics.fit_residual_weight,
    }
    out.update({f"ms_{k}_per_solve": 1e3 * v / max(solves, 1) for k, v in sim.seconds.items()})
    out.update(factorizations=sim.solver.n_factorizations, krylov_iterations=sim.solver.n_iterations)
    if s.mesh.remesh is not None:
        out.update(
            remeshes=st.remeshes if st is not None else 0,
            remesh_seconds=st.remesh_wall if st is not None else 0.0,
            symbolic_analyses=sim.solver.n_analyses,
            final_nodes=sim.mesh.n_nodes,
        )
    return out


class _ProgressBar:
    """tqdm bar over simulated time; silent when stderr is not a terminal."""

    def __init__(self, t0: float, t_end: float):
        from tqdm import tqdm

        self._bar = tqdm(
            total=round(t_end, 6),
            initial=round(t0, 6),
            unit="t_a",
            disable=None,
            bar_format="{l_bar}{bar}| t={n:.3f}/{total:.3f} [{elapsed}<{remaining}{postfix}]",
        )
        self._t = t0
        self._start = time.perf_counter()

    def __call__(self, t, ev, dt, stats):
        if self._bar.disable:
            return
        self._bar.update(round(t - self._t, 6))
        self._t = t
        rate = stats.steps / max(time.perf_counter() - self._start, 1e-9)
        vmax = float(np.max(np.abs(ev.normal_speed)))
        self._bar.set_postfix_str(f"{rate:.1f} steps/s, dt={dt:.2g}, max|v_n|={vmax:.2e}", refresh=False)

    def close(self):
        self._bar.close()
