# Figures under results/figures (every format in config figures.formats), with report captions.


def _report(name, category):
    """The figure's files; the PNG goes into the report with its caption."""
    caption = f"../report/{name}.rst"
    return [report(f, caption=caption, category=category) if f.endswith(".png") else f for f in figure_files(name)]


rule figure_convergence:
    input:
        "results/aggregate/convergence.nc",
    output:
        _report("convergence", "1. Static sphere"),
    log:
        "results/logs/figures/convergence.log",
    script:
        "../scripts/figures.py"


rule figure_furrow_radii:
    input:
        "results/aggregate/furrow.nc",
    output:
        _report("furrow_radii", "2. Furrow"),
    log:
        "results/logs/figures/furrow_radii.log",
    script:
        "../scripts/figures.py"


rule figure_velocity_profiles:
    input:
        [f"{d}/trajectory.h5" for d in run_dirs("furrow")],
    output:
        _report("velocity_profiles", "2. Furrow"),
    params:
        rows=run_rows("furrow"),
        times=config["figures"]["profile_times"],
    log:
        "results/logs/figures/velocity_profiles.log",
    script:
        "../scripts/figures.py"


rule figure_fold_depth:
    input:
        "results/aggregate/fold.nc",
    output:
        _report("fold_depth", "3. Fold"),
    log:
        "results/logs/figures/fold_depth.log",
    script:
        "../scripts/figures.py"


rule figure_snapshots_fold:
    input:
        [f"{d}/trajectory.h5" for d in run_dirs("fold")],
    output:
        _report("snapshots_fold", "3. Fold"),
    params:
        rows=run_rows("fold"),
        times=config["figures"]["snapshot_times"],
    log:
        "results/logs/figures/snapshots_fold.log",
    script:
        "../scripts/figures.py"


rule figure_orientation:
    input:
        "results/aggregate/reorientation.nc",
    output:
        _report("orientation", "4. Sheared cortex"),
    log:
        "results/logs/figures/orientation.log",
    script:
        "../scripts/figures.py"


rule figure_snapshots_reorientation:
    input:
        [f"{d}/trajectory.h5" for d in run_dirs("reorientation")],
    output:
        _report("snapshots_reorientation", "4. Sheared cortex"),
    params:
        rows=run_rows("reorientation"),
        times=config["figures"]["snapshot_times"],
    log:
        "results/logs/figures/snapshots_reorientation.log",
    script:
        "../scripts/figures.py"


rule figure_accuracy_cost:
    input:
        "results/aggregate/cost.nc",
    output:
        _report("accuracy_cost", "5. Accuracy and cost"),
    log:
        "results/logs/figures/accuracy_cost.log",
    script:
        "../scripts/figures.py"


rule cost_table:
    input:
        "results/aggregate/cost.nc",
    output:
        report("results/figures/cost_table.html", caption="../report/cost_table.rst", category="5. Accuracy and cost"),
    log:
        "results/logs/figures/cost_table.log",
    script:
        "../scripts/figures.py"
