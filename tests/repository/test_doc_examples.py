"""The examples of the README and the documentation run as written (on small meshes).

Every fenced block marked ```bash or ```python in ``README.md`` and ``docs/**/*.md`` is extracted:

* a ``bash`` block runs its ``cortex-ti ...`` lines in order, each in a process of its own (forked
  from one that did the imports once: ``tests/preloaded.py``), in one fresh folder per block;
  other commands (``pip``, ``snakemake``, ``python benchmarks/...``) are left to their own tests.
  A ``cortex-ti run`` gets ``mesh.nodes=162`` (replacing any node count the example gives) and,
  for a dynamic scene, its end time (the scene's, or the one the example sets) times
  :data:`TIME_SCALE`, so a run takes seconds;
* a ``python`` block is run by a fresh process (the same way) in a fresh folder.

Files an example reads but no earlier line of its block wrote (``p8.h5`` in a block that plots
it, ``my_scene.yaml``) are made first: :data:`FIXTURES` says from which scene.

A block that needs what a test cannot give it (the whole workflow's results) is skipped by a line
``<!-- examples: skip (reason) -->`` just above its fence, or by an entry of :data:`SKIP`
(a file and a piece of the block's text, with the reason).
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
from pathlib import Path

import preloaded
import pytest

REPO = Path(__file__).resolve().parents[2]
NODES = 162
TIME_SCALE = 0.01
#: Blocks skipped: (file relative to the repository, a piece of the block's text) -> reason.
SKIP = {
    ("README.md", "results/aggregate/"): "reads the stores of the whole workflow",
}
#: Inputs an example may read without writing them first: file name -> (scene, extra overrides).
FIXTURES = {
    "y20.h5": ("sphere_y20_full", []),
    "p8.h5": ("furrow_p8_a1", []),
    "RUN.h5": ("furrow_p4_a1", []),
    "fold.h5": ("fold_broad", []),
    "ax.h5": ("furrow_p4_a3", ["model=axisymmetric"]),
    "run.h5.partial": ("furrow_p4_a1", []),
    "a6.h5": ("furrow_p4_a1", ["active_stress.0.amplitude=6", "mesh.remesh.min_angle=25"]),
    "noise.h5": ("myosin_noise", []),
}
SKIP_MARK = re.compile(r"<!--\s*examples:\s*skip\b")
FENCE = re.compile(r"^```(\w*)\s*$")


def example_files() -> list[Path]:
    files = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
    return [f for f in files if f.is_file()]


def blocks(path: Path) -> list[tuple[str, int, str, str | None]]:
    """``(language, first line number, text, skip reason)`` of the bash and python blocks of ``path``."""
    lines = path.read_text().splitlines()
    out, i = [], 0
    rel = str(path.relative_to(REPO))
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        lang, start = m.group(1), i + 1
        j = start
        while j < len(lines) and not lines[j].startswith("```"):
            j += 1
        text = "\n".join(lines[start:j])
        if lang in ("bash", "python"):
            reason = None
            k = i - 1
            while k >= 0 and not lines[k].strip():
                k -= 1
            if k >= 0 and SKIP_MARK.search(lines[k]):
                reason = lines[k].strip()
            for (file, piece), why in SKIP.items():
                if file == rel and piece in text:
                    reason = why
            out.append((lang, start + 1, text, reason))
        i = j + 1
    return out


def all_blocks():
    params = []
    for path in example_files():
        for lang, line, text, reason in blocks(path):
            marks = [pytest.mark.skip(reason=reason)] if reason else []
            params.append(pytest.param(path, lang, text, id=f"{path.relative_to(REPO)}:{line}", marks=marks))
    return params


def env() -> dict:
    return dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")]), CORTEX_TI_THREADS="2"
    )


def cortex(argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``python -m cortex_ti ARGV`` in a process of its own (forked from one that did the imports:
    tests/preloaded.py)."""
    return preloaded.run(["-m", "cortex_ti", *argv], cwd=cwd, env=env(), timeout=900)


def small(argv: list[str]) -> list[str]:
    """A ``run`` command on :data:`NODES` nodes and a scaled end time (see the module docstring)."""
    if not argv or argv[0] != "run":
        return argv
    from cortex_ti.scene import load_scene

    out, t_end = [], None
    i = 0
    while i < len(argv):
        a = argv[i]
        if a == "--set" and i + 1 < len(argv):
            key, _, value = argv[i + 1].partition("=")
            if key == "mesh.nodes":
                i += 2
                continue
            if key == "time.t_end":
                t_end = float(value)
                i += 2
                continue
        out.append(a)
        i += 1
    out += ["--set", f"mesh.nodes={NODES}"]
    scene = load_scene(argv[1])
    if scene.settings.dynamic:
        t_end = scene.settings.time.t_end if t_end is None else t_end
        out += ["--set", f"time.t_end={t_end * TIME_SCALE:.6g}"]
    return out


