"""Benchmarks: medians of step costs, ratios between solvers, one long run.

Each module runs as a script, ``python -m cases.bench.NAME``:
:mod:`.continuum` (cost per step against node count; the target run to radius 150),
:mod:`.particles` (cost per step against particle count and threads),
:mod:`.contact_solvers` (BBPGD and APGD on the same packings),
:mod:`.timestep` (the time step's effect on the solver passes and on the results).
Their measured tables are in docs/benchmarks.md.
"""
