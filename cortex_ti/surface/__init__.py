"""The cortex surface: meshes, their validation and connectivity, and the discrete geometry.

Owns the :class:`~cortex_ti.surface.mesh.Mesh` container and icospheres (``mesh``), reading a
user's mesh (``reading``) and checking it (``validation``), the measures of the flat-triangle
mesh: areas, enclosed volume, centroid, quality, second moment (``measures``, the one home of
these integrals), one- and two-rings (``topology``),
the fit schemes and stencils (``fits``, registry :data:`~cortex_ti.surface.fits.FIT_SCHEMES`),
remeshing with the fields carried over (``remesh``; MMG through the ``remesh`` extra; the
smallest angles and their repair in ``quality``, the closest-point query in ``closest``) and the
Taichi kernels of frames, areas, fit operators and the fitted surface patch (``geometry``).
Imports only :mod:`cortex_ti.errors` and :mod:`cortex_ti.runtime` (the latter only in
``geometry``); knows nothing of scenes or physics.
"""
