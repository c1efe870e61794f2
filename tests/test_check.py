"""``cortex-ti check`` is ``run`` without the run (issue 34): what a run refuses before its first
solve, check refuses with the same line (step sizes, the ALE step limit, remeshing without its
extra); values that are legal but unphysical are warned of by both."""

from __future__ import annotations

import logging

import pytest

import cortex_ti as ct
from cortex_ti.cli import main
from cortex_ti.errors import SceneError

pytestmark = pytest.mark.usefixtures("taichi_runtime")

SMALL = ["--set", "mesh.nodes=162", "--set", "time.t_end=0.01"]


def _line(capsys, argv) -> str:
    assert main(argv) == 2
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cortex-ti: error: "), err
    return lines[0]


def _same_refusal(capsys, tmp_path, sets):
    said = _line(capsys, ["check", "furrow_p8_a1", *SMALL, *sets])
    out = tmp_path / "x.h5"
    assert _line(capsys, ["run", "furrow_p8_a1", *SMALL, *sets, "-o", str(out), "--threads", "1"]) == said
    assert list(tmp_path.iterdir()) == []
    return said


def test_a_step_no_run_can_take_is_refused_by_check_run_and_python(tmp_path, capsys):
    """time.dt = 1e-300 was 'valid' and then spun (euler) or crashed (bdf2): 3e298 steps to t = 0.01."""
    said = _same_refusal(capsys, tmp_path, ["--set", "time.dt=1e-300"])
    assert "time.dt = 1e-300 is too small for time.t_end = 0.01" in said
    with pytest.raises(SceneError, match="time.dt = 1e-300 is too small"):
        ct.load_scene("furrow_p8_a1", dt=1e-300, t_end=0.01)
    # the bound: at most 1e8 steps (t_end / dt); 1e8 steps exactly are allowed
    ct.load_scene("furrow_p8_a1", dt=1e-10, t_end=0.01)
    with pytest.raises(SceneError, match="at most 1e"):
        ct.load_scene("furrow_p8_a1", dt=0.99e-10, t_end=0.01)


def test_an_ale_step_above_the_stability_limit_is_refused_by_check_as_by_run(tmp_path, capsys):
    sets = ["--set", "mesh.motion=ale", "--set", "tension_transport=material"]
    big = ["--set", "time.scheme=euler", "--set", "time.dt=2", "--set", "time.t_end=4"]  # 162 nodes: limit ~0.6
    said = _same_refusal(capsys, tmp_path, [*sets, *big])
    assert "keeps the ALE mesh velocity stable" in said and "time.dt = 2 is above the largest step" in said
    assert main(["check", "furrow_p8_a1", *SMALL, *sets, "--set", "time.scheme=euler", "--set", "time.dt=1e-4"]) == 0


def test_remeshing_without_its_extra_is_refused_by_check(tmp_path, capsys, monkeypatch):
    import cortex_ti.surface.remesh as remesh

    monkeypatch.setattr(remesh, "remesh_available", lambda: False)
    said = _same_refusal(capsys, tmp_path, ["--set", "mesh.remesh.min_angle=20"])
    assert "mesh.remesh.min_angle is set but" in said


def test_a_negative_density_is_warned_of_by_check_and_run(tmp_path, capsys, caplog):
    negative = ["--set", "fields.myosin.initial=[{type: harmonics, terms: [{l: 0, m: 0, coeff: -5}]}]"]
    with caplog.at_level(logging.WARNING, logger="cortex_ti"):
        assert main(["check", "myosin_ring", *SMALL, *negative]) == 0
    said = [r.getMessage() for r in caplog.records if "density is negative" in r.getMessage()]
    assert said == [
        "scene 'myosin_ring': the initial myosin density is negative at 162 of 162 nodes (down to -0.41): "
        "a density is an amount per area, never below 0"
    ]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="cortex_ti"):
        assert main(["check", "myosin_ring", *SMALL]) == 0  # the scene as built: no word
    assert not [r for r in caplog.records if "density is negative" in r.getMessage()]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="cortex_ti"):
        ct.run("myosin_ring", nodes=162, t_end=0.002, dt=1e-3, overrides=[negative[1]], threads=1)
    assert [r for r in caplog.records if "density is negative" in r.getMessage()]
