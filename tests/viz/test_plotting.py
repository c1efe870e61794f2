"""Plots of a trajectory (cortex_ti.viz.plotting) and ``cortex-ti plot``.

The trajectory is written here with TrajectoryWriter on a 162-node icosphere with velocities
whose per-node values are known in closed form: frames 0 and 1 are rigid rotations
``v = omega x X`` (``|v| = sqrt(|omega|^2 |X|^2 - (omega . X)^2)``), frame 2 is a purely normal
flow ``v = (1 + x) n`` (``v . n = 1 + x``). The checks are on the numbers matplotlib was given
and drew (face arrays, RGBA colours, line data, arrow segments, image sizes), not on pixels.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from matplotlib import colormaps
from matplotlib.colors import Normalize
from matplotlib.image import imread

from cortex_ti.analysis.diagnostics import DIAGNOSTIC_ATTRS
from cortex_ti.cli import main
from cortex_ti.errors import CortexError
from cortex_ti.io import (
    TrajectoryWriter,
    load_trajectory,
    open_trajectory,
    partial_path,
)
from cortex_ti.surface.mesh import icosphere
from cortex_ti.viz.plotting import (
    figure_frame_and_series,
    frame_index,
    plot_frame,
    plot_timeseries,
    save_figure,
    view_direction,
)

TIMES = (0.0, 0.5, 1.25)
OMEGA = (np.array([0.3, -0.2, 1.0]), np.array([-1.0, 0.5, 0.25]))
SERIES = {
    "pole_radius": [1.0, 1.1, 1.25],
    "furrow_radius": [1.0, 0.9, 0.7],
    "orientation_angle": [np.nan, 12.0, 30.0],
    "volume": [4.18, 4.17, 4.16],
}


def normals_of(points, faces):
    """Area-weighted unit node normals, written out independently of cortex_ti."""
    n = np.zeros_like(points)
    for a, b, c in faces:
        fn = np.cross(points[b] - points[a], points[c] - points[a])
        n[a] += fn
        n[b] += fn
        n[c] += fn
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def rotation_speed(omega, x):
    return np.sqrt(np.maximum(omega @ omega * np.einsum("nc,nc->n", x, x) - (x @ omega) ** 2, 0.0))


class Frames:
    """The known fields of the three frames."""

    def __init__(self):
        self.mesh = icosphere(162)
        self.faces = self.mesh.faces.astype(np.int64)
        base = self.mesh.points
        self.points = [base * (1.0 + 0.05 * k) for k in range(3)]
        self.velocity = [np.cross(OMEGA[0], self.points[0]), np.cross(OMEGA[1], self.points[1])]
        self.normals2 = normals_of(self.points[2], self.faces)
        self.velocity.append((1.0 + self.points[2][:, :1]) * self.normals2)
        self.zeta = [1.0 + base[:, 2] + k for k in range(3)]


@pytest.fixture(scope="module")
def frames():
    return Frames()


def write_trajectory(path, frames, series=True, n=3):
    extra = {name: (("time",), DIAGNOSTIC_ATTRS[name]) for name in SERIES} if series else {}
    w = TrajectoryWriter(
        path, frames.mesh.faces, frames.mesh.n_nodes, {"scene": "name: plot_test\n", "effects": "x"}, extra_vars=extra
    )
    for k in range(n):
        w.append(
            TIMES[k],
            frames.points[k],
            frames.velocity[k],
            frames.zeta[k],
            1.0,
            **({name: values[k] for name, values in SERIES.items()} if series else {}),
        )
    return w


@pytest.fixture(scope="module")
def traj(tmp_path_factory, frames):
    path = tmp_path_factory.mktemp("traj") / "run.h5"
    write_trajectory(path, frames).finish()
    return path


@pytest.fixture
def ds(traj):
    with open_trajectory(traj) as d:
        yield d


def sorted_rows(rgba):
    rgba = np.asarray(rgba)
    return rgba[np.lexsort(rgba.T[::-1])]


def velocity_arrows(ax):
    found = [c for c in ax.collections if c.get_gid() == "velocity"]
    assert len(found) <= 1
    return found[0] if found else None


# ---------------------------------------------------------------------------------------------
# plot_frame
# ---------------------------------------------------------------------------------------------
def test_face_colours_are_the_colormap_of_the_mean_speed(ds, frames):
    ax, surface = plot_frame(ds, frame=1, color="speed", arrows=False)
    speed = rotation_speed(OMEGA[1], frames.points[1])
    expected = speed[frames.faces].mean(axis=1)
    assert expected.std() > 0.1  # a real spread of colours
    np.testing.assert_allclose(surface.get_array(), expected, rtol=0, atol=1e-13)
    norm = Normalize(expected.min(), expected.max())
    assert (surface.norm.vmin, surface.norm.vmax) == pytest.approx((expected.min(), expected.max()), abs=1e-13)
    ax.figure.draw_without_rendering()
    drawn = surface.get_facecolor()  # depth-sorted by the 3D projection
    assert drawn.shape == (320, 4)
    np.testing.assert_allclose(sorted_rows(drawn), sorted_rows(colormaps["viridis"](norm(expected))), atol=1e-12)
    # equal aspect: a cube of equal spans around frame 1's shape (2% margin without arrows)
    lo, hi = frames.points[1].min(axis=0), frames.points[1].max(axis=0)
    for lim, centre in zip((ax.get_xlim(), ax.get_ylim(), ax.get_zlim()), 0.5 * (lo + hi), strict=False):
        assert lim == pytest.approx((centre - 0.51 * (hi - lo).max(), centre + 0.51 * (hi - lo).max()), abs=1e-12)
    aspect = ax.get_box_aspect()  # (1, 1, 1) times matplotlib's zoom
    assert aspect[0] == aspect[1] == aspect[2]
    assert "t = 0.5" in ax.get_title()


def test_colour_limits_and_map_can_be_given(ds, frames):
    ax, surface = plot_frame(ds, frame=0, color="speed", arrows=False, cmap="magma", clim=(0.0, 3.0))
    expected = rotation_speed(OMEGA[0], frames.points[0])[frames.faces].mean(axis=1)
    ax.figure.draw_without_rendering()
    np.testing.assert_allclose(
        sorted_rows(surface.get_facecolor()), sorted_rows(colormaps["magma"](expected / 3.0)), atol=1e-12
    )


def test_active_stress_and_normal_velocity_colours(ds, frames):
    _, surface = plot_frame(ds, frame=2, color="active_stress", arrows=False)
    np.testing.assert_allclose(surface.get_array(), frames.zeta[2][frames.faces].mean(axis=1), rtol=0, atol=1e-14)
    _, surface = plot_frame(ds, frame=2, color="normal_velocity", arrows=False)
    vn = 1.0 + frames.points[2][:, 0]  # v = (1 + x) n, so v . n = 1 + x
    np.testing.assert_allclose(surface.get_array(), vn[frames.faces].mean(axis=1), rtol=0, atol=1e-13)
    assert surface.norm.vmin == -surface.norm.vmax == pytest.approx(-np.abs(surface.get_array()).max())
    assert surface.cmap.name == "RdBu_r"


@pytest.mark.parametrize("view", [(30.0, -60.0), (80.0, 10.0), (-10.0, 135.0)])
def test_arrows_on_the_visible_side(ds, frames, view):
    """One arrow (three segments: shaft and two head strokes) per moving node facing the camera."""
    facing = normals_of(frames.points[1], frames.faces) @ view_direction(*view)
    assert np.abs(facing).min() > 1e-6  # no node on the silhouette
    speed = rotation_speed(OMEGA[1], frames.points[1])
    expected = int(np.count_nonzero((facing > 0) & (speed > 0)))
    assert 60 < expected < 100  # about half of the 162 nodes
    ax, _ = plot_frame(ds, frame=1, arrows=True, view=view, max_arrows=1000)
    assert (ax.elev, ax.azim) == view
    ax.figure.draw_without_rendering()
    assert len(velocity_arrows(ax).get_segments()) == 3 * expected
    # a subsample: exactly max_arrows of them
    ax, _ = plot_frame(ds, frame=1, arrows=True, view=view, max_arrows=25)
    ax.figure.draw_without_rendering()
    assert len(velocity_arrows(ax).get_segments()) == 3 * 25
    ax, _ = plot_frame(ds, frame=1, arrows=False, view=view)
    assert velocity_arrows(ax) is None


def test_plot_frame_into_given_axes_keeps_its_view(ds):
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.add_subplot(projection="3d")
    ax.view_init(elev=10.0, azim=40.0)
    out, _ = plot_frame(ds, frame=0, ax=ax)
    assert out is ax and (ax.elev, ax.azim) == (10.0, 40.0)
    with pytest.raises(ValueError, match="3D axes"):
        plot_frame(ds, ax=fig.add_subplot(2, 2, 1))
    with pytest.raises(CortexError, match="unknown colour 'spead'"):
        plot_frame(ds, color="spead")


# ---------------------------------------------------------------------------------------------
# frame selection
# ---------------------------------------------------------------------------------------------
def test_frame_selection_by_index_and_by_nearest_time(ds):
    """Times 0, 0.5, 1.25: an int is an index, a float a time (nearest frame, the earlier on a tie)."""
    assert [frame_index(ds, k) for k in (0, 1, 2, -1, -3, np.int64(1))] == [0, 1, 2, 2, 0, 1]
    picks = {0.0: 0, 0.2: 0, 0.25: 0, 0.26: 1, 0.85: 1, 0.875: 1, 0.9: 2, 1.25: 2, 1.5: 2, -0.3: 0, np.float64(0.6): 1}
    for t, k in picks.items():
        assert frame_index(ds, t) == k, t
    ax, _ = plot_frame(ds, frame=0.3, arrows=False)
    assert ax.get_title().startswith("t = 0.5 t_a")
    for bad, words in (
        (3, "frame 3 is out of range: the trajectory has 3 frame(s)"),
        (-4, "frame -4 is out of range"),
        (1.6, "time 1.6 is outside the trajectory"),
        (-0.4, "time -0.4 is outside"),
        (float("nan"), "not a finite number"),
        (True, "integer index or a time"),
        ("1", "integer index or a time"),
    ):
        with pytest.raises(CortexError, match=re.escape(words)):
            frame_index(ds, bad)


# ---------------------------------------------------------------------------------------------
# time series and the combined figure
# ---------------------------------------------------------------------------------------------
def test_timeseries_lines_are_the_dataset_values(ds):
    with pytest.warns(UserWarning, match="no per-frame variable 'nope'"):
        ax, lines = plot_timeseries(
            ds, ("pole_radius", "nope", "furrow_radius", "orientation_angle", "volume"), mark_time=0.5
        )
    assert list(lines) == ["pole_radius", "furrow_radius", "orientation_angle", "volume"]
    for name, line in lines.items():
        np.testing.assert_array_equal(line.get_xdata(), TIMES)
        np.testing.assert_array_equal(line.get_ydata(), SERIES[name])  # NaN where the file has NaN
    # one y axis per unit: R0 on ax, degrees and R0^3 on twins
    assert lines["pole_radius"].axes is ax and lines["furrow_radius"].axes is ax
    assert lines["orientation_angle"].axes is not ax and lines["volume"].axes is not ax
    assert lines["orientation_angle"].axes is not lines["volume"].axes
    assert lines["orientation_angle"].axes.get_ylabel().endswith("[degrees]")
    assert ax.get_ylabel() == "pole_radius, furrow_radius [R0]"
    assert lines["volume"].axes.get_ylabel() == "enclosed volume [R0^3]"
    assert ax.get_xlabel() == "time [t_a]"
    (mark,) = [ln for ln in ax.get_lines() if ln.get_gid() == "mark_time"]
    np.testing.assert_array_equal(mark.get_xdata(), [0.5, 0.5])
    # a comma-separated string works too; one unit: no twin axes
    ax, lines = plot_timeseries(ds, "pole_radius, furrow_radius")
    assert list(lines) == ["pole_radius", "furrow_radius"] and len(ax.figure.axes) == 1


def test_timeseries_without_any_known_name_is_an_error(ds):
    with pytest.warns(UserWarning), pytest.raises(CortexError) as info:
        plot_timeseries(ds, ["nope", "neither"])
    assert str(info.value) == (
        "none of the series 'nope', 'neither' is in the trajectory; it has: pressure, "
        "pole_radius, furrow_radius, orientation_angle, volume"
    )


def test_figure_frame_and_series(ds, frames):
    fig = figure_frame_and_series(
        ds, frame=0.6, color="speed", arrows=True, series=("pole_radius", "orientation_angle")
    )
    kinds = [ax.name for ax in fig.axes]
    assert kinds.count("3d") == 1 and len(fig.axes) == 4  # 3D, colorbar, series, twin
    ax3d = fig.axes[kinds.index("3d")]
    surface = ax3d.collections[0]
    expected = rotation_speed(OMEGA[1], frames.points[1])[frames.faces].mean(axis=1)
    np.testing.assert_allclose(surface.get_array(), expected, rtol=0, atol=1e-13)
    series_ax = next(ax for ax in fig.axes if any(ln.get_gid() == "mark_time" for ln in ax.get_lines()))
    (mark,) = [ln for ln in series_ax.get_lines() if ln.get_gid() == "mark_time"]
    np.testing.assert_array_equal(mark.get_xdata(), [0.5, 0.5])  # the time of the frame drawn
    assert tuple(fig.get_size_inches()) == (11.0, 4.8) and fig.dpi == 150.0
    fig = figure_frame_and_series(ds, frame=-1, color="active_stress", arrows=False, series=None)
    assert [ax.name for ax in fig.axes].count("3d") == 1 and len(fig.axes) == 2
    assert tuple(fig.get_size_inches()) == (6.5, 5.5)


def collisions(fig) -> list[tuple[str, str]]:
    """Pairs of parts of a drawn figure that overlap: the colour bars (with their ticks and
    labels), the 3D panels' axis labels (when their axes are drawn), the panels' titles."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.transforms import Bbox

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    r = canvas.get_renderer()
    parts = []
    for i, ax in enumerate(fig.axes):
        if ax.get_label() == "<colorbar>":
            parts.append((f"colour bar {i}", ax.get_tightbbox(r)))
        else:
            if ax.name == "3d" and ax._axis3don:  # mplot3d's own switch of set_axis_on/off
                parts += [
                    (f"{a.label.get_text()} of panel {i}", a.label.get_window_extent(r))
                    for a in (ax.xaxis, ax.yaxis, ax.zaxis)
                ]
            if ax.title.get_text():
                parts.append((f"title of panel {i}", ax.title.get_window_extent(r)))
    found = [
        (a, "the page edge")
        for a, box in parts
        if not (fig.bbox.contains(box.x0, box.y0) and fig.bbox.contains(box.x1, box.y1))
    ]
    found += [(a, b) for j, (a, ba) in enumerate(parts) for b, bb in parts[j + 1 :] if Bbox.intersection(ba, bb)]
    return found


