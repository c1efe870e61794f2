"""Seeing a run (cortex_ti.viz): the renderer choice and its one line, PyVista pictures, the
``cortex-ti plot`` figure drawn with them, movies (``cortex-ti movie``) and the browser viewer
(``cortex-ti view``) loaded in headless Chromium.

The trajectory is a real run: furrow_p8_a1 on 162 nodes to t = 0.05 (6 frames). The checks are on
real output read back by other software than the writer's: pictures' pixels against the colour
map of the quantity, movies decoded by ffmpeg / Pillow (frame count, size, frame rate), the viewer
as Chromium shows it.

The tests that need the [viz] extra skip with one line without it; the viewer test needs
Debian's chromium and Playwright (``apt-get install chromium``, ``pip install -e '.[test,viz]'``).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from matplotlib import colormaps
from matplotlib.image import imread

from cortex_ti.cli import main
from cortex_ti.errors import CortexError
from cortex_ti.io import load_trajectory
from cortex_ti.viz import extra
from cortex_ti.viz.plotting import COLORS
from cortex_ti.viz.render import Renderer, choose_renderer

HAVE_PYVISTA = not extra.missing("pyvista")
HAVE_MOVIE = not extra.missing("movie")
HAVE_VIEW = not extra.missing("view")
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
HAVE_PLAYWRIGHT = importlib.util.find_spec("playwright") is not None
VIZ_SKIP = "needs the [viz] extra: pip install -e '.[viz]'"

CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--no-first-run",
    "--disable-component-update",
    "--disable-sync",
    "--disable-quic",
]


@pytest.fixture(scope="module")
def run(tmp_path_factory, taichi_runtime):
    out = tmp_path_factory.mktemp("viz") / "furrow.h5"
    assert (
        main(
            [
                "run",
                "furrow_p8_a1",
                "-o",
                str(out),
                "--set",
                "mesh.nodes=162",
                "--set",
                "time.t_end=0.05",
                "--set",
                "time.save_every=0.01",
            ]
        )
        == 0
    )
    return out


@pytest.fixture(scope="module")
def ds(run):
    return load_trajectory(run)


@pytest.fixture(scope="module")
def pyvista_renderer():
    if not HAVE_PYVISTA:
        pytest.skip(VIZ_SKIP)
    renderer = choose_renderer("auto")
    if renderer.name != "pyvista":
        pytest.skip(f"no OpenGL off screen here ({renderer.reason}); Debian's libegl1 or libosmesa6 provide it")
    return renderer


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    """``rgb / (r + g + b)``: unchanged when lighting scales a colour."""
    return rgb / np.maximum(rgb.sum(axis=-1, keepdims=True), 1e-6)


def colormap_distance(pixels: np.ndarray, cmap: str, lit: bool = False) -> np.ndarray:
    """Distance of each RGB pixel (0..1) to the nearest of 1024 colours of the colour map; for
    a lit surface (``lit``) the distance of the chromaticities."""
    from scipy.spatial import cKDTree

    table = colormaps[cmap](np.linspace(0.0, 1.0, 1024))[:, :3]
    if lit:
        pixels, table = chromaticity(pixels), chromaticity(table)
    return cKDTree(table).query(pixels)[0]


def fits_better(pixels: np.ndarray, cmap: str, other: str) -> bool:
    """Lit pixels (the colourful ones: not black arrows nor grey edges) are of the colour map
    ``cmap`` rather than ``other``: their median chromaticity distance is less than half."""
    colourful = pixels[np.ptp(pixels, axis=1) > 0.15][::5]
    return 2.0 * np.median(colormap_distance(colourful, cmap, lit=True)) < np.median(
        colormap_distance(colourful, other, lit=True)
    )


def not_background(image: np.ndarray) -> np.ndarray:
    """Pixels that are not (nearly) white, the background of every picture here."""
    rgb = image[..., :3].astype(float) / (255.0 if image.dtype == np.uint8 else 1.0)
    return rgb[np.any(rgb < 0.94, axis=-1)]


# ---------------------------------------------------------------------------------------------
# which renderer, and the one line
# ---------------------------------------------------------------------------------------------
def test_renderer_choice_and_its_line(monkeypatch):
    assert choose_renderer("matplotlib") == Renderer("matplotlib", "asked for (--renderer matplotlib)")
    assert (
        choose_renderer("matplotlib").line == "cortex-ti: 3D pictures by matplotlib: asked for (--renderer matplotlib)"
    )
    with pytest.raises(CortexError, match="unknown renderer 'opengl'"):
        choose_renderer("opengl")
    # without pyvista: auto falls back and names the extra; pyvista asked for is refused
    monkeypatch.setattr("cortex_ti.viz.render.missing", lambda feature: ["pyvista", "vtk"])
    choose_renderer.cache_clear()
    try:
        r = choose_renderer("auto")
        assert r.name == "matplotlib" and "pyvista, vtk not installed" in r.reason and extra.VIZ_EXTRA in r.reason
        assert "\n" not in r.line
        with pytest.raises(CortexError, match="--renderer pyvista cannot draw here"):
            choose_renderer("pyvista")
    finally:
        choose_renderer.cache_clear()


def test_no_opengl_falls_back_to_matplotlib(monkeypatch):
    """Every OpenGL window failing (as on a machine without EGL or OSMesa): matplotlib, and why."""
    if not HAVE_PYVISTA:
        pytest.skip(VIZ_SKIP)
    monkeypatch.setattr("cortex_ti.viz.render._probe", lambda window, timeout=120.0: None)
    monkeypatch.delenv("VTK_DEFAULT_OPENGL_WINDOW", raising=False)
    monkeypatch.delenv("DISPLAY", raising=False)
    choose_renderer.cache_clear()
    try:
        r = choose_renderer("auto")
        assert r == Renderer("matplotlib", "no OpenGL off screen here (VTK's EGL, OSMesa windows failed)")
    finally:
        choose_renderer.cache_clear()


def test_the_probe_finds_a_working_window(pyvista_renderer):
    assert pyvista_renderer.reason.startswith("VTK off screen through ")
    assert os.environ["VTK_DEFAULT_OPENGL_WINDOW"] or os.environ.get("DISPLAY")


# ---------------------------------------------------------------------------------------------
# PyVista pictures
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("color", list(COLORS))
def test_pyvista_picture_is_the_colour_map_of_the_quantity(ds, pyvista_renderer, color):
    """Unlit, without edges, arrows, bar or text, every pixel of the surface is a colour of the
    quantity's colour map, and the surface fills a good part of the picture."""
    from cortex_ti.viz.render import PyVistaFrames

    with PyVistaFrames(
        ds, color, [5], size=(400, 300), arrows=False, scalar_bar=False, time_label=False, edges=False, lighting=False
    ) as fr:
        image = fr.render(5)
    assert image.shape == (300, 400, 3) and image.dtype == np.uint8
    surface = not_background(image)
    assert surface.shape[0] > 0.2 * 300 * 400
    far = colormap_distance(surface, COLORS[color][1]) > 0.05
    # only the outline's pixels, blended with the background, may be off the map: at most one
    # ring of pixels round a nearly round shape, 2 sqrt(pi A) for A surface pixels
    assert far.sum() <= 2.0 * np.sqrt(np.pi * surface.shape[0])
    # and a different quantity's map does not fit as well (the check can fail)
    other = "plasma" if COLORS[color][1] != "plasma" else "viridis"
    assert (colormap_distance(surface, other) > 0.05).mean() > 0.2


