"""Nothing lost: runs killed at random times, and runs that fill the disk, resumed to the end.

One scene (default ``furrow_p4_a1`` on 642 nodes to t = 0.5) is run once uninterrupted (the
reference), then

* ``--kills`` times: started, sent SIGKILL, SIGTERM or SIGINT (in turn) at a random moment: once
  the run has committed k frames, k drawn uniformly from 0 to the reference's frame count - 1
  (k = 0: at a random moment of its start-up), and then a random fraction of the time between two
  frames later, so kills land anywhere, between the flushes of a frame too (the moment is set by
  the run's progress, not by the clock, which a busy machine stretches); then ``--resume``\\ d to
  the end;
* ``--disk`` times: run with its output on a full disk, then ``--resume``\\ d after space is freed.
  The disk is a tmpfs mounted for the run with a random size between 10 % and 90 % of the final
  file (when this process may mount: root with CAP_SYS_ADMIN), else a file-size limit
  (``RLIMIT_FSIZE``) of that size, which fails the same writes with EFBIG.

For each run it checks: the interrupted command ended as documented (exit 130 / 143 with one
line for SIGINT / SIGTERM, exit 2 with one line for a full disk, no traceback), the partial file
it left is readable (its committed frames), the resumed run ends with exit 0 and no stray file
(``.partial``, ``.lock``, ``.copy``), and the final trajectory equals the reference: the same
frames, every variable within ``--atol`` (1e-12). A file that is missing, unreadable or differs
counts as lost or corrupted. The summary table (markdown) goes to stdout and to ``--table``.

Usage::

    python benchmarks/fault_injection.py                  # 50 kills + 20 full disks (about 20 min on 2 cores)
    python benchmarks/fault_injection.py --smoke          # 1 kill + 1 full disk on 162 nodes (seconds)

Run from a copy of the code (``git archive``) so that editing the checkout does not change the runs
under way; the table then names the commit given as ``CORTEX_TI_COMMIT``.
"""

from __future__ import annotations

import argparse
import os
import random
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

SIGNALS = (signal.SIGKILL, signal.SIGTERM, signal.SIGINT)
EXPECTED_RC = {signal.SIGKILL: -signal.SIGKILL, signal.SIGTERM: 143, signal.SIGINT: 130}


def command(args, out: Path, *extra: str) -> list[str]:
    cmd = [
        sys.executable,
        "-m",
        "cortex_ti",
        "run",
        args.scene,
        "-o",
        str(out),
        "--threads",
        "1",
        "--set",
        f"mesh.nodes={args.nodes}",
        "--set",
        f"time.t_end={args.t_end}",
    ]
    for o in args.set:
        cmd += ["--set", o]
    return cmd + list(extra)


def compare(ref: Path, out: Path, atol: float) -> tuple[bool, float, str]:
    """``(equal, largest difference, why not)`` of two trajectories: every variable but the solver's
    residuals (:data:`~cortex_ti.simulation.run.SOLVE_DIAGNOSTICS`), which measure round-off itself
    (their values, 1e-10 and below, are round-off, and differ between two runs by as much)."""
    from cortex_ti.errors import CortexError
    from cortex_ti.io import load_trajectory
    from cortex_ti.simulation.run import SOLVE_DIAGNOSTICS

    if not out.is_file():
        return False, np.inf, "missing"
    try:
        a, b = load_trajectory(ref), load_trajectory(out)
    except CortexError as exc:
        return False, np.inf, f"unreadable: {exc}"
    if a.sizes != b.sizes or set(a.variables) != set(b.variables):
        return False, np.inf, f"layout differs: {dict(b.sizes)} vs {dict(a.sizes)}"
    worst, where = 0.0, ""
    for name in a.variables:
        if name in SOLVE_DIAGNOSTICS:
            continue
        x, y = np.asarray(a[name].values), np.asarray(b[name].values)
        if x.dtype.kind != "f":
            if not np.array_equal(x, y):
                return False, np.inf, f"{name} differs"
            continue
        if not np.array_equal(np.isnan(x), np.isnan(y)):
            return False, np.inf, f"{name}: NaN in other places"
        ok = ~np.isnan(x)
        if ok.any() and float(np.max(np.abs(x[ok] - y[ok]))) > worst:
            worst, where = float(np.max(np.abs(x[ok] - y[ok]))), name
    return worst <= atol, worst, f"(largest in {where})" if worst <= atol else f"{where} differs by {worst:.3g}"


def strays(folder: Path, keep: set[str]) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


def partial_state(out: Path) -> tuple[str, int]:
    """What the interrupted run left: ``("none" | "ok" | "unreadable", committed frames)``."""
    from cortex_ti.errors import CortexError
    from cortex_ti.io.trajectory import committed_frames, partial_path

    part = partial_path(out)
    if not part.exists():
        return "none", 0
    try:
        return "ok", committed_frames(part)[0]
    except CortexError:
        return "unreadable", 0


