"""The index ``benchmarks/README.md`` lists every script of ``benchmarks/`` and
``benchmarks/investigations/`` and no other, each with its kind; a one-off opens with its question
and its answer; scripts share helpers through ``_bench.py`` only.

Every benchmark script runs: its ``--smoke`` mode (a tiny case, seconds) in a process of its own
(forked from one that did the imports once: ``tests/preloaded.py``),
from an empty folder, must finish with status 0, print its report, and write nothing where it was
started (a smoke run's files go to a temporary folder). The numbers of a smoke run mean nothing and
are not checked: the benchmarks' measurements live on the validation pages, never in pass/fail
tests. Marked slow (about a minute or two in all). A benchmark of a peer library (an optional extra
that the test extra does not install, ``NEEDS``) is skipped with one line where that library is missing.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import preloaded
import pytest

ROOT = Path(__file__).resolve().parents[2]
#: benchmark -> (the module it needs, the extra that installs it)
NEEDS = {"peer_ngsolve": ("ngsolve", "peers")}
BENCH = ROOT / "benchmarks"
HELPERS = {"_bench.py", "page.py"}
SCRIPTS = sorted(p for p in [*BENCH.glob("*.py"), *BENCH.glob("investigations/*.py")] if p.name not in HELPERS)
KINDS = {"standing", "one-off", "tool", "tool (deprecated)", "helper"}


def _index() -> dict[str, str]:
    """``benchmarks/README.md``'s table: script (relative to benchmarks/) -> kind."""
    rows = re.findall(r"^\| `([\w/]+\.py)` \| ([^|]+?) \|", (BENCH / "README.md").read_text(), flags=re.M)
    return {name: kind for name, kind in rows}


def test_the_index_lists_every_script_and_only_those():
    index = _index()
    present = {p.relative_to(BENCH).as_posix() for p in [*BENCH.glob("*.py"), *BENCH.glob("investigations/*.py")]}
    assert sorted(present - set(index)) == [], "scripts missing from benchmarks/README.md"
    assert sorted(set(index) - present) == [], "benchmarks/README.md lists scripts that are not there"
    assert {k for k in index.values()} <= KINDS
    placed = {name for name, kind in index.items() if (kind == "one-off") != name.startswith("investigations/")}
    assert placed == set(), "one-offs, and only they, live in benchmarks/investigations/"


def test_every_one_off_opens_with_its_question_and_answer():
    for path in sorted(BENCH.glob("investigations/*.py")):
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        assert doc.startswith("Question: ") and "\n\nAnswer: " in doc, path.name


def test_benchmarks_import_no_sibling_script_but_the_helper():
    """Helpers are shared through ``_bench.py`` only: no script imports another script."""
    names = {p.stem for p in SCRIPTS}
    for path in SCRIPTS:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                used = {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                used = {node.module.split(".")[0]}
            else:
                continue
            assert not used & names, (path.name, used & names)


def test_every_benchmark_has_a_smoke_mode():
    missing = [p.name for p in SCRIPTS if "--smoke" not in p.read_text()]
    assert missing == []


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=[p.relative_to(BENCH).with_suffix("").as_posix() for p in SCRIPTS])
def test_smoke_mode_runs(script, tmp_path):
    module, extra = NEEDS.get(script.stem, (None, None))
    if module and importlib.util.find_spec(module) is None:
        pytest.skip(f"{script.name} needs {module} (the {extra} extra: pip install -e '.[{extra}]')")
    env = {
        **os.environ,
        "MPLBACKEND": "Agg",
        "CORTEX_TI_THREADS": "1",
        "OMP_NUM_THREADS": "1",
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    res = preloaded.run([str(script), "--smoke"], cwd=tmp_path, env=env, timeout=600)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-3000:]
    assert res.stdout.strip(), "a benchmark prints its report"
    assert list(tmp_path.iterdir()) == [], "a smoke run writes only into a temporary folder"


@pytest.mark.slow
def test_a_benchmark_writes_its_validation_page(tmp_path):
    """benchmarks/page.py: the page carries the commit, the date, the machine and the command."""
    from cortex_ti import provenance

    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "CORTEX_TI_THREADS": "1", "PYTHONPATH": path}
    res = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "page.py"),
            "demo",
            "--title",
            "Demo",
            "--out-dir",
            str(tmp_path),
            "--",
            "spectrum",
            "--smoke",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    text = (tmp_path / "demo.md").read_text()
    assert text.startswith("# Demo\n")
    assert f"commit {provenance()['cortex_ti_commit']} on " in text
    assert "cores" in text and "python benchmarks/spectrum.py --smoke" in text
    assert "| case |" in text  # the benchmark's own table


def test_a_failing_benchmark_writes_no_page(tmp_path):
    res = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "page.py"),
            "demo",
            "--out-dir",
            str(tmp_path),
            "--",
            "spectrum",
            "--no-such-option",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode != 0
    assert list(tmp_path.iterdir()) == []
