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

=========  =================================  =====================================
column     scene key                          meaning
=========  =================================  =====================================
scene      (the base scene)                   built-in scene name or YAML file
nodes      ``mesh.nodes``                     icosphere node count N
fit        ``numerics.fit``                   quadratic (one ring) or quartic
scheme     ``time.scheme``                    euler, heun, adaptive, adaptive_euler
implicit   ``time.implicit_tension``          true / false: semi-implicit tension ('auto'
                                              is resolved for the row's scheme)
residual   ``numerics.fit_residual_weight``   weight of the fit-residual rows (0: off)
dt         ``time.dt``                        (first) time step, t_a
t_end      ``time.t_end``                     end time, t_a
zeta_hat   ``active_stress.0.amplitude``      amplitude of the ring/fold pattern
p          ``active_stress.0.p``              exponent of Eq. 59
gamma      ``mesh.shear``                     initial simple shear x -> x + gamma z
tilt       ``active_stress.0.axis``           pattern axis rotated by tilt (degrees)
                                              about +y, toward +x (the shear direction)
=========  =================================  =====================================
"""

from __future__ import annotations

import itertools
import json
import math
from collections.abc import Iterable, Mapping
from pathlib import Path

from .assemble import scene_fit_residual_weight
from .dynamics import scene_implicit_tension
from .errors import SceneError
from .scene import load_scene

__all__ = ["PARAMETERS", "STUDY_COLUMNS", "expand_runs", "scene_overrides", "tilt_axis", "format_value",
           "job_resources"]

#: Column -> scene key it sets (``tilt`` is special: it sets the pattern axis).
PARAMETERS: dict[str, str] = {
    "nodes": "mesh.nodes",
    "fit": "numerics.fit",
    "scheme": "time.scheme",
    "implicit": "time.implicit_tension",
    "residual": "numerics.fit_residual_weight",
    "dt": "time.dt",
    "t_end": "time.t_end",
    "zeta_hat": "active_stress.0.amplitude",
    "p": "active_stress.0.p",
    "gamma": "mesh.shear",
    "tilt": "active_stress.0.axis",
}

#: The columns of each study's table, in folder order.
STUDY_COLUMNS: dict[str, tuple[str, ...]] = {
    "furrow": ("scene", "zeta_hat", "p", "nodes", "fit", "scheme", "dt", "t_end"),
    "fold": ("scene", "zeta_hat", "nodes", "fit", "scheme", "dt", "t_end"),
    "reorientation": ("scene", "gamma", "tilt", "nodes", "fit", "scheme", "dt", "t_end"),
    "accuracy": ("scene", "nodes", "fit", "residual", "scheme", "implicit", "dt", "t_end"),
}


def format_value(value) -> str:
    """A parameter value as it appears in folder names and overrides: the shortest text that
    reads back to the same number (``5e-04`` -> ``0.0005``, ``2562.0`` -> ``2562``), the
    string itself otherwise."""
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
    """Unit pattern axis rotated from +z by ``degrees`` about +y, toward +x."""
    a = math.radians(float(degrees))
    return [round(math.sin(a), 15), 0.0, round(math.cos(a), 15)]


def _scene_value(scene, column: str):
    key = PARAMETERS[column]
    try:
        value = scene[key]
    except KeyError:
        if column == "tilt":
            return 0.0
        raise SceneError(f"scene {scene.name!r} has no value for sweep column {column!r} ({key})") from None
    if column == "tilt":
        ax, _, az = (float(v) for v in value)
        return math.degrees(math.atan2(ax, az))
    return value


def expand_runs(study: str, records: Iterable[Mapping]) -> list[dict[str, str]]:
    """One row per run: the records' lists expanded, every column of the study filled.

    Values a record leaves out are read from its base scene, so the row describes the run
    completely. Rows are returned in order, duplicates dropped; all values are strings
    (:func:`format_value`).

    Raises
    ------
    SceneError
        Unknown study or column, a record without ``scene``, an empty list, or a value
        that cannot name a folder.
    """
    if study not in STUDY_COLUMNS:
        raise SceneError(f"unknown study {study!r}; known: {', '.join(STUDY_COLUMNS)}")
    columns = STUDY_COLUMNS[study]
    rows: list[dict[str, str]] = []
    for i, rec in enumerate(records):
        if not isinstance(rec, Mapping):
            raise SceneError(f"{study} runs[{i}] must be a mapping of parameters, got {rec!r}")
        unknown = sorted(set(rec) - set(columns))
        if unknown:
            raise SceneError(f"{study} runs[{i}]: unknown parameter(s) {', '.join(unknown)}; "
                             f"accepted: {', '.join(columns)}")
        if "scene" not in rec:
            raise SceneError(f"{study} runs[{i}] names no scene")
        lists = {k: (list(v) if isinstance(v, (list, tuple)) else [v]) for k, v in rec.items()}
        for k, v in lists.items():
            if not v:
                raise SceneError(f"{study} runs[{i}].{k} is an empty list")
        keys = list(lists)
        for combo in itertools.product(*(lists[k] for k in keys)):
            given = dict(zip(keys, combo))
            scene = load_scene(str(given["scene"]))
            row = {}
            for col in columns:
                value = given[col] if col in given else _scene_value(scene, col)
                row[col] = format_value(value)
            # the scene's own null weight is not an override: leave it out, then say what runs
            given_row = {k: v for k, v in row.items() if not (k == "residual" and v == "None")}
            try:    # a combination the scene rules refuse fails here, not in a job
                run_scene = load_scene(str(given["scene"]), scene_overrides(given_row))
            except SceneError as exc:
                raise SceneError(f"{study} runs[{i}] {row}: {exc}") from None
            if row.get("residual") == "None":   # the fit's default weight
                row["residual"] = format_value(scene_fit_residual_weight(run_scene))
            if row.get("implicit") == "auto":   # on for the first-order schemes
                row["implicit"] = format_value(scene_implicit_tension(run_scene))
            if row not in rows:
                rows.append(row)
    return rows


def scene_overrides(row: Mapping) -> list[str]:
    """The ``KEY=VALUE`` overrides that make the row's base scene into the run (no ``scene``)."""
    out = []
    for col, value in row.items():
        if col == "scene":
            continue
        if col not in PARAMETERS:
            raise SceneError(f"unknown sweep column {col!r}; known: scene, {', '.join(PARAMETERS)}")
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
    from .io import read_benchmark

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
        return {"mem_mb": int(math.ceil(margin * max(rss))), "runtime": max(5, int(math.ceil(margin * max(wall) / 60.0)))}
    return {"mem_mb": int(1000 + 0.5 * nodes), "runtime": int(60 + nodes // 20)}
