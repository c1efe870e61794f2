"""Parameter sweeps as data: the workflow's tables of runs and how a row becomes a scene.

The workflow config (``config/config.yaml``) lists, per study, *records* of run
parameters; a value that is a list is swept (the record expands to the Cartesian
product of its lists). :func:`expand_runs` turns the records into a table with one row
per run and every column of the study filled (missing values come from the base scene
itself, so the table says exactly what ran); :func:`scene_overrides` turns a row into the
``--set KEY=VALUE`` overrides of ``cortex-ti run``. The workflow feeds the tables to
``snakemake.utils.Paramspace``, which names each run's folder after its parameters, e.g.
``results/runs/furrow/scene~furrow_p8_a1/zeta_hat~1/p~8/nodes~2562/.../trajectory.h5``.

Parameters (columns) and the scene values they set:

===========  =================================  =====================================
column       scene key                          meaning
===========  =================================  =====================================
scene        (the base scene)                   built-in scene name or YAML file
nodes        ``mesh.nodes``                     icosphere node count N
formulation  ``numerics.formulation``           rayleigh_p1 (the default) or paper
fit          ``numerics.fit``                   quadratic (one ring) or quartic
scheme       ``time.scheme``                    bdf2, bdf3, euler, heun, adaptive, adaptive_euler
implicit     ``time.implicit_tension``          true / false: semi-implicit tension ('auto'
                                                is resolved for the row's scheme)
residual     ``numerics.fit_residual_weight``   weight of the fit-residual rows (0: off)
dt           ``time.dt``                        (first) time step, t_a
tol          ``time.tol``                       local error per step of an adaptive scheme, R0
t_end        ``time.t_end``                     end time, t_a
zeta_hat     ``active_stress.0.amplitude``      amplitude of the ring/fold pattern (null: the
                                                scene has no pattern, and null sets nothing)
p            ``active_stress.0.p``              exponent of Eq. 59 (null: as zeta_hat)
gamma        ``mesh.shear``                     initial simple shear x -> x + gamma z
tilt         ``active_stress.0.axis``           pattern axis rotated by tilt (degrees)
                                                about +y, toward +x (the shear direction)
model        ``model``                          3d or axisymmetric (the same scene's twin)
bending_form ``axisymmetric.bending_form``      paper (Eq. 45) or dissipation: the twin's
                                                bending-viscosity force, its 3D runs' form
inner        ``fluid.inner``                    the cytoplasm's viscosity (eta_s / R0)
outer        ``fluid.outer``                    the medium's viscosity (eta_s / R0)
remesh       ``mesh.remesh.min_angle``          remesh below this angle (deg); null: never
                                                (the axisymmetric model has no mesh)
degree       ``fields.myosin.initial.0.         degree l of the myosin's seeded harmonic
             terms.0.l``                        (its first term)
seed         ``fields.myosin.initial.0.         amplitude of that harmonic (units of c0)
             terms.0.coeff``
myosin_gamma ``fields.myosin.tension.gamma``    slope of the linear tension law (activity
                                                A = zeta0 gamma)
turnover     ``fields.myosin.turnover``         turnover rate k of the myosin, 1/t_a
bending      ``rigidity.bending``               bending rigidity kappa, eta_s R0^2/t_a (the
                                                scene must have the effect bending_rigidity)
neck         ``division.neck_radius``           the neck radius of the cut (R0; null: no cut;
                                                the axisymmetric model stops there)
save_every   ``time.save_every``                interval between frames, t_a
===========  =================================  =====================================
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

from ..errors import SceneError
from ..physics.formulations import FORMULATIONS
from ..scene import load_scene
from .registry import STUDIES

__all__ = [
    "PARAMETERS",
    "PATTERN_COLUMNS",
    "expand_runs",
    "twin_rows",
    "twin_key",
    "scene_overrides",
    "tilt_axis",
    "format_value",
    "job_resources",
]

#: Column -> scene key it sets (``tilt`` is special: it sets the pattern axis).
PARAMETERS: dict[str, str] = {
    "nodes": "mesh.nodes",
    "formulation": "numerics.formulation",
    "fit": "numerics.fit",
    "scheme": "time.scheme",
    "implicit": "time.implicit_tension",
    "residual": "numerics.fit_residual_weight",
    "dt": "time.dt",
    "tol": "time.tol",
    "dt_max": "time.dt_max",
    "t_end": "time.t_end",
    "zeta_hat": "active_stress.0.amplitude",
    "center": "active_stress.0.center",
    "p": "active_stress.0.p",
    "gamma": "mesh.shear",
    "tilt": "active_stress.0.axis",
    "model": "model",
    "bending_form": "axisymmetric.bending_form",
    "remesh": "mesh.remesh.min_angle",
    "degree": "fields.myosin.initial.0.terms.0.l",
    "seed": "fields.myosin.initial.0.terms.0.coeff",
    "myosin_gamma": "fields.myosin.tension.gamma",
    "turnover": "fields.myosin.turnover",
    "bending": "rigidity.bending",
    "inner": "fluid.inner",
    "outer": "fluid.outer",
    "neck": "division.neck_radius",
    "save_every": "time.save_every",
}

#: The columns read from the scene's first active-stress pattern: column -> its key there. A scene
#: without a pattern has them ``null``, and a ``null`` sets nothing (:func:`scene_overrides`); the
#: stores keep it as nan.
PATTERN_COLUMNS = {"zeta_hat": "amplitude", "p": "p", "center": "center"}

#: The columns read from the scene's myosin field: column -> path inside ``fields.myosin``.
_MYOSIN = {
    "degree": ("initial", 0, "terms", 0, "l"),
    "seed": ("initial", 0, "terms", 0, "coeff"),
    "myosin_gamma": ("tension", "gamma"),
    "turnover": ("turnover",),
}


def format_value(value) -> str:
    """A parameter value as it appears in folder names and overrides: the shortest text that
    reads back to the same number (``5e-04`` -> ``0.0005``, ``2562.0`` -> ``2562``), ``null``
    for an unset one (a setting that is off), the string itself otherwise.

    >>> format_value(5e-4), format_value(2562.0), format_value(True), format_value("quartic"), format_value(None)
    ('0.0005', '2562', 'true', 'quartic', 'null')"""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            raise SceneError(f"a sweep value must be finite, got {value!r}")
        if float(value).is_integer() and abs(value) < 1e15:
            return str(int(value))
        return repr(float(value))
    text = str(value)
    if not text or any(c in text for c in "/~ \t\n"):
        raise SceneError(f"sweep value {text!r} cannot name a folder (no '/', '~' or spaces)")
    return text


def tilt_axis(degrees: float) -> list[float]:
    """Unit pattern axis rotated from +z by ``degrees`` about +y, toward +x.

    >>> tilt_axis(90), tilt_axis(0)
    ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0])"""
    a = math.radians(float(degrees))
    return [round(math.sin(a), 15), 0.0, round(math.cos(a), 15)]


def _settings_value(settings, column: str):
    """The value of a sweep column in a run's resolved settings."""
    if column == "tilt":
        ax, _, az = (float(v) for v in settings.pattern_axis)
        # rounded: the axis is stored to 15 digits (tilt_axis), so 45 must not come back as
        # 44.999999999999964 and name another folder than the same run without the column
        return round(math.degrees(math.atan2(ax, az)), 9)
    if column in PATTERN_COLUMNS:
        # a scene without a prescribed pattern (a myosin ring that forms by itself) has none: null
        return settings.patterns[0].get(PATTERN_COLUMNS[column]) if settings.patterns else None
    if column == "model":
        return settings.model
    if column == "bending":  # 0 without the effect bending_rigidity
        return settings.rigidity.bending
    if column == "neck":  # null without a cut
        return settings.division_neck
    if column == "remesh":
        return None if settings.mesh.remesh is None else settings.mesh.remesh.min_angle
    if column in ("inner", "outer"):  # null without the effect fluids
        return None if settings.fluid is None else getattr(settings.fluid, column)
    if column in _MYOSIN:
        value = settings.field("myosin")
        try:
            for key in _MYOSIN[column]:
                value = value[key]
        except (TypeError, KeyError, IndexError):
            raise SceneError(
                f"scene {settings.name!r} has no {'.'.join(map(str, ('fields.myosin', *_MYOSIN[column])))} "
                f"for sweep column {column!r}"
            ) from None
        return value
    section, key = {
        "nodes": ("mesh", "nodes"),
        "formulation": ("numerics", "formulation"),
        "fit": ("numerics", "fit"),
        "scheme": ("time", "scheme"),
        "implicit": ("time", "implicit_tension"),
        "residual": ("numerics", "fit_residual_weight"),
        "dt": ("time", "dt"),
        "tol": ("time", "tol"),
        "dt_max": ("time", "dt_max"),
        "t_end": ("time", "t_end"),
        "save_every": ("time", "save_every"),
        "gamma": ("mesh", "shear"),
        "bending_form": ("axisymmetric", "bending_form"),
    }[column]
    return getattr(getattr(settings, section), key)


