"""Every output command under faults: export (VTKHDF, PVD), movie (MP4, GIF) and the run's summary
with a full disk, a read-only folder and SIGTERM at a random moment (issue 34).

A small trajectory (``furrow_p8_a1`` on 162 nodes, 21 frames) is written once; then each command
runs ``--trials`` times under each fault, in a process of its own, its output in a folder that is

* a full disk: a tmpfs mounted with a random size between 5 % and 95 % of the command's output
  (root with CAP_SYS_ADMIN), else a file-size limit (``RLIMIT_FSIZE``) of that size, which fails
  the same writes with EFBIG;
* a read-only folder: that tmpfs remounted read-only (root), else a folder without write
  permission (which root ignores: then the fault is skipped);
* SIGTERM: sent at a random moment between 0 and the command's undisturbed duration.

Each trial passes when the command either finished (exit 0, its output complete: it reads back
with every frame) or failed as documented: exit 2 (the disk, the folder) or 143 (SIGTERM) with one
line ``cortex-ti: error: ...`` / ``cortex-ti: interrupted ...`` and no traceback, and in both
cases the folder holds nothing else: no partial, temporary or probe file, no stray frame, no
unreadable file. A SIGTERM that lands while the interpreter starts, before ``cortex-ti`` installs
its handlers, ends the process by the signal's default action (exit -15, no line): it passes when
nothing was written. The table (markdown) goes to stdout.

Usage::

    python benchmarks/output_faults.py               # 5 trials of each command under each fault
    python benchmarks/output_faults.py --smoke       # 1 trial of the exports, file-size limit only (seconds)

The movie rows need the [viz] extra (imageio, imageio-ffmpeg); without it they are skipped.
"""

from __future__ import annotations

import argparse
import json
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

ROOT = Path(__file__).resolve().parents[1]
FRAMES = 21


def _env() -> dict:
    # no .pyc written: under a file-size limit one would be cut short, and kept
    return {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
        "PYTHONDONTWRITEBYTECODE": "1",
    }


def _cli(*args) -> list[str]:
    return [sys.executable, "-m", "cortex_ti", *args]


def commands(traj: Path, movies: bool) -> dict:
    """name -> (argv given the output folder, the files a complete output has, checker)."""
    out = {
        "export vtkhdf": (lambda d: _cli("export", str(traj), "-o", str(d / "t.vtkhdf")), _check_vtkhdf),
        "export pvd": (lambda d: _cli("export", str(traj), "-o", str(d), "--format", "pvd"), _check_pvd),
        "run --summary": (
            lambda d: _cli(
                "run", "furrow_p8_a1", "-o", str(d / "r.h5"), "--summary", str(d / "r.json"),
                "--set", "mesh.nodes=162", "--set", "time.t_end=0.02", "--threads", "1",
            ),
            _check_run,
        ),
    }  # fmt: skip
    if movies:
        for fmt in ("mp4", "gif"):
            out[f"movie {fmt}"] = (
                lambda d, fmt=fmt: _cli(
                    "movie", str(traj), "-o", str(d / f"m.{fmt}"), "--size", "160x160", "--renderer", "matplotlib"
                ),
                _check_movie,
            )
    return out


def _check_vtkhdf(folder: Path) -> str | None:
    import h5py

    files = sorted(p.name for p in folder.iterdir())
    if files != ["t.vtkhdf"]:
        return f"files {files}"
    with h5py.File(folder / "t.vtkhdf", "r") as h5:
        n = int(h5["VTKHDF/Steps"].attrs["NSteps"])
    return None if n == FRAMES else f"{n} steps"


def _check_pvd(folder: Path) -> str | None:
    import xml.etree.ElementTree as ET

    import meshio

    names = [e.get("file") for e in ET.parse(folder / "t.pvd").getroot().findall("./Collection/DataSet")]
    files = sorted(p.name for p in folder.iterdir())
    if files != sorted(["t.pvd", *names]) or len(names) != FRAMES:
        return f"files {files}"
    for name in names:
        meshio.read(folder / name)
    return None


def _check_movie(folder: Path) -> str | None:
    files = [p for p in folder.iterdir()]
    if len(files) != 1:
        return f"files {sorted(p.name for p in files)}"
    path = files[0]
    if path.suffix == ".mp4":
        import imageio_ffmpeg

        n = imageio_ffmpeg.count_frames_and_secs(str(path))[0]
    else:
        from PIL import Image

        n = Image.open(path).n_frames
    return None if n == FRAMES else f"{n} frames"


def _check_run(folder: Path) -> str | None:
    import xarray as xr

    files = sorted(p.name for p in folder.iterdir())
    if "r.h5" in files:
        if files != ["r.h5", "r.json"]:
            return f"files {files}"
        xr.load_dataset(folder / "r.h5", engine="h5netcdf")
    elif files not in ([], ["r.json"]) and not (set(files) <= {"r.json", "r.h5.partial"}):
        return f"files {files}"
    if "r.json" in files:
        json.loads((folder / "r.json").read_text())
    return None


def _mount(folder: Path, size: int, ro: bool = False) -> bool:
    if os.geteuid() != 0:
        return False
    opts = f"size={max(size, 4096)}" + (",ro" if ro else "")
    res = subprocess.run(["mount", "-t", "tmpfs", "-o", opts, "tmpfs", str(folder)], capture_output=True)
    return res.returncode == 0