@pytest.mark.parametrize("series", [("pole_radius", "orientation_angle"), None])
def test_plot_figure_has_no_overlapping_labels(ds, series):
    fig = figure_frame_and_series(ds, frame=1, color="speed", arrows=True, series=series)
    assert collisions(fig) == []


def test_small_multiples_of_bare_frames_have_no_overlapping_labels(ds):
    """A grid of snapshots as in the report: bare frames (``axes=False``) with their colour bars
    below. The same grid with axes and vertical bars beside them (as before) does collide, so
    the check can fail."""
    from matplotlib.figure import Figure

    from cortex_ti.viz.plotting import colorbar_below

    def grid(bare: bool):
        fig = Figure(figsize=(2.6 * 3, 2.7 * 2), layout="constrained")
        for i in range(6):
            ax = fig.add_subplot(2, 3, i + 1, projection="3d")
            _, m = plot_frame(ds, i % 3, arrows=True, ax=ax, axes=not bare)
            if bare:
                colorbar_below(fig, ax, m, "|v| / v_a", fontsize=7)
            else:
                fig.colorbar(m, ax=ax, shrink=0.6, label="|v| / v_a")
            ax.set_title(f"t = {i}", fontsize=8)
        return fig

    assert collisions(grid(bare=True)) == []
    assert collisions(grid(bare=False)) != []
    ax = Figure().add_subplot(projection="3d")
    plot_frame(ds, 0, ax=ax)
    assert ax._axis3don  # the default keeps the axes