def expand_runs(study: str, records: Iterable[Mapping]) -> list[dict[str, str]]:
    """One row per run: the records' lists expanded, every column of the study filled.

    Values a record leaves out are those the run resolves to (its scene's, with the record's
    values applied: e.g. the semi-implicit tension of the row's scheme), so the row describes
    the run completely. Rows are returned in order, duplicates dropped; all values are strings
    (:func:`format_value`).

    Raises
    ------
    SceneError
        Unknown study or column, a record without ``scene``, an empty list, a value that
        cannot name a folder, or a combination the scene rules refuse (it fails here, not in a job).
    """
    if study not in STUDIES:
        raise SceneError(f"unknown study {study!r}; known: {', '.join(STUDIES)}")
    columns = STUDIES[study].columns
    rows: list[dict[str, str]] = []
    for i, rec in enumerate(records):
        for given in _combinations(study, i, rec, columns):
            overrides = scene_overrides({k: format_value(v) for k, v in given.items()})
            try:
                settings = load_scene(str(given["scene"]), overrides).settings
            except SceneError as exc:
                raise SceneError(f"{study} runs[{i}] {given}: {exc}") from None
            row = {
                col: format_value(given["scene"] if col == "scene" else _settings_value(settings, col))
                for col in columns
            }
            if row not in rows:
                rows.append(row)
    return rows


