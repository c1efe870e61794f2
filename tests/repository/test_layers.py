"""The package's layers (CONTRIBUTING.md): imports go one way, and the light layers start no Taichi.

* every import of every module of the package, read with :mod:`ast` (module-level and inside
  functions alike), goes to the module's own layer or a layer below it, in the order
  :data:`LAYERS` (the one list; CONTRIBUTING.md states it in words and a test checks they agree);
* in a fresh interpreter, loading a scene, the study registry, the sweeps and the stores, the
  formulation and term registries, the run set-up and the axisymmetric model import no Taichi,
  nor does ``cortex-ti check``.
"""

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "cortex_ti"

#: The layers from the bottom; a module may import its own layer and the layers below.
#: ``__main__`` and the package's ``__init__`` sit on top (the front door may import anything);
#: below it only ``__version__`` may be taken from the package itself.
LAYERS = (
    ("errors", "about", "_version"),
    ("solve", "runtime"),
    ("surface",),
    ("physics",),
    ("analysis",),
    ("dynamics",),
    ("scene",),
    ("io", "plotting"),
    ("viz",),
    ("simulation", "axisymmetric"),
    ("models", "studies"),
    ("api", "cli"),
)
TOP = ("__main__", "__init__")
PACKAGE_METADATA = {"__version__"}


def _rank(part: str) -> int:
    if part in TOP:
        return len(LAYERS)
    for k, names in enumerate(LAYERS):
        if part in names:
            return k
    raise LookupError(part)


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts  # ('cortex_ti', 'physics', 'terms', 'base')
        yield path, parts, parts[:-1]  # the package relative imports start from


def _targets(node, package):
    """The package-internal names an import statement reaches, as tuples of parts."""
    if isinstance(node, ast.Import):
        return [tuple(a.name.split(".")) for a in node.names if a.name.split(".")[0] == "cortex_ti"]
    if not isinstance(node, ast.ImportFrom):
        return []
    if node.level:
        base = package[: len(package) - node.level + 1]
        mod = base + tuple(node.module.split(".")) if node.module else base
    else:
        mod = tuple((node.module or "").split("."))
    if mod[0] != "cortex_ti":
        return []
    if len(mod) == 1:  # from cortex_ti import x: a submodule, or the package's own metadata
        return [(mod[0], a.name) if a.name not in PACKAGE_METADATA else ("cortex_ti", "<metadata>") for a in node.names]
    return [mod]


def _layer_of(parts) -> str:
    if len(parts) == 2 and parts[1] == "__init__":
        return "__init__"
    return parts[1]


def test_every_import_goes_to_the_own_layer_or_below():
    wrong, unplaced = [], set()
    for path, parts, package in _modules():
        src = _layer_of(parts)
        try:
            src_rank = _rank(src)
        except LookupError:
            unplaced.add(src)
            continue
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            for target in _targets(node, package):
                dst = target[1] if len(target) > 1 else "__init__"
                if dst == "<metadata>":
                    continue
                try:
                    ok = _rank(dst) <= src_rank
                except LookupError:
                    unplaced.add(dst)
                    continue
                if not ok:
                    where = f"{path.relative_to(ROOT)}:{node.lineno}"
                    wrong.append(f"{where} ({src}) imports {'.'.join(target)} ({dst})")
    assert not unplaced, (
        f"modules or subpackages in no layer (add them to LAYERS and CONTRIBUTING.md): {sorted(unplaced)}"
    )
    assert not wrong, "imports running back up the layers:\n" + "\n".join(wrong)


def test_the_import_check_sees_an_import_running_up():
    """The check itself: an upward import, relative or absolute, is caught."""
    tree = ast.parse("from ..simulation import Simulation\nimport cortex_ti.studies.figures\n")
    targets = [t for node in ast.walk(tree) for t in _targets(node, ("cortex_ti", "physics"))]
    assert targets == [("cortex_ti", "simulation"), ("cortex_ti", "studies", "figures")]
    assert all(_rank(t[1]) > _rank("physics") for t in targets)


def test_contributing_states_the_same_order():
    """CONTRIBUTING.md's sentence "from the bottom: `errors` -> ..." lists the layers of
    :data:`LAYERS` in the same order (names separated by commas share a layer)."""
    text = (ROOT / "CONTRIBUTING.md").read_text()
    match = re.search(r"from the bottom:(.*?)\.\s", text, flags=re.DOTALL)
    assert match, "CONTRIBUTING.md no longer states the layer order ('from the bottom: ...')"
    stated = []
    for step in match.group(1).split("→"):
        names = tuple(re.findall(r"`([a-z_]+)`", step))
        if names:
            stated.append(names)
    assert tuple(stated) == LAYERS


LIGHT = [
    "cortex_ti.scene",
    "cortex_ti.studies.registry",
    "cortex_ti.studies.sweeps",
    "cortex_ti.studies.stores",
    "cortex_ti.physics.formulations",
    "cortex_ti.physics.terms",
    "cortex_ti.simulation.setup",
    "cortex_ti.axisymmetric.run",
    "cortex_ti.io",
]


def _fresh(code: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=300, check=False
    )


def test_the_light_layers_import_no_taichi():
    """The issue's own check, and the rest of what is documented as light."""
    code = (
        "import cortex_ti.scene, cortex_ti.studies.registry, sys; assert 'taichi' not in sys.modules\n"
        + "".join(f"import {m}\n" for m in LIGHT)
        + "heavy = sorted(m for m in sys.modules if m.split('.')[0] == 'taichi')\n"
        + "assert not heavy, heavy[:3]\n"
    )
    res = _fresh(code)
    assert res.returncode == 0, res.stderr


@pytest.mark.parametrize("scene", ["furrow_p4_a1", "sphere_y20_tangential"])
def test_check_starts_no_taichi(scene):
    """``cortex-ti check`` builds the mesh and evaluates the tension, all without Taichi."""
    res = _fresh(
        "import sys\nfrom cortex_ti.cli import main\n"
        f"assert main(['check', '{scene}', '--set', 'mesh.nodes=162']) == 0\n"
        "assert 'taichi' not in sys.modules\n"
    )
    assert res.returncode == 0, res.stderr
    assert "valid" in res.stdout


def test_the_3d_run_does_import_taichi():
    """The check above can fail: the solver route does load Taichi."""
    res = _fresh("import sys\nfrom cortex_ti.simulation import Simulation\nassert 'taichi' in sys.modules\n")
    assert res.returncode == 0, res.stderr