@pytest.mark.slow
def test_cli_plot_with_pyvista_says_so_in_one_line(run, tmp_path, capsys, pyvista_renderer):
    out = tmp_path / "p.png"
    assert main(["plot", str(run), "-o", str(out), "--renderer", "pyvista", "--color", "active_stress"]) == 0
    stdout, stderr = capsys.readouterr()
    assert stdout.strip() == str(out)
    assert stderr.strip().splitlines() == [pyvista_renderer.line]
    image = imread(out)
    assert image.shape[:2] == (720, 1650)  # 11 x 4.8 in at 150 dpi
    left = image[100:540, 100:560, :3]  # the 3D panel, between title and bar
    surface = not_background(left)
    assert surface.shape[0] > 0.3 * left.shape[0] * left.shape[1]
    # lit, the pixels are the colour map's shaded: of its chromaticities, not another map's
    assert fits_better(surface, "plasma", "viridis") and not fits_better(surface, "viridis", "plasma")


def test_cli_plot_with_matplotlib_says_so(run, tmp_path, capsys):
    out = tmp_path / "m.png"
    assert main(["plot", str(run), "-o", str(out), "--renderer", "matplotlib", "--series", ""]) == 0
    stderr = capsys.readouterr().err
    assert stderr.strip() == "cortex-ti: 3D pictures by matplotlib: asked for (--renderer matplotlib)"
    assert imread(out).shape[:2] == (825, 975)