def twin_key(row: Mapping) -> tuple[str, str, str, str]:
    """What identifies a run's axisymmetric twin: its scene, ring amplitude and exponent, and the
    bending viscosity's normal force (a 3D run's: its formulation's
    :attr:`~cortex_ti.physics.formulations.Formulation.bending_form`; a twin's: its ``bending_form``)."""
    settings = load_scene(str(row["scene"])).settings
    if "bending_form" in row:
        form = str(row["bending_form"])
    else:
        form = FORMULATIONS[str(row.get("formulation", settings.numerics.formulation))].bending_form
    return (
        str(row["scene"]),
        str(row.get("zeta_hat", format_value(_settings_value(settings, "zeta_hat")))),
        str(row.get("p", format_value(_settings_value(settings, "p")))),
        form,
    )


def twin_rows(rows: Iterable[Mapping], columns: Sequence[str]) -> list[dict[str, str]]:
    """The axisymmetric twins of the runs ``rows`` (of any studies): one row per distinct
    (scene, zeta_hat, p, bending form) whose scene the axisymmetric model accepts, to the latest
    ``t_end`` of its runs (:func:`twin_key`). Runs whose scene is not axisymmetric have no twin."""
    latest: dict[tuple, float] = {}
    for row in rows:
        key = twin_key(row)
        if key not in latest:
            try:
                load_scene(
                    key[0],
                    scene_overrides({"zeta_hat": key[1], "p": key[2], "model": "axisymmetric", "bending_form": key[3]}),
                )
            except SceneError:
                continue
            latest[key] = float(row["t_end"])
        latest[key] = max(latest[key], float(row["t_end"]))
    values = {"model": "axisymmetric"}
    return [
        {
            col: {"scene": k[0], "zeta_hat": k[1], "p": k[2], "bending_form": k[3], "t_end": format_value(t)}.get(
                col, values.get(col)
            )
            for col in columns
        }
        for k, t in latest.items()
    ]


