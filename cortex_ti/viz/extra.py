"""The optional ``[viz]`` dependencies: which command needs which module, and the one-line
refusal when one is missing."""

from __future__ import annotations

import importlib.util

from ..errors import CortexError

__all__ = ["NEEDS", "RENDERERS", "VIZ_EXTRA", "missing", "require"]

#: Values of ``--renderer`` (:func:`cortex_ti.viz.render.choose_renderer`).
RENDERERS: tuple[str, ...] = ("auto", "pyvista", "matplotlib")

#: How to install the optional dependencies of the viewer, the movies and the PyVista pictures.
VIZ_EXTRA = "pip install 'cortex-ti[viz]'"

#: What each feature imports: feature -> modules.
NEEDS: dict[str, tuple[str, ...]] = {
    "pyvista": ("pyvista", "vtk"),
    "movie": ("imageio", "imageio_ffmpeg"),
    "view": ("pyvista", "vtk", "trame", "trame_vtk", "trame_vuetify"),
}


def _absent(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is None
    except (ImportError, ValueError):  # e.g. a parent package that fails to import
        return True


def missing(feature: str) -> list[str]:
    """The modules of ``feature`` (a key of :data:`NEEDS`) that cannot be found here."""
    return [m for m in NEEDS[feature] if _absent(m)]


def require(feature: str, command: str) -> None:
    """Raise a one-line :class:`CortexError` naming the extra if ``feature`` cannot run here."""
    absent = missing(feature)
    if absent:
        raise CortexError(f"{command} needs the [viz] extra ({', '.join(absent)} not installed): {VIZ_EXTRA}")
