"""A setting is resolved once, in :class:`~cortex_ti.scene.settings.RunSettings` (CONTRIBUTING.md):
no module of the layers below ``scene``, nor of ``simulation/``, reads a scene's raw data.

The rule, read with :mod:`ast`: an expression that names a scene (a name or an attribute ending in
``scene``: ``scene``, ``sim.scene``, ``self.scene``) is never followed by ``.data`` / ``._data``
(the validated mapping) nor subscripted (``scene["time.dt_max"]``, :meth:`Scene.__getitem__`).
What such code needs is a typed field of ``RunSettings`` (``scene.settings``); writing the scene's
YAML (``scene.to_yaml()``) is not reading a setting and is allowed.
"""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "cortex_ti"

#: the layers below ``scene`` (CONTRIBUTING.md; tests/repository/test_layers.py LAYERS) and the run
CHECKED = (
    "errors.py",
    "about.py",
    "_version.py",
    "solve",
    "runtime",
    "surface",
    "physics",
    "analysis",
    "truth",
    "dynamics",
    "simulation",
)


def _names_scene(node) -> bool:
    if isinstance(node, ast.Name):
        return node.id.endswith("scene")
    return isinstance(node, ast.Attribute) and node.attr.endswith("scene")


def raw_reads(source: str) -> list[int]:
    """The lines of ``source`` that read a scene's raw data (the rule of the module docstring)."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr in ("data", "_data") and _names_scene(node.value):
            lines.append(node.lineno)
        elif isinstance(node, ast.Subscript) and _names_scene(node.value):
            lines.append(node.lineno)
    return sorted(lines)


def _checked_files():
    for entry in CHECKED:
        path = PACKAGE / entry
        yield from ([path] if path.is_file() else sorted(path.rglob("*.py")))


@pytest.mark.parametrize(
    "code, hits",
    [
        ('asked = sim.scene.data["time"].get("dt_max")', 1),
        ("x = self.scene._data", 1),
        ('dt = scene["time.dt_max"]', 1),
        ("from_dict(sim.scene.data, ['time.t_end=1'])", 1),
        ("dt = sim.settings.time.dt_max", 0),
        ("text = sim.scene.to_yaml()", 0),
        ("reach.data[:] = 1.0", 0),  # a sparse matrix's data, not a scene's
    ],
)
def test_rule_finds_raw_reads(code, hits):
    """The rule itself: it flags each way of reading a scene's raw data, and only those."""
    assert len(raw_reads(code)) == hits


def test_nothing_below_scene_reads_raw_scene_data():
    files = list(_checked_files())
    assert any(p.parts[-2:] == ("simulation", "run.py") for p in files)  # the run is among them
    found = [
        f"{path.relative_to(ROOT)}:{line}" for path in files for line in raw_reads(path.read_text(encoding="utf-8"))
    ]
    assert not found, "raw scene data read below the scene layer (use RunSettings): " + ", ".join(found)


def test_settings_know_whether_the_scene_set_dt_max():
    from cortex_ti.dynamics.schemes import SCHEMES
    from cortex_ti.scene import load_scene

    base = [
        "effects=[active_stress,shear_viscosity,bulk_viscosity,normal_balance,shape_evolution]",
        "time.scheme=adaptive",
    ]
    default = load_scene("sphere_y20_full", base).settings.time
    assert not default.dt_max_set and default.dt_max == SCHEMES["adaptive"].default_dt_max
    given = load_scene("sphere_y20_full", [*base, "time.dt_max=0.002"]).settings.time
    assert given.dt_max_set and given.dt_max == 0.002


def test_remesh_size_defaults_resolved_against_the_initial_mesh():
    """The defaults as the scene schema's descriptions state them: h_min = mean edge / 7.5; a budget
    run keeps the initial node count with h_max = 3 mean edges, a curvature run h_max = mean edge."""
    from cortex_ti.scene import load_scene

    def sized(*sets):
        dynamic = "effects=[active_stress,shear_viscosity,bulk_viscosity,normal_balance,shape_evolution]"
        scene = load_scene("sphere_y20_full", [dynamic, "mesh.remesh.min_angle=20", *sets])
        return scene.settings.mesh.remesh.sized(0.3, 642)

    o = sized()
    assert (o.h_min, o.h_max, o.nodes) == (pytest.approx(0.04), pytest.approx(0.9), 642)
    o = sized("mesh.remesh.size=curvature")
    assert (o.h_min, o.h_max, o.nodes) == (pytest.approx(0.04), pytest.approx(0.3), None)
    o = sized("mesh.remesh.h_min=0.02", "mesh.remesh.h_max=0.5", "mesh.remesh.nodes=1000")
    assert (o.h_min, o.h_max, o.nodes) == (0.02, 0.5, 1000)
