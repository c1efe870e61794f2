"""The one helper module of the benchmarks: every script in ``benchmarks/`` imports it as a sibling
(``import _bench``; a script in ``benchmarks/investigations/`` puts ``benchmarks/`` on its path first).

* the header every report opens with (:func:`header`): the commit (from
  :func:`cortex_ti.provenance`), the date (UTC), the machine and the command, one format for every
  page (``page.py`` uses the same :func:`machine` and commit);
* section-wise reports (:func:`run_sections`);
* a table block of a page rewritten in place (:func:`write_block`), the fixed SciPy workload that
  times are quoted against (:func:`reference_seconds`);
* measurements several scripts take: the first solve of a scene against the exact sphere flow
  (:func:`t0_error`), the axisymmetric twin of a ring furrow (:func:`twin`, :func:`at`);
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

import numpy as np

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


def run_command(scene: str, out, summary, sets=(), force: bool = False) -> list[str]:
    """The ``cortex-ti run`` command of one timed benchmark run: ``scene`` to ``out`` on one thread, its
    summary to ``summary``, each of ``sets`` a ``--set KEY=VALUE`` (in order), ``--force`` if asked."""
    cmd = ["cortex-ti", "run", scene, "-o", str(out), *(["--force"] if force else []), "--threads", "1"]
    cmd += ["--summary", str(summary)]
    for kv in sets:
        cmd += ["--set", kv]
    return cmd


def timed_command(cmd: list[str], who: str) -> tuple[float, float]:
    """Run ``cmd`` in a child process on one thread (OpenMP, MKL, OpenBLAS); its wall seconds and CPU
    seconds (user + system of the child). A failure ends the benchmark naming ``who`` and the command."""
    import resource
    import subprocess

    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    started = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - started
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{who}: {' '.join(cmd)} failed:\n{proc.stderr[-2000:]}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


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


def t0_error(scene_name: str, nodes: int, fit: str, formulation: str, bending: bool, overrides=()) -> dict:
    from cortex_ti.physics.patterns import evaluate_active_stress
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.truth.analytic import error_measures
    from cortex_ti.truth.sphere_exact import sphere_flow

    ov = [
        f"mesh.nodes={nodes}",
        f"numerics.fit={fit}",
        f"numerics.formulation={formulation}",
        "solver.reuse=false",
        *overrides,
    ]
    base = load_scene(scene_name, ov)
    drop = ("shape_evolution",) if bending else ("bending_viscosity", "shape_evolution")
    extra = [] if bending else ["viscosity.bending=0", "viscosity.bending_bulk=0"]
    effects = "effects=[" + ",".join(sorted(e for e in base.effects if e not in drop)) + "]"
    scene = load_scene(scene_name, ov + extra + [effects])
    sim = Simulation(scene)
    t0 = time.perf_counter()
    sol = sim.solve()
    wall = time.perf_counter() - t0
    s = scene.settings
    v = s.viscosity
    pats = list(s.patterns)
    x = sim.mesh.points
    exact, p_exact, info = sphere_flow(
        lambda p: evaluate_active_stress(p, pats),
        x,
        eta_s=v.shear,
        eta_b=v.bulk,
        eta_bar=v.bending if bending else 0.0,
        eta_bar_b=v.bending_bulk if bending else 0.0,
        lmax="auto",
        tol=1e-6,
    )
    n = x / np.linalg.norm(x, axis=1)[:, None]
    pole = int(np.argmax(x @ np.asarray(s.pattern_axis)))
    return dict(
        scene=scene_name,
        nodes=nodes,
        fit=fit,
        formulation=formulation,
        bending=bending,
        eps_rel=error_measures(sol.velocity, exact)[1],
        pole_vn=float(sol.velocity[pole] @ n[pole]),
        pole_exact=float(exact[pole] @ n[pole]),
        pressure=sol.pressure,
        pressure_exact=float(p_exact),
        truncation=float(info["truncation_error_rel"]),
        seconds=wall,
    )


def twin(amplitude: float, t_end: float, where, scene: str) -> dict:
    """The axisymmetric model of the same scene: its furrow radius over time, the time its material
    stretch passes the limit (inf: never) and why it stopped."""
    from cortex_ti.axisymmetric.evolve import first_unresolved
    from cortex_ti.io.trajectory import load_trajectory
    from cortex_ti.models import MODELS
    from cortex_ti.scene import load_scene

    sets = ["model=axisymmetric", "mesh.remesh.min_angle=null", f"active_stress.0.amplitude={amplitude}"]
    scene_ = load_scene(scene, [*sets, f"time.t_end={t_end}", "time.save_every=0.05"])
    runner = MODELS["axisymmetric"].build(scene_, "cpu", 1)
    out = where / f"axisym_a{amplitude:g}.h5"
    runner.run(out, progress=False, force=True)
    ds = load_trajectory(out)
    if "label_resolved" in ds:  # the run judged it by its own points' limit (adaptive: only a fold)
        bad = np.flatnonzero(ds["label_resolved"].values < 0.5)
        k = int(bad[0]) if bad.size else None
    else:
        k = first_unresolved(ds["material_stretch"].values)
    return {
        "times": ds["time"].values,
        "furrow": ds["furrow_radius"].values,
        "stopped": runner.summary()["stopped"],
        "resolved_until": float("inf") if k is None else float(ds["time"].values[k]),
    }


def at(times, values, t):
    """The value at the frame nearest ``t`` (NaN past the last frame)."""
    if t > times[-1] + 1e-9:
        return float("nan")
    return float(values[int(np.argmin(np.abs(times - t)))])
