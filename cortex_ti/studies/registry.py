"""The one registry of the workflow's studies, stores and figures.

The Snakemake rules (``workflow/rules/*.smk``), the workflow scripts, the stores, the figures
and the tests all read these tables; adding a study or a figure means adding an entry here
(and, for a figure, its drawing function in :mod:`cortex_ti.studies.figures`). No heavy imports:
the workflow reads this module when it builds its DAG.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "Study",
    "FigureSpec",
    "STUDIES",
    "FIGURES",
    "STORES",
    "TABLES",
    "TABLE_CATEGORY",
    "figure_names",
    "study_store_names",
    "configured_studies",
    "optional_studies",
    "figures_of",
    "stores_of",
]


@dataclass(frozen=True)
class Study:
    """A parameter study: the columns of its sweep table and what its store keeps."""

    name: str
    columns: tuple[str, ...]  # the sweep table's columns, in folder order
    description: str
    variables: tuple[str, ...] = ()  # per-frame variables of its (run, time) store; () for none
    failures_are_data: bool = False  # a run that goes unstable is a result (a failed point), not an error
    twin_of: tuple[str, ...] = ()  # derived, not configured: the axisymmetric twins of these studies' runs
    optional: bool = False  # a config may leave it out (then its stores and figures are not made)

    @property
    def has_store(self) -> bool:
        return bool(self.variables)


@dataclass(frozen=True)
class FigureSpec:
    """A figure of the workflow: what it is drawn from and how it appears in the report."""

    name: str
    source: str  # "store": from results/aggregate/<data>.nc; "runs": from the trajectories of studies <data>;
    # "static": from the static runs at nodes data[0], fit data[1], formulation data[2]
    data: tuple[str, ...]
    draw: str  # the function of cortex_ti.studies.figures that draws it
    category: str  # the report's section
    caption: str  # reStructuredText shown under it in the report
    options: tuple[str, ...] = ()  # keys of the config's ``figures`` section passed to ``draw``


_STUDIES = (
    Study(
        "furrow",
        ("scene", "zeta_hat", "p", "nodes", "formulation", "fit", "scheme", "dt", "t_end"),
        "Furrow formation under a contractile ring (paper Eq. 59, Figs. 4-8): pole radius (half the "
        "pole-to-pole distance along the pattern axis) and furrow radius (mean radius of the section in the "
        "ring's plane) against time, one run per parameter set.",
        variables=("pole_radius", "furrow_radius", "volume", "area", "max_normal_speed", "max_tangential_speed"),
    ),
    Study(
        "fold",
        ("scene", "zeta_hat", "nodes", "formulation", "fit", "scheme", "dt", "t_end"),
        "Fold formation under a stripe of higher tension (paper Sec. 4.3, Fig. 9): equatorial radii across "
        "and beside the stripe and the fold depth against time.",
        variables=("pole_radius", "volume", "area", "max_normal_speed"),
    ),
    Study(
        "reorientation",
        ("scene", "gamma", "tilt", "nodes", "formulation", "fit", "scheme", "dt", "t_end"),
        "A cortex sheared at the start (x -> x + gamma z) under the ring of Eq. 59 (paper Figs. 10-12): angle "
        "between the long axis of the surface and the pattern axis, and the radii along the current long "
        "axis, against time.",
        variables=(
            "orientation_angle",
            "pole_radius_long_axis",
            "furrow_radius_long_axis",
            "pole_radius",
            "furrow_radius",
            "volume",
            "max_normal_speed",
        ),
    ),
    Study(
        "accuracy",
        ("scene", "nodes", "formulation", "fit", "residual", "scheme", "implicit", "dt", "tol", "t_end"),
        "What accuracy costs: one furrow scene over resolutions, fits, time schemes, steps and tolerances; each run's "
        "error against the reference and its wall time go into the cost store.",
        failures_are_data=True,
    ),
    Study(
        "axisymmetric",
        ("scene", "model", "zeta_hat", "p", "bending_form", "t_end"),
        "The axisymmetric twin of every axisymmetric run of the furrow and accuracy studies: the same scene "
        "solved by the spectral meridian solver (model: axisymmetric), to the latest end time of its 3D runs, "
        "with the bending viscosity's force in the form their formulation discretises (bending_form). "
        "It is the truth the 3D radii and velocity profiles are measured against.",
        variables=("pole_radius", "furrow_radius", "volume", "area", "max_normal_speed", "max_tangential_speed"),
        twin_of=("furrow", "accuracy"),
    ),
    Study(
        "self_organisation",
        ("scene", "model", "degree", "seed", "myosin_gamma", "turnover", "nodes", "tol", "dt_max", "t_end"),
        "A self-organising cortex (issue 20): a myosin density carried by the flow it drives. Runs seeded "
        "with one harmonic of degree `degree` (amplitude `seed`) at the linear law's slope `myosin_gamma` "
        "and turnover `turnover`, whose seeded mode grows or decays at a rate fitted to the log of its "
        "amplitude; and the nonlinear ring (scene myosin_ring) in 3D and in the axisymmetric model. Per "
        "frame: the radii and the amplitude of each degree of the myosin (myosin_amplitude).",
        variables=("pole_radius", "furrow_radius", "volume", "area", "max_normal_speed"),
        optional=True,
    ),
)

# Issue 18: deep rings to the brink of division (its own block, so other studies merge beside it).
_STUDIES += (
    Study(
        "fluids",
        ("scene", "model", "inner", "outer", "nodes", "t_end"),
        "The cell in a fluid (issue 36): the paper's furrow with a cytoplasm and a medium (furrow_in_fluid) and a "
        "cell that swims by its cortex's polarised flow (polarised_swimmer), with the fluids' viscosities inner and "
        "outer (eta_s / R0) swept: the hydrodynamic length eta_s / mu. 3D runs and the axisymmetric model (the "
        "truth; model: axisymmetric). Per frame the radii, the volume and the volume centroid along the axis.",
        variables=("furrow_radius", "pole_radius", "volume"),
        optional=True,
    ),
    Study(
        "constriction",
        ("scene", "model", "zeta_hat", "p", "bending", "remesh", "nodes", "t_end"),
        "Deep rings without bending viscosity (issue 18; with bending rigidity `bending`, issue 35): the neck "
        "radius against time, by the axisymmetric "
        "model with adaptive points (the truth, converged to its neck of 0.1; frames whose label map it does "
        "not resolve are left out) and in 3D "
        "with remeshing, of prescribed rings (zeta_hat, p) and of the myosin ring that forms by itself "
        "(scene myosin_constriction; its zeta_hat and p are null); and, from the axisymmetric runs of "
        "prescribed rings over the ring-to-pole tension ratio 1 + zeta_hat, the "
        "threshold above which the furrow closes (to a neck of 0.1 R0) instead of arresting; the rings with "
        "rigidity (scene constriction_rigid) mapped over kappa and the ratio, closing to a neck of 1e-2 R0.",
        variables=(
            "neck_radius",
            "furrow_radius",
            "pole_radius",
            "volume",
            "min_angle_deg",
            "material_stretch",
            "label_resolved",
        ),
    ),
)

# Issue 35: one cell becomes two (its own block, so other studies merge beside it).
_STUDIES += (
    Study(
        "cytokinesis",
        ("scene", "model", "zeta_hat", "center", "bending", "remesh", "neck", "nodes", "save_every", "t_end"),
        "One cell becomes two (issue 35): prescribed rings of strength zeta_hat with bending rigidity `bending` "
        "closed to the cut at the neck radius `neck`, in 3D (scenes cytokinesis, cytokinesis_rigid, "
        "cytokinesis_asymmetric: the cut and "
        "the two daughters) and in the axisymmetric model (constriction_p4, constriction_rigid with the same ring: "
        "the run stops at the cut). Per run: complete or failed division, the constriction time t_c, the neck "
        "radius against time and the exponent a of neck ~ (t_c - t)^a near the cut, and the volume ratio of the "
        "two sides (the daughters' bodies after a 3D cut; before it, the split at the neck's plane). `center` is "
        "the ring's polar angle (rad; pi/2 the equator; scene cytokinesis_asymmetric: pi/2 - 0.001): an "
        "off-centre ring's ratio is set by the ring and the lobe mode, so it is not called slipping.",
        variables=(
            "neck_radius",
            "furrow_radius",
            "pole_radius",
            "volume",
            "n_bodies",
            "volume_upper",
            "volume_lower",
            "lobe_rate",
            "min_angle_deg",
        ),
        optional=True,
    ),
)

#: The studies by name (the config's sections of run records).
STUDIES: dict[str, Study] = {s.name: s for s in _STUDIES}

#: The xarray stores under results/aggregate: the static convergence store, one per study with
#: per-frame variables, and the cost of every run.
STORES: tuple[str, ...] = ("convergence", *(s.name for s in _STUDIES if s.has_store), "cost")

_SPHERE = "1. Figs. 2, 3: flow on a static sphere"
_SHAPES = "2. Figs. 4, 6: the furrow"
_FURROW = "3. Figs. 5, 7, 8: furrow dynamics against the axisymmetric solution"
_FOLD = "4. Fig. 9: fold formation"
_SHEAR = "5. Figs. 10-12: the sheared cortex reorients"
_COST = "6. What accuracy costs"
_SELF = "7. A self-organising cortex (beyond the paper)"

#: The figures in the paper's order: the report shows them in this order, each with its caption
#: (what the paper shows there and what to compare) and a table of the numbers to compare and
#: of the cost of the runs behind it.
_FIGURES = (
    FigureSpec(
        "sphere_flows",
        "static",
        ("2562", "quadratic", "paper"),
        "sphere_flows_figure",
        _SPHERE,
        "Paper Figs. 2B-E (zeta = Y20) and 3B-E (zeta = Y21, plus a uniform part): the instantaneous flow on a static "
        "sphere of 2562 nodes with the paper's quadratic fit, for the full force balance (i: normal flow, inward at "
        "the poles and outward at the equator for Y20) and the tangential one (ii: v_n = 0, flow from the equator to "
        "the poles). Right: the velocity at the nodes against the polar angle with the analytic solution "
        "(docs/method/conventions.md), which the paper reports as 'very good agreement'.",
    ),
    FigureSpec(
        "convergence",
        "store",
        ("convergence",),
        "convergence_figure",
        _SPHERE,
        "Paper Figs. 2F,G and 3F,G: the relative velocity error eps_rel (Eq. 58) against the number of nodes N, "
        "for the paper's one-ring quadratic fit and the two-ring quartic fit. The paper reports both systems "
        "converging inversely to N; dotted and dashed lines are N^-1 and N^-2 guides. Store: "
        "``results/aggregate/convergence.nc``.",
    ),
    FigureSpec(
        "furrow_pictures",
        "runs",
        ("furrow",),
        "snapshots_figure",
        _SHAPES,
        "Paper Figs. 4A-C (p = 8, zeta_hat = 1) and 6A-E (p = 4, zeta_hat = 1 and 3): the contractile ring of Eq. 59 "
        "on the initial sphere, the initial flow (inward at the ring, outward at the poles) and the final shape, "
        "where no normal flow remains and a tangential flow runs toward the ring.",
        options=("picture_times",),
    ),
    FigureSpec(
        "furrow_radii",
        "store",
        ("furrow", "axisymmetric"),
        "radii_figure",
        _FURROW,
        "Paper Figs. 5A, 7A, 8A: pole radius (half the pole-to-pole distance) and furrow radius (at the equator) "
        "against time. Dots: the 3D runs; black lines: the axisymmetric solution of the same scene (model: "
        "axisymmetric, with the scene's own bending viscosity; converged to ~1e-12 R0). The paper shows 'excellent "
        "agreement' with its axisymmetric code; the table gives the deviations. Stores: "
        "``results/aggregate/furrow.nc``, ``results/aggregate/axisymmetric.nc``.",
    ),
    FigureSpec(
        "velocity_profiles",
        "runs",
        ("furrow", "axisymmetric"),
        "profiles_figure",
        _FURROW,
        "Paper Figs. 5B-G, 7B-G, 8B-G: tangential speed ``|v_t|`` (left of each pair) and normal velocity v_n (right, "
        "positive outward) at the nodes against their height z, at t = 0.1, 1.5 and 3, one column pair per furrow "
        "run; black lines: the axisymmetric solution of the same scene. The tangential flow grows while the "
        "normal flow decays as the shape settles, as in the paper.",
        options=("profile_times",),
    ),
    FigureSpec(
        "reference_check",
        "store",
        ("axisymmetric",),
        "reference_check_figure",
        _FURROW,
        "Cross-check of the axisymmetric solver with an independent code: the external reference run shipped in "
        "``cortex_ti/data/axisym`` (the authors' axisymmetric code, p = 8, zeta_hat = 1, a tiny bending moment "
        "instead of the bending viscosity). Left: pole and furrow radius; right: their deviation from it, for the "
        "reference's problem (no bending viscosity; within its own time error, ~1e-4) and for the scene with its "
        "bending viscosity (what the 3D runs are compared with: up to ~6e-4 early on).",
    ),
    FigureSpec(
        "fold_depth",
        "store",
        ("fold",),
        "fold_figure",
        _FOLD,
        "Paper Fig. 9: a stripe of higher tension through both poles (zeta_hat = 3.5, sigma_phi = 200, narrow; "
        "zeta_hat = 4.5, sigma_phi = 12, broad) pulls in a fold. The equatorial radius across the stripe (solid) "
        "and beside it (dashed), and the fold depth (their difference) against time; the paper shows the fold "
        "forming with an in-plane flow from the poles toward it. Store: ``results/aggregate/fold.nc``.",
    ),
    FigureSpec(
        "snapshots_fold",
        "runs",
        ("fold",),
        "snapshots_figure",
        _FOLD,
        "Paper Fig. 9A-F in 3D: the active stress on the initial sphere, then the shape coloured by the speed "
        "``|v|`` with velocity arrows at the configured times and at the end of the run.",
        options=("snapshot_times",),
    ),
    FigureSpec(
        "orientation",
        "store",
        ("reorientation",),
        "orientation_figure",
        _SHEAR,
        "Paper Figs. 10-12: a cortex sheared at the start (x -> x + gamma z) turns its long axis back toward the "
        "pattern's axis before the furrow closes (Figs. 10, 12); with the pattern tilted toward the shear it keeps "
        "its orientation (Fig. 11). Left: the angle between the long axis (second-moment tensor) and the pattern "
        "axis; right: pole and furrow radius along the current long axis. Store: "
        "``results/aggregate/reorientation.nc``.",
    ),
    FigureSpec(
        "snapshots_reorientation",
        "runs",
        ("reorientation",),
        "snapshots_figure",
        _SHEAR,
        "Paper Figs. 10-12 B-E in 3D: per run the active stress on the sheared start, then ``|v|`` with velocity "
        "arrows at t = 3.5e-3, 3.5e-2, 8.7e-2 and 3.5 t_a (the paper's times).",
        options=("snapshot_times",),
    ),
    FigureSpec(
        "accuracy_cost",
        "store",
        ("cost",),
        "accuracy_cost_figure",
        _COST,
        "Not in the paper: what accuracy costs in time. The largest deviation of pole and furrow radius from the "
        "axisymmetric solution of the same scene over the run, against the run's wall time, one point per (N, fit, "
        "time scheme, tension treatment, dt): colour = N, marker = scheme, filled = semi-implicit tension. The "
        "dashed line joins the Pareto front (no other run is both cheaper and more accurate), tabulated beside "
        "it; red crosses: runs that went unstable (the reason is in their summary). Times are wall-clock seconds "
        "of one job on the machine that ran the workflow, start-up included.",
    ),
)

_FIGURES += (
    FigureSpec(
        "myosin_rates",
        "store",
        ("self_organisation",),
        "myosin_rates_figure",
        _SELF,
        "Not in the paper: the uniform myosin cortex's growth rates. Left: the rate of each degree l at the "
        "largest activity of the runs; middle: the rate of l = 1 and l = 2 against the activity A = zeta0 gamma; "
        "right: every run's and the spectrum tool's deviation from the closed form against N, with an N^-1 "
        "(h^2) guide. "
        "Lines: the closed form (docs/derivations/myosin_stability.md, with the scene's bending viscosity); "
        "open markers and thin lines: the spectrum tool (the state Jacobian projected on each degree, "
        "dynamics.spectrum.degree_jacobian) at the runs' resolutions; filled markers: the runs, the slope of "
        "``log |c_l|`` of the seeded harmonic over the second half of each run. The 3D rates sit below the closed "
        "form by the O(h^2) error of the linearisation (docs/validation/myosin_rates.md). Store: "
        "``results/aggregate/self_organisation.nc``.",
    ),
    FigureSpec(
        "myosin_onset",
        "store",
        ("self_organisation",),
        "myosin_onset_figure",
        _SELF,
        "Not in the paper: where the uniform myosin cortex loses stability, in the (turnover k, activity A) "
        "plane. Black lines: the closed form's onsets A_c(l) = (eta_s (L-2) + eta_b L)(D + k / L) for l = 2 and "
        "mu_1 / G_1 for l = 1 (polarity goes first); coloured lines: the spectrum tool's onset at each "
        "resolution (where its largest rate of that degree crosses zero); markers: the runs seeded with that "
        "degree, filled where the seeded mode grew, open where it decayed.",
    ),
    FigureSpec(
        "myosin_ring",
        "store",
        ("self_organisation",),
        "myosin_ring_figure",
        _SELF,
        "Not in the paper: a ring that forms by itself. Scene myosin_ring: the myosin cortex above the onset of "
        "l = 2, seeded with more myosin at the equator; the mode grows, myosin gathers into an equatorial ring "
        "and the cell constricts. Left: the furrow radius of the 3D runs and of the axisymmetric twin (the same "
        "scene, model: axisymmetric, the truth while the 3D run stays mirror-symmetric); right: ``|3D - twin|``, "
        "with the issue's 2e-3 R0. The 3D ring lags by the 3D l = 2 rate's O(h^2) error "
        "(docs/validation/myosin_ring.md).",
    ),
)

# Issue 18: deep rings (its own block, so other figures merge beside it).
_FIGURES += (
    FigureSpec(
        "constriction",
        "store",
        ("constriction",),
        "constriction_figure",
        "8. Deep rings: does the furrow close?",
        "Not in the paper (issue 18): rings ``zeta = 1 + zeta_hat exp(-10 |theta - pi/2|^4)`` without bending "
        "viscosity, the tension glued to the normally moving points. Left: the neck radius against time, lines the "
        "axisymmetric model (adaptive points; dotted from the first frame whose label map they do not resolve), "
        "dots the 3D runs with remeshing. Middle, when the study has it: the same for the myosin ring that "
        "forms by itself (scene myosin_constriction). Right: the neck at the end of each axisymmetric run against "
        "the ring-to-pole tension ratio 1 + zeta_hat: closed (reached 0.1 R0), arrested (slower than 1e-4 R0/t_a "
        "at the end) or still closing, and the threshold between the largest ratio that arrests and the smallest "
        "that closes. Store: ``results/aggregate/constriction.nc``.",
    ),
)

# Issue 36: the cell in a fluid.
_FIGURES += (
    FigureSpec(
        "fluids",
        "store",
        ("fluids",),
        "fluids_figure",
        "9. The cell in a fluid",
        "Not in the paper (issue 36): the cortex between a cytoplasm and a medium (Stokes fluids, boundary "
        "integrals), over the hydrodynamic length ell = eta_s / mu (R0). Left: the furrow radius of furrow_in_fluid "
        "against time (lines: the axisymmetric model, the truth; markers: 3D). Middle: the furrow's depth "
        "R_f(0) - R_f(t_end) and the time it took to reach half of it, against ell: the fluids slow the "
        "furrow, the vacuum's is the limit of large ell. Right: the speed of polarised_swimmer (the slope of its "
        "volume centroid over the second half of the run) against ell, with Lamb's speed of the sphere at "
        "t = 0 (docs/derivations/fluid_sphere.md). Store: ``results/aggregate/fluids.nc``.",
    ),
)

# Issue 35: one cell becomes two.
_FIGURES += (
    FigureSpec(
        "cytokinesis",
        "store",
        ("cytokinesis",),
        "cytokinesis_figure",
        "10. One cell becomes two",
        "Not in the paper (issue 35): rings closed to a cut at the neck radius 0.1 R0, with and without bending "
        "rigidity, in the axisymmetric model (lines; the run stops at its cut) and in 3D (markers; the cut and the "
        "two daughters). Left: the neck radius against time, the cut dotted. Middle: the neck against the time to "
        "the pinch t_p fitted with the late-time law neck = A (t_p - t)^a (dashed). Right: the volume ratio of the "
        "two sides minus 1 (the daughters after a cut, before it the split at the neck's plane); above the dashed "
        "1e-2 the furrow slips. The table puts the published rings (Turlier et al. 2014; 20:1 to a furrow of "
        "0.06 R0; TraceFEM 10:1) beside ours. Store: ``results/aggregate/cytokinesis.nc``.",
    ),
)

#: The figures by name (results/figures/<name>.<format>).
FIGURES: dict[str, FigureSpec] = {f.name: f for f in _FIGURES}

#: Tables of the report (results/figures/<name>.html), drawn from a store: name -> (store, caption).
TABLES: dict[str, tuple[str, str]] = {
    "cost_table": (
        "cost",
        "Cost of every run of the workflow: wall time and peak memory (Snakemake benchmark "
        "files), steps and solves, time per step and per stage of a solve (cortex-ti run "
        "summaries), and the error against the axisymmetric reference where one exists. "
        "Store: ``results/aggregate/cost.nc``.",
    ),
}
TABLE_CATEGORY = _COST


def figure_names() -> list[str]:
    return list(FIGURES)


def _left_out(config) -> set[str]:
    """The optional studies ``config`` leaves out: absent, or with an empty ``runs`` list (a config
    given with ``--configfile`` is merged into the default one, so it leaves a study out that way)."""
    return {s.name for s in _STUDIES if s.optional and not (config.get(s.name) or {}).get("runs")}


def configured_studies(config=None) -> list[str]:
    """The studies the config lists runs for (the others are derived from them); with ``config``
    (the workflow's configuration) without the optional ones it leaves out."""
    left_out = set() if config is None else _left_out(config)
    return [s.name for s in _STUDIES if not s.twin_of and s.name not in left_out]


def optional_studies() -> list[str]:
    """The studies a configuration may leave out."""
    return [s.name for s in _STUDIES if s.optional]


def stores_of(config) -> list[str]:
    """The stores the configuration ``config`` makes: every store but those of the studies it leaves out."""
    return [name for name in STORES if name not in _left_out(config)]


def figures_of(config) -> list[str]:
    """The figures the configuration ``config`` draws: those whose stores or studies it makes."""
    return [f.name for f in _FIGURES if not _left_out(config).intersection(f.data)]


def study_store_names() -> list[str]:
    """The studies that have a (run, time) store."""
    return [s.name for s in _STUDIES if s.has_store]