# ---------------------------------------------------------------------------------------------
# saving
# ---------------------------------------------------------------------------------------------
def test_save_figure_formats_and_size(ds, tmp_path):
    fig = figure_frame_and_series(ds, 1, "speed", True, ("pole_radius",), figsize=(4.0, 3.0), dpi=50.0)
    png = save_figure(fig, tmp_path / "sub" / "f.png")
    assert png == tmp_path / "sub" / "f.png"
    assert imread(png).shape[:2] == (150, 200)
    assert imread(save_figure(fig, tmp_path / "g.png", dpi=100)).shape[:2] == (300, 400)
    assert (save_figure(fig, tmp_path / "f.pdf")).read_bytes().startswith(b"%PDF")
    assert b"<svg" in (save_figure(fig, tmp_path / "f.SVG")).read_bytes()[:1000]
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["f.SVG", "f.pdf", "f.png", "g.png", "sub"]


def test_failed_save_leaves_no_file(ds, tmp_path, monkeypatch):
    fig = figure_frame_and_series(ds, 1, "speed", False, None, figsize=(2.0, 2.0), dpi=20.0)
    for name in ("f.jpg", "f", "f.png.bak"):
        with pytest.raises(CortexError, match=f"cannot save a figure as '.*{name}': unknown format"):
            save_figure(fig, tmp_path / name)
    assert list(tmp_path.iterdir()) == []
    # a failure while writing: the temporary file is removed and an existing figure is kept
    old = save_figure(fig, tmp_path / "keep.png").read_bytes()

    def broken(fh, **kw):
        fh.write(b"half a figure")
        raise RuntimeError("disk full")

    monkeypatch.setattr(fig, "savefig", broken)
    for name in ("keep.png", "new.pdf"):
        with pytest.raises(RuntimeError, match="disk full"):
            save_figure(fig, tmp_path / name)
    assert [p.name for p in tmp_path.iterdir()] == ["keep.png"]
    assert (tmp_path / "keep.png").read_bytes() == old


