"""The package's layers (CONTRIBUTING.md): imports go one way, and the light layers start no Taichi.

* every import of every module of the package, read with :mod:`ast` (module-level and inside
  functions alike), goes to the module's own layer or a layer below it, in the order
  :data:`LAYERS` (the one list; CONTRIBUTING.md states it in words and a test checks they agree);
* no module imports itself through others: the graph of the package's modules, with an edge for
  every import that runs (module-level and inside functions alike: a deferred import is a cycle
  deferred, not removed), has no cycle. Imports under ``if TYPE_CHECKING:`` are left out: they
  never run (every module has ``from __future__ import annotations``) and only name a type;
* the exact solutions (:mod:`cortex_ti.truth`) are imported by no production module: only tests,
  benchmarks, the validation studies and the deprecated paths that forward to them;
* in a fresh interpreter, loading a scene, the study registry, the sweeps and the stores, the
  formulation and term registries, the run set-up and the axisymmetric model import no Taichi,
  nor does ``cortex-ti check``.
"""

import ast
import re
import subprocess
import sys
import warnings
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
    ("analysis", "truth"),
    ("dynamics",),
    ("scene",),
    ("io",),
    ("viz",),
    ("simulation", "axisymmetric"),
    ("models", "studies"),
    ("api", "cli"),
)
TOP = ("__main__", "__init__")
PACKAGE_METADATA = {"__version__"}
#: Deprecated modules at the package root that forward to their new home for one release; each
#: takes the layer of the module it forwards to (``cortex_ti.plotting`` -> ``cortex_ti.viz.plotting``).
FORWARDS = {"plotting": "viz"}


def _rank(part: str) -> int:
    part = FORWARDS.get(part, part)
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


#: Modules generated at build time (setuptools-scm), absent from a clean checkout.
GENERATED = {("cortex_ti", "_version")}


def _module_name(parts):
    return parts[:-1] if parts[-1] == "__init__" else parts


def _type_checking_nodes(tree):
    """The nodes inside ``if TYPE_CHECKING:`` blocks (never run)."""
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If):
            test = node.test
            name = test.id if isinstance(test, ast.Name) else getattr(test, "attr", None)
            if name == "TYPE_CHECKING":
                for child in node.body:
                    skip.update(id(n) for n in ast.walk(child))
    return skip


def _import_graph():
    """``{module: {modules it imports}}`` over the package, module names as tuples of parts. An
    ``from package import name`` goes to the submodule ``name`` when there is one, else to the
    package's ``__init__``; imports under ``if TYPE_CHECKING:`` are left out."""
    modules = {_module_name(parts): (path, package) for path, parts, package in _modules()}
    graph, unknown = {}, set()
    for name, (path, package) in modules.items():
        tree = ast.parse(path.read_text(), filename=str(path))
        skip = _type_checking_nodes(tree)
        edges = set()
        for node in ast.walk(tree):
            if id(node) in skip:
                continue
            for target in _targets(node, package):
                if target == ("cortex_ti", "<metadata>"):
                    target = ("cortex_ti",)
                if target in GENERATED:
                    continue
                if isinstance(node, ast.ImportFrom) and node.names and target in modules:
                    subs = [target + (a.name,) for a in node.names if target + (a.name,) in modules]
                    rest = [a for a in node.names if target + (a.name,) not in modules]
                    edges.update(subs)
                    if rest:
                        edges.add(target)
                    continue
                if target not in modules:
                    unknown.add(".".join(target))
                    continue
                edges.add(target)
        edges.discard(name)
        graph[name] = edges
    assert not unknown, f"imports of modules that do not exist: {sorted(unknown)}"
    return graph


def _cycles(graph):
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(".".join(c) for c in comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle():
    """Terms declare and formulations integrate: no module reaches itself through its imports."""
    graph = _import_graph()
    cycles = _cycles(graph)
    shown = []
    for comp in cycles:
        members = {tuple(c.split(".")) for c in comp}
        edges = [f"  {'.'.join(v)} -> {'.'.join(w)}" for v in sorted(members) for w in sorted(graph[v]) if w in members]
        shown.append(", ".join(comp) + "\n" + "\n".join(edges))
    assert not cycles, "import cycles (break each by moving what both sides share to a lower module):\n" + "\n".join(
        shown
    )


def test_the_cycle_check_sees_a_cycle():
    """The check itself: a cycle through a function-level import is found, a TYPE_CHECKING one is not."""
    graph = {("a",): {("b",)}, ("b",): {("c",)}, ("c",): {("a",)}, ("d",): {("a",)}}
    assert _cycles(graph) == [["a", "b", "c"]]
    tree = ast.parse("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .core import Simulation\n")
    skipped = _type_checking_nodes(tree)
    assert [n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and id(n) not in skipped][0].module == "typing"
    tree = ast.parse("def f():\n    from ..galerkin import normal_form_force\n")
    node = next(n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom))
    assert _targets(node, ("cortex_ti", "physics", "terms")) == [("cortex_ti", "physics", "galerkin")]


#: The truths (exact solutions) and who may import them besides tests and benchmarks: the truths
#: themselves, the validation studies, and the deprecated paths forwarding to them.
TRUTH = ("cortex_ti", "truth")
TRUTH_IMPORTERS = (
    ("cortex_ti", "truth"),
    ("cortex_ti", "studies"),
    ("cortex_ti", "analysis", "sphere_exact"),
    ("cortex_ti", "analysis", "analytic"),
)


def test_production_code_imports_no_truth():
    """The exact solutions stay out of what a run computes: only the studies (the validation
    figures and numbers), the tests and the benchmarks compare with them."""
    graph = _import_graph()
    wrong = [
        f"{'.'.join(v)} imports {'.'.join(w)}"
        for v in sorted(graph)
        for w in sorted(graph[v])
        if w[:2] == TRUTH and not any(v[: len(p)] == p for p in TRUTH_IMPORTERS)
    ]
    assert not wrong, "production code imports a truth (use physics.spherical, or move the caller):\n" + "\n".join(
        wrong
    )
    assert any(w[:2] == TRUTH for v in graph for w in graph[v]), "the check sees no import of a truth at all"


def test_the_old_truth_paths_forward_with_a_warning():
    """``cortex_ti.analysis.sphere_exact`` and ``.analytic`` keep working for one release."""
    import importlib

    from cortex_ti.truth import analytic, sphere_exact

    for name, new, attr in (("sphere_exact", sphere_exact, "sphere_flow"), ("analytic", analytic, "scene_solution")):
        old = importlib.import_module(f"cortex_ti.analysis.{name}")
        with pytest.warns(DeprecationWarning, match=f"cortex_ti.truth.{name}"):
            assert getattr(old, attr) is getattr(new, attr)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a probe for a name it never had warns of nothing
            assert not hasattr(old, "pytest_plugins")
        with pytest.warns(DeprecationWarning):
            exec(f"from cortex_ti.analysis.{name} import {attr}", {})


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