@pytest.mark.parametrize("renderer_name", ["pyvista", "matplotlib"])
def test_report_snapshot_panels(ds, renderer_name, request):
    """Bare frames in a grid as the report draws them (cortex_ti.viz.figure.frame_panel): nothing
    collides, and each PyVista panel is its picture cut to the shape (content up to the edges)."""
    from matplotlib.figure import Figure
    from test_plotting import collisions

    from cortex_ti.viz.figure import frame_panel

    renderer = (
        request.getfixturevalue("pyvista_renderer") if renderer_name == "pyvista" else choose_renderer("matplotlib")
    )
    fig = Figure(figsize=(2.6 * 3, 2.7 * 2), layout="constrained")
    for i in range(6):
        ax, bar = frame_panel(
            fig, (2, 3, i + 1), ds, i, "speed" if i % 2 else "active_stress", renderer=renderer, pixels=300
        )
        ax.set_title(f"t = {float(ds['time'][i]):.4g}", fontsize=8)
        assert bar.ax.get_label() == "<colorbar>"
        if renderer_name == "pyvista":
            (image,) = ax.get_images()
            picture = np.asarray(image.get_array())
            ink = np.any(picture[..., :3] < 245, axis=-1)  # what crop_to_content keeps
            extent = max(np.ptp(np.flatnonzero(ink.any(axis=1))), np.ptp(np.flatnonzero(ink.any(axis=0)))) + 1
            assert extent >= 0.9 * max(picture.shape[:2])  # the shape spans the panel (3 % margins)
            assert not_background(np.asarray(picture)).shape[0] > 0.4 * picture.shape[0] * picture.shape[1]
    assert collisions(fig) == []


# ---------------------------------------------------------------------------------------------
# movies
# ---------------------------------------------------------------------------------------------
def read_movie(path):
    import imageio.v3 as iio

    frames = iio.imread(path, index=None)
    return frames, iio.immeta(path)


