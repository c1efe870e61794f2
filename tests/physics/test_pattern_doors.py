"""A python pattern as a user writes it (issue 34): its module beside the scene file or in the working
directory imports without PYTHONPATH, through the console script as through Python; an error inside
it (an exception, ``sys.exit``, at import or at the call) is one ``cortex-ti: error:`` line naming the
pattern, its file and line, with the traceback only behind ``--debug``."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

import cortex_ti as ct
from cortex_ti.cli import main
from cortex_ti.errors import SceneError

REPO = Path(__file__).resolve().parents[2]
MODULE = """
import sys


def ok(points, a=1.0):
    return a * points[:, 2]


def bad(points):
    raise ValueError("my pattern is broken")  # line 10


def leave(points):
    sys.exit(3)  # line 14
"""
QUITTER = "import sys\nsys.exit(3)\n"


def _scene(folder: Path, name: str, function: str) -> Path:
    data = ct.load_scene("furrow_p8_a1", nodes=162).data
    data["active_stress"] = [{"type": "python", "function": function}]
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _cli(*args, cwd):
    exe = shutil.which("cortex-ti")
    cmd = [exe] if exe else [sys.executable, "-c", "import sys; from cortex_ti.cli import main; sys.exit(main())"]
    env = {**os.environ, "PYTHONPATH": str(REPO)}  # the package only: not the scene's folder
    return subprocess.run([*cmd, *args], capture_output=True, text=True, cwd=cwd, env=env, timeout=300)


@pytest.fixture
def folder(tmp_path):
    where = tmp_path / "scenes"
    where.mkdir()
    (where / "doorpat_q.py").write_text(MODULE)
    (where / "doorquit_q.py").write_text(QUITTER)
    yield where
    for name in ("doorpat_q", "doorquit_q"):
        sys.modules.pop(name, None)


def test_a_pattern_module_beside_its_scene_or_in_the_working_directory_imports(folder, tmp_path, monkeypatch, capsys):
    scene = _scene(folder, "ok", "doorpat_q:ok")
    res = _cli("check", str(scene), cwd=tmp_path)  # the console script; the module beside the scene only
    assert res.returncode == 0 and "valid" in res.stdout, res.stderr
    sys.modules.pop("doorpat_q", None)
    ok = ["check", "furrow_p8_a1", "--set", "mesh.nodes=162"]
    ok += ["--set", "active_stress=[{type: python, function: 'doorpat_q:ok'}]"]
    monkeypatch.chdir(tmp_path)  # neither beside a scene file (a built-in one) nor in the working directory
    assert main(ok) == 2 and "cannot import module 'doorpat_q'" in capsys.readouterr().err
    monkeypatch.chdir(folder)  # in the working directory
    assert main(ok) == 0 and "valid" in capsys.readouterr().out
    assert str(folder) not in sys.path and os.getcwd() not in sys.path  # searched, not kept on the path
    # Python: the folder of a scene file is searched too
    from cortex_ti.physics.patterns import evaluate_active_stress

    sys.modules.pop("doorpat_q", None)
    monkeypatch.chdir(tmp_path)
    patterns = list(ct.load_scene(scene).settings.patterns)
    assert evaluate_active_stress([[0.0, 0.0, 0.5]], patterns)[0] == pytest.approx(0.5)


@pytest.mark.parametrize(
    "function, said, line",
    [
        ("doorpat_q:bad", "python pattern 'doorpat_q:bad' raised ValueError: my pattern is broken", 10),
        ("doorpat_q:leave", "python pattern 'doorpat_q:leave' called sys.exit(3)", 14),
        ("doorquit_q:f", "cannot import module 'doorquit_q' (SystemExit: 3", 2),
    ],
)
def test_an_error_in_a_pattern_is_one_line_naming_its_file_and_line(folder, tmp_path, capsys, function, said, line):
    scene = _scene(folder, "broken", function)
    module = folder / (function.split(":")[0] + ".py")
    for command in (["check", str(scene)], ["run", str(scene), "-o", str(tmp_path / "x.h5"), "--threads", "1"]):
        assert main(command) == 2
        lines = capsys.readouterr().err.strip().splitlines()
        assert len(lines) == 1, lines
        assert lines[0].startswith("cortex-ti: error: ") and said in lines[0] and f"{module}:{line}" in lines[0]
        assert "--debug" in lines[0]
    assert not (tmp_path / "x.h5").exists() and sorted(p.name for p in tmp_path.iterdir()) == ["scenes"]
    assert main(["--debug", "check", str(scene)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("cortex-ti: error: ") and "Traceback (most recent call last)" in err
    # Python: a SceneError with the same words, the user's exception chained to it
    with pytest.raises(SceneError, match="doorpat_q|doorquit_q") as caught:
        ct.run(scene, nodes=162, t_end=0.01, threads=1)
    assert said in str(caught.value) and caught.value.__cause__ is not None