def _combinations(study: str, i: int, rec, columns) -> Iterable[dict]:
    """The record's lists expanded: one mapping of the given columns per run."""
    if not isinstance(rec, Mapping):
        raise SceneError(f"{study} runs[{i}] must be a mapping of parameters, got {rec!r}")
    unknown = sorted(set(rec) - set(columns))
    if unknown:
        raise SceneError(
            f"{study} runs[{i}]: unknown parameter(s) {', '.join(unknown)}; accepted: {', '.join(columns)}"
        )
    if "scene" not in rec:
        raise SceneError(f"{study} runs[{i}] names no scene")
    lists = {k: (list(v) if isinstance(v, (list, tuple)) else [v]) for k, v in rec.items()}
    for k, v in lists.items():
        if not v:
            raise SceneError(f"{study} runs[{i}].{k} is an empty list")
    keys = list(lists)
    for combo in itertools.product(*(lists[k] for k in keys)):
        yield dict(zip(keys, combo, strict=True))


def scene_overrides(row: Mapping) -> list[str]:
    """The ``KEY=VALUE`` overrides that make the row's base scene into the run (no ``scene``)."""
    out = []
    for col, value in row.items():
        if col == "scene":
            continue
        if col not in PARAMETERS:
            raise SceneError(f"unknown sweep column {col!r}; known: scene, {', '.join(PARAMETERS)}")
        if col in PATTERN_COLUMNS and value == "null":
            continue
        if col == "tilt":
            out.append(f"{PARAMETERS[col]}={tilt_axis(float(value))}")
        else:
            out.append(f"{PARAMETERS[col]}={value}")
    return out


def job_resources(benchmarks: Iterable, nodes: int, margin: float = 1.5) -> dict[str, int]:
    """Memory (``mem_mb``) and wall-time limit (``runtime``, minutes) for a job at ``nodes``.

    From earlier runs: every Snakemake benchmark file in ``benchmarks`` whose neighbouring
    ``summary.json`` says it ran at ``nodes`` counts; the limits are ``margin`` times the
    largest peak memory and wall time seen (runtime at least 5 minutes). Without such runs, a
    default that grows with N (measured on a 2-core machine: ~0.3 GB and under a minute per
    thousand steps at 2562 nodes; 10242 nodes about four times that).
    """
    from ..io.files import read_benchmark

    rss, wall = [], []
    for b in benchmarks:
        summary = Path(b).with_name("summary.json")
        try:
            n = json.loads(summary.read_text()).get("n_nodes")
            bench = read_benchmark(b)
        except (OSError, ValueError):
            continue
        if n == nodes and math.isfinite(bench.get("max_rss", math.nan)) and math.isfinite(bench.get("s", math.nan)):
            rss.append(bench["max_rss"])
            wall.append(bench["s"])
    if rss:
        return {
            "mem_mb": int(math.ceil(margin * max(rss))),
            "runtime": max(5, int(math.ceil(margin * max(wall) / 60.0))),
        }
    return {"mem_mb": int(1000 + 0.5 * nodes), "runtime": int(60 + nodes // 20)}
