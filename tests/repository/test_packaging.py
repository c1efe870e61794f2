"""The package installs like a real package: a wheel carries the built-in scenes, the scene schema and
the reference data, so a non-editable install works from any folder."""

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_wheel_carries_scenes_schema_and_reference_data(tmp_path):
    res = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path), str(ROOT)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    wheel = next(tmp_path.glob("cortex_ti-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    scenes = {p.name for p in (ROOT / "cortex_ti" / "scene" / "scenes").glob("*.yaml")}
    # the paper's 12, issue 18's two deep rings, issue 20's four myosin scenes, issue 36's four in fluids,
    # issue 35's cytokinesis (flat, curved with rigidity, and its ring off the equator) and rigid ring
    assert len(scenes) == 26
    assert {f"cortex_ti/scene/scenes/{s}" for s in scenes} <= names
    assert "cortex_ti/scene/scene.schema.json" in names
    data = {p.name for p in (ROOT / "cortex_ti" / "data" / "axisym").iterdir()}
    assert {f"cortex_ti/data/axisym/{d}" for d in data} <= names
    # every subpackage (a missing __init__ would silently drop one from the wheel)
    for pkg in (ROOT / "cortex_ti").rglob("__init__.py"):
        assert str(pkg.relative_to(ROOT)) in names
