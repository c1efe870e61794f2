"""A division's record on the trajectory segment it starts (cortex_ti.io.trajectory.read_divisions),
kept when the mesh changes again (a remeshing) before the segment's first frame."""

from __future__ import annotations

import numpy as np

from cortex_ti.io.trajectory import TrajectoryWriter, read_divisions
from cortex_ti.surface.mesh import icosphere


def test_the_record_survives_a_remeshing_before_the_next_frame(tmp_path):
    a, b, c = icosphere(42), icosphere(162), icosphere(12)
    path = tmp_path / "d.h5"
    w = TrajectoryWriter(path, a.faces, 42, {"scene": "name: x\n", "effects": "x"})
    w.append(0.0, a.points, np.zeros((42, 3)), np.ones(42), 0.0)
    record = {"division_time": 0.25, "division_volumes": np.array([1.0, 2.0])}
    w.start_segment(b.faces, 162, attrs=record)  # the cut
    w.start_segment(c.faces, 12)  # a remeshing before any frame on the cut's mesh
    w.append(0.5, c.points, np.zeros((12, 3)), np.ones(12), 0.0)
    w.finish()
    got = read_divisions(path)
    assert got == [{"segment": 1, "division_time": 0.25, "division_volumes": [1.0, 2.0]}]


def test_a_file_from_before_the_division_key_resumes_without_division():
    from cortex_ti.io.layout import scene_difference

    old = "name: x\nmesh:\n  nodes: 42\n"
    assert scene_difference(old, old + "division:\n  neck_radius: null\n") is None
    assert "division" in scene_difference(old, old + "division:\n  neck_radius: 0.1\n")


def test_a_file_from_before_a_new_key_resumes_where_the_key_keeps_its_default():
    """A run written before the ring's ``center`` existed (its stored scene lacks the key) resumes under
    today's scene, whose ring carries the default pi/2 (it refused: "center is (not set) in the file"); a
    ring moved off the equator does not resume; a stored scene from before ``numerics.formulation``
    (the paper's) still differs from today's default formulation."""
    import yaml

    from cortex_ti.io.layout import scene_difference
    from cortex_ti.scene import load_scene

    new = load_scene("furrow_p4_a1").to_yaml()
    old = yaml.safe_load(new)
    del old["active_stress"][0]["center"]
    stored = yaml.safe_dump(old)
    assert scene_difference(stored, new) is None
    moved = load_scene("furrow_p4_a1", ["active_stress.0.center=1.5"]).to_yaml()
    assert "active_stress.0.center" in scene_difference(stored, moved)
    del old["numerics"]["formulation"]
    assert "numerics.formulation is 'paper' in the file" in scene_difference(yaml.safe_dump(old), new)
