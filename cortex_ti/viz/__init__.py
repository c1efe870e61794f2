"""Seeing a run: figures of a trajectory, 3D pictures of frames, movies and an interactive viewer
in the browser.

Owns the matplotlib figures of a trajectory (:mod:`~cortex_ti.viz.plotting`: the colour
quantities :data:`~cortex_ti.viz.plotting.COLORS`, their node values, the frame rule, a frame in
3D, the time series; moved here from ``cortex_ti.plotting``, which forwards with a
:class:`DeprecationWarning` for one release), the choice of the 3D renderer
(:mod:`~cortex_ti.viz.render`: PyVista/VTK off screen where OpenGL works, matplotlib otherwise,
said in one line), the pictures of a frame and the ``cortex-ti plot`` figure built on them
(:mod:`~cortex_ti.viz.figure`), movies (:mod:`~cortex_ti.viz.movie`, ``cortex-ti movie``) and
the trame viewer (:mod:`~cortex_ti.viz.viewer`, ``cortex-ti view``).

May import ``errors``, ``surface`` (vertex normals) and ``io`` (reading trajectories).
The heavy libraries (pyvista, vtk, imageio, trame) come with the ``[viz]`` extra and are
imported only inside the functions that use them: importing this package costs nothing.
"""

from .extra import VIZ_EXTRA, require

__all__ = ["VIZ_EXTRA", "require"]
