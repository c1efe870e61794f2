"""What the self_organisation study's figures and numbers measure: the runs' rates, the closed form
at the runs' parameters and the spectrum tool's rates and onsets.

* A run's rate: the slope of ``log |c_l|`` of its seeded degree l (the store's
  ``myosin_amplitude``) over the second half of the run, where the other branch of degree l has
  died out (its rate is at least ~2 / t_a faster).
* The closed form: :mod:`cortex_ti.analysis.myosin_stability` with the scene's viscosities, bending
  viscosity, gauge, diffusion and tension law; for l = 1 the myosin branch (the other is the free
  translation, neutral).
* The spectrum tool: :func:`cortex_ti.dynamics.spectrum.degree_jacobian` on the scene's uniform
  state at the runs' resolution, taken once per (scene, nodes, l) and moved to any activity and
  turnover (it is affine in both); for l = 1 the rates of its myosin block (the shape columns of
  degree 1 are the translation's, ~0).
"""

from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
import xarray as xr

__all__ = [
    "RateRun",
    "rate_table",
    "closed_rate",
    "closed_onset",
    "ring_runs",
    "rate_runs",
    "run_rates",
    "spectrum_rate",
    "spectrum_onset",
]


@functools.cache
def _scene(scene: str):
    from ..scene import load_scene

    return load_scene(scene).settings


def _theory(scene: str) -> dict:
    """The closed form's keywords of a scene (all but the activity and the turnover)."""
    s = _scene(scene)
    f = s.field("myosin")
    vis = s.viscosity
    return {
        "D": float(f["diffusion"]),
        "c0": float(f["c0"]),
        "eta_s": vis.shear,
        "eta_b": vis.bulk,
        "eta_bar": vis.bending if s.has("bending_viscosity") else 0.0,
        "eta_bar_b": vis.bending_bulk if s.has("bending_viscosity") else 0.0,
        "translation": s.translation,
        "formulation": s.numerics.formulation,
    }


def _zeta0(scene: str) -> float:
    return float(_scene(scene).field("myosin")["tension"]["zeta0"])


def closed_rate(scene: str, l: int, activity: float, turnover: float) -> float:
    """The closed form's rate of the growing (or slowest-decaying) mode of degree l, at the activity
    ``A = zeta0 gamma`` and turnover ``k`` (l = 1: the myosin branch)."""
    from ..analysis import myosin_stability as ms

    kw = _theory(scene)
    D, z0 = kw.pop("D"), _zeta0(scene)
    if int(l) == 1:
        return float(ms.mode_matrix(1, z0, activity / z0, D, turnover, **kw)[0, 0])
    return float(np.real(ms.growth_rates(int(l), z0, activity / z0, D, turnover, decimals=None, **kw)[0]))


def closed_onset(scene: str, l: int, turnover) -> np.ndarray:
    """The closed form's critical activity of degree l at each turnover."""
    from ..analysis import myosin_stability as ms

    kw = _theory(scene)
    D = kw.pop("D")
    kw.pop("c0")
    return np.array([ms.critical_activity(int(l), D, float(k), **kw) for k in np.atleast_1d(turnover)])


@functools.cache
def _degree_jacobian(scene: str, nodes: int, l: int):
    from ..dynamics.spectrum import degree_jacobian
    from ..scene import load_scene
    from ..simulation import Simulation

    uniform = load_scene(scene, [f"mesh.nodes={nodes}", "fields.myosin.initial=[]", "fields.myosin.noise.amplitude=0"])
    return degree_jacobian(Simulation(uniform), l)


def spectrum_rate(scene: str, nodes: int, l: int, activity: float, turnover: float) -> float:
    """The spectrum tool's rate of degree l at ``nodes`` (as :func:`closed_rate`; the largest real part)."""
    dj = _degree_jacobian(scene, int(nodes), int(l))
    G = dj.at(activity, turnover)
    if int(l) == 1:
        m = G.shape[0] // 2
        G = G[:m, :m]
    return float(np.max(np.linalg.eigvals(G).real))


def spectrum_onset(scene: str, nodes: int, l: int, turnover: float, top: float = 10.0) -> float:
    """The activity at which :func:`spectrum_rate` of degree l crosses zero (NaN if not below ``top``)."""
    from scipy.optimize import brentq

    f = functools.partial(lambda a, k: spectrum_rate(scene, nodes, l, a, k), k=float(turnover))
    if f(1e-9) >= 0.0 or f(top) <= 0.0:
        return math.nan
    return float(brentq(f, 1e-9, top, xtol=1e-10))


def ring_runs(ds: xr.Dataset) -> dict[str, tuple[list[int], int]]:
    """``{scene: (3D run indices, axisymmetric run index)}`` of the scenes the study runs in both models."""
    out = {}
    for j in np.flatnonzero(ds["model"].values == "axisymmetric"):
        scene = str(ds["scene"].values[j])
        idx = [int(i) for i in np.flatnonzero((ds["scene"].values == scene) & (ds["model"].values != "axisymmetric"))]
        out[scene] = (idx, int(j))
    return out


def rate_runs(ds: xr.Dataset) -> list[int]:
    """The 3D runs that measure a rate: those of scenes without an axisymmetric twin in the study."""
    ring = set(ring_runs(ds))
    return [
        i
        for i in range(ds.sizes["run"])
        if ds["model"].values[i] != "axisymmetric" and str(ds["scene"].values[i]) not in ring
    ]


def run_rates(ds: xr.Dataset) -> np.ndarray:
    """Per run: the slope of ``log`` of its seeded degree's amplitude over the second half of its
    frames (NaN for a run without the amplitude)."""
    from ..analysis.harmonics import growth_rate

    t = ds["time"].values
    out = np.full(ds.sizes["run"], np.nan)
    for i in range(ds.sizes["run"]):
        if "myosin_amplitude" not in ds:
            break
        a = ds["myosin_amplitude"].values[i, :, int(ds["degree"].values[i])]
        ok = np.isfinite(a)
        if ok.sum() < 4:
            continue
        late = ok & (t >= 0.5 * t[ok][-1])
        out[i] = growth_rate(t[late], a[late])
    return out


def activity(ds: xr.Dataset, i: int) -> float:
    """The activity ``A = zeta0 gamma`` of run ``i``."""
    return _zeta0(str(ds["scene"].values[i])) * float(ds["myosin_gamma"].values[i])


class RateRun(NamedTuple):
    """One run that measures a rate (:func:`rate_table`)."""

    index: int
    scene: str
    degree: int
    nodes: int
    activity: float
    turnover: float
    rate: float


def rate_table(ds: xr.Dataset) -> list[RateRun]:
    """The rate runs of a store (:func:`rate_runs`) with their parameters and measured rates."""
    rates = run_rates(ds)
    return [
        RateRun(
            i,
            str(ds["scene"].values[i]),
            int(ds["degree"].values[i]),
            int(ds["nodes"].values[i]),
            activity(ds, i),
            float(ds["turnover"].values[i]),
            float(rates[i]),
        )
        for i in rate_runs(ds)
    ]
