"""Run a Python command line in a fresh process without paying the imports each time.

Many tests run a command as a user would, in a process of its own (the benchmarks' smoke modes,
the documentation's ``cortex-ti`` lines and Python blocks): about 140 processes, each of which
spent ~1.7 CPU s importing NumPy, SciPy, Taichi, Matplotlib, xarray and the package before doing
anything (measured 2026-12-07 on the 2-core machine): a fifth of the suite's time.

:class:`Preloaded` starts one server process (this file run as a script) that does those imports
once, without initialising Taichi, with one BLAS thread. Each :meth:`Preloaded.run` forks the server:
the child changes to the command's folder, takes the command's environment, arguments and standard
streams, and runs the script (``runpy.run_path``), the module (``-m``) or the code (``-c``) as
``__main__``; its exit status is the command's. A fork is a new process: what one command
registers, changes or leaks is gone with it, as with ``subprocess.run``. Where ``os.fork`` does not
exist, or with ``CORTEX_TI_TEST_PRELOAD=0``, :meth:`Preloaded.run` is ``subprocess.run``.

Why not ``multiprocessing``'s forkserver: it pickles a target function rather than running a
command line with its own streams and exit status, which is what the tests compare with a user's.
"""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys
import tempfile
from pathlib import Path

#: the imports the server does once (what a command of this package imports anyway)
PRELOAD = (
    "numpy",
    "scipy.sparse.linalg",
    "scipy.linalg",
    "matplotlib",
    "matplotlib.pyplot",
    "h5py",
    "xarray",
    "taichi",
    "cortex_ti.cli",
    "cortex_ti.simulation.run",
    "cortex_ti.io",
)


def enabled() -> bool:
    return hasattr(os, "fork") and os.environ.get("CORTEX_TI_TEST_PRELOAD", "1") != "0"


class Preloaded:
    """The server (started on first use) and the commands it runs; :meth:`close` ends it."""

    def __init__(self, pythonpath: str):
        self.pythonpath = pythonpath
        self.proc: subprocess.Popen | None = None

    def _server(self) -> subprocess.Popen:
        if self.proc is None or self.proc.poll() is not None:
            env = {
                **os.environ,
                "PYTHONPATH": self.pythonpath,
                "MPLBACKEND": "Agg",
                "OMP_NUM_THREADS": "1",
                "OPENBLAS_NUM_THREADS": "1",
                "MKL_NUM_THREADS": "1",
            }
            self.proc = subprocess.Popen(
                [sys.executable, __file__],
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                env=env,
                text=True,
                bufsize=1,
            )
            ready = self.proc.stdout.readline()
            if ready.strip() != "ready":
                raise RuntimeError(f"the preloading server did not start: {ready!r}")
        return self.proc

    def run(self, argv: list[str], cwd, env: dict, timeout: float) -> subprocess.CompletedProcess:
        """``subprocess.run([sys.executable, *argv], cwd, env, capture_output, text, timeout)``."""
        if not enabled():
            return subprocess.run(
                [sys.executable, *argv], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout
            )
        proc = self._server()
        with tempfile.TemporaryDirectory() as tmp:
            out, err = Path(tmp) / "out", Path(tmp) / "err"
            request = {"argv": list(argv), "cwd": str(cwd), "env": dict(env), "out": str(out), "err": str(err)}
            proc.stdin.write(json.dumps(request) + "\n")
            proc.stdin.flush()
            pid = int(json.loads(proc.stdout.readline())["pid"])
            ready, _, _ = select.select([proc.stdout], [], [], timeout)
            if not ready:
                os.kill(pid, signal.SIGKILL)
                proc.stdout.readline()
                raise subprocess.TimeoutExpired([sys.executable, *argv], timeout)
            code = int(json.loads(proc.stdout.readline())["returncode"])
            return subprocess.CompletedProcess(
                [sys.executable, *argv], code, out.read_text(errors="replace"), err.read_text(errors="replace")
            )

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.stdin.close()
            self.proc.wait(timeout=60)


_SHARED: Preloaded | None = None


def run(argv: list[str], cwd, env: dict, timeout: float) -> subprocess.CompletedProcess:
    """:meth:`Preloaded.run` on this test process's server (started on first use, ended at exit)."""
    global _SHARED
    if _SHARED is None:
        import atexit

        root = str(Path(__file__).resolve().parents[1])
        _SHARED = Preloaded(os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]))
        atexit.register(_SHARED.close)
    return _SHARED.run(argv, cwd, env, timeout)


def _child(request: dict, protocol: int) -> int:
    """In the forked child: become the command and run it; its exit status."""
    import runpy
    import traceback

    os.close(protocol)
    os.chdir(request["cwd"])
    os.environ.clear()
    os.environ.update(request["env"])
    fd_in = os.open(os.devnull, os.O_RDONLY)
    os.dup2(fd_in, 0)
    for fd, path in ((1, request["out"]), (2, request["err"])):
        f = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(f, fd)
        os.close(f)
    sys.stdout = open(1, "w", closefd=False, buffering=1)  # noqa: SIM115
    sys.stderr = open(2, "w", closefd=False, buffering=1)  # noqa: SIM115
    sys.stdin = open(0, closefd=False)  # noqa: SIM115
    argv = request["argv"]
    try:
        if argv[0] == "-m":
            sys.argv = [argv[1], *argv[2:]]
            runpy.run_module(argv[1], run_name="__main__", alter_sys=True)
        elif argv[0] == "-c":
            sys.argv = ["-c", *argv[2:]]
            exec(compile(argv[1], "<string>", "exec"), {"__name__": "__main__", "__builtins__": __builtins__})
        else:
            sys.argv = list(argv)
            sys.path.insert(0, str(Path(argv[0]).resolve().parent))
            runpy.run_path(argv[0], run_name="__main__")
        code = 0
    except SystemExit as exc:
        if exc.code is None:
            code = 0
        elif isinstance(exc.code, int):
            code = exc.code
        else:
            print(exc.code, file=sys.stderr)
            code = 1
    except BaseException:  # noqa: BLE001 - the command's own failure, reported as Python would
        traceback.print_exc()
        code = 1
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:  # noqa: BLE001
        pass
    return code


def _serve() -> None:
    import importlib

    # the replies go to the client through a copy of the standard output; what the imports print
    # (Taichi's banner) goes nowhere
    protocol = os.dup(1)
    out = os.fdopen(protocol, "w")
    null = os.open(os.devnull, os.O_WRONLY)
    os.dup2(null, 1)
    os.close(null)
    for name in PRELOAD:
        try:
            importlib.import_module(name)
        except Exception:  # noqa: BLE001 - an optional module missing: its command imports it (and fails) itself
            pass
    out.write("ready\n")
    out.flush()
    for line in sys.stdin:
        request = json.loads(line)
        pid = os.fork()
        if pid == 0:
            code = 1
            try:
                code = _child(request, protocol)
            finally:
                os._exit(code)
        out.write(json.dumps({"pid": pid}) + "\n")
        out.flush()
        _, status = os.waitpid(pid, 0)
        out.write(json.dumps({"returncode": os.waitstatus_to_exitcode(status)}) + "\n")
        out.flush()


if __name__ == "__main__":
    _serve()
