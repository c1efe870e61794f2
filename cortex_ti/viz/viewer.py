"""The interactive viewer of a trajectory in the browser (``cortex-ti view``): a time slider, a
choice of colour quantity, the time of the frame shown, and the 3D view (turn it with the mouse).

Built on trame (a web application served from Python) with VTK rendering on the server
(``VtkRemoteView``: the browser receives pictures, so it needs no WebGL) through the same
off-screen PyVista scene as the pictures and movies (:class:`cortex_ti.viz.render.PyVistaFrames`,
colour limits over the whole trajectory). It listens on ``127.0.0.1`` by default.
"""

from __future__ import annotations

import logging

import numpy as np

from ..errors import CortexError
from .plotting import COLORS, DEFAULT_VIEW
from .render import PyVistaFrames, choose_renderer

__all__ = ["build_viewer", "serve"]

log = logging.getLogger("cortex_ti")


def build_viewer(ds, name: str = "trajectory", color: str = "speed", server=None, size=(900, 800), reload=None):
    """The trame server of the viewer of ``ds`` (not started) and its :class:`PyVistaFrames`.

    State variables: ``frame`` (index), ``last`` (the last frame index), ``color`` (a key of
    :data:`cortex_ti.viz.plotting.COLORS`), ``time_text``. ``reload``: a function returning the
    trajectory read again (e.g. the ``.partial`` file of a run still going); with it, a
    "reload" button shows the frames written since, the colour limits taken over all of them.
    """
    if color not in COLORS:
        raise CortexError(f"unknown colour {color!r}; choose one of: {', '.join(COLORS)}")
    renderer = choose_renderer("auto")
    if renderer.name != "pyvista":
        raise CortexError(f"cortex-ti view needs VTK rendering off screen: {renderer.reason}")
    from trame.app import get_server
    from trame.ui.vuetify3 import SinglePageLayout
    from trame.widgets import html
    from trame.widgets import vtk as vtk_widgets
    from trame.widgets import vuetify3 as v3
    from vtkmodules.vtkInteractionStyle import vtkInteractorStyleTrackballCamera
    from vtkmodules.vtkRenderingCore import vtkRenderWindowInteractor

    run = {"n": int(ds.sizes["time"]), "times": np.asarray(ds["time"].values, dtype=float)}
    n = run["n"]
    scene = PyVistaFrames(ds, color, list(range(n)), size=size, view=DEFAULT_VIEW, time_label=False)
    scene.show(n - 1)
    window = scene.plotter.ren_win
    interactor = vtkRenderWindowInteractor()
    interactor.SetRenderWindow(window)
    interactor.SetInteractorStyle(vtkInteractorStyleTrackballCamera())
    interactor.EnableRenderOff()

    server = server or get_server(name=f"cortex-ti view {name}", client_type="vue3")
    state, ctrl = server.state, server.controller
    state.trame__title = f"cortex-ti: {name}"
    state.frame = n - 1
    state.last = n - 1
    state.color = color
    state.colors = [{"title": COLORS[c][0], "value": c} for c in COLORS]

    def describe(k: int) -> str:
        return f"t = {run['times'][k]:.4g} t_a  (frame {k}; frames 0..{run['n'] - 1})"

    state.time_text = describe(n - 1)

    @state.change("frame", "color")
    def _update(frame, color, **_):
        k = min(max(int(frame), 0), run["n"] - 1)
        if color != scene.color:
            scene.set_color(color)
        scene.show(k)
        state.time_text = describe(k)
        ctrl.view_update()

    def _reload():
        new = reload()
        run["n"], run["times"] = int(new.sizes["time"]), np.asarray(new["time"].values, dtype=float)
        scene.set_frames(new, range(run["n"]))  # colour limits and arrow scale over the frames now there
        state.last = run["n"] - 1
        if state.frame == run["n"] - 1:  # the slider did not move: draw anyway
            _update(state.frame, state.color)
        state.frame = run["n"] - 1

    with SinglePageLayout(server) as layout:
        layout.title.set_text(name)
        layout.title.style = "min-width: 8em;"
        with layout.toolbar:
            v3.VSpacer()
            v3.VSelect(
                v_model=("color",),
                items=("colors",),
                label="colour",
                density="compact",
                hide_details=True,
                style="max-width: 260px;",
            )
            v3.VSlider(
                v_model=("frame",),
                min=0,
                max=("last",),
                step=1,
                label="frame",
                density="compact",
                hide_details=True,
                style="max-width: 380px; margin-left: 16px;",
            )
            html.Div("{{ time_text }}", style="margin: 0 16px; min-width: 220px;")
            if reload is not None:
                v3.VBtn(
                    "reload",
                    click=_reload,
                    variant="outlined",
                    density="compact",
                    title="read the trajectory again (a run still going has more frames)",
                )
        with layout.content, v3.VContainer(fluid=True, classes="pa-0 fill-height"):
            view = vtk_widgets.VtkRemoteView(window, interactive_ratio=1, interactive_quality=80)
            ctrl.view_update = view.update
            ctrl.view_reset_camera = view.reset_camera
    return server, scene


def serve(
    ds,
    name: str = "trajectory",
    color: str = "speed",
    host: str = "127.0.0.1",
    port: int = 8080,
    open_browser: bool = True,
    reload=None,
) -> int:
    """Build the viewer and serve it until interrupted (port 0: a free one); returns 0."""
    if port == 0:
        import socket

        with socket.socket() as s:
            s.bind((host, 0))
            port = s.getsockname()[1]
    server, scene = build_viewer(ds, name, color, reload=reload)
    print(f"cortex-ti: viewing {name} at http://{host}:{port}/ (Ctrl+C to stop)", flush=True)
    try:
        server.start(host=host, port=port, open_browser=open_browser, show_connection_info=False)
    finally:
        scene.close()
    return 0