class Fixtures:
    """The fixture runs (:data:`FIXTURES`), each made once per test process in a folder of
    pytest's and copied into every test folder that reads it (``p8.h5`` is read by a dozen blocks)."""

    def __init__(self, store: Path):
        self.store = store
        self.made: dict[str, Path] = {}

    def copy(self, name: str, folder: Path) -> None:
        if name not in self.made:
            scene, extra = FIXTURES.get(name, ("furrow_p4_a1", []))
            final = name[: -len(".partial")] if name.endswith(".partial") else name
            argv = small(["run", scene, "-o", str(self.store / final)] + [x for o in extra for x in ("--set", o)])
            res = cortex(argv, self.store)
            assert res.returncode == 0, f"fixture {name}: {res.stderr}"
            self.made[name] = self.store / final
        shutil.copy(self.made[name], folder / name)


@pytest.fixture(scope="session")
def fixtures(tmp_path_factory) -> Fixtures:
    return Fixtures(tmp_path_factory.mktemp("doc-fixtures"))


def inputs(argv: list[str]) -> list[str]:
    """Files a command reads: the trajectory of plot/export, the scene file of run/check."""
    if argv[:1] in (["plot"], ["export"], ["movie"], ["view"]) and len(argv) > 1:
        return [argv[1]]
    if argv[:1] in (["run"], ["check"]) and len(argv) > 1 and argv[1].endswith((".yaml", ".yml")):
        return [argv[1]]
    return []


@pytest.mark.slow
@pytest.mark.parametrize("path, lang, text", all_blocks())
def test_example_runs_as_written(path, lang, text, tmp_path, fixtures):
    if lang == "python":
        for name in sorted(set(re.findall(r"[\"']([\w.-]+\.h5(?:\.partial)?)[\"']", text))):
            # a file the block's own run writes is not made first (a run refuses an existing output)
            if not re.search(r"\brun\([^)\n]*[\"']" + re.escape(name) + "[\"']", text):
                fixtures.copy(name, tmp_path)
        compile(text, f"{path.name} example", "exec")  # a syntax error names the page
        # in a fresh interpreter: an example that registers a term or a pattern must not change the
        # registries the other tests of this session see
        res = preloaded.run(["-c", text], cwd=tmp_path, env=env(), timeout=600)
        assert res.returncode == 0, f"{path.name}: a python example failed:\n{res.stderr[-2000:]}"
        return
    ran = 0
    for line in text.splitlines():
        try:
            argv = shlex.split(line, comments=True)
        except ValueError as exc:
            pytest.fail(f"{path.name}: cannot read the line {line!r}: {exc}")
        if not argv or argv[0] != "cortex-ti":
            continue
        argv = argv[1:]
        for name in inputs(argv):
            if not (tmp_path / name).exists():
                if name.endswith((".yaml", ".yml")):
                    shutil.copy(REPO / "cortex_ti/scene/scenes/furrow_p4_a1.yaml", tmp_path / name)
                else:
                    fixtures.copy(name, tmp_path)
        res = cortex(small(argv), tmp_path)
        assert res.returncode == 0, f"{path.name}: `{line.strip()}` failed ({res.returncode}):\n{res.stderr[-2000:]}"
        assert "Traceback" not in res.stderr
        ran += 1
    if ran == 0:
        pytest.skip("no cortex-ti command in this block")


def test_the_extractor_finds_the_readme_examples():
    """The extractor itself (a regression check of this test's parser on a block written here)."""
    sample = REPO / "README.md"
    found = blocks(sample)
    assert any(lang == "bash" and "cortex-ti run" in text for lang, _, text, _ in found)
    assert any(lang == "python" for lang, _, _, _ in found)
    assert small(["run", "furrow_p8_a1", "-o", "x.h5", "--set", "mesh.nodes=10242", "--set", "time.t_end=5"]) == [
        "run",
        "furrow_p8_a1",
        "-o",
        "x.h5",
        "--set",
        f"mesh.nodes={NODES}",
        "--set",
        "time.t_end=0.05",
    ]