@pytest.mark.parametrize(
    "suffix, every, size, fps, renderer",
    [
        (".mp4", 1, "320x240", 12.0, "auto"),
        (".gif", 2, "251x200", 5.0, "auto"),
        (".mp4", 3, "300x300", 4.0, "matplotlib"),  # the fallback without OpenGL
    ],
)
def test_movie_has_one_picture_per_frame_of_the_asked_size(run, tmp_path, capsys, suffix, every, size, fps, renderer):
    if not HAVE_MOVIE:
        pytest.skip(VIZ_SKIP)
    out = tmp_path / f"m{suffix}"
    assert (
        main(
            [
                "movie",
                str(run),
                "-o",
                str(out),
                "--every",
                str(every),
                "--size",
                size,
                "--fps",
                str(fps),
                "--color",
                "normal_velocity",
                "--renderer",
                renderer,
            ]
        )
        == 0
    )
    stdout, stderr = capsys.readouterr()
    assert stdout.strip() == str(out)
    assert stderr.strip().splitlines() == [choose_renderer(renderer).line]
    frames, meta = read_movie(out)
    w, h = (int(v) for v in size.split("x"))
    n = len(range(0, 6, every))
    assert frames.shape[:3] == (n, h, w - w % 2)  # odd widths rounded down to even
    if suffix == ".mp4":
        assert meta["fps"] == pytest.approx(fps)
    else:
        assert meta["duration"] == pytest.approx(1000.0 / fps, abs=10)  # GIF stores centiseconds
    for frame in frames:
        assert not_background(frame).shape[0] > 0.1 * h * w  # not blank
    # the time in the corner changes from frame to frame
    corner = frames[:, : h // 8, : w // 2].astype(float)
    assert all(np.abs(corner[i + 1] - corner[i]).max() > 50 for i in range(n - 1))
    assert [p.name for p in tmp_path.iterdir()] == [out.name]


@pytest.mark.parametrize(
    "args, words",
    [
        (["-o", "OUT/m.avi"], "unknown format '.avi'; use .mp4, .gif"),
        (["-o", "OUT/m.mp4", "--color", "pressure"], "unknown --color 'pressure'"),
        (["-o", "OUT/m.mp4", "--fps", "0"], "--fps must be > 0"),
        (["-o", "OUT/m.mp4", "--size", "big"], "--size must be WIDTHxHEIGHT"),
        (["-o", "OUT/m.mp4", "--every", "0"], "--every must be >= 1"),
        (["-o", "OUT/m.mp4", "--view", "1"], "--view must be ELEV,AZIM"),
    ],
)
def test_movie_bad_input_one_line_exit_2_nothing_written(run, tmp_path, capsys, args, words):
    args = [a.replace("OUT", str(tmp_path)) for a in args]
    assert main(["movie", str(run), *args]) == 2
    stdout, stderr = capsys.readouterr()
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cortex-ti: error: ") and words in lines[0], stderr
    assert not stdout and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", [["movie", "-o", "OUT/m.mp4"], ["view", "--no-browser"]])
def test_without_the_viz_extra_one_line_names_it(run, tmp_path, capsys, monkeypatch, command):
    real = importlib.util.find_spec
    blocked = {"imageio", "imageio_ffmpeg", "pyvista", "vtk", "trame", "trame_vtk", "trame_vuetify"}
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name in blocked else real(name, *a))
    argv = [command[0], str(run), *[a.replace("OUT", str(tmp_path)) for a in command[1:]]]
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"cortex-ti: error: cortex-ti {command[0]} needs the [viz] extra")
    assert lines[0].endswith("pip install 'cortex-ti[viz]'")
    assert list(tmp_path.iterdir()) == []


# ---------------------------------------------------------------------------------------------
# the viewer, in headless Chromium
# ---------------------------------------------------------------------------------------------
def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for_port(port: int, proc, timeout: float = 120.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if proc.poll() is not None:
            raise AssertionError(f"cortex-ti view exited ({proc.returncode}): {proc.stderr.read()}")
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=1.0):
                return
        except OSError:
            time.sleep(0.3)
    raise AssertionError(f"cortex-ti view did not listen on port {port} within {timeout:g} s")


def view_image(page) -> np.ndarray:
    """The picture of the 3D view as Chromium shows it (RGB, 0..1)."""
    import io

    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(page.locator("img").first.screenshot())).convert("RGB")) / 255.0


