"""Scenes: the shipped scenes, every validation rule, overrides, round trips."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest
import yaml

from cortex_ti.errors import CortexError, SceneError
from cortex_ti.physics.model import EFFECTS
from cortex_ti.scene import (
    VALID_NODE_COUNTS,
    apply_override,
    builtin_scene_names,
    builtin_scene_path,
    load_scene,
    scene_from_dict,
)

SHIPPED = ["sphere_y20_full", "sphere_y20_tangential", "sphere_y21_full", "sphere_y21_tangential"]
FULL = ["active_stress", "shear_viscosity", "bulk_viscosity", "normal_balance", "incompressibility"]
TANGENTIAL = ["active_stress", "shear_viscosity", "fixed_normal_velocity"]
SQRT_4PI = math.sqrt(4 * math.pi)


def base() -> dict:
    """A fresh raw copy of the sphere_y20_full scene mapping."""
    return yaml.safe_load(builtin_scene_path("sphere_y20_full").read_text())


def scene_error(data=None, overrides=(), source=None) -> str:
    """The SceneError message of building a scene (fails the test if none is raised)."""
    with pytest.raises(SceneError) as info:
        scene_from_dict(base() if data is None else data, overrides, source=source)
    return str(info.value)


# ----------------------------------------------------------------------------- shipped scenes

FURROWS = [
    "furrow_p4_a1",
    "furrow_p4_a3",
    "furrow_p8_a1",
    "fold_broad",
    "fold_narrow",
    "shear_035",
    "shear_035_tilted",
    "shear_075",
    "constriction_p4",
    "constriction_rigid",
]
#: issue 20's scenes: a myosin cortex that organises itself
MYOSIN = ["myosin_decay", "myosin_ring", "myosin_noise", "myosin_cued_ring", "myosin_constriction"]
#: issue 36's scenes: a cell between a cytoplasm and a medium (effect fluids)
FLUIDS = ["cell_in_shear", "sedimenting_cell", "furrow_in_fluid", "polarised_swimmer"]
#: issue 35's scenes: one cell becoming two
DIVISION = ["cytokinesis", "cytokinesis_rigid", "cytokinesis_asymmetric"]


def test_builtin_names_are_exactly_the_shipped_scenes():
    assert builtin_scene_names() == sorted(SHIPPED + FURROWS + MYOSIN + FLUIDS + DIVISION)
    for name in SHIPPED + FURROWS + MYOSIN + FLUIDS + DIVISION:
        path = builtin_scene_path(name)
        assert path.name == f"{name}.yaml" and path.parent.name == "scenes"
        assert path.parent.parent.name == "scene"  # package data of cortex_ti.scene


def test_no_scene_copies_outside_the_package():
    import cortex_ti

    repo = Path(cortex_ti.__file__).parent.parent
    copies = [
        p
        for p in repo.rglob("*.yaml")
        if p.stem in builtin_scene_names() and "scene" not in p.parent.parent.name and ".git" not in p.parts
    ]
    assert not copies


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_scene_values(name):
    scene = load_scene(builtin_scene_path(name))
    full = name.endswith("_full")
    assert scene.name == name
    assert scene.source == str(builtin_scene_path(name).resolve())
    assert "Sec. 4.1" in scene["description"]
    assert scene["mesh.nodes"] == 2562 and scene["mesh.file"] is None
    assert scene["mesh.radius"] == 1.0
    assert scene["viscosity.shear"] == 1.0
    assert scene["viscosity.bulk"] == (1.0 if full else 0.0)
    assert scene["viscosity.bending"] == 0.0 and scene["viscosity.bending_bulk"] == 0.0
    assert scene["effects"] == (FULL if full else TANGENTIAL)
    assert scene.effects == frozenset(FULL if full else TANGENTIAL)
    assert scene.has("normal_balance") is full
    assert scene.has("fixed_normal_velocity") is (not full)
    patterns = scene["active_stress"]
    assert len(patterns) == 1 and patterns[0]["type"] == "harmonics"
    if "y20" in name:
        assert patterns[0]["terms"] == [{"l": 2, "m": 0, "coeff": 1.0}]
    else:
        t00, t21 = patterns[0]["terms"]
        assert (t00["l"], t00["m"]) == (0, 0)
        assert abs(t00["coeff"] - SQRT_4PI) <= 1e-15
        # zeta_00 * Y_00 = zeta_00 / sqrt(4 pi) = 1
        assert abs(t00["coeff"] / SQRT_4PI - 1.0) <= 1e-15
        assert t21 == {"l": 2, "m": 1, "coeff": 1.0}
    # defaults filled from the schema
    assert scene["solver"] == {"backend": "auto", "reuse": True, "rtol": 1e-10, "refine": True}
    assert scene["time"] == {
        "dt": 5e-4,
        "t_end": 3.0,
        "scheme": "euler",
        "save_every": 0.01,
        "save_times": [],
        "steady_tol": 0.0,
        "stop_neck": None,
        "tol": None,  # the scheme's own default, resolved in the settings
        "dt_max": None,
        "implicit_tension": "auto",
    }
    assert (scene.settings.time.tol, scene.settings.time.dt_max) == (1e-4, 0.05)
    # the scene's own method (the paper's, quartic), the other keys filled from the schema
    assert scene["numerics"] == {
        "formulation": "paper",
        "fit": "quartic",
        "fit_residual_weight": 0.0,  # not null
        "pressure_weights": "petrov",
        "active_force": "balanced",
        "implicit_tension_weight": 1.0,
    }


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_scene_round_trips_through_yaml(name, tmp_path):
    scene = load_scene(builtin_scene_path(name))
    text = scene.to_yaml()
    again = scene_from_dict(yaml.safe_load(text))
    assert again == scene and again.data == scene.data
    assert again.to_yaml() == text
    (tmp_path / "copy.yaml").write_text(text)
    from_file = load_scene(tmp_path / "copy.yaml")
    assert from_file == scene and hash(from_file) == hash(scene)
    # float precision survives: sqrt(4 pi) exactly
    if "y21" in name:
        assert yaml.safe_load(text)["active_stress"][0]["terms"][0]["coeff"] == SQRT_4PI


def test_load_scene_by_bare_builtin_name():
    assert load_scene("sphere_y21_tangential") == load_scene(builtin_scene_path("sphere_y21_tangential"))


def test_unknown_builtin_scene_lists_available():
    with pytest.raises(SceneError) as info:
        builtin_scene_path("sphere_y99")
    msg = str(info.value)
    assert "sphere_y99" in msg
    for name in SHIPPED:
        assert name in msg


# ----------------------------------------------------------------------------- Scene API


def test_scene_getitem_has_effects():
    scene = load_scene("sphere_y20_full")
    assert scene["viscosity.shear"] == 1.0 and isinstance(scene["viscosity.shear"], float)
    assert scene["active_stress.0.terms.0.l"] == 2
    with pytest.raises(KeyError):
        scene["viscosity.shaer"]
    with pytest.raises(KeyError):
        scene["active_stress.5"]
    # returned containers are copies: the scene cannot be changed through them
    scene["viscosity"]["shear"] = 99.0
    assert scene["viscosity.shear"] == 1.0
    assert scene.has("incompressibility") and not scene.has("shape_evolution")
    with pytest.raises(ValueError, match="unknown effect 'incompresibility'"):
        scene.has("incompresibility")


def test_effects_vocabulary():
    assert list(EFFECTS) == [
        "active_stress",
        "shear_viscosity",
        "bulk_viscosity",
        "bending_viscosity",
        "bending_rigidity",
        "normal_balance",
        "fixed_normal_velocity",
        "incompressibility",
        "shape_evolution",
        "fluids",
    ]
    assert all(isinstance(d, str) and d for d in EFFECTS.values())
    assert VALID_NODE_COUNTS == (12, 42, 162, 642, 2562, 10242, 40962, 163842)


def test_defaults_and_canonical_numbers():
    data = {
        "name": "minimal",
        "mesh": {"nodes": 42},
        "viscosity": {"shear": 2, "bulk": 0},
        "active_stress": [{"type": "ring"}],
        "effects": ["active_stress", "shear_viscosity", "normal_balance", "shape_evolution"],
    }
    scene = scene_from_dict(data)
    assert data["viscosity"] == {"shear": 2, "bulk": 0}  # input not modified
    assert scene["description"] == ""
    assert scene["mesh"] == {
        "nodes": 42,
        "file": None,
        "radius": 1.0,
        "shear": 0.0,
        "transform": None,
        "motion": "normal",
        "ale_time": 0.05,
        "relax_start": None,
        "remesh": {
            "min_angle": None,
            "quality": 30.0,
            "size": "budget",
            "nodes": None,
            "coarser": None,
            "edge_angle": 0.25,
            "h_min": None,
            "h_max": None,
            "hausd": None,
            "hgrad": 1.3,
            "settle_steps": 0,
            "mirror": False,
            "settle_dt": 1e-3,
        },
    }
    assert scene.settings.mesh.remesh is None  # off by default
    assert scene["viscosity"] == {"shear": 2.0, "bulk": 0.0, "bending": 0.0, "bending_bulk": 0.0}
    assert type(scene["viscosity.shear"]) is float
    assert scene["active_stress"] == [
        {
            "type": "ring",
            "zeta0": 1.0,
            "amplitude": 1.0,
            "sigma": 10.0,
            "p": 8.0,
            "axis": [0.0, 0.0, 1.0],
            "center": math.pi / 2,
        }
    ]
    assert scene["time.dt"] == 5e-4 and scene["time.scheme"] == "euler"
    assert list(scene.data) == [
        "name",
        "description",
        "model",
        "translation",
        "tension_transport",
        "mesh",
        "viscosity",
        "rigidity",
        "fluid",
        "active_stress",
        "fields",
        "effects",
        "numerics",
        "solver",
        "time",
        "division",
        "axisymmetric",
    ]


def test_yaml_reads_exponent_without_dot_as_float(tmp_path):
    text = builtin_scene_path("sphere_y20_full").read_text() + "time:\n  dt: 1e-3\n"
    (tmp_path / "s.yaml").write_text(text)
    assert load_scene(tmp_path / "s.yaml")["time.dt"] == 0.001


# ----------------------------------------------------------------------------- file errors


def test_missing_scene_file(tmp_path):
    path = tmp_path / "nope.yaml"
    with pytest.raises(SceneError, match="nope.yaml") as info:
        load_scene(path)
    assert "not found" in str(info.value)
    assert isinstance(info.value, CortexError)


def test_missing_bare_scene_name_lists_builtins(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SceneError) as info:
        load_scene("sphere_y30")
    msg = str(info.value)
    assert msg.startswith("scene file 'sphere_y30' not found")
    assert "sphere_y20_full" in msg


def test_scene_yaml_is_a_list(tmp_path):
    path = tmp_path / "list.yaml"
    path.write_text("- name: x\n- mesh: 1\n")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    assert "list.yaml" in msg and "mapping" in msg and "list" in msg


@pytest.mark.parametrize(
    "text, words",
    [
        ("name: [unclosed\n", ["bad.yaml", "not valid YAML", "line"]),
        ("", ["bad.yaml", "empty"]),
        ("name: a\nname: b\n", ["bad.yaml", "duplicate key 'name'", "line 2"]),
    ],
)
def test_bad_yaml_files(tmp_path, text, words):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    for word in words:
        assert word in str(info.value)


def test_error_names_the_scene_file(tmp_path):
    path = tmp_path / "x.yaml"
    path.write_text(builtin_scene_path("sphere_y20_full").read_text().replace("bulk: 1.0", "bulk: .nan"))
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value) == f"scene '{path}': viscosity.bulk must be a finite number >= 0, got nan"


# ----------------------------------------------------------------------------- schema errors


@pytest.mark.parametrize(
    "override, expected",
    [
        # unknown keys, top level and nested, with suggestions
        ("viscosity.shaer=1", "unknown key 'viscosity.shaer' (did you mean 'viscosity.shear'?)"),
        ("viscocity.bulk=1", "unknown key 'viscocity' (did you mean 'viscosity'?)"),
        ("time.dtt=1", "unknown key 'time.dtt' (did you mean 'time.dt'?)"),
        (
            "foo=1",
            "unknown key 'foo' (valid keys here: name, description, model, translation, tension_transport, mesh, "
            "viscosity, rigidity, fluid, "
            "active_stress, fields, effects, numerics, solver, time, division, axisymmetric)",
        ),
        # wrong types
        ("viscosity.bulk=abc", "viscosity.bulk: 'abc' is not of type 'number'"),
        ("solver.reuse=3", "solver.reuse: 3 is not of type 'boolean'"),
        ("viscosity=3", "viscosity: 3 is not of type 'object'"),
        ("mesh.nodes=642.5", "mesh.nodes: 642.5 is not of type 'integer', 'null'"),
        # bad numbers
        ("viscosity.bulk=-1", "viscosity.bulk must be a finite number >= 0, got -1"),
        ("viscosity.shear=.nan", "viscosity.shear must be a finite number >= 0, got nan"),
        ("viscosity.bulk=.inf", "viscosity.bulk must be a finite number >= 0, got inf"),
        ("viscosity.bulk=-.inf", "viscosity.bulk must be a finite number >= 0, got -inf"),
        ("mesh.radius=0", "mesh.radius must be a finite number > 0, got 0"),
        ("solver.rtol=-1e-3", "solver.rtol must be a finite number > 0, got -0.001"),
        ("time.dt=.nan", "time.dt must be a finite number > 0, got nan"),
        ("active_stress.0.terms.0.coeff=.inf", "active_stress.0.terms.0.coeff must be a finite number, got inf"),
        # enums
        ("solver.backend=mkl", "solver.backend must be one of: auto, superlu, pardiso, cholmod; got 'mkl'"),
        ("time.scheme=rk4", "time.scheme must be one of: euler, heun, adaptive, adaptive_euler, bdf2, bdf3; got 'rk4'"),
    ],
)
def test_schema_errors_name_the_key(override, expected):
    assert (
        scene_error(overrides=[override])
        == "scene 'sphere_y20_full': " + (f"override '{override}': " if "unknown key" in expected else "") + expected
    )


def test_unknown_nested_key_in_yaml():
    data = base()
    data["viscosity"]["shaer"] = 1.0
    assert scene_error(data).endswith("unknown key 'viscosity.shaer' (did you mean 'viscosity.shear'?)")
    data = base()
    data["active_stress"][0]["terms"][0]["cof"] = 1.0
    assert scene_error(data).endswith(
        "unknown key 'active_stress.0.terms.0.cof' (did you mean 'active_stress.0.terms.0.coeff'?)"
    )
    data = base()
    data["solvr"] = {}
    assert scene_error(data).endswith("unknown key 'solvr' (did you mean 'solver'?)")


def test_missing_required_keys():
    data = base()
    del data["effects"]
    assert scene_error(data).endswith(": effects is required")
    data = base()
    del data["mesh"]
    assert "mesh is required" in scene_error(data)
    data = base()
    del data["active_stress"][0]["terms"][0]["m"]
    assert scene_error(data).endswith("active_stress.0.terms.0.m is required")


def test_unknown_pattern_type_lists_known_types():
    data = base()
    data["active_stress"][0]["type"] = "stripes"
    msg = scene_error(data)
    assert msg.endswith("active_stress.0.type must be one of: harmonics, ring, fold, field, python; got 'stripes'")


def test_pattern_keys_checked_per_type():
    data = base()
    data["active_stress"].append({"type": "ring", "sigmaa": 3})
    assert scene_error(data).endswith("unknown key 'active_stress.1.sigmaa' (did you mean 'active_stress.1.sigma'?)")
    data = base()
    data["active_stress"][0]["sigma"] = 3.0  # a ring key on a harmonics pattern
    assert "unknown key 'active_stress.0.sigma'" in scene_error(data)
    data = base()
    data["active_stress"].append({"type": "ring", "axis": [0, 1]})
    assert scene_error(data).endswith("active_stress.1.axis must have 3 items, got [0, 1]")
    data = base()
    data["active_stress"].append({"type": "ring", "axis": [0, 0, 0]})
    assert "active_stress.1.axis must not be all zero" in scene_error(data)
    data = base()
    data["active_stress"].append({"sigma": 1})
    assert scene_error(data).endswith("active_stress.1.type is required (one of: harmonics, ring, fold, field, python)")


def test_m_larger_than_l():
    data = base()
    data["active_stress"][0]["terms"][0]["m"] = -3
    assert scene_error(data).endswith("active_stress.0.terms.0.m = -3 but |m| must be <= l = 2")
    data["active_stress"][0]["terms"][0]["m"] = -2
    assert scene_from_dict(data)["active_stress.0.terms.0.m"] == -2


def test_negative_l():
    assert scene_error(overrides=["active_stress.0.terms.0.l=-1"]).endswith(
        "active_stress.0.terms.0.l must be an integer >= 0, got -1"
    )


# ----------------------------------------------------------------------------- rules


def test_invalid_node_count_lists_valid_values():
    msg = scene_error(overrides=["mesh.nodes=100"])
    assert "mesh.nodes = 100" in msg
    assert "12, 42, 162, 642, 2562, 10242, 40962, 163842" in msg


def test_nodes_and_file_both_set(tmp_path):
    mesh = tmp_path / "cell.obj"
    mesh.write_text("v 0 0 0\n")
    data = base()
    data["mesh"]["file"] = str(mesh)
    msg = scene_error(data)
    assert "mesh.nodes = 2562 and mesh.file" in msg and "exactly one" in msg
    data["mesh"] = {"radius": 1.0}
    assert "exactly one of mesh.nodes" in scene_error(data)


def test_missing_mesh_file_names_resolved_path(tmp_path):
    scene_file = tmp_path / "sub" / "s.yaml"
    scene_file.parent.mkdir()
    data = base()
    data["mesh"] = {"file": "meshes/cell.obj"}
    scene_file.write_text(yaml.safe_dump(data))
    with pytest.raises(SceneError) as info:
        load_scene(scene_file)
    resolved = tmp_path / "sub" / "meshes" / "cell.obj"
    assert f"mesh.file: '{resolved}' does not exist" in str(info.value)


def test_mesh_file_resolves_against_scene_folder(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "cell.obj").write_text("v 0 0 0\n")
    data = base()
    data["mesh"] = {"file": "meshes/cell.obj"}
    (tmp_path / "s.yaml").write_text(yaml.safe_dump(data))
    scene = load_scene(tmp_path / "s.yaml")
    assert scene["mesh.file"] == str(tmp_path / "meshes" / "cell.obj")
    assert scene["mesh.nodes"] is None
    # the stored absolute path round-trips
    assert scene_from_dict(yaml.safe_load(scene.to_yaml())) == scene


def test_unknown_and_duplicate_effects():
    msg = scene_error(
        overrides=["effects=[active_stress, shear_viscosity, bulk_viscosity, normal_balance, incompresibility]"]
    )
    assert "effects.4: unknown effect 'incompresibility' (did you mean 'incompressibility'?)" in msg
    assert "known effects: " + ", ".join(EFFECTS) in msg
    msg = scene_error(
        overrides=["effects=[active_stress, shear_viscosity, bulk_viscosity, normal_balance, active_stress]"]
    )
    assert msg.endswith("effects lists 'active_stress' twice")


@pytest.mark.parametrize(
    "effects, words",
    [
        (FULL + ["fixed_normal_velocity"], ["exactly one of 'normal_balance' and 'fixed_normal_velocity'", "both"]),
        (["active_stress", "shear_viscosity", "bulk_viscosity"], ["exactly one of", "neither"]),
        (
            ["active_stress", "shear_viscosity", "bulk_viscosity", "fixed_normal_velocity", "incompressibility"],
            ["'incompressibility' requires 'normal_balance'"],
        ),
        (
            ["active_stress", "shear_viscosity", "bulk_viscosity", "fixed_normal_velocity", "shape_evolution"],
            ["'shape_evolution' requires 'normal_balance'"],
        ),
    ],
)
def test_effect_combinations(effects, words):
    data = base()
    data["effects"] = effects
    msg = scene_error(data)
    for word in words:
        assert word in msg


def test_bending_viscosity_requires_normal_balance():
    data = base()
    data["viscosity"]["bending"] = 0.1
    data["effects"] = [
        "active_stress",
        "shear_viscosity",
        "bulk_viscosity",
        "fixed_normal_velocity",
        "bending_viscosity",
    ]
    assert "'bending_viscosity' requires 'normal_balance'" in scene_error(data)


@pytest.mark.parametrize("bulk", [0.0, 1.0])
def test_shear_viscosity_is_required(bulk):
    """Without eta_s the tangential problem has a kernel of all divergence-free flows."""
    data = base()
    data["viscosity"].update(shear=0.0, bulk=bulk)
    data["effects"] = ["active_stress", "normal_balance"] + (["bulk_viscosity"] if bulk else [])
    assert "effects must contain 'shear_viscosity'" in scene_error(data)


def test_coefficient_effect_mismatch_both_ways():
    # coefficient on, effect off
    data = base()
    data["effects"].remove("bulk_viscosity")
    assert scene_error(data) == (
        "scene 'sphere_y20_full': viscosity.bulk = 1 but the effect 'bulk_viscosity' is off: "
        "add it to effects or set viscosity.bulk: 0"
    )
    # effect on, coefficient off
    assert scene_error(overrides=["viscosity.shear=0"]).endswith(
        "the effect 'shear_viscosity' is on but viscosity.shear = 0: "
        "set viscosity.shear > 0 or remove 'shear_viscosity' from effects"
    )
    # bending: coefficient without effect, effect without coefficient
    assert scene_error(overrides=["viscosity.bending_bulk=0.25"]).endswith(
        "viscosity.bending_bulk = 0.25 but the effect 'bending_viscosity' is off: "
        "add it to effects or set viscosity.bending_bulk: 0"
    )
    data = base()
    data["effects"].append("bending_viscosity")
    assert "viscosity.bending = 0 and viscosity.bending_bulk = 0" in scene_error(data)
    data["viscosity"]["bending"] = 0.5
    assert scene_from_dict(data).has("bending_viscosity")
    # active stress: patterns without effect, effect without patterns
    data = base()
    data["effects"].remove("active_stress")
    assert "active_stress has 1 pattern(s) but the effect 'active_stress' is off" in scene_error(data)
    assert "the effect 'active_stress' is on but the active_stress list is empty" in scene_error(
        overrides=["active_stress=[]"]
    )


def test_passive_scene_without_active_stress_is_valid():
    data = base()
    del data["active_stress"]
    data["effects"].remove("active_stress")
    assert scene_from_dict(data)["active_stress"] == []


# ----------------------------------------------------------------------------- overrides


def test_override_numbers_and_lists():
    scene = scene_from_dict(
        base(),
        [
            "mesh.nodes=642",
            "viscosity.shear=2.5",
            "effects=[active_stress, shear_viscosity, normal_balance]",
            "viscosity.bulk=0",
        ],
    )
    assert scene["mesh.nodes"] == 642
    assert scene["viscosity.shear"] == 2.5 and scene["viscosity.bulk"] == 0.0
    assert scene["effects"] == ["active_stress", "shear_viscosity", "normal_balance"]


def test_override_is_applied_before_validation():
    # a valid scene made invalid by an override, caught with the key named
    assert scene_error(overrides=["viscosity.bulk=-1"]).endswith("viscosity.bulk must be a finite number >= 0, got -1")
    # an invalid scene made valid by an override
    data = base()
    data["viscosity"]["bulk"] = -1.0
    assert scene_from_dict(data, ["viscosity.bulk=2"])["viscosity.bulk"] == 2.0


def test_override_creates_missing_section():
    data = base()
    assert "time" not in data
    apply_override(data, "time.dt=1e-3")
    assert data["time"] == {"dt": 0.001}
    scene = scene_from_dict(base(), ["time.dt=2.5e-4", "time.scheme=adaptive"])
    assert scene["time.dt"] == 2.5e-4 and scene["time.scheme"] == "adaptive"
    assert scene["time.t_end"] == 3.0  # the rest from defaults


def test_override_list_items():
    scene = scene_from_dict(base(), ["active_stress.0.terms.0.coeff=-2"])
    assert scene["active_stress.0.terms.0.coeff"] == -2.0
    data = base()
    with pytest.raises(SceneError, match="active_stress has 1 item"):
        apply_override(data, "active_stress.4.type=ring")


def test_override_unknown_path_suggests():
    data = base()
    with pytest.raises(SceneError) as info:
        apply_override(data, "viscosity.shaer=1")
    assert str(info.value) == (
        "override 'viscosity.shaer=1': unknown key 'viscosity.shaer' (did you mean 'viscosity.shear'?)"
    )
    with pytest.raises(SceneError) as info:
        apply_override(data, "time.stepp=1")
    assert str(info.value) == "override 'time.stepp=1': unknown key 'time.stepp' (did you mean 'time.dt'?)"
    assert data == base()  # failed overrides leave the data untouched


@pytest.mark.parametrize("assignment", ["viscosity.bulk", "=1", "viscosity..bulk=1", "viscosity.bulk=[1"])
def test_malformed_overrides(assignment):
    with pytest.raises(SceneError, match="override"):
        apply_override(base(), assignment)


def test_override_switches_mesh_source(tmp_path, monkeypatch):
    (tmp_path / "cell.obj").write_text("v 0 0 0\n")
    monkeypatch.chdir(tmp_path)
    scene = scene_from_dict(base(), ["mesh.file=cell.obj"], source=str(builtin_scene_path("sphere_y20_full")))
    # relative to the working directory, not to the scene file's folder
    assert scene["mesh.file"] == str(tmp_path / "cell.obj")
    assert scene["mesh.nodes"] is None
    # and back again
    back = scene_from_dict(scene.data, ["mesh.nodes=642"])
    assert back["mesh.nodes"] == 642 and back["mesh.file"] is None
    # a missing file from an override names the resolved path
    msg = scene_error(overrides=["mesh.file=none.obj"])
    assert f"mesh.file: '{tmp_path / 'none.obj'}' does not exist" in msg


def test_scene_from_dict_does_not_modify_input():
    data = base()
    before = copy.deepcopy(data)
    scene_from_dict(data, ["viscosity.shear=3", "time.dt=1e-4"])
    assert data == before


@pytest.mark.parametrize(
    "name,p,amp,bend,bend_b",
    [
        ("furrow_p8_a1", 8, 1.0, 5e-4, 2.5e-3),
        ("furrow_p4_a1", 4, 1.0, 5e-4, 2.5e-3),
        ("furrow_p4_a3", 4, 3.0, 1e-4, 3.5e-3),
    ],
)
def test_furrow_scenes_carry_the_paper_parameters(name, p, amp, bend, bend_b):
    """docs/method/conventions.md, 'Scenes of the paper': Eq. 59 with zeta_0 = 1, sigma = 10, eta_s = eta_b = 1."""
    scene = load_scene(name)
    (ring,) = scene["active_stress"]
    assert ring["type"] == "ring" and ring["p"] == p and ring["amplitude"] == amp
    assert ring["zeta0"] == 1.0 and ring["sigma"] == 10.0 and ring["axis"] == [0, 0, 1]
    assert scene["viscosity.shear"] == scene["viscosity.bulk"] == 1.0
    assert (scene["viscosity.bending"], scene["viscosity.bending_bulk"]) == (bend, bend_b)
    assert scene["mesh.nodes"] == 2562 and scene["time.t_end"] == 3.0
    # the paper's Euler step was 5e-4; the scenes step with bdf2 (its first step 1e-3, local error per step
    # 4e-6 * 10242 / N, 1.6e-5 at 2562 nodes) and the semi-implicit tension (docs/derivations/time_schemes.md)
    assert scene["time.scheme"] == "bdf2" and scene["time.dt"] == 1e-3
    assert scene.settings.time.tol == 1.6e-5
    assert scene.settings.time.implicit_tension and scene.settings.numerics.formulation == "rayleigh_p1"
    assert {"shape_evolution", "bending_viscosity", "incompressibility"} <= scene.effects


# ----------------------------------------------------------------------------- user-supplied patterns

RING = {"type": "ring", "zeta0": 1.0, "amplitude": 1.0, "sigma": 10.0, "p": 8}


def ring_closed_form(points):
    """Paper Eq. 59 about +z (zeta0 = amplitude = 1, sigma = 10, p = 8), written out here."""
    import numpy as np

    x, y, z = np.asarray(points, dtype=float).T
    theta = np.arctan2(np.hypot(x, y), z)
    return 1.0 + np.exp(-10.0 * np.abs(theta - np.pi / 2) ** 8)


def write_ring_field(path, n=162):
    import numpy as np

    from cortex_ti.surface.mesh import icosphere

    path.parent.mkdir(parents=True, exist_ok=True)
    np.save(path, ring_closed_form(icosphere(n).points))
    return path


def with_patterns(patterns, nodes=162) -> dict:
    data = base()
    data["mesh"] = {"nodes": nodes}
    data["active_stress"] = patterns
    return data


def test_field_file_resolves_against_scene_folder(tmp_path):
    write_ring_field(tmp_path / "sub" / "fields" / "ring.npy")
    (tmp_path / "sub" / "s.yaml").write_text(
        yaml.safe_dump(with_patterns([{"type": "field", "file": "fields/ring.npy"}]))
    )
    scene = load_scene(tmp_path / "sub" / "s.yaml")
    assert scene["active_stress"] == [
        {"type": "field", "file": str(tmp_path / "sub" / "fields" / "ring.npy"), "name": None, "scale": 1.0}
    ]
    assert scene_from_dict(yaml.safe_load(scene.to_yaml())) == scene  # the absolute path round-trips
    # the same relative path in a scene without a file resolves against the working directory
    msg = scene_error(with_patterns([{"type": "field", "file": "fields/ring.npy"}]))
    assert f"active_stress.0.file: '{Path.cwd() / 'fields' / 'ring.npy'}' does not exist" in msg


def test_missing_field_file_names_resolved_path(tmp_path):
    (tmp_path / "sub").mkdir()
    data = with_patterns([RING, {"type": "field", "file": "fields/none.npy"}])
    (tmp_path / "sub" / "s.yaml").write_text(yaml.safe_dump(data))
    with pytest.raises(SceneError) as info:
        load_scene(tmp_path / "sub" / "s.yaml")
    resolved = tmp_path / "sub" / "fields" / "none.npy"
    assert str(info.value).endswith(
        f"active_stress.1.file: '{resolved}' does not exist "
        f"(the relative path 'fields/none.npy' resolves against '{tmp_path / 'sub'}')"
    )
    data["active_stress"][1]["file"] = str(tmp_path)
    assert f"active_stress.1.file: '{tmp_path}' is a folder, not a file" in scene_error(data)


def test_field_file_in_an_override_resolves_against_the_working_directory(tmp_path, monkeypatch):
    """As for mesh.file: a path typed on the command line is relative to where it is typed, also
    inside a list or mapping value."""
    write_ring_field(tmp_path / "cwd" / "ring.npy")
    write_ring_field(tmp_path / "scenes" / "ring.npy")
    scene_file = tmp_path / "scenes" / "s.yaml"
    scene_file.write_text(yaml.safe_dump(with_patterns([{"type": "field", "file": "ring.npy"}])))
    monkeypatch.chdir(tmp_path / "cwd")
    assert load_scene(scene_file)["active_stress.0.file"] == str(tmp_path / "scenes" / "ring.npy")
    for override in [
        "active_stress.0.file=ring.npy",
        "active_stress.0={type: field, file: ring.npy}",
        "active_stress=[{type: field, file: ring.npy, scale: 2}]",
    ]:
        assert load_scene(scene_file, [override])["active_stress.0.file"] == str(tmp_path / "cwd" / "ring.npy"), (
            override
        )


def test_field_and_python_patterns_are_checked_by_the_schema(tmp_path):
    file = str(write_ring_field(tmp_path / "ring.npy"))
    assert scene_error(with_patterns([{"type": "field"}])).endswith("active_stress.0.file is required")
    assert scene_error(with_patterns([{"type": "field", "file": file, "scael": 2}])).endswith(
        "unknown key 'active_stress.0.scael' (did you mean 'active_stress.0.scale'?)"
    )
    assert scene_error(with_patterns([{"type": "field", "file": ""}])).endswith(
        "active_stress.0.file must not be empty"
    )
    assert scene_error(with_patterns([{"type": "field", "file": file, "scale": float("nan")}])).endswith(
        "active_stress.0.scale must be a finite number, got nan"
    )
    assert "active_stress.0.scale" in scene_error(with_patterns([{"type": "field", "file": file, "scale": "big"}]))
    assert scene_error(with_patterns([{"type": "python"}])).endswith("active_stress.0.function is required")
    assert scene_error(with_patterns([{"type": "python", "function": "no_colon"}])).endswith(
        "active_stress.0.function must look like 'mypackage.patterns:blob', got 'no_colon'"
    )
    assert scene_error(with_patterns([{"type": "python", "function": "a.b:c", "params": [1, 2]}])).startswith(
        "scene 'sphere_y20_full': active_stress.0.params:"
    )
    assert "active_stress.0.function" in scene_error(with_patterns([{"type": "python", "function": ring_closed_form}]))
    assert "unknown key 'active_stress.0.file'" in scene_error(
        with_patterns([{"type": "python", "function": "a.b:c", "file": file}])
    )
    # valid: defaults filled in, params kept as given; the scene does not import the module
    scene = scene_from_dict(
        with_patterns(
            [
                {"type": "python", "function": "not_installed.mod:f", "params": {"width": 2, "axis": [0, 0, 1]}},
                {"type": "field", "file": file, "name": "zeta", "scale": 2},
            ]
        )
    )
    assert scene["active_stress"] == [
        {"type": "python", "function": "not_installed.mod:f", "params": {"width": 2, "axis": [0, 0, 1]}},
        {"type": "field", "file": file, "name": "zeta", "scale": 2.0},
    ]
    assert scene_from_dict(yaml.safe_load(scene.to_yaml())) == scene
    assert scene_from_dict(with_patterns([{"type": "python", "function": "a.b:c"}]))["active_stress.0.params"] == {}


USER_MODULE = """
import numpy as np