# ---------------------------------------------------------------------------------------------
# cortex-ti plot
# ---------------------------------------------------------------------------------------------
def run(argv, capsys):
    rc = main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


@pytest.mark.slow
def test_cli_plot_writes_png_and_pdf(traj, tmp_path, capsys):
    out = tmp_path / "frame.png"
    rc, stdout, stderr = run(["plot", str(traj), "-o", str(out), "--time", "0.6", "--color", "normal_velocity"], capsys)
    assert rc == 0, stderr
    assert stdout.strip() == str(out)
    image = imread(out)
    assert out.stat().st_size > 10_000 and image.shape[:2] == (720, 1650)  # 4.8 x 11 in at 150 dpi
    assert image[..., :3].std() > 0.05  # not a blank page
    rc, _, stderr = run(
        [
            "plot",
            str(traj),
            "-o",
            str(out),
            "--frame",
            "0",
            "--no-arrows",
            "--series",
            "",
            "--view",
            "10,45",
            "--dpi",
            "40",
        ],
        capsys,
    )
    assert rc == 0, stderr
    assert imread(out).shape[:2] == (220, 260)  # 5.5 x 6.5 in at 40 dpi
    pdf = tmp_path / "frame.pdf"
    rc, _, stderr = run(["plot", str(traj), "-o", str(pdf), "--series", "volume,pole_radius"], capsys)
    assert rc == 0, stderr
    assert pdf.read_bytes().startswith(b"%PDF")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frame.pdf", "frame.png"]