@pytest.mark.slow
@pytest.mark.skipif(not HAVE_VIEW, reason="the viewer test needs the [viz] extra: pip install -e '.[test,viz]'")
def test_viewer_off_screen_follows_slider_and_colour(ds, pyvista_renderer):
    """The viewer's own application (no browser): its server state driven as the page drives it,
    its render window read back off screen. The picture has content, the slider to frame 0 changes
    it and the time shown, the colour choice changes its colour map. (With Chromium, the test below
    does the same through the page.)"""
    from trame.app import get_server

    from cortex_ti.viz.viewer import build_viewer

    server = get_server(name=f"viewer-test-{os.getpid()}", client_type="vue3")
    server, scene = build_viewer(ds, "furrow", server=server, size=(600, 600))
    server.state.ready()  # what the server does once it starts: from now on, changes run the callbacks

    def picture():
        scene.plotter.render()
        return np.asarray(scene.plotter.screenshot(return_img=True))

    last = picture()
    h, w = last.shape[:2]
    surface = not_background(last)
    assert surface.shape[0] > 0.15 * h * w  # not blank: the cortex
    assert server.state.time_text.startswith("t = 0.05 t_a")
    server.state.frame = 0
    server.state.flush()
    assert server.state.time_text.startswith("t = 0 t_a")
    first = picture()
    assert np.abs(first.astype(float) - last).max() > 0.2 * 255
    server.state.color = "active_stress"
    server.state.flush()
    stress = not_background(picture())
    assert fits_better(stress, "plasma", "viridis") and fits_better(surface, "viridis", "plasma")


