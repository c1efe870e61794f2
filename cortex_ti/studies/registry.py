"""The one registry of the workflow's studies, stores and figures.

The Snakemake rules (``workflow/rules/*.smk``), the workflow scripts, the stores, the figures
and the tests all read these tables; adding a study or a figure means adding an entry here
(and, for a figure, its drawing function in :mod:`cortex_ti.studies.figures`). No heavy imports:
the workflow reads this module when it builds its DAG.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Study", "FigureSpec", "STUDIES", "FIGURES", "STORES", "TABLES", "TABLE_CATEGORY", "figure_names",
           "study_store_names", "configured_studies"]


@dataclass(frozen=True)
class Study:
    """A parameter study: the columns of its sweep table and what its store keeps."""

    name: str
    columns: tuple[str, ...]          # the sweep table's columns, in folder order
    description: str
    variables: tuple[str, ...] = ()   # per-frame variables of its (run, time) store; () for none
    failures_are_data: bool = False   # a run that goes unstable is a result (a failed point), not an error
    twin_of: tuple[str, ...] = ()     # derived, not configured: the axisymmetric twins of these studies' runs

    @property
    def has_store(self) -> bool:
        return bool(self.variables)


@dataclass(frozen=True)
class FigureSpec:
    """A figure of the workflow: what it is drawn from and how it appears in the report."""

    name: str
    source: str            # "store": drawn from results/aggregate/<data>.nc; "runs": from the trajectories of studies <data>
    data: tuple[str, ...]
    draw: str              # the function of cortex_ti.studies.figures that draws it
    category: str          # the report's section
    caption: str           # reStructuredText shown under it in the report
    options: tuple[str, ...] = ()   # keys of the config's ``figures`` section passed to ``draw``


_STUDIES = (
    Study("furrow", ("scene", "zeta_hat", "p", "nodes", "fit", "scheme", "dt", "t_end"),
          "Furrow formation under a contractile ring (paper Eq. 59, Figs. 4-8): pole radius (half the "
          "pole-to-pole distance along the pattern axis) and furrow radius (mean radius of the section in the "
          "ring's plane) against time, one run per parameter set.",
          variables=("pole_radius", "furrow_radius", "volume", "area", "max_normal_speed", "max_tangential_speed")),
    Study("fold", ("scene", "zeta_hat", "nodes", "fit", "scheme", "dt", "t_end"),
          "Fold formation under a stripe of higher tension (paper Sec. 4.3, Fig. 9): equatorial radii across "
          "and beside the stripe and the fold depth against time.",
          variables=("pole_radius", "volume", "area", "max_normal_speed")),
    Study("reorientation", ("scene", "gamma", "tilt", "nodes", "fit", "scheme", "dt", "t_end"),
          "A cortex sheared at the start (x -> x + gamma z) under the ring of Eq. 59 (paper Figs. 10-12): angle "
          "between the long axis of the surface and the pattern axis, and the radii along the current long "
          "axis, against time.",
          variables=("orientation_angle", "pole_radius_long_axis", "furrow_radius_long_axis", "pole_radius",
                     "furrow_radius", "volume", "max_normal_speed")),
    Study("accuracy", ("scene", "nodes", "fit", "residual", "scheme", "implicit", "dt", "t_end"),
          "What accuracy costs: one furrow scene over resolutions, fits, time schemes and steps; each run's "
          "error against the reference and its wall time go into the cost store.",
          failures_are_data=True),
    Study("axisymmetric", ("scene", "model", "zeta_hat", "p", "t_end"),
          "The axisymmetric twin of every axisymmetric run of the furrow and accuracy studies: the same scene "
          "solved by the spectral meridian solver (model: axisymmetric), to the latest end time of its 3D runs. "
          "It is the truth the 3D radii and velocity profiles are measured against.",
          variables=("pole_radius", "furrow_radius", "volume", "area", "max_normal_speed", "max_tangential_speed"),
          twin_of=("furrow", "accuracy")),
)

#: The studies by name (the config's sections of run records).
STUDIES: dict[str, Study] = {s.name: s for s in _STUDIES}

#: The xarray stores under results/aggregate: the static convergence store, one per study with
#: per-frame variables, and the cost of every run.
STORES: tuple[str, ...] = ("convergence", *(s.name for s in _STUDIES if s.has_store), "cost")

_FIGURES = (
    FigureSpec(
        "convergence", "store", ("convergence",), "convergence_figure", "1. Static sphere",
        "Relative velocity error eps_rel (paper Eq. 58) of the static sphere scenes against their analytic "
        "solutions, over the number of nodes N, for the one-ring quadratic fit of the paper and the two-ring "
        "quartic fit. Left: the full force balance (case i, Y20 and Y21 patterns: paper Figs. 2F and 3F); right: "
        "the tangential balance only (case ii: paper Figs. 2G and 3G). Dotted and dashed lines are N^-1 and N^-2 "
        "guides. Store: ``results/aggregate/convergence.nc``."),
    FigureSpec(
        "furrow_radii", "store", ("furrow", "axisymmetric"), "radii_figure", "2. Furrow",
        "Pole radius (half the pole-to-pole distance) and furrow radius (radius at the equator) against time for "
        "the contractile ring of Eq. 59, one panel per (p, zeta_hat). Dots: 3D runs; black lines: the "
        "axisymmetric reference where it exists (p = 8, zeta_hat = 1: paper Fig. 5A). The p = 4 panels match "
        "paper Figs. 7A (zeta_hat = 1) and 8A (zeta_hat = 3); no reference data are shipped for them. Store: "
        "``results/aggregate/furrow.nc``."),
    FigureSpec(
        "velocity_profiles", "runs", ("furrow", "axisymmetric"), "profiles_figure", "2. Furrow",
        "Tangential speed ``|v_t|`` (left of each pair) and normal velocity v_n (right, positive outward) at the "
        "nodes against their height z, at the configured times, one column pair per furrow run (paper Figs. "
        "5B-G for p = 8, 7B-G and 8B-G for p = 4). Black lines: the axisymmetric reference profile (p = 8, "
        "zeta_hat = 1 at t = 0.1, 1.5, 3). Panels past a run's end time are left empty. Normals are those of "
        "the fitted surface, as in the solver.",
        options=("profile_times",)),
    FigureSpec(
        "reference_check", "store", ("axisymmetric",), "reference_check_figure", "2. Furrow",
        "Cross-check of the axisymmetric solver with an independent code: the external reference run shipped in "
        "``cortex_ti/data/axisym`` (the authors' axisymmetric code, p = 8, zeta_hat = 1, a tiny bending moment "
        "instead of the bending viscosity). Left: pole and furrow radius; right: their deviation from it, for the "
        "reference's problem (no bending viscosity; within its own time error, ~1e-4) and for the scene with its "
        "bending viscosity (what the 3D runs are compared with: up to ~6e-4 early on)."),
    FigureSpec(
        "fold_depth", "store", ("fold",), "fold_figure", "3. Fold",
        "Fold formation (paper Fig. 9): the equatorial radius across the stripe of higher tension (solid) and "
        "beside it (dashed), and the fold depth (their difference) against time, for the narrow (zeta_hat = 3.5, "
        "sigma_phi = 200) and broad (zeta_hat = 4.5, sigma_phi = 12) stripes. Store: ``results/aggregate/fold.nc``."),
    FigureSpec(
        "snapshots_fold", "runs", ("fold",), "snapshots_figure", "3. Fold",
        "Fold formation in 3D (paper Fig. 9): the active stress on the initial sphere, then the shape coloured "
        "by the speed ``|v|`` with velocity arrows at the configured times up to the end of the run.",
        options=("snapshot_times",)),
    FigureSpec(
        "orientation", "store", ("reorientation",), "orientation_figure", "4. Sheared cortex",
        "The sheared cortex (paper Figs. 10-12): angle between the long axis of the surface (principal axis of "
        "its second-moment tensor) and the pattern axis against time (left), and the pole and furrow radius "
        "measured along the current long axis (right), for each initial shear gamma and pattern tilt. The "
        "untilted runs turn back toward the pattern axis (Figs. 10, 12); the tilted run keeps its orientation "
        "(Fig. 11). Store: ``results/aggregate/reorientation.nc``."),
    FigureSpec(
        "snapshots_reorientation", "runs", ("reorientation",), "snapshots_figure", "4. Sheared cortex",
        "The sheared cortex in 3D (paper Figs. 10-12): per run the active stress on the sheared start, then "
        "``|v|`` with velocity arrows at the configured times (those before the run's end) and at its end.",
        options=("snapshot_times",)),
    FigureSpec(
        "accuracy_cost", "store", ("cost",), "accuracy_cost_figure", "5. Accuracy and cost",
        "What accuracy costs in time: the largest deviation of pole and furrow radius from the axisymmetric "
        "reference (p = 8, zeta_hat = 1) over the run, against the wall time of the run, one point per (N, fit, "
        "time scheme, tension treatment, dt): colour = N, marker = scheme, filled = semi-implicit tension, open = "
        "the paper's explicit step. The line joins the Pareto front (no other configuration is both cheaper and "
        "more accurate). Red crosses: configurations that went unstable (the reason is in their summary). Times "
        "are wall-clock seconds of one job on the machine that ran the workflow, start-up included."),
)

#: The figures by name (results/figures/<name>.<format>).
FIGURES: dict[str, FigureSpec] = {f.name: f for f in _FIGURES}

#: Tables of the report (results/figures/<name>.html), drawn from a store: name -> (store, caption).
TABLES: dict[str, tuple[str, str]] = {
    "cost_table": ("cost", "Cost of every run of the workflow: wall time and peak memory (Snakemake benchmark "
                           "files), steps and solves, time per step and per stage of a solve (cortex-ti run "
                           "summaries), and the error against the axisymmetric reference where one exists. "
                           "Store: ``results/aggregate/cost.nc``."),
}
TABLE_CATEGORY = "5. Accuracy and cost"


def figure_names() -> list[str]:
    return list(FIGURES)


def configured_studies() -> list[str]:
    """The studies the config lists runs for (the others are derived from them)."""
    return [s.name for s in _STUDIES if not s.twin_of]


def study_store_names() -> list[str]:
    """The studies that have a (run, time) store."""
    return [s.name for s in _STUDIES if s.has_store]
