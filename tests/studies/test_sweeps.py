"""Sweep tables of the workflow: config records -> one row per run -> scene overrides."""

import json
import math

import numpy as np
import pytest

from cortex_ti.errors import SceneError
from cortex_ti.scene import load_scene
from cortex_ti.studies.figures import pareto_front
from cortex_ti.studies.registry import STUDIES
from cortex_ti.studies.sweeps import (
    expand_runs,
    format_value,
    job_resources,
    scene_overrides,
    tilt_axis,
    twin_key,
    twin_rows,
)


def test_lists_expand_to_the_cartesian_product_and_missing_values_come_from_the_scene():
    rows = expand_runs("furrow", [{"scene": "furrow_p4_a1", "zeta_hat": [1, 3], "dt": [5e-4, 1e-3]}])
    assert len(rows) == 4
    assert [(r["zeta_hat"], r["dt"]) for r in rows] == [
        ("1", "0.0005"),
        ("1", "0.001"),
        ("3", "0.0005"),
        ("3", "0.001"),
    ]
    scene = load_scene("furrow_p4_a1")
    for r in rows:
        assert list(r) == list(STUDIES["furrow"].columns)
        assert r["p"] == format_value(scene["active_stress.0.p"]) == "4"
        assert r["nodes"] == str(scene["mesh.nodes"])
        assert r["scheme"] == scene["time.scheme"]


def test_duplicate_records_give_one_run():
    rows = expand_runs("fold", [{"scene": "fold_narrow"}, {"scene": "fold_narrow", "nodes": 2562}])
    assert len(rows) == 1


def test_overrides_rebuild_the_run_scene():
    row = expand_runs("reorientation", [{"scene": "shear_035", "gamma": 0.75, "tilt": 45, "t_end": 0.2}])[0]
    scene = load_scene(row["scene"], scene_overrides(row))
    assert scene["mesh.shear"] == 0.75
    assert scene["time.t_end"] == 0.2
    axis = np.asarray(scene["active_stress.0.axis"])
    assert np.allclose(axis, [math.sqrt(0.5), 0.0, math.sqrt(0.5)], atol=1e-14)
    # the tilted built-in scene reads back as tilt 45
    tilted = expand_runs("reorientation", [{"scene": "shear_035_tilted"}])[0]
    assert float(tilted["tilt"]) == pytest.approx(45.0, abs=1e-9)


def test_tilt_axis_rotates_z_toward_x():
    assert np.allclose(tilt_axis(0), [0, 0, 1])
    assert np.allclose(tilt_axis(90), [1, 0, 0], atol=1e-15)
    assert np.linalg.norm(tilt_axis(30)) == pytest.approx(1.0, abs=1e-14)


def test_values_are_the_shortest_exact_text():
    assert format_value(5e-4) == "0.0005"
    assert format_value(2562.0) == "2562"
    assert float(format_value(0.1 + 0.2)) == 0.1 + 0.2


@pytest.mark.parametrize(
    "records, message",
    [
        ([{"nodes": 642}], "names no scene"),
        ([{"scene": "furrow_p8_a1", "gamma": 0.3}], "unknown parameter(s) gamma"),
        ([{"scene": "furrow_p8_a1", "dt": []}], "empty list"),
        ([{"scene": "furrow_p8_a1", "fit": "a/b"}], "cannot name a folder"),
        ([{"scene": "furrow_p8_a1", "dt": float("nan")}], "finite"),
        ([{"scene": "no_such_scene"}], "no_such_scene"),
    ],
)
def test_bad_records_name_the_problem(records, message):
    with pytest.raises(SceneError, match=message.replace("(", r"\(").replace(")", r"\)")):
        expand_runs("furrow", records)


def test_unknown_study():
    with pytest.raises(SceneError, match="unknown study"):
        expand_runs("nope", [])


def test_job_resources_from_benchmarks(tmp_path):
    def bench(folder, nodes, s, rss):
        folder.mkdir(parents=True)
        (folder / "benchmark.tsv").write_text(
            "s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\tmean_load\tcpu_time\n"
            f"{s}\t0:00:01\t{rss}\t1\t1\t1\t0\t0\t1\t1\n"
        )
        (folder / "summary.json").write_text(json.dumps({"n_nodes": nodes}))
        return folder / "benchmark.tsv"

    files = [
        bench(tmp_path / "a", 2562, 600.0, 300.0),
        bench(tmp_path / "b", 2562, 100.0, 400.0),
        bench(tmp_path / "c", 642, 9000.0, 9000.0),
    ]
    got = job_resources(files, 2562)
    assert got == {"mem_mb": 600, "runtime": 15}  # 1.5 x 400 MB, 1.5 x 600 s = 15 min
    default = job_resources(files, 10242)  # nothing measured at that size
    assert default["mem_mb"] > job_resources([], 2562)["mem_mb"]


