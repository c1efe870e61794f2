"""What the benchmarks' ``--smoke`` modes share: the help text, a temporary folder, and a tiny
trajectory for the scripts that measure a stored run.

A smoke mode runs a benchmark's own code path on a tiny case (162 nodes, a few steps) in seconds,
writing only into a temporary folder, so ``tests/repository/test_benchmarks.py`` can run every benchmark and a
broken one fails a test. Its numbers mean nothing.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

HELP = (
    "smoke test: a tiny case (162 nodes, a few steps, files in a temporary folder) that checks the "
    "script runs, in seconds; its numbers mean nothing"
)


def folder() -> Path:
    """A fresh temporary folder for a smoke run's files."""
    return Path(tempfile.mkdtemp(prefix="cortex-ti-smoke-"))


def tiny_run(
    scene: str = "furrow_p4_a1",
    t_end: float = 0.05,
    nodes: int = 162,
    where: Path | None = None,
    overrides=(),
    name: str | None = None,
) -> Path:
    """Run ``scene`` on a tiny mesh to ``t_end`` and return its trajectory file (in a temporary folder)."""
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation.core import Simulation

    where = where or folder()
    scene_ = load_scene(scene, [f"mesh.nodes={nodes}", f"time.t_end={t_end}", *overrides])
    return Simulation(scene_).run(where / f"{name or scene}.h5", progress=False)