@pytest.mark.parametrize(
    "args,words",
    [
        (["--color", "pressure"], ["unknown --color 'pressure'", "speed, active_stress, normal_velocity"]),
        (["--series", "pole_radius,force_residual"], ["unknown series 'force_residual'", "pole_radius, furrow_radius"]),
        (["--frame", "3"], ["frame 3 is out of range", "3 frame(s)"]),
        (["--frame", "-4"], ["frame -4 is out of range"]),
        (["--time", "9"], ["time 9 is outside the trajectory", "t = 0 .. 1.25"]),
        (["--view", "10"], ["--view must be ELEV,AZIM", "'10'"]),
        (["--dpi", "0"], ["--dpi must be > 0"]),
    ],
)
def test_cli_plot_bad_input(traj, tmp_path, capsys, args, words):
    out = tmp_path / "f.png"
    rc, stdout, stderr = run(["plot", str(traj), "-o", str(out), *args], capsys)
    assert rc == 2
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cortex-ti: error: "), stderr
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert "Traceback" not in stderr and not stdout
    assert list(tmp_path.iterdir()) == []


def test_cli_plot_missing_file_and_bad_suffix(traj, tmp_path, capsys):
    rc, _, stderr = run(["plot", str(tmp_path / "none.h5"), "-o", str(tmp_path / "f.png")], capsys)
    assert rc == 2 and stderr.strip() == f"cortex-ti: error: trajectory file '{tmp_path / 'none.h5'}' not found"
    rc, _, stderr = run(["plot", str(traj), "-o", str(tmp_path / "f.jpeg")], capsys)
    assert rc == 2 and "unknown format '.jpeg'; use .png, .pdf, .svg" in stderr
    not_hdf5 = tmp_path / "text.h5"
    not_hdf5.write_text("no")
    rc, _, stderr = run(["plot", str(not_hdf5), "-o", str(tmp_path / "f.png")], capsys)
    assert rc == 2 and f"cannot read trajectory '{not_hdf5}'" in stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["text.h5"]