def test_pareto_front():
    cost = np.array([1.0, 2.0, 3.0, 4.0, np.nan, 2.5])
    err = np.array([1.0, 0.5, 0.7, 0.1, 0.01, 0.5])
    # 3 (cost 3, err .7) and 5 (cost 2.5, err .5 tie) are dominated; NaN ignored
    assert pareto_front(cost, err).tolist() == [0, 1, 3]


def test_the_implicit_tension_column_says_what_runs():
    """'auto' (the scene default) is resolved per scheme; a refused combination fails when the
    table is built, not in a job."""
    rows = expand_runs(
        "accuracy",
        [
            {"scene": "furrow_p8_a1", "scheme": ["euler", "adaptive_euler", "heun"]},
            {"scene": "furrow_p8_a1", "scheme": "euler", "implicit": False},
        ],
    )
    assert [(r["scheme"], r["implicit"]) for r in rows] == [
        ("euler", "true"),
        ("adaptive_euler", "true"),
        ("heun", "false"),
        ("euler", "false"),
    ]
    for r in rows:
        assert load_scene(r["scene"], scene_overrides(r))["time.implicit_tension"] is (r["implicit"] == "true")
    with pytest.raises(SceneError, match=r"accuracy runs\[0\].*first-order"):
        expand_runs("accuracy", [{"scene": "furrow_p8_a1", "scheme": "heun", "implicit": True}])


def test_the_residual_column_gives_the_weight_that_runs():
    rows = expand_runs(
        "accuracy",
        [
            {"scene": "furrow_p8_a1", "nodes": 642, "formulation": "paper", "residual": [0, 1e-3]},
            {"scene": "furrow_p8_a1", "nodes": 642, "formulation": "paper"},
        ],
    )
    assert [r["residual"] for r in rows] == ["0", "0.001"]  # the scene's default (null) is 0
    assert load_scene(rows[1]["scene"], scene_overrides(rows[1]))["numerics.fit_residual_weight"] == 1e-3


def test_a_swept_tilt_names_the_same_folder_as_the_scenes_own():
    """tilt 45 given in a record and the shear_035_tilted scene's own 45-degree axis are one run
    (the axis round-trips through 15 digits; the folder must not read 44.999999999999964)."""
    rows = expand_runs(
        "reorientation", [{"scene": "shear_035_tilted", "tilt": [22.5, 45]}, {"scene": "shear_035_tilted"}]
    )
    assert [r["tilt"] for r in rows] == ["22.5", "45"]


def test_the_remesh_column_turns_remeshing_off_for_the_axisymmetric_model():
    """One scene, both models: its 3D runs remesh at the scene's angle; ``remesh: null`` (written
    ``null`` in the folder name) turns it off so the axisymmetric model, which has no mesh, accepts it."""
    rows = expand_runs(
        "constriction",
        [{"scene": "constriction_p4", "model": "axisymmetric", "remesh": None}, {"scene": "constriction_p4"}],
    )
    assert [(r["model"], r["remesh"]) for r in rows] == [("axisymmetric", "null"), ("3d", "25")]
    twin, three_d = (load_scene(r["scene"], scene_overrides(r)).settings for r in rows)
    assert twin.model == "axisymmetric" and twin.mesh.remesh is None
    assert three_d.mesh.remesh is not None and three_d.mesh.remesh.min_angle == 25
    with pytest.raises(SceneError, match="no triangle mesh"):
        expand_runs("constriction", [{"scene": "constriction_p4", "model": "axisymmetric"}])


def test_a_scene_without_a_pattern_has_null_pattern_columns_and_its_twin():
    """myosin_constriction's ring forms by itself: its zeta_hat and p are null (not an error), a null
    sets nothing (the run is the scene's), a given value still needs a pattern, and its twin key is
    the same scene's with null pattern columns. A patterned scene given ``zeta_hat: null`` runs its own
    amplitude, and the row says so."""
    rows = expand_runs(
        "constriction",
        [
            {"scene": "myosin_constriction", "model": "axisymmetric", "remesh": None},
            {"scene": "myosin_constriction"},
            {"scene": "constriction_p4", "zeta_hat": None},
        ],
    )
    assert [(r["model"], r["zeta_hat"], r["p"]) for r in rows] == [
        ("axisymmetric", "null", "null"),
        ("3d", "null", "null"),
        ("3d", "6", "4"),
    ]
    assert not any(o.startswith("active_stress") for o in scene_overrides(rows[0]))
    settings = load_scene("myosin_constriction", scene_overrides(rows[1])).settings
    assert not settings.patterns and settings.mesh.remesh.min_angle == 25
    assert twin_key(rows[1]) == twin_key(rows[0]) == ("myosin_constriction", "null", "null", "dissipation")
    with pytest.raises(SceneError, match="myosin_constriction"):
        expand_runs("constriction", [{"scene": "myosin_constriction", "zeta_hat": 6}])


