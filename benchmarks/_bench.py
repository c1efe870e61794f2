"""The one helper module of the benchmarks: every script in ``benchmarks/`` imports it as a sibling
(``import _bench``; a script in ``benchmarks/investigations/`` puts ``benchmarks/`` on its path first).

* the header every report opens with (:func:`header`): the commit (from
  :func:`cortex_ti.provenance`), the date (UTC), the machine and the command, one format for every
  page (``page.py`` uses the same :func:`machine` and commit);
* section-wise reports (:func:`run_sections`);
* a table block of a page rewritten in place (:func:`write_block`), the fixed SciPy workload that
  times are quoted against (:func:`reference_seconds`);
* what the ``--smoke`` modes share: the help text, a temporary folder, a tiny trajectory.

A smoke mode runs a benchmark's own code path on a tiny case (162 nodes, a few steps) in seconds,
writing only into a temporary folder, so ``tests/repository/test_benchmarks.py`` can run every
benchmark and a broken one fails a test. Its numbers mean nothing.
"""

from __future__ import annotations

import os
import platform
import re
import shlex
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

HELP = (
    "smoke test: a tiny case (162 nodes, a few steps, files in a temporary folder) that checks the "
    "script runs, in seconds; its numbers mean nothing"
)


def commit(short: bool = True) -> str:
    """The checkout's commit as :func:`cortex_ti.provenance` records it (``-dirty`` with uncommitted
    changes, ``unknown`` outside a git checkout); ``short``: its first 7 digits."""
    from cortex_ti import provenance

    full = provenance()["cortex_ti_commit"]
    if not short or full == "unknown":
        return full
    return full[:7] + ("-dirty" if full.endswith("-dirty") else "")


def machine() -> str:
    """CPU model, cores, memory and OS of this machine, in one line."""
    cpu = platform.processor() or platform.machine()
    try:
        info = Path("/proc/cpuinfo").read_text()
        cpu = re.search(r"^model name\s*:\s*(.+)$", info, flags=re.M).group(1).strip()
    except (OSError, AttributeError):
        pass
    mem = ""
    try:
        kb = int(re.search(r"^MemTotal:\s*(\d+)", Path("/proc/meminfo").read_text(), flags=re.M).group(1))
        mem = f", {kb / 2**20:.0f} GB"
    except (OSError, AttributeError):
        pass
    return f"{cpu}, {os.cpu_count()} cores{mem}, {platform.system()} {platform.release()}"


def header(argv: list[str] | None = None, note: str = "") -> str:
    """The one header of a benchmark's report, an HTML comment (invisible on the site, kept in the
    page's source): commit, date, machine and the command (``argv``: ``sys.argv`` by default), then
    ``note`` (what else the numbers depend on, e.g. the threads)."""
    argv = list(sys.argv if argv is None else argv)
    script = Path(argv[0])
    where = script.parent.name
    name = f"benchmarks/{script.name}" if where == "benchmarks" else f"benchmarks/{where}/{script.name}"
    when = datetime.now(timezone.utc)
    extra = f"; {note}" if note else ""
    return (
        f"<!-- measured at commit {commit()} on {when:%Y-%m-%d %H:%M} UTC, {machine()}{extra}; "
        f"`{shlex.join(['python', name, *argv[1:]])}` -->\n"
    )


def run_sections(sections: dict, chosen, argv: list[str] | None = None) -> None:
    """Print the :func:`header`, then run the ``chosen`` ``sections`` (all when empty) in order,
    each followed by a comment with its wall time."""
    print(header(argv))
    for name in chosen or sections:
        t0 = time.perf_counter()
        sections[name]()
        print(f"<!-- section {name}: {time.perf_counter() - t0:.0f} s -->\n", flush=True)


def write_block(page: Path, text: str, name: str) -> None:
    """Replace the block between ``<!-- name:begin -->`` and ``<!-- name:end -->`` of ``page`` with
    ``text`` (appended when the page has none), atomically."""
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    body = page.read_text() if page.exists() else f"{begin}\n{end}\n"
    if begin not in body or end not in body:
        body += f"\n{begin}\n{end}\n"
    pre, rest = body.split(begin, 1)
    _, post = rest.split(end, 1)
    tmp = page.with_suffix(".tmp")
    tmp.write_text(f"{pre}{begin}\n{text}{end}{post}")
    os.replace(tmp, page)


def reference_seconds(repeats: int = 5) -> float:
    """Best of ``repeats`` wall times of a fixed SciPy workload: SuperLU factorisation and solve
    of the 5-point Laplacian on a 160 x 160 grid (~0.1 s on an idle 2-core machine)."""
    import numpy as np
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    n = 160
    lap = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    a = (sp.kron(lap, sp.eye(n)) + sp.kron(sp.eye(n), lap)).tocsc()
    b = np.ones(n * n)
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        spla.splu(a).solve(b)
        best = min(best, time.perf_counter() - t)
    return best


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
