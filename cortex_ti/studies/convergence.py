"""Errors of static sphere runs against their analytic solutions, gathered over resolutions."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import xarray as xr

from ..about import provenance
from ..io.trajectory import Trajectory
from ..truth.analytic import error_measures, scene_solution


def run_errors(path) -> dict:
    """eps and eps_rel (paper Eqs. 57, 58) of the first frame of one trajectory file."""
    with Trajectory(path, lazy=True) as tr:
        settings = tr.settings
        points = tr.mesh(0)[0]
        velocity = tr.nodal("velocity", 0)
    eps, eps_rel = error_measures(velocity, scene_solution(settings, points))
    return {
        "scene": settings.name,
        "nodes": points.shape[0],
        "formulation": settings.numerics.formulation,
        "fit": settings.numerics.fit,
        "eps": eps,
        "eps_rel": eps_rel,
    }


def convergence_dataset(paths: Iterable) -> xr.Dataset:
    """``eps(scene, formulation, fit, nodes)`` and ``eps_rel(...)`` with units and descriptions
    (NaN for a combination that did not run, e.g. a fit the config does not ask of a formulation)."""
    rows = [run_errors(p) for p in paths]
    dims = ("scene", "formulation", "fit", "nodes")
    values = {d: sorted({r[d] for r in rows}) for d in dims}
    shape = tuple(len(values[d]) for d in dims)
    eps = np.full(shape, np.nan)
    eps_rel = np.full(shape, np.nan)
    for r in rows:
        idx = tuple(values[d].index(r[d]) for d in dims)
        eps[idx], eps_rel[idx] = r["eps"], r["eps_rel"]
    return xr.Dataset(
        {
            "eps": (
                dims,
                eps,
                {
                    "units": "R0/t_a",
                    "long_name": "mean velocity error",
                    "description": "paper Eq. 57: (1/N) sum over nodes of |v - v_an|",
                },
            ),
            "eps_rel": (
                dims,
                eps_rel,
                {
                    "units": "1",
                    "long_name": "relative rms velocity error",
                    "description": "paper Eq. 58: sqrt(mean over nodes of |v - v_an|^2) / max over nodes of |v_an|",
                },
            ),
        },
        coords={
            "scene": values["scene"],
            "formulation": values["formulation"],
            "fit": values["fit"],
            "nodes": ("nodes", values["nodes"], {"long_name": "number of mesh nodes N"}),
        },
        attrs={
            "description": "Static sphere scenes (paper Figs. 2F,G and 3F,G) against the analytic solutions of "
            "docs/method/conventions.md",
            **provenance(),
        },
    )