def test_the_myosin_columns_set_the_seeded_harmonic_the_law_and_the_turnover():
    """A self_organisation row names the myosin the run has: the seeded harmonic's degree and
    amplitude, the linear law's slope and the turnover, read back from the scene the row makes."""
    rows = expand_runs(
        "self_organisation",
        [{"scene": "myosin_decay", "degree": 3, "seed": 1e-3, "myosin_gamma": 0.7, "turnover": 0.05, "nodes": 642}],
    )
    assert rows == [
        {
            "scene": "myosin_decay",
            "model": "3d",
            "degree": "3",
            "seed": "0.001",
            "myosin_gamma": "0.7",
            "turnover": "0.05",
            "nodes": "642",
            "tol": "6.4e-05",  # bdf2's default at 642 nodes
            "dt_max": "0.2",  # bdf2's default
            "t_end": "10",
        }
    ]
    f = load_scene("myosin_decay", scene_overrides(rows[0])).settings.field("myosin")
    assert f["initial"][0]["terms"][0] == {"l": 3, "m": 0, "coeff": 1e-3}
    assert (f["tension"]["gamma"], f["turnover"]) == (0.7, 0.05)
    with pytest.raises(SceneError, match="fields.myosin.initial.0.terms.0.l"):
        expand_runs("self_organisation", [{"scene": "myosin_noise"}])  # noise, no seeded harmonic


def test_the_self_organisation_store_holds_each_degrees_amplitude(tmp_path):
    """The store's ``myosin_amplitude`` at t = 0 is the seeded harmonic exactly (the expansion
    reproduces a harmonic to round-off), and the run's volume is held."""
    from cortex_ti.simulation import Simulation
    from cortex_ti.studies.stores import study_dataset

    rows = expand_runs("self_organisation", [{"scene": "myosin_decay", "degree": 2, "nodes": 162, "t_end": 0.5}])
    path = Simulation(load_scene("myosin_decay", scene_overrides(rows[0]))).run(tmp_path / "d.h5", progress=False)
    ds = study_dataset("self_organisation", rows, [path])
    a = ds["myosin_amplitude"].isel(run=0)
    assert a.dims == ("time", "l") and ds["degree"].values[0] == 2
    assert a.values[0, 2] == pytest.approx(0.05, abs=1e-13) and a.values[0, [1, 3, 4]].max() < 1e-13
    assert a.values[0, 0] == pytest.approx(math.sqrt(4 * math.pi), rel=1e-13)
    assert 0.0 < a.values[-1, 2] < a.values[0, 2]  # below onset it decays


def test_twins_solve_the_bending_form_of_the_runs_they_serve():
    """A 3D run's twin solves the bending viscosity its formulation discretises (rayleigh_p1: the
    dissipation's derivative; paper: Eq. 45), so runs of the two formulations get two twins, and a
    scene run with ``model: axisymmetric`` resolves ``auto`` to its formulation's form."""
    rows = [
        {"scene": "furrow_p4_a1", "formulation": "rayleigh_p1", "t_end": "3"},
        {"scene": "furrow_p4_a1", "formulation": "paper", "t_end": "1"},
        {"scene": "furrow_p4_a1", "formulation": "rayleigh_p2", "t_end": "2"},
    ]
    twins = twin_rows(rows, STUDIES["axisymmetric"].columns)
    assert sorted((t["bending_form"], t["t_end"]) for t in twins) == [("dissipation", "3"), ("paper", "1")]
    for twin in twins:
        settings = load_scene(twin["scene"], scene_overrides(twin)).settings
        assert settings.model == "axisymmetric" and settings.axisymmetric.bending_form == twin["bending_form"]
    for formulation, form in (("rayleigh_p1", "dissipation"), ("paper", "paper")):
        overrides = ["model=axisymmetric", f"numerics.formulation={formulation}"]
        assert load_scene("furrow_p4_a1", overrides).settings.axisymmetric.bending_form == form