def one_line(stderr: str, prefix: str) -> bool:
    lines = [ln for ln in stderr.splitlines() if ln.startswith("cortex-ti:")]
    return len(lines) == 1 and lines[0].startswith(prefix) and "Traceback" not in stderr


def resume(args, out: Path, log) -> subprocess.CompletedProcess:
    res = subprocess.run(command(args, out, "--resume"), capture_output=True, text=True, timeout=3600)
    if res.returncode != 0:
        log(f"    resume failed ({res.returncode}): {res.stderr.strip().splitlines()[-1:]}")
    return res


def wait_for(proc, out: Path, k: int) -> None:
    """Until ``proc`` has committed ``k`` frames (or ended)."""
    from cortex_ti.io.trajectory import committed_frames, partial_path

    part = partial_path(out)
    while proc.poll() is None:
        if part.exists():
            try:
                if committed_frames(part)[0] >= k:
                    return
            except Exception:  # being created
                pass
        time.sleep(0.01)


def kill_run(args, i: int, ref: Path, ref_wall: float, n_frames: int, work: Path, rng: random.Random, log) -> dict:
    sig = SIGNALS[i % len(SIGNALS)]
    folder = work / f"kill{i:03d}"
    folder.mkdir()
    out = folder / "run.h5"
    k = rng.randrange(n_frames)
    proc = subprocess.Popen(command(args, out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.perf_counter()
    if k:
        wait_for(proc, out, k)
        delay = rng.uniform(0.0, ref_wall / n_frames)
    else:
        delay = rng.uniform(0.0, ref_wall / 2)
    time.sleep(delay)
    delay = time.perf_counter() - t0
    finished_first = proc.poll() is not None
    if not finished_first:
        proc.send_signal(sig)
    _, err = proc.communicate(timeout=3600)
    # finished: before the signal, or the signal came during the interpreter's shutdown, after the
    # command was done (the program then ignores it, SIGKILL excepted)
    finished = finished_first or out.exists()
    row = {"kind": signal.Signals(sig).name, "delay": delay, "rc": proc.returncode, "finished": finished}
    if finished:
        row["ended_ok"] = proc.returncode == 0 or (sig == signal.SIGKILL and proc.returncode == -signal.SIGKILL)
    elif sig == signal.SIGKILL:
        row["ended_ok"] = proc.returncode == -signal.SIGKILL
    else:
        row["ended_ok"] = proc.returncode == EXPECTED_RC[sig] and one_line(err, "cortex-ti: interrupted")
    row["partial"], row["frames_kept"] = partial_state(out)
    if not out.exists():
        resume(args, out, log)
    row["equal"], row["diff"], row["why"] = compare(ref, out, args.atol)
    row["strays"] = strays(folder, {"run.h5"})
    return row


def _can_mount() -> bool:
    if os.geteuid() != 0 or not shutil.which("mount"):
        return False
    probe = Path(tempfile.mkdtemp(prefix="mount-probe-"))
    try:
        ok = (
            subprocess.run(
                ["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(probe)], capture_output=True
            ).returncode
            == 0
        )
        if ok:
            subprocess.run(["umount", str(probe)], check=True)
        return ok
    finally:
        probe.rmdir()


def disk_run(args, i: int, ref: Path, size: int, work: Path, rng: random.Random, mount: bool, log) -> dict:
    folder = work / f"disk{i:03d}"
    folder.mkdir()
    limit = int(rng.uniform(0.1, 0.9) * size)
    out = folder / "run.h5"
    if mount:
        subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={limit}", "tmpfs", str(folder)], check=True)
        preexec = None
    else:

        def preexec():
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    try:
        res = subprocess.run(command(args, out), capture_output=True, text=True, preexec_fn=preexec, timeout=3600)
        row = {
            "kind": "tmpfs" if mount else "RLIMIT_FSIZE",
            "limit": limit,
            "rc": res.returncode,
            "finished": res.returncode == 0,
        }
        row["ended_ok"] = res.returncode == 0 or (res.returncode == 2 and one_line(res.stderr, "cortex-ti: error:"))
        row["message"] = res.stderr.strip().splitlines()[-1] if res.stderr.strip() else ""
        row["partial"], row["frames_kept"] = partial_state(out)
        if mount:  # free space: grow the disk under the files
            subprocess.run(["mount", "-o", f"remount,size={4 * size}", str(folder)], check=True)
        if not out.exists():
            resume(args, out, log)
        row["equal"], row["diff"], row["why"] = compare(ref, out, args.atol)
        row["strays"] = strays(folder, {"run.h5"})
    finally:
        if mount:
            subprocess.run(["umount", str(folder)], check=False)
    return row


def table(rows: list[dict], kinds, header: str) -> list[str]:
    lines = [
        header,
        "",
        "| fault | runs | ended as documented | before the first frame | frames kept (min-max) "
        "| resumed equal to the reference | largest difference | lost or corrupted | stray files |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for kind in kinds:
        rs = [r for r in rows if r["kind"] == kind]
        if not rs:
            continue
        kept = [r["frames_kept"] for r in rs if not r["finished"]]
        diffs = [r["diff"] for r in rs]
        lines.append(
            f"| {kind} | {len(rs)} | {sum(r['ended_ok'] for r in rs)} | "
            f"{sum(1 for r in rs if not r['finished'] and r['frames_kept'] == 0)} | "
            f"{min(kept) if kept else '-'}-{max(kept) if kept else '-'} | {sum(r['equal'] for r in rs)} | "
            f"{max(diffs):.2g} | {sum(not r['equal'] or r['partial'] == 'unreadable' for r in rs)} | "
            f"{sum(bool(r['strays']) for r in rs)} |"
        )
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", default="furrow_p4_a1")
    p.add_argument("--nodes", type=int, default=642)
    p.add_argument("--t-end", type=float, default=0.5)
    p.add_argument(
        "--set",
        action="append",
        default=["solver.reuse=false", "time.scheme=euler", "time.dt=5e-3"],
        metavar="KEY=VALUE",
        help="scene overrides (default solver.reuse=false: a reused factorisation makes a solve depend "
        "on the earlier ones, so a resumed run agrees only to solver.rtol; and a one-step scheme: bdf2, "
        "the dynamic scenes' default, restarts from the last frame with its one-step start, so its "
        "resumed run agrees with the uninterrupted one to its time error, not to round-off)",
    )
    p.add_argument("--kills", type=int, default=50)
    p.add_argument("--disk", type=int, default=20)
    p.add_argument("--atol", type=float, default=1e-12)
    p.add_argument("--seed", type=int, default=16)
    p.add_argument("--no-mount", action="store_true", help="use RLIMIT_FSIZE even where a tmpfs could be mounted")
    p.add_argument("--table", type=Path, default=None, help="also write the table (markdown) here")
    p.add_argument(
        "--smoke",
        action="store_true",
        help="1 kill and 1 full disk on 162 nodes to t = 0.1 (tests/io/test_faults.py tests more)",
    )
    args = p.parse_args(argv)
    if args.smoke:
        args.kills, args.disk, args.nodes, args.t_end = 1, 1, 162, 0.1
    rng = random.Random(args.seed)
    log = lambda msg: print(msg, file=sys.stderr, flush=True)  # noqa: E731
    mount = not args.no_mount and _can_mount()
    work = Path(tempfile.mkdtemp(prefix="fault-injection-"))
    try:
        ref = work / "reference.h5"
        t0 = time.perf_counter()
        subprocess.run(command(args, ref), check=True, capture_output=True)
        ref_wall = time.perf_counter() - t0
        size = ref.stat().st_size
        from cortex_ti.io.trajectory import committed_frames

        n_frames = committed_frames(ref)[0]
        log(f"reference: {ref_wall:.1f} s, {size} bytes")
        rows = []
        for i in range(args.kills):
            rows.append(kill_run(args, i, ref, ref_wall, n_frames, work, rng, log))
            r = rows[-1]
            log(
                f"kill {i:3d} {r['kind']:7s} after {r['delay']:5.2f} s: rc {r['rc']}, kept {r['frames_kept']}, "
                f"equal {r['equal']} ({r['diff']:.2g}) {r['why']} {r['strays'] or ''}"
            )
        for i in range(args.disk):
            rows.append(disk_run(args, i, ref, size, work, rng, mount, log))
            r = rows[-1]
            log(
                f"disk {i:3d} {r['limit']:8d} B: rc {r['rc']}, kept {r['frames_kept']}, equal {r['equal']} "
                f"({r['diff']:.2g}) {r['why']} {r['strays'] or ''}; {r['message'][:150]}"
            )
    finally:
        shutil.rmtree(work, ignore_errors=True)
    header = (
        f"{_bench.header()}\n{args.scene}, {args.nodes} nodes, t_end = {args.t_end}, `--threads 1`; "
        f"reference run {ref_wall:.1f} s, {size} bytes; full disk by {'tmpfs' if mount else 'RLIMIT_FSIZE'}; "
        f"seed {args.seed}, atol {args.atol:g}"
    )
    lines = table(rows, ["SIGKILL", "SIGTERM", "SIGINT", "tmpfs", "RLIMIT_FSIZE"], header)
    text = "\n".join(lines) + "\n"
    print(text)
    if args.table is not None:
        args.table.write_text(text)
    bad = sum(not r["equal"] or not r["ended_ok"] or r["strays"] or r["partial"] == "unreadable" for r in rows)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