def test_cli_plot_static_run_without_diagnostics(frames, tmp_path, capsys):
    """A static run has no shape diagnostics: by default only the 3D panel; naming one is an error."""
    path = tmp_path / "static.h5"
    write_trajectory(path, frames, series=False, n=1).finish()
    out = tmp_path / "static.png"
    rc, _, stderr = run(["plot", str(path), "-o", str(out)], capsys)
    assert rc == 0, stderr
    assert imread(out).shape[:2] == (825, 975)  # the 3D panel alone
    rc, _, stderr = run(["plot", str(path), "-o", str(out), "--series", "pole_radius"], capsys)
    assert rc == 2 and "unknown series 'pole_radius'" in stderr and "has pressure" in stderr


WRITER = """
import sys, time
sys.path.insert(0, {tests!r})
from test_plotting import Frames, write_trajectory
w = write_trajectory({path!r}, Frames(), n=2)      # two frames flushed, the file stays open (and locked)
print("ready", flush=True)
sys.stdin.readline()                                # until the test is done
"""


@pytest.mark.slow
def test_cli_plot_reads_the_partial_file_of_a_running_simulation(tmp_path, capsys):
    path = tmp_path / "live.h5"
    code = textwrap.dedent(WRITER.format(tests=str(Path(__file__).parent), path=str(path)))
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    try:
        assert proc.stdout.readline().strip() == "ready", proc.stderr.read()
        assert partial_path(path).exists() and not path.exists()
        if os.environ.get("HDF5_USE_FILE_LOCKING", "").upper() != "FALSE":
            with pytest.raises(OSError, match="lock"):  # what the writer's lock does to a plain open
                open_trajectory(path).load()
        ds = load_trajectory(path)
        np.testing.assert_array_equal(ds["time"].values, TIMES[:2])
        for given in (partial_path(path), path):  # the .partial name, or the final one
            out = tmp_path / "live.png"
            rc, _, stderr = run(["plot", str(given), "-o", str(out)], capsys)
            assert rc == 0, stderr
            assert imread(out).shape[:2] == (720, 1650)
    finally:
        proc.stdin.close()
        proc.wait(timeout=30)
    assert proc.returncode == 0