def ring(points, zeta0, amplitude, sigma, p):
    x, y, z = points.T
    theta = np.arctan2(np.hypot(x, y), z)
    return zeta0 + amplitude * np.exp(-sigma * np.abs(theta - np.pi / 2) ** p)
"""


@pytest.mark.usefixtures("taichi_runtime")
def test_static_solve_with_field_and_python_patterns_equals_the_ring(tmp_path, monkeypatch):
    """The full static system at 162 nodes: the ring of Eq. 59 given as a per-node field file and
    as a user's Python function gives the velocity of the built-in ring pattern (1e-12)."""
    import sys

    import numpy as np

    from cortex_ti.simulation import Simulation

    (tmp_path / "ring_patterns_for_scene_test.py").write_text(USER_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "ring_patterns_for_scene_test", raising=False)
    file = write_ring_field(tmp_path / "ring.npy")
    params = {k: RING[k] for k in ("zeta0", "amplitude", "sigma", "p")}
    sims = {
        name: Simulation(scene_from_dict(with_patterns([pattern])))
        for name, pattern in [
            ("ring", RING),
            ("field", {"type": "field", "file": str(file)}),
            ("python", {"type": "python", "function": "ring_patterns_for_scene_test:ring", "params": params}),
        ]
    }
    np.testing.assert_allclose(sims["field"].zeta, sims["ring"].zeta, rtol=0, atol=1e-14)
    np.testing.assert_allclose(sims["python"].zeta, sims["ring"].zeta, rtol=0, atol=1e-14)
    ring = sims["ring"].solve()
    scale = np.abs(ring.velocity).max()
    assert scale > 0.1  # the ring drives a real flow
    for name in ("field", "python"):
        sol = sims[name].solve()
        np.testing.assert_allclose(sol.velocity, ring.velocity, rtol=0, atol=1e-12, err_msg=name)
        assert sol.pressure == pytest.approx(ring.pressure, abs=1e-12)
    sys.modules.pop("ring_patterns_for_scene_test", None)


def test_holding_the_centroid_needs_the_normal_balance():
    with pytest.raises(SceneError, match="translation = centroid needs the normal force balance"):
        load_scene("sphere_y20_tangential", ["translation=centroid"])


def test_the_default_tolerance_follows_the_remeshing_budget():
    """bdf2's default ``time.tol`` follows the mesh's error, ~1/N: after the first remeshing the mesh
    has the budget's nodes, so a larger ``mesh.remesh.nodes`` sets it (a 10242-node budget on a
    2562-node start got 2562's tolerance, and its step moved a node half its edge at t = 0.31)."""
    from cortex_ti.dynamics.schemes import BDF2

    def tol(*over):
        return load_scene("cytokinesis_rigid", list(over)).settings.time.tol

    assert tol() == BDF2.default_tol_for(2562)
    assert tol("mesh.remesh.nodes=10242") == BDF2.default_tol_for(10242) < tol()
    assert tol("mesh.remesh.nodes=642") == tol()  # a smaller budget: the start's, the finer, keeps it
    assert tol("mesh.remesh.nodes=10242", "time.tol=1e-5") == 1e-5
