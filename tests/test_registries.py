"""Each vocabulary has one source: its registry. The scene schema is built from the registries,
the workflow's config schema agrees with them (a test, since Snakemake validates against a
file), and registering a new pattern really makes it a valid scene pattern."""

from pathlib import Path

import numpy as np
import pytest
import yaml

from cortex_ti.dynamics.schemes import SCHEMES
from cortex_ti.errors import SceneError
from cortex_ti.physics.formulations import FORMULATIONS
from cortex_ti.physics.galerkin import PRESSURE_WEIGHTS
from cortex_ti.physics.model import EFFECTS
from cortex_ti.physics.patterns import PATTERNS, pattern_schemas, register_pattern
from cortex_ti.physics.terms import TERMS
from cortex_ti.physics.terms.active import ACTIVE_FORCES
from cortex_ti.scene import full_schema, load_scene, scene_from_dict
from cortex_ti.solve.factorizations import FACTORIZATIONS
from cortex_ti.studies.registry import FIGURES, STORES, STUDIES, TABLES
from cortex_ti.surface.fits import FIT_SCHEMES

ROOT = Path(__file__).resolve().parents[1]
CONFIG_SCHEMA = yaml.safe_load((ROOT / "config" / "schema" / "config.schema.yaml").read_text())


def _enum(defn):
    """The values a config-schema definition (value or list of values) allows."""
    return defn["oneOf"][0]["enum"]


def test_scene_schema_enums_are_the_registries():
    schema = full_schema()
    props = schema["properties"]
    assert props["numerics"]["properties"]["fit"]["enum"] == list(FIT_SCHEMES)
    assert props["numerics"]["properties"]["formulation"]["enum"] == list(FORMULATIONS)
    assert props["numerics"]["properties"]["pressure_weights"]["enum"] == list(PRESSURE_WEIGHTS)
    assert props["numerics"]["properties"]["active_force"]["enum"] == list(ACTIVE_FORCES)
    assert props["time"]["properties"]["scheme"]["enum"] == list(SCHEMES)
    assert props["solver"]["properties"]["backend"]["enum"] == ["auto", *FACTORIZATIONS]
    assert schema["$defs"]["pattern"]["properties"]["type"]["enum"] == list(PATTERNS)
    assert all(schema["$defs"][name] == pattern_schemas()[name] for name in PATTERNS)


def test_config_schema_vocabularies_agree_with_the_registries():
    defs = CONFIG_SCHEMA["$defs"]
    assert _enum(defs["scheme"]) == list(SCHEMES)
    assert _enum(defs["fit"]) == list(FIT_SCHEMES)
    assert _enum(defs["formulation"]) == list(FORMULATIONS)
    methods = CONFIG_SCHEMA["properties"]["static"]["properties"]["methods"]
    assert methods["propertyNames"]["enum"] == list(FORMULATIONS)
    assert methods["additionalProperties"]["items"]["enum"] == list(FIT_SCHEMES)
    # every study of the registry has its section, and no section is unknown to it
    sections = set(CONFIG_SCHEMA["properties"]) - {"threads", "static", "figures"}
    configured = {name for name, s in STUDIES.items() if not s.twin_of}  # the others are derived
    assert sections == configured
    for name in configured:
        study = STUDIES[name]
        allowed = set(CONFIG_SCHEMA["properties"][name]["properties"]["runs"]["items"]["properties"])
        assert allowed == set(study.columns), name


def test_every_term_declares_a_known_effect():
    assert all(t.effect is None or t.effect in EFFECTS for t in TERMS)


def test_every_store_and_figure_source_is_registered():
    assert set(STORES) >= {"convergence", "cost"} | {n for n, s in STUDIES.items() if s.has_store}
    for spec in FIGURES.values():
        if spec.source == "static":  # the static runs at (nodes, fit, formulation)
            assert int(spec.data[0]) > 0 and spec.data[1] in FIT_SCHEMES and spec.data[2] in FORMULATIONS, spec.name
            continue
        assert set(spec.data) <= (set(STORES) if spec.source == "store" else set(STUDIES)), spec.name
    from cortex_ti.studies import figures

    assert all(callable(getattr(figures, spec.draw)) for spec in FIGURES.values())


def test_every_caption_is_valid_restructuredtext():
    """The report renders the captions with docutils: one that it cannot parse (a ``|x|`` read as a
    substitution) shows an error in the report."""
    import io

    import docutils.core

    for name, caption in [*((f.name, f.caption) for f in FIGURES.values()), *TABLES.items()]:
        text = caption if isinstance(caption, str) else caption[1]
        warnings = io.StringIO()
        docutils.core.publish_doctree(text, settings_overrides={"report_level": 2, "warning_stream": warnings})
        assert warnings.getvalue() == "", (name, warnings.getvalue())


def test_a_registered_pattern_is_a_valid_scene_pattern():
    base = yaml.safe_load(load_scene("sphere_y20_full").to_yaml())
    base["active_stress"] = [{"type": "test_cosine", "k": 2.0}]
    with pytest.raises(SceneError, match="test_cosine"):
        scene_from_dict(base)  # not registered yet: the schema refuses the type
    schema = {
        "type": "object",
        "additionalProperties": False,
        "required": ["type"],
        "properties": {"type": {"const": "test_cosine"}, "k": {"type": "number", "default": 1.0}},
    }

    @register_pattern("test_cosine", schema=schema)
    def cosine(points, k=1.0):
        return np.cos(k * points[:, 2])

    try:
        scene = scene_from_dict(base)
        assert scene["active_stress.0"] == {"type": "test_cosine", "k": 2.0}
        bad = dict(base, active_stress=[{"type": "test_cosine", "q": 1.0}])
        with pytest.raises(SceneError, match="unknown key 'active_stress.0.q'"):
            scene_from_dict(bad)  # and its own schema checks its parameters
    finally:
        PATTERNS.pop("test_cosine")
