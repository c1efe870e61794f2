"""The paper's studies as a workflow: registry, sweep tables, stores and figures.

Owns the one registry of studies and figures (``registry``) that the Snakemake rules, the
workflow scripts and the tests read, the sweep tables (``sweeps``: config records -> one row
per run -> scene overrides), the xarray stores (``stores``, ``convergence``) and the figures
(``figures``). Sits on top of everything else; nothing in the package imports it.
"""