@pytest.mark.skipif(not CHROMIUM, reason="the viewer test needs Chromium: apt-get install chromium")
@pytest.mark.skipif(
    not (HAVE_VIEW and HAVE_PLAYWRIGHT),
    reason="the viewer test needs the [viz] extra and Playwright: pip install -e '.[test,viz]'",
)
def test_viewer_in_headless_chromium_shows_the_run_and_follows_slider_and_colour(run, tmp_path, pyvista_renderer):
    """Loaded in Chromium: a picture with content, the slider to frame 0 changes it, the colour
    choice changes its colour map; "reload" reads the file again (here cut to 3 frames)."""
    from playwright.sync_api import sync_playwright

    from cortex_ti.io import write_dataset

    live = tmp_path / "live.h5"
    shutil.copy(run, live)
    port = free_port()
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(Path(__file__).parents[2]), os.environ.get("PYTHONPATH")])),
    }
    proc = subprocess.Popen(
        [sys.executable, "-m", "cortex_ti", "view", str(live), "--port", str(port), "--no-browser"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        wait_for_port(port, proc)
        with sync_playwright() as pw, tempfile.TemporaryDirectory() as profile:
            browser = pw.chromium.launch_persistent_context(
                profile,
                executable_path=CHROMIUM,
                headless=True,
                args=CHROMIUM_FLAGS,
                viewport={"width": 1280, "height": 900},
            )
            page = browser.new_page()
            page.goto(f"http://127.0.0.1:{port}/", timeout=120_000)
            page.get_by_text("t = 0.05 t_a").wait_for(timeout=120_000)  # the last frame first
            page.locator("img").first.wait_for(timeout=120_000)
            page.wait_for_timeout(1500)
            page.screenshot(path=str(tmp_path / "viewer.png"))
            last = view_image(page)
            h, w = last.shape[:2]
            assert h > 300 and w > 300
            surface = not_background(last)
            assert surface.shape[0] > 0.15 * h * w  # not blank: the cortex
            assert len(np.unique((surface * 255).astype(np.uint8), axis=0)) > 500
            # the slider: Home goes to frame 0
            page.locator("input[type=range], .v-slider-thumb").first.focus()
            page.keyboard.press("Home")
            page.get_by_text("t = 0 t_a").wait_for(timeout=120_000)
            page.wait_for_timeout(1500)
            first = view_image(page)
            assert np.abs(first - last).max() > 0.2 and (np.abs(first - last) > 0.1).mean() > 0.005
            # the colour: active stress (plasma) instead of speed (viridis)
            page.locator(".v-select").first.click()
            page.get_by_text(COLORS["active_stress"][0]).last.click()
            page.wait_for_timeout(2500)
            stress = not_background(view_image(page))
            assert fits_better(stress, "plasma", "viridis") and fits_better(surface, "viridis", "plasma")
            # reload: the file now has 3 frames; the viewer goes to the last of them
            write_dataset(load_trajectory(run).isel(time=slice(0, 3)), live)
            page.get_by_text("reload").click()
            page.get_by_text("t = 0.02 t_a  (frame 2; frames 0..2)").wait_for(timeout=120_000)
            browser.close()
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()


# ---------------------------------------------------------------------------------------------
# the command line stays light
# ---------------------------------------------------------------------------------------------
def test_parser_is_light_and_names_every_colour():
    """Building the parser (every ``cortex-ti run`` does) imports neither matplotlib nor VTK, and
    the help of ``--color`` names every colour quantity of the registry."""
    code = (
        "import sys, cortex_ti.cli as c; p = c._parser(); "
        "print(sorted(m for m in ('matplotlib', 'vtk', 'pyvista', 'trame') if m in sys.modules))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[2])},
    ).stdout
    assert out.strip() == "[]"
    from cortex_ti.cli import _parser

    sub = next(a for a in _parser()._actions if a.dest == "command")
    for command in ("movie", "view"):
        (color,) = [a for a in sub.choices[command]._actions if a.dest == "color"]
        assert all(name in color.help for name in COLORS), color.help


# ------------------------------------------------------------ the movie's faults (issue 34)
def _movie_error(capsys, argv, words):
    assert main(argv) == 2
    stdout, stderr = capsys.readouterr()
    lines = [ln for ln in stderr.strip().splitlines() if not ln.startswith("cortex-ti: 3D pictures")]
    assert len(lines) == 1 and lines[0].startswith("cortex-ti: error: ") and words in lines[0], stderr
    assert not stdout


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_a_movie_onto_a_full_disk_leaves_nothing(run, tmp_path, capsys, monkeypatch, suffix):
    """Checked before drawing (little free space: one line) and after writing (the disk filled while
    the movie was encoded: ffmpeg says so only in its log, Pillow raises): one line, exit 2, no file."""
    if not HAVE_MOVIE:
        pytest.skip(VIZ_SKIP)
    import collections
    import errno
    import shutil

    import cortex_ti.viz.movie as movie

    argv = ["movie", str(run), "-o", str(tmp_path / f"m{suffix}"), "--size", "128x128", "--renderer", "matplotlib"]
    usage = collections.namedtuple("usage", "total used free")
    with monkeypatch.context() as m:
        m.setattr(shutil, "disk_usage", lambda path: usage(10**6, 10**6 - 100, 100))
        _movie_error(capsys, argv, "MB free; nothing was written")
    assert list(tmp_path.iterdir()) == []
    if suffix == ".mp4":  # ffmpeg's file cut short: it must not decode
        real = movie._check_mp4

        def cut(path, n):
            with open(path, "r+b") as fh:
                fh.truncate(path.stat().st_size // 2)
            real(path, n)

        monkeypatch.setattr(movie, "_check_mp4", cut)
        _movie_error(capsys, argv, "does not decode")
    else:

        def full(path, data):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

        monkeypatch.setattr(movie, "write_synced", full)
        _movie_error(capsys, argv, "No space left on device")
    assert list(tmp_path.iterdir()) == []


def test_a_codec_error_is_one_line_and_leaves_nothing(run, tmp_path, capsys, monkeypatch):
    if not HAVE_MOVIE:
        pytest.skip(VIZ_SKIP)
    import imageio.v2 as iio

    real = iio.get_writer
    monkeypatch.setattr(iio, "get_writer", lambda target, **o: real(target, **{**o, "codec": "no_such_codec_q"}))
    _movie_error(capsys, ["movie", str(run), "-o", str(tmp_path / "m.mp4"), "--renderer", "matplotlib"], "movie")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_movie_into_a_read_only_folder_is_refused_before_drawing(run, tmp_path, capsys, monkeypatch):
    if not HAVE_MOVIE:
        pytest.skip(VIZ_SKIP)
    import cortex_ti.viz.movie as movie

    monkeypatch.setattr(movie, "frame_renderer", lambda *a, **k: pytest.fail("drew a frame"))
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        _movie_error(capsys, ["movie", str(run), "-o", str(ro / "m.mp4"), "--renderer", "matplotlib"], "Permission")
        assert list(ro.iterdir()) == []
    finally:
        ro.chmod(0o755)
