"""The repository keeps to its lint and format rules: `ruff check` with the configuration in
pyproject.toml ([tool.ruff]: pycodestyle, pyflakes, import order, bugbear, pyupgrade; line length 120)
finds nothing, and `ruff format --check` would change nothing, in every Python file the repository
holds (the package, the tests, the benchmarks, the documentation's Python and the gallery).

Skipped with one line when ruff is not installed (it comes with the `test` extra).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _ruff() -> list[str] | None:
    exe = shutil.which("ruff")
    if exe:
        return [exe]
    try:
        import ruff  # noqa: F401  (the PyPI package ships the binary and a module that finds it)
    except ImportError:
        return None
    return [sys.executable, "-m", "ruff"]


def test_ruff_finds_nothing():
    ruff = _ruff()
    if ruff is None:
        pytest.skip("ruff is not installed (python -m pip install -e '.[test]')")
    res = subprocess.run(
        [*ruff, "check", "--no-cache", "--output-format", "concise", "cortex_ti", "docs/conf.py", "docs/examples"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stdout[-4000:] + res.stderr[-2000:]


def test_the_rules_are_the_configured_ones():
    """A regression check that the configuration is the one read (not a default): line length 120."""
    ruff = _ruff()
    if ruff is None:
        pytest.skip("ruff is not installed (python -m pip install -e '.[test]')")
    res = subprocess.run(
        [*ruff, "check", "--show-settings", "cortex_ti/__init__.py"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    assert "line_length = 120" in res.stdout
