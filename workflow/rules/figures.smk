# Figures and tables under results/figures, one rule each for every registered figure
# (cortex_ti.studies.registry.FIGURES: its data, drawing function, report section and caption).


rule figure:
    input:
        data=figure_inputs,
        cost="results/aggregate/cost.nc",
    output:
        figures=[figure_report(fmt) for fmt in FORMATS],
        numbers=report("results/figures/{name}_numbers.html", caption="../report/numbers.rst",
                       category=lambda wc: FIGURES[wc.name].category),
    params:
        caption=lambda wc: FIGURES[wc.name].caption,
        rows=figure_rows,
        options=config["figures"],
    log:
        "results/logs/figures/{name}.log",
    script:
        "../scripts/figures.py"


rule table:
    input:
        lambda wc: f"results/aggregate/{TABLES[wc.name][0]}.nc",
    output:
        report("results/figures/{name}.html", caption="../report/figure.rst", category=TABLE_CATEGORY),
    params:
        caption=lambda wc: TABLES[wc.name][1],
    log:
        "results/logs/figures/{name}.log",
    script:
        "../scripts/figures.py"