def _umount(folder: Path) -> None:
    subprocess.run(["umount", str(folder)], capture_output=True)


def trial(argv, check, where: Path, fault: str, size: int, duration: float, rng) -> tuple[bool, str]:
    """One run of a command under ``fault``; (passed, what happened)."""
    folder = where / "out"
    folder.mkdir()
    mounted = False
    limit = None
    if fault == "full disk":
        cap = int(rng.uniform(0.05, 0.95) * size)
        mounted = _mount(folder, cap)
        limit = None if mounted else cap
    elif fault == "read-only folder":
        mounted = _mount(folder, 1 << 20, ro=True)
        if not mounted:
            if os.geteuid() == 0:
                folder.rmdir()
                return True, "skipped (root ignores permissions and cannot mount)"
            folder.chmod(0o555)

    def pre():
        if limit is not None:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    try:
        proc = subprocess.Popen(argv(folder), env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                preexec_fn=pre, cwd=where)  # fmt: skip
        if fault == "SIGTERM":
            time.sleep(rng.uniform(0.0, duration))
            proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=600)
        lines = [ln for ln in err.splitlines() if ln.startswith("cortex-ti: ") and "3D pictures" not in ln]
        rc = proc.returncode
        if "Traceback" in err:
            return False, f"rc {rc}, a traceback"
        # SIGTERM: -15 if it came while the interpreter started, before cortex-ti could answer it
        expected = {"SIGTERM": (0, 143, -15), "full disk": (0, 2), "read-only folder": (2,)}[fault]
        if rc not in expected:
            return False, f"rc {rc}: {err.strip()[-300:]}"
        said = [ln for ln in lines if "warning" not in ln]
        if rc == -signal.SIGTERM and said:  # the default action: nothing can be said
            return False, f"rc {rc}, {len(said)} lines"
        if rc not in (0, -signal.SIGTERM) and len(said) != 1:
            return False, f"rc {rc}, {len(said)} lines"
        try:
            problem = check(folder) if rc == 0 else _leftovers(folder)
        except Exception as exc:  # an unreadable output
            return False, f"rc {rc}, unreadable output: {type(exc).__name__}: {exc}"
        return problem is None, f"rc {rc}" + (f", {problem}" if problem else "")
    finally:
        if mounted:
            _umount(folder)
        folder.chmod(0o755)
        shutil.rmtree(folder, ignore_errors=True)


def _leftovers(folder: Path) -> str | None:
    """What a failed or interrupted command may leave: nothing, but a run's partial file (frames kept
    for --resume) and its summary."""
    files = sorted(p.name for p in folder.iterdir())
    extra = [f for f in files if f not in ("r.h5.partial", "r.json")]
    if extra:
        return f"left {extra}"
    if "r.json" in files:
        json.loads((folder / "r.json").read_text())
    if "r.h5.partial" in files:
        from cortex_ti.io.trajectory import committed_frames

        committed_frames(folder / "r.h5.partial")
    return None


def main() -> int:
    global FRAMES
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--smoke", action="store_true")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    from cortex_ti.viz import extra

    rng = random.Random(args.seed)
    movies = not args.smoke and not extra.missing("movie")
    with tempfile.TemporaryDirectory(prefix="cortex-ti-output-faults-") as tmp:
        where = Path(tmp)
        traj = where / "t.h5"
        every = 0.005 if args.smoke else 0.001  # smoke: 5 frames to export, not 21
        FRAMES = round(0.02 / every) + 1
        subprocess.run(
            _cli("run", "furrow_p8_a1", "-o", str(traj), "--set", "mesh.nodes=162", "--set", "time.t_end=0.02",
                 "--set", f"time.save_every={every}", "--threads", "1"),
            env=_env(), check=True, capture_output=True,
        )  # fmt: skip
        cmds = commands(traj, movies)
        if args.smoke:
            cmds = {k: v for k, v in cmds.items() if k.startswith("export")}
        faults = ("full disk",) if args.smoke else ("full disk", "read-only folder", "SIGTERM")
        trials = 1 if args.smoke else args.trials
        rows = []
        for name, (argv, check) in cmds.items():
            clean = where / "clean"
            clean.mkdir()
            t0 = time.perf_counter()
            res = subprocess.run(argv(clean), env=_env(), capture_output=True, text=True, cwd=where)
            duration = time.perf_counter() - t0
            assert res.returncode == 0 and check(clean) is None, (name, res.stderr)
            size = sum(p.stat().st_size for p in clean.iterdir())
            shutil.rmtree(clean)
            for fault in faults:
                results = [trial(argv, check, where, fault, size, duration, rng) for _ in range(trials)]
                passed = sum(ok for ok, _ in results)
                outcomes = sorted({what for _, what in results})
                rows.append((name, fault, passed, len(results), "; ".join(outcomes)[:200]))
    print("| command | fault | passed | outcomes |")
    print("|---|---|---|---|")
    for name, fault, passed, n, outcomes in rows:
        print(f"| {name} | {fault} | {passed}/{n} | {outcomes} |")
    if not movies and not args.smoke:
        print("\n(movie rows skipped: the [viz] extra is not installed)")
    return 0 if all(p == n for _, _, p, n, _ in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
